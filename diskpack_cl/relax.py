"""Poisson disk relaxation by disk packing (Algorithm 1 of the paper).

Every iteration moves each point to the centre of the maximal inscribed
circle (MIC) of its Voronoi cell on the unit torus, until the normalized
Poisson disk radius rho reaches `eps`.  The new disks lie inside the old
cells, which do not overlap, so the new minimum distance is at least twice
the smallest MIC radius, which is at least half the old minimum distance:
rho never decreases.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, fields, replace

import numpy as np

from ._cores import on_cores
from .domain import Domain
from .engine import BACKENDS, check_backend, make_engine, stage_record
from .io import validate_points
from .options import check_fields, option
from .memory import check_poisson_memory, freed_memory_kept
from .preview import Previewable
from .progress import stage
from .measures import (HEXAGONAL_CELL, close_pairs, coincident_pairs, hexagonal_radius,
                       min_distance, min_distance_at_most, min_distance_since,
                       nearest_neighbor_distances, normalized_radius)

__all__ = ["relax_poisson", "RelaxOptions", "RELAX_FIELDS", "RelaxResult", "BACKENDS",
           "max_points_for_radius", "TRIAL_RELAX", "RadiusResult", "STALL_GAIN", "OVER_RELAX",
           "relax_summary"]

#: Iteration cap of :func:`relax_poisson` when none is given.
MAX_ITER = 1000


@dataclass(frozen=True)
class RelaxOptions:
    """The options of :func:`relax_poisson` (``diskpack poisson`` and ``relax``).

    Examples
    --------
    >>> RelaxOptions(eps=0.85).kwargs()
    {'eps': 0.85, 'max_iter': 1000, 'backend': 'auto', 'grid': None}
    >>> RelaxOptions().replace(backend="gpu")
    Traceback (most recent call last):
    ...
    ValueError: backend must be one of ('opencl', 'exact', 'auto'), got 'gpu'
    """

    eps: float = option(0.8, "stop when the normalized radius rho reaches EPS (default 0.8)",
                        lo=0, hi=1, lo_open=True, hi_open=True, metavar="EPS")
    max_iter: int = option(None, f"iteration cap (default {MAX_ITER})", integer=True, lo=0,
                           metavar="N")
    backend: str = option("auto", "opencl: MICs on the OpenCL device, checked in float64; "
                          "exact: scipy only; auto (default): opencl when a device exists, "
                          "else exact", cli_choices=BACKENDS, check=check_backend)
    grid: int = option(None, "raster size G x G of the raster route (devices without "
                       "float64; default: automatic)", integer=True, lo=1, metavar="G")
    patience: int = option(100, "iterations without progress before the run stops as stalled",
                           integer=True, lo=1, metavar="N")

    def __post_init__(self):
        check_fields(self)

    def replace(self, **changes):
        """A copy with `changes` (option names), checked."""
        return replace(self, **changes)

    def kwargs(self):
        """The relaxation's options, the iteration cap resolved (JSON for a batch item);
        ``patience`` only where it is not the default, so that a manifest written before
        it was an option still marks its items done."""
        out = {"eps": self.eps, "max_iter": MAX_ITER if self.max_iter is None else self.max_iter,
               "backend": self.backend, "grid": self.grid}
        if self.patience != RelaxOptions.patience:
            out["patience"] = self.patience
        return out


#: The names of :class:`RelaxOptions`' fields.
RELAX_FIELDS = frozenset(f.name for f in fields(RelaxOptions))


def relax_summary(res, eps):
    """The summary of a relaxation that every door reports (``--json``, batch records).

    The keys are those of :func:`diskpack_cl.poisson.poisson_summary` for the same
    quantities (``docs/guide/formats.md``).

    Examples
    --------
    >>> res = relax_poisson(np.random.default_rng(0).random((64, 2)), 0.7, backend="exact")
    >>> s = relax_summary(res, 0.7)
    >>> s["n"], s["stop_reason"], s["rho_final"] >= 0.7
    (64, 'eps', True)
    """
    return {"n": int(len(res.points)), "dim": int(res.points.shape[1]),
            "iterations": int(res.iterations), "rho_start": float(res.rho[0]),
            "rho_final": float(res.rho[-1]), "eps": float(eps), "stop_reason": res.stop_reason,
            "seconds": float(res.seconds), "backend": res.backend, "device": res.device,
            "stages": res.stages,
            "stage_seconds": {k: float(v) for k, v in res.timings.items()}}


#: The local route's first global moves take each point these many times the way to
#: its MIC centre, one factor a move (successive over-relaxation), as far as keeps rho
#: from falling (:func:`_moved`); the later moves are Algorithm 1's (over-relaxing
#: every move of a long run need not converge).  Two such moves order the set as three
#: plain ones do (1M points: ring peak, low-frequency power and abs(psi6) the same
#: within the seeds' spread), and leave 1.5-1.6 % of the points bad: the set goes
#: local after them, one MIC call sooner.
OVER_RELAX = (1.8, 1.2)

#: The local route measures its last rho from the pairs closer than this many
#: ``eps r_max``: none is left below 2, and the smallest is just above (a search
#: at 2 would come back empty and grow, about 1 s at 1M).
FINAL_REACH = 2.1

#: Progress that counts: within ``patience`` iterations rho must grow by this
#: share of itself or of its gap to eps (the smaller), or the run stops as
#: ``"stalled"``; a set creeping towards a rho it cannot reach stops instead
#: of running to ``max_iter``, a tiny cluster that grows geometrically goes on.
STALL_GAIN = 1e-3

#: Fewest points a thread of an over-relaxed move (:func:`_moved`) moves.
MOVE_PART = 100_000


@dataclass
class RelaxResult(Previewable):
    """Outcome of :func:`relax_poisson`. A notebook shows its points as dots
    (``_repr_png_``), as :meth:`preview` returns them (a 3D set: a slice of it).

    Attributes
    ----------
    points : (n, 2) float64
        Relaxed points in [0, 1)^2.
    rho : (iterations + 1,) float64
        Normalized Poisson disk radius before the first and after every iteration.
    iterations : int
    stop_reason : str
        ``"eps"`` (rho reached eps), ``"stalled"`` (rho stopped growing) or
        ``"max_iter"``.
    seconds : float
        Wall time of the iterations.
    timings : dict
        Seconds per stage, summed over iterations: the engine's
        (:mod:`diskpack_cl.engine`), ``buckets``, ``device``, ``refine``,
        ``fallback`` for the per-cell kernel; ``raster_labels``,
        ``mic_estimate``, ``exact`` for the raster route; ``exact`` for scipy.
    backend, device : str
    stats : dict
        ``engine`` (``cells``, ``raster`` or ``exact``), ``fallback`` (why
        ``auto`` chose exact, if it did), and the engine's counts summed over
        iterations (cells the device could not prove and their fallback; for
        the exact solver, widened and linprog cells).

    Examples
    --------
    >>> from diskpack_cl.sampling import dart_throwing
    >>> res = relax_poisson(dart_throwing(200, seed=0), eps=0.8, backend="exact")
    >>> res.stop_reason, bool(res.rho[-1] >= 0.8), len(res.rho) == res.iterations + 1
    ('eps', True, True)
    """

    points: np.ndarray
    rho: np.ndarray
    iterations: int
    stop_reason: str
    seconds: float
    timings: dict
    backend: str
    device: str
    stats: dict = field(default_factory=dict)

    @property
    def seconds_per_iteration(self):
        return self.seconds / max(self.iterations, 1)

    @property
    def stages(self):
        """Where the relaxation ran, as the summaries' ``stages``: ``{"engine": record}``
        (:func:`~diskpack_cl.engine.stage_record`, with the route and any fallback)."""
        why = self.stats.get("fallback")   # the per-cell kernel's count of that name is no reason
        return {"engine": stage_record(self.backend, self.device, route=self.stats.get("engine"),
                                       fallback=why if isinstance(why, str) else None)}


def _check_points(points, domain):
    """The start set as a float64 copy: :func:`~diskpack_cl.io.validate_points`' checks
    (two columns, two points at least, finite, inside a box), wrapped onto a torus, no
    two points the same."""
    X = np.array(validate_points(points, domain=domain))   # a copy: wrapped in place below
    if domain.periodic:
        X = domain.wrap(X, copy=False)
    dup = coincident_pairs(X, domain)
    if len(dup):
        where = "on the torus" if domain.periodic else "in the box"
        shown = ", ".join(f"{i}={j}" for i, j in dup[:5])
        raise ValueError(f"{len(dup)} pair(s) of coincident points {where} (rows {shown}); "
                         "remove duplicates first")
    return X


def relax_poisson(points, eps=None, options=None, *, device=None, callback=None, route="auto",
                  verify=False, profile=False, domain=None, local=False, **overrides):
    """Relax a point set on the unit torus (or in a box) by disk packing until rho >= eps.

    Parameters
    ----------
    points : (n, 2) array_like
        Start set; on a torus, coordinates outside it are wrapped; in a box
        every point must lie inside.
    eps : float, optional
        Target normalized Poisson disk radius, in (0, 1) (default: the
        options', 0.8 as in the paper).
    options : RelaxOptions, optional
        The relaxation's options (default: ``RelaxOptions()``), each field
        described there; with `eps` and `overrides` on top:

        ``max_iter`` (iteration cap); ``backend`` (``opencl``: MICs on the
        OpenCL device, checked in float64 on the host; ``exact``: scipy
        only; ``auto``: opencl when a device exists, else exact; all give
        the same iterates to rounding, every MIC a certified LP optimum, see
        :mod:`diskpack_cl.engine`); ``grid`` (raster size, grid x grid, of
        the raster route; default about 16 grid cells per point);
        ``patience`` (stop as ``"stalled"`` when rho has not grown by
        :data:`STALL_GAIN` of itself or of its gap to `eps` in this many
        iterations).
    device : str or pyopencl.Context, optional
        OpenCL device (see :func:`diskpack_cl.get_context`).
    callback : callable, optional
        ``callback(iteration, rho)`` after each iteration. Inside a run of
        :mod:`diskpack_cl.progress` (``with running(hook):``, around this or
        :func:`diskpack_cl.poisson_disk`) the iterations are also its stage
        ``iterations``, out of `max_iter`.
    route : {"auto", "cells", "raster"}
        OpenCL route: the float64 per-cell kernel (default where the device
        has float64) or the float32 raster estimate refined on the host.
    verify : bool
        Check every iteration against an independent computation: the MIC
        radii against :func:`diskpack_cl.geometry.exact_mic` (to 1e-9) and
        rho against an exact host measure (a cell grid or a KD-tree); raises
        RuntimeError on a mismatch.
    profile : bool
        Profile the OpenCL kernels (``timings["kernel"]`` and
        ``timings["kernel_<name>"]``).
    domain : Domain, optional
        ``Domain.torus()`` (default) or a box ``Domain.rect(W, H)``: there
        each point moves to the centre of the largest disk inside its
        Voronoi cell clipped to the box (the walls are exact constraints),
        and rho is normalized by the box's area.  There rho may drop in
        an iteration (a wall cuts the disk a cell had around its site);
        the smallest MIC radius still never does after the first.
    local : bool
        Once few points are closer than ``2 eps r_max``, move only their
        neighbourhoods (:mod:`diskpack_cl.relax_local`): rho never
        decreases there, far cheaper, but the iterates differ from
        Algorithm 1's.  The global iterations before then take the device's
        proven MICs without the host's re-solve of every cell (unless
        `verify`): the rho returned is measured exactly on the host in any
        case.  Their
        first moves are over-relaxed (:data:`OVER_RELAX`), so the set goes
        local an iteration sooner with the same spectrum.
    **overrides
        Fields of :class:`RelaxOptions` (``max_iter``, ``backend``,
        ``grid``, ``patience``), over those of `options`.

    Returns
    -------
    RelaxResult

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.random.default_rng(0).random((256, 2))
    >>> res = relax_poisson(pts, eps=0.75, backend="exact")
    >>> bool(res.rho[-1] >= 0.75), res.stop_reason
    (True, 'eps')

    The same with the options object:

    >>> opt = RelaxOptions(eps=0.75, backend="exact")
    >>> bool(np.array_equal(relax_poisson(pts, options=opt).points, res.points))
    True
    """
    opt = (options or RelaxOptions()).replace(**({} if eps is None else {"eps": eps}),
                                              **overrides)
    eps, max_iter, patience = opt.eps, opt.kwargs()["max_iter"], opt.patience
    dom = Domain.torus() if domain is None else domain
    X = _check_points(points, dom)
    shape = None if opt.grid is None else (opt.grid, opt.grid)
    engine = make_engine(dom, len(X), opt.backend, device=device, grid=shape, route=route,
                         profile=profile, verify=verify)
    stats = {"engine": engine.name, **({"fallback": engine.fallback} if engine.fallback else {})}
    t_start = time.perf_counter()
    # freed_memory_kept: every iteration makes and drops the same large temporaries
    with freed_memory_kept(), stage("iterations", int(max_iter)) as advance, \
            ThreadPoolExecutor(1) as pool:
        callback = _told(callback, advance)   # and the run's progress (diskpack_cl.progress)
        # the local route measures its last rho on the host itself, from the pairs that
        # hold it, searched on the other core meanwhile (from the set it will go local with)
        reach = FINAL_REACH * eps * hexagonal_radius(len(X), dom.area)
        pairs = (lambda Y: (Y, pool.submit(close_pairs, Y, reach, dom))) if local else None
        X, rho, it, reason, nn, before = _iterate(engine, dom, X, eps, int(max_iter), patience,
                                                  callback, verify, stats, pairs)
        went_local = reason == "local"
        if went_local:
            with engine.timings("local"):
                X, rho, it, reason = _go_local(X, nn, rho, it, eps, dom, int(max_iter), patience,
                                               callback, stats, _local_solver(engine, dom),
                                               before or pairs(X))
    seconds = time.perf_counter() - t_start
    if not went_local or reason != "eps":
        _certify_rho(X, rho[-1], dom)
    return RelaxResult(X, np.array(rho), it, reason, seconds, engine.timings.seconds,
                       engine.backend, engine.device, stats)


def _told(callback, advance):
    """``callback(iteration, rho)`` that first advances the run's ``iterations`` stage."""
    def told(iteration, rho):
        advance(iteration)
        if callback is not None:
            callback(iteration, rho)
    return told


