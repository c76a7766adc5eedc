"""Measures of a colour stippling against its photograph, beside
:mod:`diskpack_cl.picture_measures`: the dots drawn with their pens' inks
(:func:`render_pens`), which the colour PNG composites alike.

Measures (:func:`color_measures`): mean CIELAB Delta E (CIE 1976) between the
photograph and the rendered stippling, both blurred by about one dot
spacing; SSIM per separated layer (:func:`diskpack_cl.picture_measures.tone_ssim`);
spacing P01 per pen and of all dots (:func:`diskpack_cl.picture_measures.spacing`).
"""

from __future__ import annotations

import numpy as np

from .colorspace import delta_e, linear_negative, linear_to_srgb, srgb_to_linear
from .pen_radii import pen_ink_radii

__all__ = ["MIN_DOTS", "render_pens", "pen_spacing", "color_measures"]


#: Pens with fewer dots get no SSIM or P01 in :func:`color_measures` (a percentile of a
#: handful of distances says nothing).
MIN_DOTS = 50


def render_pens(points, pen, radii, colors, shape, *, scale=3, invert=False):
    """Linear-light RGB (H, W, 3) of dots drawn with their pens' inks, overprinting where they overlap.

    Each pen's dots (radius ``radii[p]`` px) are drawn at `scale` times the
    image resolution (:func:`diskpack_cl.picture_measures.render_dots`), coverage
    clipped at 1; inks multiply, ``prod_p (1 - a_p (1 - c_p))``, so pens
    side by side mix by area and overlapping dots overprint; the result is
    averaged back to the image's pixels. With `invert`, light pens on black
    paper: the negative of the negative pens on white,
    ``1 - prod_p (1 - a_p c_p)`` (side by side, the area mix over black).

    Examples
    --------
    >>> img = render_pens([[2.0, 2.0]], [0], [1.0], np.array([[0.0, 0.0, 0.0]]), (4, 4))
    >>> round(float(img[..., 0].mean()), 3)   # 1 - pi / 16
    0.804
    >>> img = render_pens([[2.0, 2.0]], [0], [1.0], np.array([[1.0, 1.0, 1.0]]), (4, 4), invert=True)
    >>> round(float(img[..., 0].mean()), 3)   # pi / 16
    0.196
    """
    from .picture_measures import render_dots  # not loaded at start-up

    if invert:
        return 1.0 - render_pens(points, pen, radii, linear_negative(colors), shape, scale=scale)
    p = np.asarray(points, dtype=np.float64)
    pen = np.asarray(pen)
    H, W = shape
    absorb = 1.0 - srgb_to_linear(colors)
    lin = np.ones((H * scale, W * scale, 3))
    for q in range(len(colors)):
        mine = pen == q
        if np.any(mine):
            a = np.minimum(render_dots(p[mine] * scale, radii[q] * scale, lin.shape[:2]), 1.0)
            lin *= 1.0 - a[..., None] * absorb[q]
    return lin.reshape(H, scale, W, scale, 3).mean(axis=(1, 3))


def _own_density(points, shape):
    """The density of `points` themselves on the pixel grid, blurred over two of their
    spacings and scaled to a maximum of 1 (the reference of :func:`pen_spacing`
    without layers)."""
    from scipy import ndimage  # not loaded at start-up

    H, W = shape
    hist = np.histogram2d(points[:, 1], points[:, 0], bins=(H, W), range=((0, H), (0, W)))[0]
    blurred = ndimage.gaussian_filter(hist, 2.0 * np.sqrt(W * H / len(points)), mode="constant")
    return blurred / blurred.max()


