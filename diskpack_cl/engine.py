"""Engines: who computes the maximal inscribed circles (MICs) and centroids of power cells.

Relaxation and stippling ask their engine the same questions, through one
protocol:

- ``engine.mic(points, weights=None, *, exact=True, certify=True, warm=False)``:
  the certified MIC of every power cell, a :class:`~diskpack_cl.geometry.MIC`
  (``exact=False``: the raster estimate alone, where the engine has one;
  ``certify=False``: the ``cells`` route takes the device's proven MICs
  without the host's re-solve, for a caller that certifies what it returns;
  ``warm=True``: the ``cells`` route starts each cell's simplex from its basis
  of the last warm call, for the steps of a relaxation: the same MICs, up to
  the last bits of the centres where a cell's basis is solved in another order);
- ``engine.centroids(points, weights, density)``: ``(centroids, mass)``,
  the density-weighted centroids and masses of the power cells on the
  engine's grid (engines made with a ``grid``);
  ``engine.start_centroids(...)`` the same, begun: it returns the function
  that gives them (on the ``cells`` route a helper thread prepares and queues
  the device's pass while the host asks for the MICs).

Every engine has ``name`` (its route), ``backend`` (``opencl`` or
``exact``), ``device``, ``fallback`` (None, or why ``auto`` chose the exact
engine), ``gives_nn`` (its MICs carry nearest-neighbour distances),
``profile`` and ``timings``, the one :class:`~diskpack_cl._timing.Stopwatch`
that every stage of the engine adds its seconds to. :func:`make_engine`
makes them all.

==========  ==============================================================
route       how
==========  ==============================================================
``cells``   OpenCL float64 per-cell kernel (:class:`diskpack_cl.device.cells.CellMIC`),
            re-solved and checked on the host; the default on devices with
            ``cl_khr_fp64``
``raster``  OpenCL float32 raster estimate (:class:`diskpack_cl.device.raster.PowerRaster`)
            refined by :func:`diskpack_cl.geometry.exact_mic`; the route for
            devices without float64
``exact``   :func:`diskpack_cl.geometry.exact_mic` alone and exact float64
            grid labels (:func:`diskpack_cl.labels.grid_power_labels`); no OpenCL
==========  ==============================================================

All three return the same MICs (to rounding, and exactly the same vertex
where the MIC is unique): every answer is an LP optimum certified in float64.
The OpenCL routes label the grid for the centroids on the device (reusing the
labels of the MIC step when it labelled the same power diagram); they agree
with the exact labels except at grid cells where float32 power distances tie.
Every engine checks its sites first (:func:`diskpack_cl._checks.check_sites`:
a ValueError for no sites, NaN or infinite points or weights, weights out
of range), so that no kernel sees sites it cannot bound its work on.

Stages in ``timings``: ``buckets``, ``device``, ``refine``, ``fallback``
(the per-cell kernel); ``raster_labels``, ``mic_estimate`` (the raster);
``exact`` (:func:`~diskpack_cl.geometry.exact_mic`); ``centroids`` (the
sums over the labels); with ``profile``, ``kernel`` and ``kernel_<name>``
(device seconds, all and per kernel).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ._checks import check_sites
from ._timing import Stopwatch
from .geometry import MIC, exact_mic
from .labels import cell_centroids, grid_power_labels

__all__ = ["BACKENDS", "ROUTES", "HOST_DEVICE", "check_backend", "make_engine",
           "check_against_exact", "stage_record", "engine_record", "ExactEngine", "OpenCLEngine"]

BACKENDS = ("opencl", "exact", "auto")
ROUTES = ("auto", "cells", "raster")

#: The device of the host's stages (the exact engine, scipy's blur).
HOST_DEVICE = "cpu (scipy)"


def check_backend(backend):
    """Refuse a backend that is not one of :data:`BACKENDS`.

    Examples
    --------
    >>> check_backend("gpu")
    Traceback (most recent call last):
    ...
    ValueError: backend must be one of ('opencl', 'exact', 'auto'), got 'gpu'
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")

#: The solver counts an engine's answers carry (``MIC.stats``), per solver.
_COUNTS = {"exact": ("widened", "grown", "linprog"),
           "cells": ("flagged", "rejected", "fallback", "bytes_to_device", "bytes_from_device")}