def _iterate(engine, dom, X, eps, max_iter, patience, callback, verify, stats, pairs):
    """The relaxation loop of :func:`relax_poisson`: ``(X, rho list, iterations, stop reason,
    nearest-neighbour distances, before)``; the reason ``"local"`` hands over to local
    iterations.  `pairs` (None: no local iterations) starts the search of an iterate's
    close pairs, ``(X, future)``: from the iterate that will probably go local, once its
    nearest neighbours are in (their kernel has both cores: `before`, None where none did)."""
    local = pairs is not None
    # an engine that gives nearest-neighbour distances gives rho with the MICs
    # the local route measures the rho it returns on the host: its global iterates need
    # the device's proven MICs, not the host's re-solve of every cell (verify still has it)
    certify = not local
    step = _mic(engine, X, stats, certify) if engine.gives_nn else None
    nn = None if step is None else step.nn
    rho = [_rho(X, nn, verify, dom)]
    best_at = 0
    reason = "eps" if rho[0] >= eps else "max_iter"
    it = 0
    guess = True   # nearest neighbours alone where the next iterate will probably go local or end
    before = None
    while rho[-1] < eps and it < max_iter:
        nn, ready, soon = (_local_state(X, nn, eps, dom) if local
                           else (nn, False, _last_soon(rho, eps, it, max_iter)))
        if ready:
            return X, rho, it, "local", nn, before
        # an iterate without its MICs that did not go local or end: the guess failed, so no more
        # (at a high eps the share of bad points hovers above the local one for long)
        guess = guess and (it == 0 or step is not None)
        it += 1
        step = step or _mic(engine, X, stats, certify)
        omega = OVER_RELAX[it - 1] if local and it <= len(OVER_RELAX) else 1.0
        X = _moved(X, step, rho[-1], dom, omega)
        step = nn = None   # their memory serves the next MICs (freed_memory_kept)
        step, nn = _after_move(engine, X, stats, certify, soon and guess)
        before = pairs(X) if local and soon and guess else None
        rho.append(_rho(X, nn, verify, dom))
        if callback is not None:
            callback(it, rho[-1])
        if rho[-1] > rho[best_at] + max(1e-12, STALL_GAIN * min(rho[best_at], eps - rho[best_at])):
            best_at = it
        if rho[-1] >= eps:
            reason = "eps"
        elif it - best_at >= patience:
            reason = "stalled"
            break
    return X, rho, it, reason, None, None


