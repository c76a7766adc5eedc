"""Figures users judge point sets and stipplings by (matplotlib, optional).

matplotlib is the optional extra ``plot``: it is imported inside the functions,
and a missing install raises ``ImportError`` saying how to get it. Figures are
built on a bare :class:`matplotlib.figure.Figure` (no pyplot state, no GUI
backend), rendered to memory and written with :func:`diskpack_cl.io.atomic_write`,
so a failed run leaves no partial file. Both reports also return their numbers
as a JSON-ready dict (non-finite values become ``None``).
"""

from __future__ import annotations

import dataclasses
import io
import math
from pathlib import Path

import numpy as np
from scipy import ndimage
from PIL import Image

from . import analysis, picture_measures
from .extras import install_command
from .io import atomic_write
from .box_analysis import box_measures

__all__ = ["figure_format", "point_set_numbers", "point_set_report", "stipple_numbers",
           "stipple_report"]

_MISSING = "plots need matplotlib: " + install_command("plot")
_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}
_DPI = 100


def _figure(figsize):
    try:
        from matplotlib.figure import Figure  # the optional plot extra, for a figure only
    except ImportError as exc:
        raise ImportError(_MISSING) from exc
    return Figure(figsize=figsize, dpi=_DPI, layout="constrained")


def figure_format(path):
    """The matplotlib format of a figure path: ``png``, ``pdf`` or ``svg``.

    Raises ``ValueError`` for any other extension, so that a caller can
    refuse a bad output name before the work (matplotlib is not needed).

    Examples
    --------
    >>> figure_format("report.PNG")
    'png'
    """
    fmt = _FORMATS.get(Path(path).suffix.lower())
    if fmt is None:
        raise ValueError(f"unknown figure extension {Path(path).suffix!r} (use .png, .pdf or .svg)")
    return fmt