def check_against_exact(points, weights, domain, radii, empty, tol=1e-9):
    """Raise RuntimeError unless the MIC radii are :func:`exact_mic`'s (the verify switch).

    An independent check of any engine's answer: the same cells must be
    empty, and the radius of every other cell's maximal inscribed circle,
    which is unique, must equal scipy's to within `tol` times the domain size.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> pts = np.array([[0.25, 0.5], [0.75, 0.5]])
    >>> check_against_exact(pts, None, Domain.torus(), np.array([0.25, 0.25]), np.array([False, False]))
    >>> check_against_exact(pts, None, Domain.torus(), np.array([0.25, 0.2]), np.array([False, False]))
    Traceback (most recent call last):
    ...
    RuntimeError: 1 MIC radii differ from exact_mic's (cell 1: ...)
    """
    ref = exact_mic(points, weights, domain)
    scale = max(domain.width, domain.height)
    off = (np.abs(np.asarray(radii) - ref.radii) > tol * scale) & ~ref.empty
    bad = off | (np.asarray(empty) != ref.empty)
    if bad.any():
        i = int(np.argmax(bad))
        raise RuntimeError(f"{int(bad.sum())} MIC radii differ from exact_mic's (cell {i}: "
                           f"{radii[i]!r} against {ref.radii[i]!r})")


def stage_record(backend, device=None, *, route=None, fallback=None):
    """Where one stage of a run ran, as the summaries' ``stages`` hold it.

    ``backend`` (``opencl`` or ``exact``: the host) and ``device`` always;
    ``route`` and ``fallback`` (why the stage ran on the host where it
    could have run on a device) only where given.

    Examples
    --------
    >>> stage_record("exact", HOST_DEVICE, fallback="no float64")
    {'backend': 'exact', 'device': 'cpu (scipy)', 'fallback': 'no float64'}
    """
    record = {"backend": backend, "device": device}
    if route:
        record["route"] = route
    if fallback:
        record["fallback"] = fallback
    return record


def engine_record(engine):
    """The :func:`stage_record` of an engine: its backend, device, route and fallback.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> engine_record(make_engine(Domain.torus(), 100, "exact"))
    {'backend': 'exact', 'device': 'cpu (scipy)', 'route': 'exact'}
    """
    return stage_record(engine.backend, engine.device, route=engine.name,
                        fallback=engine.fallback)


def _answer(mic, solver, nn=None):
    """The engine's :class:`MIC`: a cell without a finite radius counts as empty; the
    solver's counts only."""
    R = np.asarray(mic.radii)
    return MIC(np.asarray(mic.centers), R, np.asarray(mic.empty, bool) | ~np.isfinite(R),
               {k: mic.stats[k] for k in _COUNTS[solver]}, nn)


class _Engine:
    """The protocol both engines share: :meth:`mic` with the verify switch, the timings."""

    fallback = None
    gives_nn = False

    def __init__(self, domain, *, verify=False, fallback=None, timings=None):
        self.domain = domain
        self.verify = verify
        if fallback is not None:
            self.fallback = fallback   # why ``auto`` chose this engine
        self.timings = Stopwatch() if timings is None else timings

    def mic(self, points, weights=None, *, exact=True, certify=True, warm=False):
        """MICs of the power cells (a :class:`~diskpack_cl.geometry.MIC`); with
        ``verify``, checked against :func:`exact_mic` (RuntimeError on a mismatch).
        ``certify=False`` spares the ``cells`` route its host re-solve (verify overrides);
        ``warm=True`` starts its simplex from the last warm call's bases."""
        m = self._mic(points, weights, exact, certify or self.verify, warm)
        if self.verify and exact:
            check_against_exact(points, weights, self.domain, m.radii, m.empty)
        return m

    def start_centroids(self, points, weights, density):
        """:meth:`centroids`, begun: the function that gives them.  Here they are
        computed when it is called (after a :meth:`mic` whose labels they may reuse)."""
        return lambda: self.centroids(points, weights, density)