def _moved(X, mic, rho, domain, omega):
    """The points X moved `omega` times the way to their MIC centres (`mic`, a
    :class:`~diskpack_cl.geometry.MIC`; 1: the centres themselves), each no farther past
    its centre than its MIC radius less half the minimum distance of X (`rho` its
    normalized radius): the MIC disks do not overlap, so no two moved points come
    closer than that minimum, and rho does not fall (as in Algorithm 1)."""
    if omega == 1.0:
        return mic.centers
    d_min = 2.0 * rho * hexagonal_radius(len(X), domain.area)
    moved = np.empty_like(mic.centers)
    # on the cores: between two MIC calls, whose kernels wait for it
    on_cores(lambda rows: _move_rows(X[rows], mic.centers[rows], mic.radii[rows], d_min, omega,
                                     domain, moved[rows]), len(X), len(X), MOVE_PART)
    return moved


def _move_rows(X, centers, radii, d_min, omega, domain, out):
    """:func:`_moved` of the rows X (their MICs' `centers` and `radii`, the set's smallest
    distance `d_min`), into `out`."""
    past = domain.shortest(np.subtract(centers, X, out=out))
    z = past.view(np.complex128).ravel()   # one (x, y) row a number: |z| without column copies
    z *= omega - 1.0
    length = np.abs(z)
    room = np.maximum(radii - 0.5 * d_min, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):   # fmin takes 1 over 0/0's NaN
        z *= np.fmin(room / length, 1.0)
    past += centers
    domain.wrap(past, copy=False)