def pen_spacing(points, pen, shape, *, layers=None, pens=None, sigma=3.0):
    """Spacing P01 of each pen's dots and of all dots together.

    Each set's nearest-neighbour distances are read against the spacing its
    density asks for (:func:`diskpack_cl.picture_measures.spacing`, 1st percentile):
    with `layers`, a pen's layer and, for all dots, all layers' coverage
    (what the dots were placed to follow); without, the density of the dots
    themselves (histogram blurred over two of their spacings), which needs
    no image but forgives dots that drift from their tone.

    Parameters
    ----------
    points, pen
        As :func:`color_measures`: all dots (pixel units) and the pen of each.
    shape : (int, int)
        Image height and width in pixels.
    layers : (P, H, W) array_like, optional
        The separated layers (coverage in [0, 1]).
    pens : int, optional
        Number of pens (default: the layers', else the largest pen + 1).
    sigma : float
        Blur in pixels of the expected density.

    Returns
    -------
    dict
        ``p01``: per pen (None for a pen of fewer than :data:`MIN_DOTS`
        dots); ``p01_joint``: of all dots.

    Examples
    --------
    >>> x, y = np.meshgrid(np.arange(2.0, 64, 4), np.arange(2.0, 64, 4))
    >>> pts = np.column_stack([x.ravel(), y.ravel()])
    >>> out = pen_spacing(pts, np.arange(256) % 2, (64, 64))
    >>> out["p01"][0] > 0.5, round(out["p01_joint"], 2) > 0.5
    (True, True)
    """
    from .picture_measures import spacing  # not loaded at start-up

    p, pen = np.asarray(points, float), np.asarray(pen)
    P = pens or (int(pen.max()) + 1 if layers is None else len(layers))
    mine = [pen == q for q in range(P)]
    if layers is None:
        dens = [_own_density(p[m], shape) if np.count_nonzero(m) else None for m in mine]
        total = _own_density(p, shape)
    else:
        dens = list(np.asarray(layers, float))
        total = np.sum(dens, axis=0)
        total = total / max(float(total.max()), 1.0)   # over 1 where overprinting layers add up
    return {"p01": [spacing(p[m], d, sigma=sigma).p01 if np.count_nonzero(m) >= MIN_DOTS else None
                    for m, d in zip(mine, dens)],
            "p01_joint": spacing(p, total, sigma=sigma).p01}


def color_measures(points, pen, layers, colors, rgb, *, sigma=None, tone_sigma=3.0, invert=False):
    """Colour fidelity and spacing of a colour stippling.

    Parameters
    ----------
    points : (n, 2) array_like
        All dots, pixel units.
    pen : (n,) array_like of int
        Pen per dot.
    layers : (P, H, W) array_like
        The separated layers the pens draw (coverage in [0, 1]).
    colors : (P, 3) array_like
        Pen colours, sRGB in [0, 1].
    rgb : (H, W, 3) array_like
        The photograph, sRGB in [0, 1].
    sigma : float, optional
        Blur in pixels for Delta E; default one dot spacing ``sqrt(W H / n)``.
    tone_sigma : float
        Blur in pixels for the SSIM and the spacing.
    invert : bool
        Light pens on black paper (:func:`render_pens`).

    Returns
    -------
    dict
        ``delta_e``: mean CIE 1976 Delta E*ab between the photograph and the
        drawing (:func:`render_pens`, each pen's dots at the radius holding
        its layer's ink, :func:`~diskpack_cl.pen_radii.pen_ink_radii`), both blurred by `sigma` in
        linear light;
        ``ssim``: per pen, :func:`diskpack_cl.picture_measures.tone_ssim` of its
        dots against its layer; ``p01`` and ``p01_joint``: :func:`pen_spacing`
        against the layers (SSIM and P01 None for a pen of fewer than
        :data:`MIN_DOTS` dots).

    Examples
    --------
    >>> from diskpack_cl import stipple_colors
    >>> img = np.dstack([np.tile(np.linspace(0, 1, 32), (24, 1)), np.full((24, 32), 0.3), np.full((24, 32), 0.8)])
    >>> res = stipple_colors(img, 80, "cmyk", backend="exact", schedule=[("mix", 3, 0.5)])
    >>> m = color_measures(res.points, res.pen, res.layers, res.colors, img)
    >>> sorted(m), len(m["p01"]) == len(res.names)
    (['delta_e', 'p01', 'p01_joint', 'sigma', 'ssim'], True)
    """
    from scipy import ndimage  # not loaded at start-up

    from .picture_measures import tone_ssim  # not loaded at start-up

    p, pen, layers = np.asarray(points, float), np.asarray(pen), np.asarray(layers, float)
    P, H, W = layers.shape
    counts = np.bincount(pen, minlength=P)
    sigma = float(np.sqrt(W * H / len(p))) if sigma is None else float(sigma)
    drawn = render_pens(p, pen, pen_ink_radii(p, pen, layers), colors, (H, W), invert=invert)

    def blur(lin):
        return linear_to_srgb(ndimage.gaussian_filter(lin, (sigma, sigma, 0), mode="reflect"))

    mine = [pen == q for q in range(P)]
    return {
        "delta_e": delta_e(blur(drawn), blur(srgb_to_linear(rgb))),
        "ssim": [tone_ssim(p[m], a, sigma=tone_sigma) if c >= MIN_DOTS else None
                 for m, a, c in zip(mine, layers, counts)],
        **pen_spacing(p, pen, (H, W), layers=layers, sigma=tone_sigma),
        "sigma": sigma,
    }