class ExactEngine(_Engine):
    """The host engine: exact MICs and exact float64 grid labels, no OpenCL.

    Parameters
    ----------
    domain : Domain
    grid : tuple of int, optional
        Grid ``(ny, nx)`` of :meth:`centroids`.
    verify : bool
        Check every MIC answer against :func:`exact_mic` (for symmetry with
        the OpenCL engine; this engine's answers are its own).
    fallback : str, optional
        Why ``auto`` chose this engine.
    timings : Stopwatch, optional
        The collector of the stages' seconds (default: a new one).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> eng = ExactEngine(Domain.rect(8, 8), (16, 16))
    >>> pts = np.array([[2.0, 2.0], [6.0, 5.0], [3.0, 6.5]])
    >>> mic = eng.mic(pts, np.zeros(3))
    >>> c, mass = eng.centroids(pts, np.zeros(3), None)
    >>> bool(np.all(mic.radii > 0)), float(mass.sum())
    (True, 256.0)
    """

    name = backend = "exact"
    device = HOST_DEVICE
    profile = False   # no kernels to time

    def __init__(self, domain, grid=None, *, verify=False, fallback=None, timings=None):
        super().__init__(domain, verify=verify, fallback=fallback, timings=timings)
        self.grid = None if grid is None else tuple(grid)

    def _mic(self, points, weights, exact, certify, warm):
        # there is no estimate to stop at, exact_mic certifies and has no simplex to start:
        # no flag changes anything
        check_sites(points, weights, self.domain)
        with self.timings("exact"):
            m = exact_mic(points, weights, self.domain)
        return _answer(m, "exact")

    def centroids(self, points, weights, density):
        """``(centroids, mass)`` of the power cells on the grid."""
        if self.grid is None:
            raise ValueError("this engine has no grid for centroids: make it with grid=(ny, nx)")
        check_sites(points, weights, self.domain)
        with self.timings("raster_labels"):
            lab = grid_power_labels(points, weights, self.domain, self.grid)
        with self.timings("centroids"):
            return cell_centroids(lab, points, density, self.domain)


class OpenCLEngine(_Engine):
    """The OpenCL engine: the ``cells`` or the ``raster`` route (see the module docstring).

    Parameters
    ----------
    domain : Domain
    ctx : pyopencl.Context
    route : {"cells", "raster"}
        Where the MICs come from: the float64 per-cell kernel, or the
        raster estimate refined by :func:`exact_mic`.
    grid : tuple of int, optional
        Raster ``(ny, nx)``: the grid of :meth:`centroids` and of the raster
        route (default: :func:`diskpack_cl.device.raster.auto_grid` of `n`).
    n : int, optional
        Number of sites, for the default grid.
    profile : bool
        Time the kernels with OpenCL events (``kernel`` and ``kernel_<name>``
        in :attr:`timings`).
    verify : bool
        Check every MIC answer against :func:`exact_mic`.
    timings : Stopwatch, optional
        The collector of the stages' seconds (default: a new one).

    Examples
    --------
    On an OpenCL device (:func:`make_engine` picks the route):

    >>> from diskpack_cl.domain import Domain
    >>> engine = make_engine(Domain.torus(), 64, "opencl")
    >>> type(engine).__name__, engine.mic(np.random.default_rng(0).random((64, 2))).radii.shape
    ('OpenCLEngine', (64,))
    """

    backend = "opencl"

    def __init__(self, domain, ctx, route, *, grid=None, n=None, profile=False, verify=False,
                 timings=None):
        from .device.context import describe  # not loaded at start-up
        from .device.cells import CellMIC  # not loaded at start-up

        super().__init__(domain, verify=verify, timings=timings)
        self.ctx, self.name, self.profile = ctx, route, profile
        self.device = describe(ctx)
        self.gives_nn = route == "cells"
        # the raster's shape, found where the raster is built: the cells route never is
        self._grid, self._n = grid, n
        self._raster = None
        self._labelled = None   # (points, weights, raster result) of the last labels
        self._helper = None     # start_centroids' thread, made on first use
        self.cells = None
        if route == "cells":
            self.cells = CellMIC(domain, device=ctx, profile=profile, timings=self.timings)
        else:   # every answer of the raster route needs the raster: built now
            self._build_raster()

    def _build_raster(self):
        from .device.raster import PowerRaster, auto_grid  # not loaded at start-up

        if self._grid is None and self._n is not None:
            self._grid = auto_grid(self._n, self.domain)
        if self._grid is None:
            raise ValueError("this engine has no grid: make it with grid=(ny, nx) or n")
        self._raster = PowerRaster(self.domain, self._grid, device=self.ctx,
                                   profile=self.profile, timings=self.timings)

    @property
    def raster(self):
        """The :class:`~diskpack_cl.device.raster.PowerRaster` of the grid, built on first use."""
        if self._raster is None:
            self._build_raster()
        return self._raster

    def _label(self, points, weights, distance):
        est = self.raster.compute(points, weights, distance=distance)
        self._labelled = (np.array(points), np.array(weights), est)
        return est

    def _mic(self, points, weights, exact, certify, warm):
        if exact and self.cells is not None:
            r = self.cells.solve(points, weights, certify=certify, warm=warm)
            return _answer(r, "cells", r.nn)
        est = self._label(points, weights, True)
        if not exact:
            R = np.asarray(est.radii)
            return MIC(np.asarray(est.centers), R, ~(R > 0))
        with self.timings("exact"):
            m = exact_mic(points, weights, self.domain, estimate=(est.centers, est.radii))
        return _answer(m, "exact")

    def centroids(self, points, weights, density):
        """``(centroids, mass)`` of the power cells (labels reused from :meth:`mic`)."""
        last = self._labelled
        if last is None or not (np.array_equal(last[0], points) and np.array_equal(last[1], weights)):
            # no labels to reuse: the raster labels and sums in one pass where it can
            return self.raster.centroids(points, weights, density)
        with self.timings("centroids"):
            return last[2].centroids(density)

    def start_centroids(self, points, weights, density):
        """:meth:`centroids`, begun: on the ``cells`` route the raster's pass (a :meth:`mic`
        there labels no grid) is prepared and queued by a helper thread, whose host work
        (buckets, buffers) runs beside the MICs' own, and its kernels beside theirs."""
        if self.cells is None:
            return super().start_centroids(points, weights, density)
        raster = self.raster   # built here: its warm-up must not run beside another stage
        if self._helper is None:
            self._helper = ThreadPoolExecutor(1, thread_name_prefix="diskpack-centroids")
        # copies: the caller may change its arrays once this returns (a step's worth of time)
        points, weights = (None if a is None else np.array(a, dtype=np.float64) for a in (points, weights))
        begun = self._helper.submit(raster.start_centroids, points, weights, density)
        return lambda: begun.result()()