def _local_state(X, nn, eps, dom):
    """``(nn, ready, soon)``: the nearest-neighbour distances of X (a KD-tree's where `nn`
    is None), whether few enough points are bad to go local now, and whether few enough
    are that the next iterate probably will (:data:`~diskpack_cl.relax_local.LOCAL_SOON`)."""
    from .relax_local import LOCAL_SHARE, LOCAL_SOON, bad_points  # not loaded at start-up

    nn = nearest_neighbor_distances(X, dom) if nn is None else nn
    share = len(bad_points(nn, eps, dom.area)) / len(X)
    return nn, share <= LOCAL_SHARE, share <= LOCAL_SOON


def _last_soon(rho, eps, it, max_iter):
    """Whether the next iterate (after `it` of at most `max_iter`) is probably the last:
    it is the last allowed, or the smaller of the last two gains of rho (list of the
    iterates' rho so far) once more would reach `eps` (the last gain alone guessed
    wrong half as often again: the early gains are uneven).  Its nearest neighbours
    then come alone (:func:`_after_move`): the last iterate's MICs would serve no move."""
    return it + 1 >= max_iter or (
        len(rho) >= 3 and rho[-1] + min(rho[-1] - rho[-2], rho[-2] - rho[-3]) >= eps)


def _after_move(engine, X, stats, certify, soon):
    """``(step, nn)`` of the moved set X: its MICs and their nearest-neighbour distances
    from an engine that gives them; where X will `soon` go local or be the last iterate
    and the engine has the per-cell kernel, its nearest-neighbour distances alone (a
    tenth of the MICs' cost at a million sites, a third at a thousand; no step: the MICs
    are solved if the loop goes on after all); else neither."""
    cells = getattr(engine, "cells", None)
    if soon and cells is not None:
        return None, cells.nearest(X)
    step = _mic(engine, X, stats, certify) if engine.gives_nn else None
    return step, None if step is None else step.nn


