"""The numbers (and figure) of ``diskpack analyze``: point sets on the unit torus, or a stippling.

:func:`analyze` reads the files, tells a stippling (an ``.npz`` with radii,
width and height) from point sets, checks them and returns the numbers of
:mod:`diskpack_cl.plots`, drawing the report figure when asked.
"""

from __future__ import annotations

import importlib.util

import numpy as np

__all__ = ["PLOT_HINT", "have_matplotlib", "analyze", "analyze_stippling", "analyze_point_sets",
           "point_file_box"]

PLOT_HINT = 'figures need matplotlib: pip install "diskpack_cl[plot]"'


def have_matplotlib():
    """Whether matplotlib can be imported (the report figures need it)."""
    try:
        return importlib.util.find_spec("matplotlib.figure") is not None
    except (ImportError, ValueError):
        return False


def analyze(paths, *, image=None, output=None, invert=False, allow_large=False, sigma=3.0,
            kmax=None, title=None, box=None):
    """The numbers of one stippling ``.npz`` (with its input `image`) or of point sets.

    Draws the report figure to `output` when given and matplotlib is there.
    Point sets lie on the unit torus, or in a box: `box` ``(W, H)``, or the
    ``box`` array that ``diskpack poisson --box`` writes into an ``.npz``
    (see :func:`analyze_point_sets`).

    Raises
    ------
    ValueError
        A stippling with other files, without `image` or of another size; an
        `image` for point sets; points off the unit torus or coinciding.
    """
    from .export import read_stipple

    stipplings = [read_stipple(p) if str(p).lower().endswith(".npz") else None for p in paths]
    if any(s is not None for s in stipplings):
        if len(paths) != 1:
            raise ValueError("a stippling .npz (with radii, width, height) is analyzed alone; "
                             "give one file")
        return analyze_stippling(paths[0], stipplings[0], image, output=output, invert=invert,
                                 allow_large=allow_large, sigma=sigma, title=title)
    if image is not None:
        raise ValueError("--image is for a stippling .npz; these are point sets")
    return analyze_point_sets(paths, output=output, kmax=kmax, title=title, box=box)


def analyze_stippling(path, st, image, *, output=None, invert=False, allow_large=False,
                      sigma=3.0, title=None):
    """Tone, spacing and the certificate (re-checked) of the stippling `st` read from `path`."""
    from .geometry import Domain, certify_disks
    from .image import load_gray

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
        from .plots import stipple_report

        return stipple_report(points, radii, darkness, output, certificate=cert, sigma=sigma,
                              title=title)
    from .plots import stipple_numbers

    return stipple_numbers(points, radii, darkness, cert, sigma=sigma)


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
    with np.load(path) as z:
        if "box" not in z.files:
            return None
        box = np.asarray(z["box"], dtype=np.float64).ravel()
    if box.shape != (2,) or not np.all(np.isfinite(box) & (box > 0)):
        raise ValueError(f"{path}: 'box' must be two positive sizes, got {box.tolist()}")
    return float(box[0]), float(box[1])


def _sets_box(paths, box):
    """The box of the point files: `box` if given, else the one their .npz record (all
    alike), else None (the unit torus)."""
    if box is not None:
        return float(box[0]), float(box[1])
    boxes = {point_file_box(p) for p in paths}
    if len(boxes) > 1:
        raise ValueError(f"the files record different boxes: {sorted(boxes, key=str)}")
    return boxes.pop()


def analyze_point_sets(paths, *, output=None, kmax=None, title=None, box=None):
    """Spectra and measures of the point files `paths` (realizations of one process).

    On the unit torus, or in the box ``(W, H)`` (`box`, or the files' own
    ``box`` record): there without wrap and with a Hann-windowed
    periodogram (:mod:`diskpack_cl.box_analysis`).
    """
    from .domain import Domain
    from .io import read_points
    from .measures import nearest_neighbor_distances

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
        from .plots import point_set_report

        return point_set_report(sets, output, title=title, kmax=kmax, box=box)
    from .plots import point_set_numbers

    return point_set_numbers(sets, kmax=kmax, box=box)
