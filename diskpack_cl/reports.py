"""The numbers (and figure) of ``diskpack analyze``: point sets on the unit torus, or a stippling.

:func:`analyze` reads the files, tells a stippling (an ``.npz`` with radii,
width and height) from point sets, checks them and returns the numbers of
:mod:`diskpack_cl.plots`, drawing the report figure when asked.
"""

from __future__ import annotations

import importlib.util

import numpy as np

__all__ = ["PLOT_HINT", "have_matplotlib", "analyze", "analyze_stippling", "analyze_point_sets"]

PLOT_HINT = 'figures need matplotlib: pip install "diskpack_cl[plot]"'


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


def analyze(paths, *, image=None, output=None, invert=False, allow_large=False, sigma=3.0,
            kmax=None, title=None):
    """The numbers of one stippling ``.npz`` (with its input `image`) or of point sets.

    Draws the report figure to `output` when given and matplotlib is there.

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
    return analyze_point_sets(paths, output=output, kmax=kmax, title=title)


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


def analyze_point_sets(paths, *, output=None, kmax=None, title=None):
    """Spectra and measures of the point files `paths` (realizations of one process).

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl.io import write_points
    >>> path = os.path.join(tempfile.mkdtemp(), "points.npy")
    >>> write_points(path, np.random.default_rng(0).random((100, 2)))
    >>> numbers = analyze_point_sets([path], kmax=8)
    >>> numbers["n"], numbers["realizations"]
    (100, 1)
    """
    from .io import read_points
    from .measures import nearest_neighbor_distances

    sets = []
    for path in paths:
        pts = read_points(path, min_points=2)
        if np.any(pts < 0) or np.any(pts > 1):
            raise ValueError(f"{path}: points must lie on the unit torus [0,1)^2 (a stippling "
                             f"in pixels is analyzed through its .npz with --image)")
        same = nearest_neighbor_distances(pts) == 0
        if same.any():
            raise ValueError(f"{path}: {int(same.sum())} of {len(pts)} points coincide with "
                             f"another (first: row {int(np.argmax(same))}); rho, the spectra "
                             f"and the hexatic order need distinct points")
        sets.append(pts)
    if output is not None and have_matplotlib():
        from .plots import point_set_report

        return point_set_report(sets, output, title=title, kmax=kmax)
    from .plots import point_set_numbers

    return point_set_numbers(sets, kmax=kmax)