def _local_solver(engine, dom):
    """The per-cell kernel for the local steps' cells (its own, so that its seconds stay
    out of the global iterations' stages) where the engine has one, else None (exact_mic)."""
    from .device.cells import CellMIC  # not loaded at start-up

    cells = getattr(engine, "cells", None)
    return None if cells is None else CellMIC(dom, device=cells.ctx)


def _go_local(X, nn, rho, it, eps, dom, max_iter, patience, callback, stats, solver=None,
              before=None):
    """Local iterations after `it` global ones (their cells solved by `solver`, a
    :class:`~diskpack_cl.device.cells.CellMIC`, or by exact_mic); the last rho measured on the
    host, from `before` where given: X then, and a future of its
    :func:`~diskpack_cl.measures.close_pairs` within :data:`FINAL_REACH`."""
    from .relax_local import relax_local  # not loaded at start-up

    X, more, reason = relax_local(X, nn, eps, dom, max_iter=max_iter - it, patience=patience,
                                  callback=callback, first=it + 1, stall_gain=STALL_GAIN,
                                  solver=solver)
    stats["local_iterations"] = len(more)
    rho = rho + more
    if reason == "eps":   # no pair left below 2 eps r_max: the exact rho is just above
        r_max = hexagonal_radius(len(X), dom.area)
        rho[-1] = 0.5 * _final_distance(X, FINAL_REACH * eps * r_max, dom, before) / r_max
    return X, rho, it + len(more), reason