def _save(fig, path, fmt):
    """Render in memory, then write atomically; PNGs get a 64-colour palette.

    The figures are grey with a few coloured marks, and a palette keeps
    dotty panels (stipplings, periodograms) well under 300 KB.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=_DPI)
    data = buf.getvalue()
    if fmt == "png":
        with Image.open(io.BytesIO(data)) as im:
            small = im.convert("RGB").quantize(colors=64, dither=Image.Dither.NONE)
        out = io.BytesIO()
        small.save(out, format="PNG", optimize=True)
        data = out.getvalue()
    with atomic_write(path, "wb") as fh:
        fh.write(data)


def format_number(x):
    """A JSON-ready Python number (None for nan/inf)."""
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    x = float(x)
    return x if math.isfinite(x) else None


def _nums(a):
    return [format_number(v) for v in np.asarray(a).ravel()]


def _real(x):
    """A number of :func:`format_number` back as a float (None is nan)."""
    return float("nan") if x is None else x


def _point_set_measures(sets, kmax, box=None):
    """(numbers, (freqs, P, centres, power, aniso)) of the realizations `sets`
    (on the unit torus, or in the box ``(W, H)``: :mod:`diskpack_cl.box_analysis`)."""
    if box is not None:
        numbers, curves = box_measures(sets, box, kmax=kmax)
        return {k: (_nums(v) if isinstance(v, list) else v if isinstance(v, str) else format_number(v))
                for k, v in numbers.items()}, curves
    freqs, P = analysis.periodogram(sets, kmax=kmax)
    centres, power = analysis.radial_power(P, freqs)
    _, aniso = analysis.anisotropy(P, freqs)
    rhos = [analysis.normalized_radius(s) for s in sets]
    mean_rhos = [analysis.mean_normalized_radius(s) for s in sets]
    psi6 = analysis.hexatic_order(sets[0]).mean if len(sets[0]) >= 3 else float("nan")
    finite = np.isfinite(aniso)
    peak = int(np.argmax(power))
    numbers = {
        "n": int(len(sets[0])),
        "realizations": len(sets),
        "kmax": int(freqs[-1]),
        "rho": format_number(rhos[0]),
        "rho_min": format_number(min(rhos)),
        "rho_mean": format_number(np.mean(rhos)),
        "mean_rho": format_number(np.mean(mean_rhos)),
        "psi6_mean": format_number(psi6),
        "peak_frequency": format_number(centres[peak]),
        "peak_power": format_number(power[peak]),
        "anisotropy_mean_db": format_number(aniso[finite].mean()) if finite.any() else None,
        "anisotropy_reference_db": format_number(-10.0 * math.log10(len(sets))),
        "radial_frequency": _nums(centres),
        "radial_power": _nums(power),
        "anisotropy_db": _nums(aniso),
    }
    return numbers, (freqs, P, centres, power, aniso)


def point_set_numbers(points_list, *, kmax=None, box=None):
    """The numbers of :func:`point_set_report`, without a figure (no matplotlib).

    Parameters
    ----------
    points_list : array_like
        One (n, 2) point set, a (K, n, 2) stack or a sequence of point sets
        (the realizations), all on the unit torus [0,1)^2.
    kmax : int, optional
        Periodogram range (see :func:`diskpack_cl.analysis.periodogram`).
    box : (float, float), optional
        The sets lie in the box ``[0, W] x [0, H]``, not on the torus: no
        wrap, a Hann-windowed periodogram (:mod:`diskpack_cl.box_analysis`).

    Returns
    -------
    dict
        The dict :func:`point_set_report` returns (non-finite values None).

    Examples
    --------
    >>> pts = np.random.default_rng(0).random((64, 2))
    >>> numbers = point_set_numbers(pts, kmax=8)
    >>> numbers["n"], numbers["realizations"], numbers["kmax"]
    (64, 1, 8)
    """
    return _point_set_measures(analysis._as_realizations(points_list), kmax, box)[0]


def _points_panel(ax_pts, first, K):
    dot = max(0.05, min(4.0, 2000.0 / len(first)))
    ax_pts.scatter(first[:, 0] % 1.0, first[:, 1] % 1.0, s=dot, c="k", linewidths=0)
    ax_pts.set(xlim=(0, 1), ylim=(1, 0), aspect="equal", xticks=[], yticks=[])
    ax_pts.set_title("points" + (f" (1 of {K})" if K > 1 else ""), fontsize=9)


def _periodogram_panel(ax_per, P, k, K):
    import matplotlib  # the optional plot extra, for a figure only
    from matplotlib.colors import LogNorm  # the optional plot extra, for a figure only

    positive = P[P > 0]
    vmax = max(float(positive.max()) if positive.size else 1.0, 4.0)
    ax_per.imshow(
        np.where(P > 0, P, np.nan),
        cmap=matplotlib.colormaps["gray"].with_extremes(bad="k"),
        norm=LogNorm(vmin=0.05, vmax=vmax, clip=True),
        extent=(-k - 0.5, k + 0.5, -k - 0.5, k + 0.5), origin="lower", interpolation="nearest",
    )
    ax_per.set(xticks=[-k, 0, k], yticks=[-k, 0, k])
    ax_per.tick_params(labelsize=7)
    ax_per.set_title(f"mean periodogram (K={K}, log)", fontsize=9)


def _spectrum_panels(ax_rad, ax_ani, centres, power, aniso, ref_db, k):
    finite = np.isfinite(aniso)
    ax_rad.plot(centres, power, color="k", lw=1)
    ax_rad.axhline(1.0, color="0.6", lw=0.8, ls="--")
    ax_rad.set_xlim(0, k)
    ax_rad.set_ylim(0, max(2.0, 1.05 * float(power.max())))
    ax_rad.set_xlabel("frequency", fontsize=8)
    ax_rad.tick_params(labelsize=7)
    ax_rad.set_title("radial mean power", fontsize=9)

    ax_ani.plot(centres[finite], aniso[finite], color="k", lw=1)
    ax_ani.axhline(ref_db, color="0.6", lw=0.8, ls="--")
    ax_ani.set_xlim(0, k)
    lo = min(ref_db - 6.0, float(np.min(aniso[finite])) - 1.0) if finite.any() else ref_db - 6.0
    hi = max(ref_db + 6.0, float(np.max(aniso[finite])) + 1.0) if finite.any() else ref_db + 6.0
    ax_ani.set_ylim(max(lo, ref_db - 30.0), min(hi, ref_db + 30.0))
    ax_ani.set_xlabel("frequency", fontsize=8)
    ax_ani.tick_params(labelsize=7)
    ax_ani.set_title("anisotropy (dB)", fontsize=9)


def point_set_report(points_list, path, *, title=None, kmax=None, box=None):
    """One figure of a point set on the unit torus, and its numbers.

    Panels: the first realization's points (small dots, square aspect), the
    mean periodogram over all realizations (log scale, grey, DC at the
    centre), the radial mean power (1 = white noise) and the anisotropy in dB
    (dashed: ``-10 log10(K)``, the value of K averaged isotropic
    realizations). The title carries n, rho (exact, from
    :func:`diskpack_cl.normalized_radius`), the mean nearest-neighbour
    rho and the mean ``|psi_6|``.

    Parameters
    ----------
    points_list : array_like
        One (n, 2) point set, a (K, n, 2) stack or a sequence of point sets
        (the realizations), all on the unit torus [0,1)^2.
    path : str or Path
        Output file, ``.png`` (or ``.pdf``/``.svg``); written atomically.
    title : str, optional
        First line of the figure title.
    kmax : int, optional
        Periodogram range (see :func:`diskpack_cl.analysis.periodogram`).
    box : (float, float), optional
        As in :func:`point_set_numbers`; the points panel shows the box
        scaled to a square.

    Returns
    -------
    dict
        ``n``, ``realizations``, ``kmax``, ``rho`` (first realization),
        ``rho_min`` and ``rho_mean`` (over realizations), ``mean_rho`` (mean
        over realizations of the mean nearest-neighbour rho), ``psi6_mean``
        (first realization), ``peak_frequency`` and ``peak_power`` of the
        radial power, ``anisotropy_mean_db`` and ``anisotropy_reference_db``,
        and the curves ``radial_frequency``, ``radial_power``,
        ``anisotropy_db`` as lists.

    Examples
    --------
    >>> import tempfile, os
    >>> pts = np.random.default_rng(0).random((256, 2))
    >>> out = os.path.join(tempfile.mkdtemp(), "report.png")
    >>> numbers = point_set_report(pts, out)  # doctest: +SKIP
    """
    fmt = figure_format(path)
    sets = analysis._as_realizations(points_list)
    numbers, (freqs, P, centres, power, aniso) = _point_set_measures(sets, kmax, box)
    first = sets[0] if box is None else sets[0] / box
    K = numbers["realizations"]
    ref_db = numbers["anisotropy_reference_db"]

    fig = _figure((10, 3))
    ax_pts, ax_per, ax_rad, ax_ani = fig.subplots(1, 4)
    k = int(freqs[-1])
    _points_panel(ax_pts, first, K)
    _periodogram_panel(ax_per, P, k, K)
    _spectrum_panels(ax_rad, ax_ani, centres, power, aniso, ref_db, k)

    head = (f"{title}\n" if title else "") + ("" if box is None else
                                               f"box {box[0]:g} x {box[1]:g}, Hann window: ")
    fig.suptitle(
        f"{head}n = {len(first)}, rho = {_real(numbers['rho']):.3f}, "
        f"mean rho = {_real(numbers['mean_rho']):.3f}, |psi6| = {_real(numbers['psi6_mean']):.3f}",
        fontsize=10,
    )
    _save(fig, path, fmt)
    return numbers


def certificate_items(certificate):
    if certificate is None:
        return None
    if dataclasses.is_dataclass(certificate) and not isinstance(certificate, type):
        items = dataclasses.asdict(certificate)
    elif isinstance(certificate, dict):
        items = dict(certificate)
    else:
        return {"text": str(certificate)}
    out = {}
    for key, value in items.items():
        if isinstance(value, (bool, np.bool_, int, np.integer, float, np.floating)):
            out[key] = format_number(value)
        elif isinstance(value, str) or value is None:
            out[key] = value
    return out


def stipple_numbers(points, radii, darkness, certificate=None, *, sigma=3.0):
    """The numbers of :func:`stipple_report`, without a figure (no matplotlib).

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Dot centres in pixel units.
    radii : array_like, shape (n,) or None
        The certified packing radii.
    darkness : ndarray, shape (ny, nx)
        Input darkness in [0, 1], 1 = black.
    certificate : dataclass, dict or object, optional
        The validity certificate (e.g. ``diskpack_cl.geometry.Certificate``).
    sigma : float
        Blur in pixels for tone and spacing.

    Returns
    -------
    dict
        The numbers of :func:`stipple_report`'s figure; a value that is not
        finite is None.

    Examples
    --------
    >>> dark = np.full((32, 32), 0.5)
    >>> pts = np.random.default_rng(1).random((50, 2)) * 32
    >>> numbers = stipple_numbers(pts, np.full(50, 1.0), dark)
    >>> numbers["n"], numbers["radius_max"], "certificate" in numbers
    (50, 1.0, False)
    """
    p, d = picture_measures._stipple_inputs(points, darkness)
    numbers = {key: format_number(v) for key, v in picture_measures.stipple_measures(p, d, sigma=sigma).items()}
    numbers["tone_radius"] = format_number(picture_measures.tone_radius(len(p), d))
    if radii is not None:
        r = np.asarray(radii, dtype=np.float64).ravel()
        if r.shape != (len(p),):
            raise ValueError(f"radii must have shape ({len(p)},), got {np.shape(radii)}")
        numbers.update(radius_min=format_number(r.min()), radius_median=format_number(np.median(r)), radius_max=format_number(r.max()))
    cert = certificate_items(certificate)
    if cert is not None:
        numbers["certificate"] = cert
    return numbers


def _spacing_panel(ax_h, sp):
    vals = sp.values[np.isfinite(sp.values)]
    hi = max(1.6, float(np.percentile(vals, 99.5)) if vals.size else 1.6)
    ax_h.hist(np.clip(vals, 0, hi), bins=60, range=(0, hi), color="0.35")
    ax_h.axvline(picture_measures.HEXAGONAL_SPACING, color="k", ls="--", lw=1)
    ax_h.axvline(sp.p01, color="k", ls=":", lw=1.2)
    ax_h.text(picture_measures.HEXAGONAL_SPACING, 0.97, " hex 1.075", transform=ax_h.get_xaxis_transform(),
              va="top", fontsize=7)
    ax_h.text(sp.p01, 0.85, f" P01 {sp.p01:.3f}", transform=ax_h.get_xaxis_transform(),
              va="top", fontsize=7)
    ax_h.set_xlabel("NN distance x sqrt(expected density)", fontsize=8)
    ax_h.tick_params(labelsize=7)
    ax_h.set_title(f"spacing (median {sp.median:.3f})", fontsize=9)


def _numbers_panel(ax_t, numbers, sp, n, size, r_tone, radii, cert):
    ax_t.axis("off")
    lines = [
        f"n = {n}, image {size[0]} x {size[1]} px",
        f"tone SSIM = {numbers['tone_ssim']:.4f}",
        f"spacing P01 = {sp.p01:.4f}, median = {sp.median:.4f}",
        f"mean |psi6| = {numbers['psi6_mean']:.4f}",
        f"dots drawn with equal-ink radius {r_tone:.3g} px",
    ]
    if radii is not None:
        lines.append(
            f"packing radii (px): min {numbers['radius_min']:.3g},\n"
            f"  median {numbers['radius_median']:.3g}, max {numbers['radius_max']:.3g}"
        )
    if cert is not None:
        lines.append("")
        lines.append("certificate:")
        for key, value in cert.items():
            shown = f"{value:.6g}" if isinstance(value, float) else str(value)
            lines.append(f"  {key} = {shown}")
    ax_t.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", fontsize=7.5, family="monospace",
              transform=ax_t.transAxes)


def stipple_report(points, radii, darkness, path, certificate=None, *, sigma=3.0, title=None):
    """One figure of a stippling beside its input, and its numbers.

    Panels: the input darkness and the rendered stippling (every dot drawn
    with the equal-ink radius of :func:`diskpack_cl.picture_measures.tone_radius`, as
    a pen with one nib would draw it); the same two blurred with a Gaussian of
    ``sigma`` pixels, with the tone SSIM; the histogram of the spacing
    (:func:`diskpack_cl.picture_measures.spacing`, hexagonal packing 1.075 marked);
    and the numbers with the certificate.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Dot centres in pixel units (x right, y down, origin top-left corner).
    radii : array_like, shape (n,) or None
        The certified packing radii (summarized in the text panel).
    darkness : ndarray, shape (ny, nx)
        Input darkness in [0, 1], 1 = black.
    path : str or Path
        Output file, ``.png`` (or ``.pdf``/``.svg``); written atomically.
    certificate : dataclass, dict or object, optional
        The validity certificate (e.g. ``diskpack_cl.geometry.Certificate``);
        its fields are printed and returned.
    sigma : float
        Blur in pixels for tone and spacing.
    title : str, optional

    Returns
    -------
    dict
        :func:`diskpack_cl.picture_measures.stipple_measures` plus ``tone_radius``,
        ``radius_min``, ``radius_median``, ``radius_max`` (when radii are
        given) and ``certificate`` (a dict of its fields, when given).

    Examples
    --------
    >>> import os, tempfile
    >>> p = np.random.default_rng(0).random((60, 2)) * 20
    >>> numbers = stipple_report(p, np.full(60, 0.5), np.full((20, 20), 0.5),
    ...                          os.path.join(tempfile.mkdtemp(), "report.png"))
    >>> numbers["n"], "radius_max" in numbers
    (60, True)
    """
    fmt = figure_format(path)
    numbers = stipple_numbers(points, radii, darkness, certificate, sigma=sigma)
    p, d = picture_measures._stipple_inputs(points, darkness)
    r_tone = numbers["tone_radius"]
    cert = numbers.get("certificate")

    drawing = picture_measures.render_dots(p, r_tone, d.shape)
    blur_draw = ndimage.gaussian_filter(drawing, sigma, mode="reflect")
    blur_dark = ndimage.gaussian_filter(d, sigma, mode="reflect")
    sp = picture_measures.spacing(p, d, sigma=sigma)

    ny, nx = d.shape
    fig = _figure((10, 6.6))
    axes = fig.subplots(2, 3)
    show = {"cmap": "gray_r", "vmin": 0.0, "vmax": 1.0, "interpolation": "antialiased"}
    panels = [
        (axes[0, 0], d, "input darkness"),
        (axes[0, 1], np.minimum(drawing, 1.0), f"stippling, n = {len(p)}"),
        (axes[1, 0], blur_dark, f"input, blurred (sigma {sigma:g} px)"),
        (axes[1, 1], np.minimum(blur_draw, 1.0), f"stippling, blurred: SSIM {numbers['tone_ssim']:.3f}"),
    ]
    for ax, img, name in panels:
        ax.imshow(img, **show)
        ax.set(xticks=[], yticks=[])
        ax.set_title(name, fontsize=9)

    _spacing_panel(axes[0, 2], sp)
    _numbers_panel(axes[1, 2], numbers, sp, len(p), (nx, ny), r_tone, radii, cert)
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, path, fmt)
    return numbers
