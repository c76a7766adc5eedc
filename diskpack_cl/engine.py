"""Engines: who computes the maximal inscribed circles (MICs) of a power diagram.

Both algorithms ask their engine one question per disk-packing step:
``engine.mic(points, weights)``, the certified MIC of every power cell.

==========  ==============================================================
engine      how
==========  ==============================================================
``cells``   OpenCL float64 per-cell kernel (:class:`diskpack_cl.cells.CellMIC`),
            re-solved and checked on the host; the default on devices with
            ``cl_khr_fp64``
``raster``  OpenCL float32 raster estimate (:class:`diskpack_cl.raster.PowerRaster`)
            refined by :func:`diskpack_cl.geometry.exact_mic`; the route for
            devices without float64
``exact``   :func:`diskpack_cl.geometry.exact_mic` alone (numpy/scipy, no OpenCL)
==========  ==============================================================

All three return the same MICs (to rounding, and exactly the same vertex
where the MIC is unique): every answer is an LP optimum certified in float64.
Every engine checks its sites first (:func:`diskpack_cl._checks.check_sites`:
a ValueError for no sites, NaN or infinite points or weights, weights out
of range), so that no kernel sees sites it cannot bound its work on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ._checks import check_sites
from .geometry import exact_mic

__all__ = ["BACKENDS", "ROUTES", "MICStep", "make_engine", "check_against_exact", "ExactEngine",
           "RasterEngine", "CellEngine"]

BACKENDS = ("opencl", "exact", "auto")
ROUTES = ("auto", "cells", "raster")


@dataclass
class MICStep:
    """One answer of an engine.

    Attributes
    ----------
    centers : (n, 2) float64
    radii : (n,) float64
        Negative where the power cell is empty (``centers`` is the site there).
    empty : (n,) bool
    nn : (n,) float64 or None
        Distance from each site to its nearest other site, when the engine
        computed it on the way (the ``cells`` engine does).
    stats : dict
        Counts, summed by the caller over iterations.
    timings : dict
        Seconds per stage.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> step = ExactEngine(Domain.torus()).mic(np.array([[0.25, 0.5], [0.75, 0.5]]))
    >>> step.radii.tolist(), step.empty.tolist()
    ([0.25, 0.25], [False, False])
    """

    centers: np.ndarray
    radii: np.ndarray
    empty: np.ndarray
    nn: np.ndarray | None = None
    stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)


class ExactEngine:
    """MICs by :func:`diskpack_cl.geometry.exact_mic` (numpy/scipy only).

    Examples
    --------
    >>> import numpy as np
    >>> from diskpack_cl.domain import Domain
    >>> step = ExactEngine(Domain.torus()).mic(np.random.default_rng(0).random((64, 2)))
    >>> step.radii.shape
    (64,)
    """

    name = "exact"
    device = "cpu (scipy)"
    gives_nn = False

    def __init__(self, domain, *, fallback=None):
        self.domain = domain
        self.fallback = fallback   # None, or why ``auto`` chose this engine

    def mic(self, points, weights=None):
        t0 = time.perf_counter()
        check_sites(points, weights, self.domain)
        m = exact_mic(points, weights, self.domain)
        stats = {k: m.stats[k] for k in ("widened", "grown", "linprog")}
        return MICStep(m.centers, m.radii, m.empty, None, stats, {"exact": time.perf_counter() - t0})


class RasterEngine:
    """MICs from the OpenCL raster estimate, refined by ``exact_mic``.

    The route for devices without float64: the raster's argmax of the
    distance to the cell boundary starts the exact solver.

    Examples
    --------
    On an OpenCL device:

    >>> from diskpack_cl.domain import Domain
    >>> pts = np.random.default_rng(0).random((100, 2))
    >>> step = RasterEngine(Domain.torus(), 100).mic(pts)
    >>> bool(np.allclose(step.radii, ExactEngine(Domain.torus()).mic(pts).radii, atol=1e-9))
    True
    """

    name = "raster"
    gives_nn = False
    fallback = None

    def __init__(self, domain, n, *, device=None, grid=None, profile=False):
        from .raster import PowerRaster, auto_grid

        shape = auto_grid(n, domain) if grid is None else grid
        self.domain = domain
        self.raster = PowerRaster(domain, shape, device=device, profile=profile)
        self.device = self.raster.device_name

    def mic(self, points, weights=None):
        before = sum(self.raster.kernel_seconds.values())
        est = self.raster.compute(points, weights)
        t0 = time.perf_counter()
        m = exact_mic(points, weights, self.domain, estimate=(est.centers, est.radii))
        timings = dict(est.timings, exact=time.perf_counter() - t0)
        if self.raster.profile:
            timings["kernel"] = sum(self.raster.kernel_seconds.values()) - before
        stats = {k: m.stats[k] for k in ("widened", "grown", "linprog")}
        return MICStep(m.centers, m.radii, m.empty, None, stats, timings)


class CellEngine:
    """MICs from the float64 per-cell kernel, checked on the host.

    Examples
    --------
    On an OpenCL device with float64:

    >>> from diskpack_cl.domain import Domain
    >>> pts = np.random.default_rng(0).random((100, 2))
    >>> step = CellEngine(Domain.torus()).mic(pts)
    >>> bool(np.allclose(step.radii, ExactEngine(Domain.torus()).mic(pts).radii, atol=1e-9))
    True
    """

    name = "cells"
    gives_nn = True
    fallback = None

    def __init__(self, domain, *, device=None, profile=False):
        from .cells import CellMIC

        self.domain = domain
        self.solver = CellMIC(domain, device=device, profile=profile)
        self.device = self.solver.device_name

    def mic(self, points, weights=None):
        r = self.solver.solve(points, weights)
        stats = {k: r.stats[k] for k in ("flagged", "rejected", "fallback", "bytes_to_device",
                                         "bytes_from_device")}
        return MICStep(r.centers, r.radii, r.empty, r.nn, stats, r.timings)


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
    RuntimeError: ...
    """
    ref = exact_mic(points, weights, domain)
    scale = max(domain.width, domain.height)
    off = (np.abs(np.asarray(radii) - ref.radii) > tol * scale) & ~ref.empty
    bad = off | (np.asarray(empty) != ref.empty)
    if bad.any():
        i = int(np.argmax(bad))
        raise RuntimeError(f"{int(bad.sum())} MIC radii differ from exact_mic's (cell {i}: "
                           f"{radii[i]!r} against {ref.radii[i]!r})")