def _final_distance(X, reach, dom, before):
    """The exact smallest distance of X: from the pairs within `reach` of the earlier X
    of `before` (:func:`_go_local`), where they serve, searching again only the points
    moved since; else by a search of all of X."""
    pairs = None if before is None else before[1].result()
    d = np.inf if pairs is None else min_distance_since(X, before[0], pairs, dom)
    # every pair within the reach is found, so a minimum at most the reach is exact
    return d if d <= reach else min_distance_at_most(X, reach, dom, grow=True)


def _mic(engine, X, stats, certify=True):
    """One engine call, its counts added up (its seconds are in ``engine.timings``)."""
    step = engine.mic(X, certify=certify)
    for k, v in step.stats.items():
        stats[k] = stats.get(k, 0) + v
    return step


def _rho(X, nn, verify, domain):
    """rho of X: from the engine's nearest-neighbour distances `nn`, or a KD-tree."""
    if nn is None:
        return normalized_radius(X, domain)
    rho = 0.5 * float(nn.min()) / hexagonal_radius(len(X), domain.area)
    if verify:
        _certify_rho(X, rho, domain)
    return rho


def _certify_rho(X, rho, domain):
    """The independent check of rho: the host's pairs within the distance rho claims
    (:func:`~diskpack_cl.measures.min_distance_at_most`; all points' neighbours if none is)."""
    r_max = hexagonal_radius(len(X), domain.area)
    d = min_distance_at_most(X, 2 * rho * r_max * (1 + 1e-9), domain)
    exact = 0.5 * d / r_max if np.isfinite(d) else normalized_radius(X, domain)
    if not abs(exact - rho) <= 1e-12:
        raise RuntimeError(f"rho {rho!r} from the engine disagrees with the host's {exact!r}")