def make_engine(domain, n=None, backend="auto", *, device=None, grid=None, route="auto",
                profile=False, verify=False, timings=None):
    """The engine for `backend` (``opencl``, ``exact`` or ``auto``): the one factory.

    Parameters
    ----------
    domain : Domain
    n : int, optional
        Number of sites (sizes the raster when `grid` is not given).
    backend : {"auto", "opencl", "exact"}
        ``auto``: OpenCL when a device exists, else exact (the engine's
        ``fallback`` says why). A `device` asked for and not found raises
        :class:`diskpack_cl.NoOpenCLError`, as ``opencl`` does.
    device : str or pyopencl.Context, optional
    grid : tuple of int, optional
        Grid ``(ny, nx)`` of the centroids and of the raster route.
    route : {"auto", "cells", "raster"}
        OpenCL route: ``auto`` takes ``cells`` on devices with float64,
        ``raster`` on GPUs without float64, and with ``backend="auto"`` the
        exact engine on a CPU without float64 (scipy alone is faster there).
    profile : bool
        Profile the kernels with OpenCL events.
    verify : bool
        Check every MIC answer against :func:`exact_mic` (slow; for testing).
    timings : Stopwatch, optional
        The collector the engine adds its stages' seconds to (default: a new
        one): a caller that times stages of its own passes its collector.

    Returns
    -------
    ExactEngine or OpenCLEngine

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> make_engine(Domain.torus(), 100, "exact").name
    'exact'
    """
    from .device.context import NoOpenCLError, get_context  # not loaded at start-up

    check_backend(backend)
    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    common = dict(verify=verify, timings=timings)
    if backend == "exact":
        return ExactEngine(domain, grid, **common)
    try:
        ctx = get_context(device)
    except NoOpenCLError as exc:
        if backend == "opencl" or device is not None:
            raise
        return ExactEngine(domain, grid, fallback=f"no OpenCL device ({exc})", **common)
    route = _route(ctx, backend, route)
    if route == "exact":
        return ExactEngine(domain, grid, **common,
                           fallback="a CPU device without float64: scipy alone is faster")
    return OpenCLEngine(domain, ctx, route, grid=grid, n=n, profile=profile, **common)


def _route(ctx, backend, route):
    """The route for `ctx`: the per-cell kernel where the device has float64; else the
    raster route on GPUs (and whenever OpenCL was asked for), the exact engine on CPUs."""
    import pyopencl as cl  # not loaded at start-up

    from .device.stage import has_fp64  # not loaded at start-up

    if route == "cells" or (route == "auto" and has_fp64(ctx)):
        return "cells"
    if route == "raster" or backend == "opencl" or ctx.devices[0].type & cl.device_type.GPU:
        return "raster"
    return "exact"
