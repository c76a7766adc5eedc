"""Poisson disk sets the way graphics users ask for them.

:func:`poisson_disk` takes either a count ``n`` or a minimum distance, a
domain (the unit torus or a box of any size and aspect ratio, with exact
walls), an optional mask (an image, a polygon or a callable) where the
points may lie, or a density for variable spacing, and a seed or a
``numpy.random.Generator``.  :class:`diskpack_cl.PoissonDisk`
(:mod:`diskpack_cl.qmc`) hands it out as ``scipy.stats.qmc.PoissonDisk``'s engine.

Two radii meet here.  scipy's ``radius`` (and this module's
``min_distance``) is the smallest distance between two points.  The paper's
Poisson disk radius ``r`` is half of it: disks of radius ``r`` around the
points do not overlap.  The normalized radius is
``rho = r / r_max(n)``, ``r_max(n) = sqrt(area / (2 sqrt(3) n))`` the
radius of the hexagonal packing of n disks in the area (rho = 1).

Given a minimum distance ``D``, the set holds the most points for which
``D`` means ``rho <= rho_max`` (default 0.8, the paper's eps: sets much
beyond it start to look regular), and one relaxation brings it there: no
search over n.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields, replace

import numpy as np

from ._checks import check_point_count, check_seed, count_text, seed_text
from .domain import Domain, box_sizes
from .memory import PageReserve, check_poisson_memory, freed_memory_kept
from .measures import HEXAGONAL_CELL, hexagonal_radius, min_distance as _min_distance
from .options import check_fields, option
from .preview import Previewable
from .relax import RelaxOptions, relax_poisson

__all__ = ["PoissonDiskResult", "PoissonOptions", "PoissonSetOptions", "as_box", "count_for_distance",
           "poisson_disk", "poisson_job", "poisson_summary", "start_points"]

#: Grid cells per side on which a callable mask or density is sampled.
FIELD_SAMPLES = 512

#: Relative radius of the dart-throwing start.  From 0.72 rather than 0.70,
#: 1M points go local after 2 (over-relaxed) global iterations instead of 3,
#: with the spectra of plain relaxation (from 0.70 the ring peak rises), for
#: about 0.2 s more of throwing (8 rounds instead of 4); at 0.74 the throwing
#: needs 19 rounds and a shrink, and saves no further iteration.
START_RADIUS = 0.72

#: A box longer than this many times its width throws its start darts folded into a
#: near-square (:func:`start_points`).
FOLD_ASPECT = 2.0

#: Bytes a point whose pages a thread touches on the cores' idle time while the darts
#: are thrown (:class:`~diskpack_cl.memory.PageReserve`): the relaxation's first arrays
#: (its MIC inputs and outputs, the moves, the local steps) then take pages already
#: touched, where each fresh one would be a page fault on the way.
RESERVED_BYTES_PER_POINT = 250

#: The start sets :func:`poisson_disk` draws.
STARTS = ("dart", "random")


def _check_start(init):
    if init not in STARTS:
        raise ValueError(f"init must be 'dart' or 'random', got {init!r}")


@dataclass(frozen=True)
class PoissonOptions(RelaxOptions):
    """The options of a Poisson disk set (:func:`poisson_disk`, ``diskpack poisson``).

    The relaxation's fields (:class:`~diskpack_cl.relax.RelaxOptions`) and
    the start set, the dimension and the route.

    Examples
    --------
    >>> PoissonOptions(dart_radius=0.7).replace(eps=0.75).eps
    0.75
    >>> PoissonOptions(init="grid")
    Traceback (most recent call last):
    ...
    ValueError: init must be 'dart' or 'random', got 'grid'
    """

    init: str = option("dart", "start set: dart throwing (default) or uniform random; on the "
                       "command line also a point file, relaxed as `diskpack relax` relaxes it",
                       check=_check_start, cli_type=str, metavar="dart|random|FILE",
                       group="start set")
    dart_radius: float = option(START_RADIUS, "relative radius of the dart-throwing start",
                                lo=0, hi=0.78, lo_open=True, hi_open=True, metavar="R",
                                group="start set")
    rho_max: float = option(0.8, "with a minimum distance: the largest rho it may ask for",
                            lo=0, hi=1, lo_open=True, hi_open=True, metavar="RHO")
    dim: int = option(2, "3: points in the unit 3-torus or a box WxHxD, relaxed to the centres "
                      "of the largest spheres in their 3D Voronoi cells (rho against FCC)",
                      choices=(2, 3), cli_type=int)
    local: bool = option(True, "end with local iterations (the fast route); False: Algorithm 1 "
                         "throughout, every cell certified", cli=False)

    def __post_init__(self):
        check_fields(self)


_OPTION_NAMES = {f.name for f in fields(PoissonOptions)}

#: Title of the fields that say how large a set is (the command line takes one of them).
SIZE = "size"


@dataclass(frozen=True)
class PoissonSetOptions:
    """The set ``diskpack poisson`` makes (:func:`poisson_job`, :func:`poisson_disk`): its
    size (``n``, ``min_distance``, or the Poisson disk ``radius`` to search the largest n
    for, :func:`diskpack_cl.max_points_for_radius`), its seed and where its points go (the
    ``mask`` and ``density`` images).

    Examples
    --------
    >>> PoissonSetOptions(min_distance=0.1).min_distance
    0.1
    >>> PoissonSetOptions(radius=0.3)
    Traceback (most recent call last):
    ...
    ValueError: radius must be in (0, 0.25), got 0.3
    """

    n: int = option(None, "number of points (default 1024; with --init FILE: the file's count; "
                    "with --mask: about N inside it)",
                    check=check_point_count, cli_type=count_text, metavar="N", flag="-n",
                    group=SIZE)
    min_distance: float = option(None, "instead of -n: the smallest distance between points "
                                 "(scipy's radius; twice the paper's radius R): as many points "
                                 "as D allows at rho <= --rho-max, relaxed once until they "
                                 "reach it", lo=0, lo_open=True, metavar="D", group=SIZE)
    radius: float = option(None, "instead of -n: find the largest n whose relaxation reaches "
                           "Poisson disk radius R (half the minimum distance, 0 < R < 0.25; the "
                           "paper's Fig. 7) and write that set; --eps is not used, --max-iter "
                           "caps each trial (default 300)", lo=0, hi=0.25, lo_open=True,
                           hi_open=True, metavar="R", group=SIZE)
    seed: int = option(None, "random seed (default: a fresh one, printed in the --json summary)",
                       check=check_seed, cli_type=seed_text)
    mask: str = option(None, "points only where the image is light (> 0.5 gray; the image spans "
                       "--box, default: the image's aspect, longer side 1): a set of the box cut "
                       "by the mask, so -n N gives about N inside it (within about 1 in 100)",
                       metavar="IMAGE")
    density: str = option(None, "variable spacing: more points where the image is dark (unequal "
                          "disk packing; needs -n)", metavar="IMAGE")

    def __post_init__(self):
        check_fields(self)


@dataclass
class PoissonDiskResult(Previewable):
    """Outcome of :func:`poisson_disk`. A notebook shows its points as dots
    (``_repr_png_``), as :meth:`preview` returns them.

    Attributes
    ----------
    points : (n, 2) float64
        The points, in the domain's coordinates (inside the mask if one was
        given).
    domain : Domain
    rho : float
        Normalized Poisson disk radius of the relaxed set in its domain (for
        a mask: of the set before the mask was applied).
    min_distance : float
        Smallest distance between two returned points (periodic on a torus).
    reached : bool
        The set reached its goal: ``rho >= eps`` for a count, the minimum
        distance for a distance.  A density has no such goal (always True).
    stop_reason : str
        The relaxation's (``eps``, ``stalled`` or ``max_iter``).
    iterations : int
    seconds, start_seconds : float
        Wall time of the relaxation and of the start set.
    eps : float
        The rho the relaxation aimed at.
    timings : dict
        Seconds per stage of the relaxation (:attr:`RelaxResult.timings`;
        ``local``: the local tail iterations and the final KD-tree measure).
    rho_start : float
        Normalized radius of the start set (NaN for a density).
    backend, device : str
        Where the relaxation ran (:attr:`RelaxResult.backend`; empty for a
        density).
    stats : dict
        The relaxation's :attr:`RelaxResult.stats` (``fallback``: why
        ``backend="auto"`` took the exact backend).
    stages : dict
        Where the relaxation (or a density's stippling) ran:
        :attr:`RelaxResult.stages` (:attr:`~diskpack_cl.stipple.StippleResult.stages`).

    Examples
    --------
    >>> res = poisson_disk(200, seed=0, backend="exact")
    >>> res.points.shape, res.reached, bool(res.rho >= 0.8), res.stop_reason
    ((200, 2), True, True, 'eps')
    """

    points: np.ndarray
    domain: Domain
    rho: float
    min_distance: float
    reached: bool
    stop_reason: str
    iterations: int
    seconds: float
    start_seconds: float
    eps: float
    timings: dict = field(default_factory=dict)
    rho_start: float = float("nan")
    backend: str = ""
    device: str = ""
    stats: dict = field(default_factory=dict)
    stages: dict = field(default_factory=dict)


def as_box(box):
    """The domain `box` names: None or ``"torus"`` (the unit torus), ``(W, H)`` or ``"WxH"``.

    Examples
    --------
    >>> as_box("2x1")
    Domain(width=2.0, height=1.0, periodic=False)
    >>> as_box(None).periodic
    True
    """
    if box is None or (isinstance(box, str) and box == "torus"):
        return Domain.torus()
    if isinstance(box, Domain):
        return box
    return Domain.rect(*box_sizes(box, "WxH"))


def count_for_distance(min_distance, area, rho_max=0.8, dim=2):
    """The most points whose hexagonal radius makes `min_distance` a rho of at most `rho_max`.

    ``n = floor(area rho_max^2 / (2 sqrt(3) (min_distance / 2)^2))``; for
    ``dim=3`` `area` is a volume and the radius the FCC packing's:
    ``n = floor(volume rho_max^3 / (4 sqrt(2) (min_distance / 2)^3))``.

    Examples
    --------
    >>> count_for_distance(0.026, 1.0)    # the paper's Fig. 7 radius 0.013
    1093
    >>> count_for_distance(0.1, 1.0, dim=3)
    724
    """
    if not (np.isfinite(min_distance) and min_distance > 0):
        raise ValueError(f"min_distance must be positive, got {min_distance}")
    if not 0.0 < rho_max < 1.0:
        raise ValueError(f"rho_max must be in (0, 1), got {rho_max}")
    if dim == 3:
        return int(np.floor(area * rho_max ** 3 / (4 * np.sqrt(2) * (0.5 * min_distance) ** 3)))
    return int(np.floor(area * rho_max ** 2 / (HEXAGONAL_CELL * (0.5 * min_distance) ** 2)))


def start_points(n, domain, seed=None, device=None, *, init="dart", dart_radius=START_RADIUS):
    """A start set of `n` points on the torus or in a box: dart throwing or uniform random.

    The darts are thrown in parallel rounds
    (:func:`diskpack_cl.parallel_darts.parallel_darts`, relative radius
    :data:`START_RADIUS`; ``docs/poisson.md`` describes the rounds and what
    they cost; ``dart_radius``: their relative radius).  ``init="random"``:
    independent uniform points instead.  In a box ``W x H`` the darts are thrown on a square torus of side
    ``max(W, H)`` with enough points that at least `n` fall in the box
    inset by a disk radius (where relaxed points end up: the walls push
    them that far in, so the relaxation saves most of its iterations); the
    box keeps those and drops its surplus at random (so its spacing is at
    least the torus set's).  A box longer than :data:`FOLD_ASPECT` times
    its width is cut into bands along its length that are stacked into a
    near-square, thrown there at once and laid end to end again; of each
    pair across a seam closer than the darts' spacing one point goes: the
    darts cost in proportion to `n`, not to the aspect.  `device`: where
    the darts' distance tests run (see :func:`~diskpack_cl.parallel_darts.parallel_darts`; the same set).

    Examples
    --------
    >>> start_points(100, Domain.rect(2, 1), seed=0).max(axis=0) <= (2, 1)
    array([ True,  True])
    """
    from .parallel_darts import parallel_darts
    from .sampling import make_rng

    rng = make_rng(seed)
    if init == "random":
        return rng.random((n, 2)) * domain.size
    if domain.periodic:
        return parallel_darts(n, rel_radius=dart_radius, seed=rng, device=device)
    inset = min(0.74 * hexagonal_radius(n, domain.area), 0.25 * min(domain.width, domain.height))
    inner = domain.size - 2.0 * inset
    folded = max(inner) > FOLD_ASPECT * min(inner)
    pts = (_darts_folded if folded else _darts_in_rect)(n, inner, rng, device, dart_radius)
    return pts[np.sort(rng.choice(len(pts), n, replace=False))] + inset


def _darts_in_rect(n, size, rng, device, dart_radius):
    """At least `n` darts in the rectangle ``[0, size]``: those of a square torus of side
    ``max(size)`` that fall inside, with enough thrown that n do."""
    from .parallel_darts import parallel_darts

    side = max(size)
    m = int(np.ceil((n + 4.0 * np.sqrt(n) + 8.0) * side ** 2 / np.prod(size)))
    while True:
        pts = parallel_darts(m, rel_radius=dart_radius, seed=rng, device=device) * side
        pts = pts[(pts[:, 0] <= size[0]) & (pts[:, 1] <= size[1])]   # a column at a time
        if len(pts) >= n:
            return pts
        m = int(m * 1.1) + 1  # pragma: no cover - 4 sigma short


def _darts_folded(n, size, rng, device, dart_radius):
    """At least `n` darts in a long rectangle, thrown folded: its length cut into k bands
    stacked into a near-square (k about the root of the aspect), thrown there at once
    (darts cost in proportion to the points, not to the box's aspect), then laid end to
    end; of each pair across a seam closer than the darts' spacing, one point goes."""
    from scipy.spatial import cKDTree

    long = int(np.argmax(size))
    length, width = size[long], size[1 - long]
    k = max(1, int(round(np.sqrt(length / width))))
    want = int(np.ceil(n * 1.02)) + 8
    while True:
        folded = _darts_in_rect(want, np.array([length / k, k * width]), rng, device, dart_radius)
        spacing = cKDTree(folded).query(folded, k=2)[0][:, 1].min()
        band = np.minimum((folded[:, 1] // width).astype(np.int64), k - 1)
        along = folded[:, 0] + band * (length / k)
        across = folded[:, 1] - band * width
        pts = np.column_stack([along, across] if long == 0 else [across, along])
        close = cKDTree(pts).query_pairs(spacing, output_type="ndarray")
        pts = np.delete(pts, np.unique(close[:, 1]), axis=0)
        if len(pts) >= n:
            return pts
        want = int(want * 1.05) + 1  # pragma: no cover - seams took more than 2 %


def _field(field, domain, name):
    """A mask or density as a 2D array over the box (row 0 at y = 0), from an array or callable."""
    if callable(field):
        side = max(domain.width, domain.height)
        nx = max(1, int(round(FIELD_SAMPLES * domain.width / side)))
        ny = max(1, int(round(FIELD_SAMPLES * domain.height / side)))
        x = (np.arange(nx) + 0.5) * domain.width / nx
        y = (np.arange(ny) + 0.5) * domain.height / ny
        field = field(*np.meshgrid(x, y))
    a = np.asarray(field, dtype=np.float64)
    if a.ndim != 2 or min(a.shape) < 1:
        raise ValueError(f"{name} must be a 2D array or a callable f(x, y), got shape {a.shape}")
    if not np.all(np.isfinite(a)) or a.min() < 0:
        raise ValueError(f"{name} must be finite and non-negative")
    return a


def _lookup(image, points, domain):
    """Values of `image` (pixels spanning the box, row 0 at y = 0) at `points`."""
    h, w = image.shape
    ix = np.clip((points[:, 0] * (w / domain.width)).astype(np.int64), 0, w - 1)
    iy = np.clip((points[:, 1] * (h / domain.height)).astype(np.int64), 0, h - 1)
    return image[iy, ix]


def _in_polygon(points, vertices):
    """Even-odd rule: which points lie inside the polygon with these vertices."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3 or not np.all(np.isfinite(v)):
        raise ValueError(f"polygon must be (k, 2) finite vertices with k >= 3, got {v.shape}")
    inside = np.zeros(len(points), dtype=bool)
    x, y = points[:, 0], points[:, 1]
    for (x0, y0), (x1, y1) in zip(v, np.roll(v, -1, axis=0)):
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < xc)
    return inside


def _region(mask, polygon, domain):
    """``(inside(points) -> bool array, area share of the box)`` of a mask or polygon."""
    if mask is not None and polygon is not None:
        raise ValueError("give a mask or a polygon, not both")
    if polygon is not None:
        def inside(p):
            return _in_polygon(p, polygon)
    else:
        image = _field(mask, domain, "mask") > 0.5

        def inside(p):
            return _lookup(image, p, domain)
    share = _share(inside, domain)
    if share == 0.0:
        raise ValueError("the mask leaves no room for points (no part of the box is inside)")
    return inside, share


def _share(inside, domain, margin=0.0):
    """The share of the box less `margin` on every side that `inside` holds (on a grid)."""
    side = max(domain.width, domain.height)
    nx = max(1, int(round(FIELD_SAMPLES * domain.width / side)))
    ny = max(1, int(round(FIELD_SAMPLES * domain.height / side)))
    inner = np.asarray(domain.size, dtype=float) - 2.0 * margin
    gx, gy = np.meshgrid(margin + (np.arange(nx) + 0.5) * inner[0] / nx,
                         margin + (np.arange(ny) + 0.5) * inner[1] / ny)
    return float(inside(np.column_stack([gx.ravel(), gy.ravel()])).mean())


def poisson_disk(n=None, *, min_distance=None, box=None, mask=None, polygon=None, density=None,
                 seed=None, walls="disks", options=None, device=None, callback=None, verify=False,
                 profile=False, **overrides):
    """A Poisson disk set by disk packing: a count or a minimum distance, torus or box.

    Parameters
    ----------
    n : int, optional
        Number of points (for a mask or polygon: about n land inside it,
        within about 1 in 100: the set is made in the box and cut).
    min_distance : float, optional
        Instead of `n`: the smallest distance between points (scipy's
        ``radius``; twice the paper's Poisson disk radius).  The set holds
        :func:`count_for_distance` points and is relaxed until it reaches
        the distance, in one run.
    box : None, "torus", "WxH", (W, H) or Domain, optional
        The unit torus (default) or the box ``[0, W] x [0, H]``, whose walls
        clip every Voronoi cell exactly.
    mask : (h, w) array_like or callable, optional
        Where points may lie: pixels > 0.5 (row 0 at y = 0, spanning the
        box), or ``mask(x, y) -> array``.  The set is made in the box and
        restricted to the mask, so its spacing holds inside.
    polygon : (k, 2) array_like, optional
        Instead of `mask`: the vertices of a polygon (even-odd rule).
    density : (h, w) array_like or callable, optional
        Relative point density over the box (variable spacing), by unequal
        disk packing (:func:`diskpack_cl.stipple`); needs `n`.
    seed : int, numpy.random.Generator or None, optional
    walls : {"disks", "points"}, optional
        What a box's walls bound.  ``"disks"`` (default): the disks of
        radius half the spacing lie inside the box, so the points keep half
        a spacing from the walls.  ``"points"`` (the meaning of
        :class:`diskpack_cl.PoissonDisk` and scipy's, where the spacing is
        between points only): the points reach the walls.  The disks are
        packed in the box grown by their radius on every side and the points
        moved back; a point the relaxation left nearer a grown wall than
        the radius goes to the wall, or is dropped where that brings it
        nearer another point than the set's distance.  No mask,
        polygon or density.
    options : PoissonOptions, optional
        The start set, the relaxation and the route (default
        ``PoissonOptions()``): ``eps`` (with `n`: the rho to reach, the
        paper's 0.8), ``rho_max`` (with `min_distance`: the largest rho the
        distance may ask for), ``init`` and ``dart_radius`` (the start set),
        ``dim`` (3: points in the unit 3-torus or a box ``WxHxD``, relaxed to
        the centres of the maximal inscribed spheres of their 3D Voronoi
        cells, rho normalized by the FCC packing; no mask or density),
        ``local`` (2D: end with local iterations; 3D: take the device's proven
        spheres without the host's re-solve of every cell; the set returned
        is measured exactly on the host either way; ``False``: Algorithm 1
        throughout, every cell certified), ``backend``, ``max_iter``,
        ``patience``, ``grid``.
    device, callback, verify, profile :
        Passed to :func:`diskpack_cl.relax_poisson`.
    **overrides
        Fields of `options` by name (``eps=0.85``), checked as the object
        checks them.

    Returns
    -------
    PoissonDiskResult

    Raises
    ------
    ValueError
        Neither or both of `n` and `min_distance`, a bad box, mask,
        polygon or density, or a distance that leaves fewer than 2 points.

    Examples
    --------
    >>> res = poisson_disk(min_distance=0.1, box="2x1", seed=0, backend="exact")
    >>> len(res.points), res.reached, bool(res.min_distance >= 0.1)
    (147, True, True)
    """
    if (n is None) == (min_distance is None):
        raise ValueError("give exactly one of n or min_distance")
    opt = (options or PoissonOptions()).replace(**overrides)
    if walls != "disks":
        grown, inset = _grown_box(walls, n, min_distance, box, opt, (mask, polygon, density))
        res = poisson_disk(n, min_distance=min_distance, box=tuple(grown.size + 2 * inset),
                           seed=seed, options=opt, device=device, callback=callback,
                           verify=verify, profile=profile)
        return replace(res, points=_onto_walls(res.points - inset, grown.size, res.min_distance),
                       domain=grown)
    if opt.dim == 3:
        if mask is not None or polygon is not None or density is not None:
            raise ValueError("3D sets take no mask, polygon or density")
        return _relaxed3(n, min_distance, box, seed, opt,
                         dict(backend=opt.backend, device=device, callback=callback,
                              max_iter=opt.kwargs()["max_iter"], patience=opt.patience,
                              certify=not opt.local))
    domain = as_box(box)
    if density is not None:
        if min_distance is not None or mask is not None or polygon is not None:
            raise ValueError("a density sets the spacing itself: give n, without a mask")
        return _with_density(n, density, domain, seed, opt.backend, device)
    share, inside = 1.0, None
    if mask is not None or polygon is not None:
        if domain.periodic:
            raise ValueError("a mask or polygon needs a box (box='WxH')")
        inside, share = _region(mask, polygon, domain)
        if n is not None:
            from ._checks import check_count

            # the relaxed points keep about a disk radius from the walls, so the mask gets
            # its share of that inner box, not of the whole box (2 % too many in a disc)
            margin = opt.eps * hexagonal_radius(check_count(n, 2) / share, domain.area)
            share = _share(inside, domain, margin) or share
    n_all, eps = _count_and_eps(n, min_distance, domain.area, share, opt.eps, opt.rho_max)
    _check_size(n_all, domain)
    run = dict(device=device, callback=callback, local=opt.local, verify=verify, profile=profile)
    return _relaxed(n_all, domain, eps, seed, inside, min_distance, opt, run)


def _finite_or_none(value):
    return float(value) if np.isfinite(value) else None


def poisson_summary(res):
    """The summary of a Poisson disk set that every door reports (``--json``, batch records).

    The keys are those of :func:`diskpack_cl.relax.relax_summary` for the same
    quantities, in 2D and 3D; a radius that does not apply (a density's) is
    None.

    Examples
    --------
    >>> s = poisson_summary(poisson_disk(100, seed=0, backend="exact"))
    >>> s["n"], s["dim"], s["torus"], s["reached"]
    (100, 2, True, True)
    """
    return {"n": int(len(res.points)), "dim": int(res.points.shape[1]),
            "box": [float(v) for v in res.domain.size], "torus": bool(res.domain.periodic),
            "iterations": int(res.iterations), "rho_start": _finite_or_none(res.rho_start),
            "rho_final": _finite_or_none(res.rho), "eps": _finite_or_none(res.eps),
            "min_distance": float(res.min_distance), "reached": bool(res.reached),
            "stop_reason": res.stop_reason, "seconds": float(res.seconds),
            "init_seconds": float(res.start_seconds), "backend": res.backend,
            "device": res.device, "stages": res.stages,
            "stage_seconds": {k: float(v) for k, v in res.timings.items()}}


def poisson_job(n, outputs, options=None, *, seed=None, device=None, callback=None, verify=False,
                profile=False, **where):
    """Make one Poisson disk set and write it: what the command line and a batch item run.

    Parameters
    ----------
    n : int or None
        The count (None with ``min_distance`` in `where`).
    outputs : sequence of str
        Point files (``.npz`` also hold ``rho``, ``eps`` and, in a box, ``box``).
    options : PoissonOptions, optional
    seed : int, optional
        The seed (None: a fresh one); the summary records it, so that the set
        can be made again.
    device, callback, verify, profile :
        As for :func:`poisson_disk`.
    **where
        ``min_distance``, ``box``, ``mask``, ``polygon``, ``density`` of
        :func:`poisson_disk`.

    Returns
    -------
    result : PoissonDiskResult
    summary : dict
        :func:`poisson_summary` with ``seed``, ``init`` and ``files``.

    Examples
    --------
    >>> import os, tempfile
    >>> out = os.path.join(tempfile.mkdtemp(), "a.npz")
    >>> res, summary = poisson_job(64, [out], seed=3, backend="exact")
    >>> bool(np.array_equal(np.load(out)["points"], poisson_disk(64, seed=3, backend="exact").points))
    True
    """
    from .io import box_record, write_points

    opt = (options or PoissonOptions()).replace(**{k: where.pop(k) for k in list(where)
                                                   if k in _OPTION_NAMES})
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % 2**31)
    res = poisson_disk(n, seed=seed, options=opt, device=device, callback=callback, verify=verify,
                       profile=profile, **where)
    for out in outputs:
        extra = {}
        if str(out).lower().endswith(".npz"):
            extra = {"rho": res.rho, "eps": res.eps, **box_record(out, res.domain)}
        write_points(out, res.points, **extra)
    summary = {**poisson_summary(res), "seed": seed, "init": opt.init,
               "files": [str(out) for out in outputs]}
    return res, summary


def _grown_box(walls, n, distance, box, opt, region):
    """``walls="points"``: the box and how far its walls move out, the disks' radius (half
    the distance; for a count ``eps r_max(n)`` in the grown box, a fixed point reached
    from below, so the radius the relaxation reaches is never smaller)."""
    from .poisson3 import as_box3, fcc_radius

    if walls != "points":
        raise ValueError(f"walls must be 'disks' or 'points', got {walls!r}")
    if any(v is not None for v in region):
        raise ValueError("walls='points' takes no mask, polygon or density")
    domain = as_box(box) if opt.dim == 2 else as_box3(box)
    if domain.periodic:
        raise ValueError("walls='points' needs a box")
    if distance is not None:
        return domain, 0.5 * float(distance)
    from ._checks import check_count

    r_max, inset, n = (hexagonal_radius if opt.dim == 2 else fcc_radius), 0.0, check_count(n, 2)
    for _ in range(100):   # each step shrinks the gap to the fixed point by 0.9 or more
        inset = opt.eps * r_max(n, float(np.prod(domain.size + 2 * inset)))
    return domain, inset


def _onto_walls(points, size, distance):
    """The points of a packing in the grown box, moved back, inside ``(0, size)``: one
    outside goes to the wall and stays if it keeps `distance` from every other point."""
    from scipy.spatial import cKDTree

    margin = 1e-9 * distance   # inside the open box, as scipy's tests ask of every point
    inside = np.clip(points, margin, size - margin)
    keep = np.ones(len(points), dtype=bool)
    moved = np.flatnonzero(np.any(inside != points, axis=1))
    if len(moved):
        tree = cKDTree(inside)
        for i in moved:   # few: one in thousands, more only in sets of a handful
            near = tree.query_ball_point(inside[i], distance)
            keep[i] = not any(keep[j] for j in near if j != i)
    return inside[keep]


def _count_and_eps(n, distance, area, share, eps, rho_max):
    """Points to relax in the box and the rho to reach: from n (scaled up by the mask's
    share of the box) or from the minimum distance (the rho it means for that count)."""
    from ._checks import check_count

    if distance is None:
        return max(2, int(round(check_count(n, 2) / share))), eps
    n_all = count_for_distance(float(distance), area, rho_max)
    if n_all < 2:
        raise ValueError(f"min_distance {distance:g} leaves {n_all} point(s) in the box "
                         f"at rho <= {rho_max:g}")
    return n_all, min(0.5 * distance / hexagonal_radius(n_all, area) * (1 + 1e-9), rho_max)


def _check_size(n, domain):
    """Refuse, before the work, a set that memory cannot hold or a box narrower than the
    set's spacing (its points would lie on a line)."""
    check_poisson_memory(n)
    spacing = 2.0 * hexagonal_radius(n, domain.area)
    if not domain.periodic and min(domain.size) < spacing:
        raise ValueError(f"a {domain.width:g} x {domain.height:g} box is narrower than the "
                         f"spacing of {n} points in it ({spacing:.3g}): make it wider or "
                         f"ask for more points")


def _relaxed3(n, distance, box, seed, opt, options):
    """The 3D :class:`PoissonDiskResult`: dart throwing, relaxation to the spheres' centres."""
    from ._checks import check_count
    from .poisson3 import as_box3, dart_throwing3, fcc_radius, relax_poisson3

    domain = as_box3(box)
    eps, rho_max = opt.eps, opt.rho_max
    if distance is not None:
        n = count_for_distance(distance, domain.volume, rho_max, dim=3)
        if n < 2:
            raise ValueError(f"min_distance {distance:g} leaves {n} point(s) at rho <= {rho_max:g}")
        eps = min(0.5 * distance / fcc_radius(n, domain.volume) * (1 + 1e-9), rho_max)
    n = check_count(n, 2)
    check_poisson_memory(n)   # as a 2D set's: named before the darts
    t0 = time.perf_counter()
    start = dart_throwing3(n, domain, seed=seed)
    t_start = time.perf_counter() - t0
    res = relax_poisson3(start, eps, domain=domain, **options)
    d_min = float(2 * res.rho[-1] * fcc_radius(n, domain.volume))
    reached = bool(d_min >= distance) if distance is not None else bool(res.rho[-1] >= eps)
    return PoissonDiskResult(res.points, domain, float(res.rho[-1]), d_min, reached,
                             res.stop_reason, res.iterations, res.seconds, t_start, float(eps),
                             res.timings, float(res.rho[0]), res.backend, res.device, res.stats,
                             res.stages)


def _relaxed(n, domain, eps, seed, inside, distance, opt, run):
    """Start set, relaxation (`opt` to `eps`, the keywords `run` of the run), mask: the
    :class:`PoissonDiskResult` of one run."""
    from .device.stage import buffers_handed_on

    t0 = time.perf_counter()
    # the relaxation's MIC outputs take the dart grids' device pages, already touched, and
    # its other arrays the pages of the reserve and those the darts freed
    with freed_memory_kept(), buffers_handed_on():
        reserve = PageReserve(RESERVED_BYTES_PER_POINT * n, idle=True)
        try:
            start = start_points(n, domain, seed, False if opt.backend == "exact" else run["device"],
                                 init=opt.init, dart_radius=opt.dart_radius)
        except BaseException:
            reserve.cancel()
            raise
        reserve.release()
        t_start = time.perf_counter() - t0
        res = relax_poisson(start, eps, opt, domain=domain, **run)
    pts = res.points
    rho = float(res.rho[-1])   # certified by relax_poisson's KD-tree
    d_min = 2.0 * rho * hexagonal_radius(len(pts), domain.area)
    reached = bool(d_min >= distance) if distance is not None else rho >= eps
    if inside is not None:
        pts = pts[inside(pts)]
        d_min = _min_distance(pts, domain) if len(pts) >= 2 else float("inf")
    return PoissonDiskResult(pts, domain, rho, float(d_min), reached, res.stop_reason,
                             res.iterations, res.seconds, t_start, float(eps), res.timings,
                             float(res.rho[0]), res.backend, res.device, res.stats, res.stages)


def _with_density(n, density, domain, seed, backend, device):
    """Variable spacing: unequal disk packing of a density image, scaled to the box."""
    from ._checks import check_count
    from .stipple import stipple

    if domain.periodic:
        domain = Domain.rect(1.0, 1.0)
    dens = _field(density, domain, "density")
    if dens.max() <= 0:
        raise ValueError("density must be positive somewhere")
    gray = 1.0 - dens / dens.max()
    if not isinstance(seed, (int, np.integer)):
        seed = int(np.random.default_rng(seed).integers(2 ** 31))
    t0 = time.perf_counter()
    res = stipple(gray, check_count(n, 2), backend=backend, device=device, seed=int(seed),
                  radii="density")
    h, w = gray.shape
    pts = res.points * (domain.width / w, domain.height / h)
    return PoissonDiskResult(pts, domain, float("nan"), _min_distance(pts, domain), True, "density",
                             len(res.history), time.perf_counter() - t0, 0.0, float("nan"),
                             stages=res.stages)