@dataclass
class RadiusResult:
    """Outcome of :func:`max_points_for_radius`.

    Attributes
    ----------
    points : (n, 2) float64
        The relaxed point set with the most points found; its minimum
        distance on the torus is at least ``2 * radius``.
    n : int
    radius : float
        The requested Poisson disk radius (half the minimum distance).
    achieved_radius : float
        ``min_distance(points) / 2``.
    rho : float
        Normalized Poisson disk radius of `points`.
    trials : list of dict
        Every relaxation run, in order: ``n``, ``target_rho``, ``reached``,
        ``rho`` (final), ``iterations``, ``stop_reason``, ``seconds``.
    seconds : float
        Wall time of the whole search.

    Examples
    --------
    >>> res = max_points_for_radius(0.06, seed=0, backend="exact")
    >>> bool(res.achieved_radius >= 0.06), res.n == len(res.points), res.n > 0
    (True, True, True)
    """

    points: np.ndarray
    n: int
    radius: float
    achieved_radius: float
    rho: float
    trials: list
    seconds: float


#: The relaxation of each trial of :func:`max_points_for_radius` unless told otherwise:
#: shorter and less patient than one relaxation, as a failing trial runs to its cap.
TRIAL_RELAX = RelaxOptions(max_iter=300, patience=60)


def max_points_for_radius(radius, options=None, *, start="dart", eps_margin=1e-9, seed=0,
                          rho_start=0.8, rho_limit=0.95, device=None, callback=None, **overrides):
    """The largest n whose relaxation reaches Poisson disk radius `radius` on the unit torus.

    For n points the radius asks for the normalized radius
    ``rho_t(n) = radius / sqrt(1 / (2 sqrt(3) n))``, which grows like
    ``sqrt(n)``. One trial at n throws a start set, relaxes it with
    :func:`relax_poisson` to ``eps = rho_t(n) * (1 + eps_margin)`` and
    succeeds when ``min_distance / 2 >= radius``. The search starts at the n
    where ``rho_t = rho_start``, steps down (halving n's excess) until a trial
    succeeds, gallops upward with doubling steps until one fails, then
    bisects between the last success and the first failure. n with
    ``rho_t(n) >= rho_limit`` count as failures without a trial (relaxation
    levels off near rho 0.92). Success is not strictly monotone in n (each
    trial has its own random start), so the answer is the largest success
    the search met, not a proof that no larger n works.

    Parameters
    ----------
    radius : float
        Poisson disk radius: half the minimum distance between points, in
        (0, 0.25).
    options : RelaxOptions, optional
        The relaxation of every trial (default :data:`TRIAL_RELAX`:
        ``max_iter`` 300, ``patience`` 60; a failing trial costs up to
        ``max_iter`` iterations); its ``eps`` is each trial's own.
    start : {"dart", "random"} or callable, optional
        Start sets: dart throwing at relative radius 0.74, uniform random
        points, or ``start(n, rng) -> (n, 2) array``.
    eps_margin : float, optional
        Relative margin on the target rho, so that rounding cannot leave the
        result just below `radius`.
    seed : int, optional
        The trial at n uses ``numpy.random.default_rng([seed, n])``: the same
        seed gives the same trials and result whatever the search path.
    rho_start : float, optional
        rho of the first trial's n.
    rho_limit : float, optional
        Trials whose target rho reaches this are not run.
    device : str or pyopencl.Context, optional
        Passed to :func:`relax_poisson`.
    callback : callable, optional
        ``callback(trial)`` with each trial's dict.
    **overrides
        Fields of :class:`RelaxOptions` (``backend``, ``max_iter``,
        ``patience``, ``grid``), over those of `options`.

    Returns
    -------
    RadiusResult

    Raises
    ------
    ValueError
        Bad `radius`, `start`, `rho_start` or `rho_limit`.
    RuntimeError
        No n >= 2 reached the radius (it is too large for the torus).

    Examples
    --------
    >>> res = max_points_for_radius(0.043, backend="exact")
    >>> res.n, bool(res.achieved_radius >= 0.043)
    (129, True)
    >>> max_points_for_radius(0.043, TRIAL_RELAX.replace(backend="exact")).n
    129
    """
    radius = float(radius)
    if not (np.isfinite(radius) and 0.0 < radius < 0.25):
        raise ValueError(f"radius must be in (0, 0.25), got {radius}")
    if not (0.0 < rho_start < rho_limit <= 1.0):
        raise ValueError(f"need 0 < rho_start < rho_limit <= 1, got {rho_start}, {rho_limit}")
    relax = (options or TRIAL_RELAX).replace(**overrides)
    t_start = time.perf_counter()
    trials = _RadiusTrials(radius, _start_sets(start), seed, eps_margin, rho_limit, callback,
                           relax, device)
    # the search relaxes sets of up to n_at(rho_limit) points: refused before the first
    check_poisson_memory(trials.n_at(rho_limit), names=("radius",))
    lo = _largest_success(trials, max(2, trials.n_at(rho_start)), trials.n_at(rho_limit) + 1)
    pts = trials.done[lo][1]
    d = min_distance(pts) / 2.0
    return RadiusResult(pts, int(lo), radius, float(d), float(normalized_radius(pts)),
                        trials.records, time.perf_counter() - t_start)