def _opencl_engine(ctx, domain, n, backend, route, grid, profile):
    """The OpenCL route for `ctx`: the per-cell kernel where the device has
    float64; else the raster route on GPUs, and for ``auto`` on CPUs without
    float64 the exact engine."""
    import pyopencl as cl

    from .cells import has_fp64

    if route == "cells" or (route == "auto" and has_fp64(ctx)):
        return CellEngine(domain, device=ctx, profile=profile)
    if route == "raster" or backend == "opencl" or ctx.devices[0].type & cl.device_type.GPU:
        return RasterEngine(domain, n, device=ctx, grid=grid, profile=profile)
    return ExactEngine(domain, fallback="a CPU device without float64: scipy alone is faster")


def make_engine(domain, n, backend="auto", *, device=None, grid=None, route="auto", profile=False):
    """The engine for `backend` (``opencl``, ``exact`` or ``auto``).

    Parameters
    ----------
    domain : Domain
    n : int
        Number of sites (sizes the raster of the ``raster`` route).
    backend : {"auto", "opencl", "exact"}
        ``auto``: OpenCL when a device exists, else exact (see
        :attr:`fallback` on the returned engine for why).
    device : str or pyopencl.Context, optional
    grid : tuple of int, optional
        Raster shape ``(ny, nx)`` of the ``raster`` route.
    route : {"auto", "cells", "raster"}
        OpenCL route: ``auto`` takes ``cells`` on devices with float64,
        ``raster`` on GPUs
        without float64, and with ``backend="auto"`` the exact engine on a
        CPU without float64.
    profile : bool
        Profile the kernels with OpenCL events.

    Returns
    -------
    ExactEngine, RasterEngine or CellEngine
        With an attribute ``fallback``: None, or the reason ``auto`` chose
        the exact engine.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> make_engine(Domain.torus(), 100, "exact").name
    'exact'
    """
    from ._device import NoOpenCLError, get_context

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    if backend == "exact":
        return ExactEngine(domain)
    try:
        ctx = get_context(device)
    except NoOpenCLError as exc:
        if backend == "opencl" or device is not None:
            raise
        return ExactEngine(domain, fallback=f"no OpenCL device ({exc})")
    return _opencl_engine(ctx, domain, n, backend, route, grid, profile)
