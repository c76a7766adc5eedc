"""The numbers (and figure) of ``diskpack analyze``: point sets on the unit torus, or a stippling.

:func:`analyze` reads the files, tells a stippling (an ``.npz`` with radii,
width and height) from point sets, checks them and returns the numbers of
:mod:`diskpack_cl.plots`, drawing the report figure when asked.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, replace

import numpy as np

from .domain import DomainOptions, box_sizes
from .options import check_fields, option
from .geometry import Domain, certify_disks
from .extras import install_command
from .image import load_gray
from .io import load_npz, read_points
from .measures import nearest_neighbor_distances

__all__ = ["PLOT_HINT", "have_matplotlib", "AnalyzeOptions", "analyze", "analyze_stippling",
           "analyze_color_stippling", "analyze_point_sets", "point_file_box"]

PLOT_HINT = "figures need matplotlib: " + install_command("plot")


@dataclass(frozen=True)
class AnalyzeOptions(DomainOptions):
    """The options of :func:`analyze` (``diskpack analyze``): the box of point sets
    (:class:`~diskpack_cl.domain.DomainOptions`), the measures and the figure.

    Examples
    --------
    >>> AnalyzeOptions(sigma=2, box="2x1").sigma
    2.0
    >>> AnalyzeOptions(box="2x1x1")
    Traceback (most recent call last):
    ...
    ValueError: box must be WxH: positive finite sizes, got '2x1x1'
    """

    invert: bool = option(False, "for a stippling: the image was stippled with --invert "
                          "(default: as recorded in the .npz)")
    sigma: float = option(3.0, "for a stippling: Gaussian blur in pixels for tone and spacing "
                          "(default 3)", unit="px", lo=0, lo_open=True)
    kmax: int = option(None, "for point sets: periodogram frequency range (default: automatic)",
                       integer=True, lo=1)
    title: str = option(None, "figure title")

    def __post_init__(self):
        check_fields(self)
        if self.box is not None:
            box_sizes(self.box, "WxH")


def have_matplotlib():
    """Whether matplotlib can be imported (the report figures need it).

    Examples
    --------
    >>> have_matplotlib()
    True
    """
    try:
        return importlib.util.find_spec("matplotlib.figure") is not None
    except (ImportError, ValueError):
        return False


def analyze(paths, options=None, *, image=None, output=None, allow_large=False, **overrides):
    """The numbers of one stippling ``.npz`` (with its input `image`) or of point sets.

    Draws the report figure to `output` when given and matplotlib is there.
    Point sets lie on the unit torus, or in a box: the options' `box`
    (``"WxH"`` or ``(W, H)``), or the ``box`` array that ``diskpack poisson
    --box`` writes into an ``.npz`` (see :func:`analyze_point_sets`).

    Parameters
    ----------
    paths : sequence of str
        One stippling, or point files (realizations of one process).
    options : AnalyzeOptions, optional
        ``invert``, ``sigma``, ``kmax``, ``title`` and ``box``.
    image : str, Path or array_like, optional
        The image a stippling was made from.
    output : str, optional
        The report figure.
    allow_large : bool
        Lift Pillow's decompression-bomb limit for `image`.
    **overrides
        Fields of `options` by name (``sigma=2``), checked as the object checks them.

    Raises
    ------
    ValueError
        A stippling with other files, without `image` or of another size; an
        `image` for point sets; points off the unit torus or coinciding.

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl.io import write_points
    >>> path = os.path.join(tempfile.mkdtemp(), "points.csv")
    >>> write_points(path, np.random.default_rng(1).random((50, 2)))
    >>> analyze([path], kmax=8)["n"]
    50
    """
    from .drawing.writers import read_stipple  # not loaded at start-up

    o = replace(options or AnalyzeOptions(), **overrides)
    stipplings = [read_stipple(p) if str(p).lower().endswith(".npz") or _pen_csv(p) else None
                  for p in paths]
    if any(s is not None for s in stipplings):
        if len(paths) != 1:
            raise ValueError("a stippling .npz (with radii, width, height) is analyzed alone; "
                             "give one file")
        if getattr(stipplings[0], "pen", None) is not None:
            if output is not None:
                raise ValueError(f"{paths[0]} is a colour stippling: its numbers print with "
                                 f"--json; the report figure is for one pen")
            return analyze_color_stippling(paths[0], stipplings[0], image, sigma=o.sigma)
        return analyze_stippling(paths[0], stipplings[0], image, output=output, invert=o.invert,
                                 allow_large=allow_large, sigma=o.sigma, title=o.title)
    if image is not None:
        raise ValueError("--image is for a stippling .npz; these are point sets")
    return analyze_point_sets(paths, output=output, kmax=o.kmax, title=o.title, box=o.box)


def analyze_stippling(path, st, image, *, output=None, invert=False, allow_large=False,
                      sigma=3.0, title=None):
    """Tone, spacing and the certificate (re-checked) of the stippling `st` read from `path`.

    Examples
    --------
    >>> import os, tempfile
    >>> from PIL import Image
    >>> from diskpack_cl import stipple, write_stipple, read_stipple
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> folder = tempfile.mkdtemp()
    >>> image, path = os.path.join(folder, "ramp.png"), os.path.join(folder, "s.npz")
    >>> Image.fromarray((g * 255).astype(np.uint8)).save(image)
    >>> _ = write_stipple(path, stipple(image, 60, schedule=[("mix", 3, 0.5)], backend="exact"))
    >>> numbers = analyze_stippling(path, read_stipple(path), image)
    >>> numbers["n"], numbers["certificate"]["valid"]
    (60, True)
    """
    points, radii, width, height = st.points, st.radii, st.width, st.height
    if image is None:
        raise ValueError(f"{path} is a stippling: give its input image with --image IMAGE "
                         f"(or --image sample)")
    if points.ndim != 2 or points.shape[1:] != (2,) or radii.shape != (len(points),):
        raise ValueError(f"{path}: points must be (n, 2) and radii (n,)")
    invert = bool(st.params.get("invert", False)) or invert
    gray = load_gray(image, invert=invert, allow_large=allow_large)
    if gray.shape != (height, width):
        raise ValueError(f"the image is {gray.shape[1]}x{gray.shape[0]} px but {path} is a "
                         f"stippling of a {width}x{height} px image")
    darkness = 1.0 - gray
    cert = certify_disks(points, radii, Domain.rect(width, height))
    if output is not None and have_matplotlib():
        from .plots import stipple_report  # not loaded at start-up

        return stipple_report(points, radii, darkness, output, certificate=cert, sigma=sigma,
                              title=title)
    from .plots import stipple_numbers  # not loaded at start-up

    return stipple_numbers(points, radii, darkness, cert, sigma=sigma)


def _pen_csv(path):
    """Whether `path` is a colour stippling's CSV (its first line names the pens)."""
    from .drawing.readers import CSV_TAG  # not loaded at start-up

    if not str(path).lower().endswith(".csv"):
        return False
    with open(path, encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    return first.startswith(CSV_TAG) and " pens=" in first


def analyze_color_stippling(path, st, image=None, *, sigma=3.0):
    """Spacing per pen and of all dots, the certificate, and with `image` the colour measures.

    Parameters
    ----------
    path : str or Path
        The file `st` was read from (for messages).
    st : types.SimpleNamespace
        A colour stippling read by :func:`diskpack_cl.read_stipple` (``points``,
        ``radii``, ``pen``, ``names``, ``colors``, ``width``, ``height``,
        ``params``).
    image : str, Path or array_like, optional
        The colour image it was stippled from. It is separated again into
        the pens' layers (CMYK and CMY as such, with the black generation and
        clean tolerances recorded in an ``.npz``; other pens by their colours;
        on black paper where its ``params`` say ``invert``).
    sigma : float
        Blur in pixels for the spacing and SSIM.

    Returns
    -------
    dict
        ``n``, ``width``, ``height``; ``pens``: per pen its ``name``,
        ``color``, ``n`` and ``p01`` (and ``ssim`` with `image`); ``p01_joint``
        of all dots; ``reference``: ``"image"`` (P01 against the layers,
        :func:`diskpack_cl.color_measures.color_measures`, with ``delta_e``) or ``"dots"``
        (against the dots' own density, :func:`diskpack_cl.color_measures.pen_spacing`);
        ``certificate``: re-checked over all dots together.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> x, y = np.meshgrid(np.arange(2.0, 64, 4), np.arange(2.0, 64, 4))
    >>> st = SimpleNamespace(points=np.column_stack([x.ravel(), y.ravel()]), radii=np.full(256, 1.5),
    ...                      pen=np.arange(256) % 2, names=("cyan", "black"), width=64, height=64,
    ...                      colors=np.array([[0.0, 1.0, 1.0], [0.0, 0.0, 0.0]]), params={})
    >>> out = analyze_color_stippling("grid.npz", st)
    >>> [p["n"] for p in out["pens"]], out["reference"], out["certificate"]["valid"]
    ([128, 128], 'dots', True)
    """
    from .color_measures import color_measures, pen_spacing  # not loaded at start-up
    from .image import load_rgb  # not loaded at start-up
    from .pens import palette_of  # not loaded at start-up
    from .separation import separate  # not loaded at start-up
    from .multipen import hex_color  # not loaded at start-up
    from .plots import certificate_items, format_number  # not loaded at start-up

    points, pen, names = np.asarray(st.points, np.float64), np.asarray(st.pen), tuple(st.names)
    W, H = int(st.width), int(st.height)
    if points.ndim != 2 or points.shape[1:] != (2,) or pen.shape != (len(points),):
        raise ValueError(f"{path}: points must be (n, 2) and pen (n,)")
    numbers = {"n": len(points), "width": W, "height": H}
    if image is None:
        measures, numbers["reference"] = pen_spacing(points, pen, (H, W), pens=len(names),
                                                  sigma=sigma), "dots"
    else:
        rgb = load_rgb(image)
        if rgb.shape[:2] != (H, W):
            raise ValueError(f"the image is {rgb.shape[1]}x{rgb.shape[0]} px but {path} is a "
                             f"stippling of a {W}x{H} px image")
        kw = {k: st.params[k] for k in ("black_generation", "clean_black", "clean_white")
              if k in st.params}
        black = bool(st.params.get("invert", False))   # light pens on black paper
        sep = separate(rgb, palette_of(names, st.colors), invert=black, **kw)
        measures = color_measures(points, pen, sep.layers, st.colors, rgb, tone_sigma=sigma,
                                  invert=black)
        numbers.update(reference="image", delta_e=format_number(measures["delta_e"]),
                       delta_e_sigma=format_number(measures["sigma"]))
    counts = np.bincount(pen, minlength=len(names))
    numbers["pens"] = [dict(name=name, color=hex_color(c), n=int(m),
                            p01=format_number(p01) if p01 is not None else None)
                       for name, c, m, p01 in zip(names, st.colors, counts, measures["p01"])]
    for entry, ssim in zip(numbers["pens"], measures.get("ssim", [])):
        entry["ssim"] = None if ssim is None else format_number(ssim)
    numbers["p01_joint"] = format_number(measures["p01_joint"])
    numbers["certificate"] = certificate_items(certify_disks(points, st.radii, Domain.rect(W, H)))
    return numbers


def point_file_box(path):
    """The box ``(W, H)`` recorded in a point ``.npz`` (its ``box`` array), else None.

    Examples
    --------
    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "box.npz")
    >>> np.savez(p, points=np.zeros((2, 2)), box=np.array([2.0, 1.0]))
    >>> point_file_box(p)
    (2.0, 1.0)
    """
    if not str(path).lower().endswith(".npz"):
        return None
    box = load_npz(path).get("box")
    if box is None:
        return None
    box = np.asarray(box).ravel()
    if box.dtype.kind not in "biuf" or box.shape != (2,) or not np.all(np.isfinite(box) & (box > 0)):
        raise ValueError(f"{path}: 'box' must be two positive sizes, got {box.tolist()}")
    return float(box[0]), float(box[1])


def _sets_box(paths, box):
    """The box of the point files: `box` if given, else the one their .npz record (all
    alike), else None (the unit torus)."""
    if box is not None:
        return tuple(box_sizes(box, "WxH"))
    boxes = {point_file_box(p) for p in paths}
    if len(boxes) > 1:
        raise ValueError(f"the files record different boxes: {sorted(boxes, key=str)}")
    return boxes.pop()


def analyze_point_sets(paths, *, output=None, kmax=None, title=None, box=None):
    """Spectra and measures of the point files `paths` (realizations of one process).

    On the unit torus, or in the box ``(W, H)`` (`box`, or the files' own
    ``box`` record): there without wrap and with a Hann-windowed
    periodogram (:mod:`diskpack_cl.box_analysis`).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "points.npy")
    >>> np.save(path, np.random.default_rng(0).random((100, 2)))
    >>> numbers = analyze_point_sets([path], kmax=8)
    >>> numbers["n"], numbers["realizations"]
    (100, 1)
    """
    box = _sets_box(paths, box)
    dom = Domain.torus() if box is None else Domain.rect(*box)
    sets = []
    for path in paths:
        pts = read_points(path, min_points=2)
        if np.any(pts < 0) or np.any(pts > dom.size):
            where = ("on the unit torus [0,1)^2 (a box set: give its box, --box WxH)"
                     if box is None else f"in the box [0, {box[0]:g}] x [0, {box[1]:g}]")
            raise ValueError(f"{path}: points must lie {where} (a stippling in pixels is "
                             f"analyzed through its .npz with --image)")
        same = nearest_neighbor_distances(pts, dom) == 0
        if same.any():
            raise ValueError(f"{path}: {int(same.sum())} of {len(pts)} points coincide with "
                             f"another (first: row {int(np.argmax(same))}); rho, the spectra "
                             f"and the hexatic order need distinct points")
        sets.append(pts)
    if output is not None and have_matplotlib():
        from .plots import point_set_report  # not loaded at start-up

        return point_set_report(sets, output, title=title, kmax=kmax, box=box)
    from .plots import point_set_numbers  # not loaded at start-up

    return point_set_numbers(sets, kmax=kmax, box=box)