def _start_sets(start):
    """``make(n, rng) -> (n, 2)`` start points of :func:`max_points_for_radius`."""
    from .sampling import dart_throwing, random_points  # not loaded at start-up

    if callable(start):
        return start
    if start == "dart":
        return lambda n, rng: dart_throwing(n, seed=rng)
    if start == "random":
        return lambda n, rng: random_points(n, seed=rng)
    raise ValueError(f"start must be 'dart', 'random' or a callable, got {start!r}")


class _RadiusTrials:
    """The trials of :func:`max_points_for_radius`, each run once: ``self(n) -> (ok, points)``."""

    def __init__(self, radius, make, seed, eps_margin, rho_limit, callback, relax, device):
        self.radius, self.make, self.seed = radius, make, int(seed)
        self.eps_margin, self.rho_limit, self.callback = eps_margin, rho_limit, callback
        self.relax, self.device = relax, device
        self.records, self.done = [], {}

    def target(self, n):
        return self.radius * np.sqrt(HEXAGONAL_CELL * n)

    def n_at(self, rho):
        return int(np.floor((rho / self.radius) ** 2 / HEXAGONAL_CELL))

    def __call__(self, n):
        if n not in self.done:
            self.done[n] = self._run(n)
        return self.done[n]

    def _run(self, n):
        t = self.target(n)
        if t >= self.rho_limit:
            return False, None
        pts = np.asarray(self.make(n, np.random.default_rng([self.seed, n])), dtype=np.float64)
        t0 = time.perf_counter()
        res = relax_poisson(pts, min(t * (1.0 + self.eps_margin), 1.0 - 1e-12), self.relax,
                            device=self.device)
        ok = bool(min_distance(res.points) / 2.0 >= self.radius)
        rec = {"n": int(n), "target_rho": float(t), "reached": ok, "rho": float(res.rho[-1]),
               "iterations": int(res.iterations), "stop_reason": res.stop_reason,
               "seconds": time.perf_counter() - t0}
        self.records.append(rec)
        if self.callback is not None:
            self.callback(rec)
        return ok, res.points if ok else None


def _largest_success(trial, n, n_hi_cap):
    """Down from `n` until a success, gallop up until a failure, bisect; the largest success."""
    if n >= n_hi_cap:
        raise RuntimeError(f"radius {trial.radius} leaves no n >= 2 with target rho below "
                           f"{trial.rho_limit}")
    # downward (10 % steps) until a success
    while not trial(n)[0]:
        if n <= 2:
            raise RuntimeError(f"no point set with n >= 2 reached radius {trial.radius}")
        n = max(2, min(n - 1, int(n * 0.9)))
    lo = n
    # gallop upward until a failure
    step = max(1, int(round(0.02 * lo)))
    hi = None
    while hi is None:
        cand = lo + step
        if cand >= n_hi_cap:
            hi = n_hi_cap
        elif trial(cand)[0]:
            lo = cand
            step *= 2
        else:
            hi = cand
    # bisect between a success (lo) and a failure (hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if trial(mid)[0]:
            lo = mid
        else:
            hi = mid
    return lo
