"""Engines of the stippling loop: who computes power-cell MICs and cell centroids.

A disk-packing or mix step asks its engine two questions:
``engine.mic(points, weights)`` (the maximal inscribed circle of every power
cell) and ``engine.centroids(points, weights, density)`` (density-weighted
centroids of the power cells on the stippling grid).  The backend names are
those of :func:`diskpack_cl.relax_poisson`:

==========  ================================================================
backend     engine
==========  ================================================================
``opencl``  :class:`OpenCLStippleEngine`: MICs from the float64 per-cell
            kernel (:class:`diskpack_cl.cells.CellMIC`) on devices with
            float64, else (``route="raster"``) the float32 raster's
            estimates refined by :func:`diskpack_cl.exact_mic`; centroids
            from the raster labels (reused from the MIC step when it
            labelled the same power diagram)
``exact``   :class:`ExactStippleEngine`: no OpenCL; exact MICs from the
            sites, exact float64 labels on the host
            (:func:`diskpack_cl.labels.grid_power_labels`)
``auto``    ``opencl`` when a device exists, else ``exact``
==========  ================================================================

Both give the same MICs (certified LP optima) and the same centroids except
at grid cells where the float32 raster labels tie.  Both check their sites
first, as :func:`diskpack_cl._checks.check_sites` does (ValueError).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._checks import check_sites
from ._timing import Stopwatch
from .engine import BACKENDS, check_against_exact
from .geometry import exact_mic
from .labels import cell_centroids, grid_power_labels

__all__ = ["CellMICs", "OpenCLStippleEngine", "ExactStippleEngine", "VerifiedEngine", "make_stipple_engine"]


@dataclass
class CellMICs:
    """MICs of every power cell from :meth:`OpenCLStippleEngine.mic` (or the exact engine).

    ``radii`` < 0 or ``empty``: no circle (the centre is then the site);
    ``timings``: seconds per stage (``raster``, ``exact``).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> engine = make_stipple_engine(Domain.rect(48, 32), (64, 96), "exact")
    >>> mics = engine.mic(np.random.default_rng(0).random((30, 2)) * [48, 32], np.zeros(30))
    >>> mics.centers.shape, bool(np.all(mics.radii > 0)), bool(mics.empty.any())
    ((30, 2), True, False)
    """

    centers: np.ndarray
    radii: np.ndarray
    empty: np.ndarray
    timings: dict = field(default_factory=dict)


def _add_kernel(seconds, name, secs):
    """Add the device seconds of kernel `name` to ``seconds["kernel_<name>"]`` and ``["kernel"]``."""
    for key in ("kernel", f"kernel_{name}"):
        seconds[key] = seconds.get(key, 0.0) + secs


def _exact(points, weights, domain, estimate, watch):
    with watch("exact"):
        mic = exact_mic(points, weights, domain, estimate=estimate)
    centers, R = np.asarray(mic.centers), np.asarray(mic.radii)
    return CellMICs(centers, R, np.asarray(mic.empty, bool) | ~np.isfinite(R), watch.seconds)


class OpenCLStippleEngine:
    """The OpenCL engine (see the module docstring).

    Parameters
    ----------
    domain : Domain
        The image rectangle.
    shape : tuple of int
        Raster ``(ny, nx)``.
    device : str or pyopencl.Context, optional
        See :func:`diskpack_cl.get_context`.
    route : {"auto", "cells", "raster"}
        Where the MICs come from: the per-cell kernel (``cells``), the
        raster estimate refined exactly (``raster``); ``auto``: cells on
        devices with float64.
    profile : bool
        Time the kernels with OpenCL events: every answer's timings then
        hold ``kernel``, the device seconds of its kernels.

    Examples
    --------
    On an OpenCL device:

    >>> from diskpack_cl.domain import Domain
    >>> pts = np.random.default_rng(0).random((30, 2)) * [48, 32]
    >>> mics = OpenCLStippleEngine(Domain.rect(48, 32), (64, 96)).mic(pts, np.zeros(30))
    >>> exact = make_stipple_engine(Domain.rect(48, 32), (64, 96), "exact").mic(pts, np.zeros(30))
    >>> bool(np.allclose(mics.radii, exact.radii, atol=1e-9))
    True
    """

    name = "opencl"
    fallback = None

    def __init__(self, domain, shape, device=None, route="auto", profile=False):
        from .cells import CellMIC, has_fp64
        from .raster import PowerRaster

        self.domain = domain
        self.profile = profile
        self.raster = PowerRaster(domain, shape=shape, device=device, profile=profile)
        self.device = self.raster.device_name
        self._labelled = None   # (points, weights, raster result) of the last labels
        # exact MICs from the float64 per-cell kernel where the device has
        # float64; else (or route="raster") the raster estimate refined by exact_mic
        use_cells = route == "cells" or (route == "auto" and has_fp64(self.raster.ctx))
        self.cells = CellMIC(domain, device=self.raster.ctx, profile=profile) if use_cells else None

    def _raster_kernel(self, before, seconds):
        """With profiling, add the raster's device seconds per kernel since
        `before` (a copy of its ``kernel_seconds``) to `seconds`: ``kernel``
        the total, ``kernel_<name>`` each kernel's."""
        if self.profile:
            for name, secs in self.raster.kernel_seconds.items():
                if secs > before.get(name, 0.0):   # ran during this call
                    _add_kernel(seconds, name, secs - before.get(name, 0.0))
        return seconds

    def _label(self, points, weights, distance):
        est = self.raster.compute(points, weights, distance=distance)
        self._labelled = (np.array(points), np.array(weights), est)
        return est

    def mic(self, points, weights, *, exact=True):
        """MICs of the power cells; ``exact=False``: the raster estimate alone."""
        watch = Stopwatch()
        if exact and self.cells is not None:
            with watch("exact"):
                r = self.cells.solve(points, weights)
            seconds = dict(watch.seconds)
            if self.profile:
                _add_kernel(seconds, "cell_mic", r.timings["kernel"])
            return CellMICs(r.centers, r.radii, r.empty | ~np.isfinite(r.radii), seconds)
        before = dict(self.raster.kernel_seconds)
        with watch("raster"):
            est = self._label(points, weights, True)
        if exact:
            mic = _exact(points, weights, self.domain, (est.centers, est.radii), watch)
        else:
            R = np.asarray(est.radii)
            mic = CellMICs(np.asarray(est.centers), R, ~(R > 0), watch.seconds)
        mic.timings = self._raster_kernel(before, dict(mic.timings))
        return mic

    def centroids(self, points, weights, density):
        """``(centroids, mass, timings)`` of the power cells (labels reused from :meth:`mic`)."""
        watch = Stopwatch()
        last = self._labelled
        before = dict(self.raster.kernel_seconds)
        with watch("raster"):
            if last is None or not (np.array_equal(last[0], points) and np.array_equal(last[1], weights)):
                last = (None, None, self._label(points, weights, False))
        with watch("centroids"):
            c, mass = last[2].centroids(density)
        return np.asarray(c), np.asarray(mass), self._raster_kernel(before, dict(watch.seconds))


class ExactStippleEngine:
    """The host engine: exact MICs and exact float64 grid labels, no OpenCL.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> eng = ExactStippleEngine(Domain.rect(8, 8), (16, 16))
    >>> pts = np.array([[2.0, 2.0], [6.0, 5.0], [3.0, 6.5]])
    >>> mic = eng.mic(pts, np.zeros(3))
    >>> c, mass, _ = eng.centroids(pts, np.zeros(3), None)
    >>> bool(np.all(mic.radii > 0)), float(mass.sum())
    (True, 256.0)
    """

    name = "exact"
    device = "cpu (scipy)"
    profile = False   # no kernels to time

    def __init__(self, domain, shape, *, fallback=None):
        self.domain = domain
        self.shape = tuple(shape)
        self.fallback = fallback   # None, or why ``auto`` chose this engine

    def mic(self, points, weights, *, exact=True):
        """Exact MICs (``exact`` is ignored: there is no estimate to stop at)."""
        check_sites(points, weights, self.domain)
        return _exact(points, weights, self.domain, None, Stopwatch())

    def centroids(self, points, weights, density):
        """``(centroids, mass, timings)`` of the power cells on the grid."""
        check_sites(points, weights, self.domain)
        watch = Stopwatch()
        with watch("raster"):
            lab = grid_power_labels(points, weights, self.domain, self.shape)
        with watch("centroids"):
            c, mass = cell_centroids(lab, points, density, self.domain)
        return c, mass, watch.seconds


class VerifiedEngine:
    """An engine whose every MIC answer is checked against :func:`exact_mic`
    (``stipple(verify=True)``): RuntimeError on a mismatch.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> engine = VerifiedEngine(make_stipple_engine(Domain.rect(48, 32), (64, 96), "exact"))
    >>> mics = engine.mic(np.random.default_rng(0).random((30, 2)) * [48, 32], np.zeros(30))
    >>> mics.radii.shape
    (30,)
    """

    def __init__(self, engine):
        self.engine = engine

    def __getattr__(self, name):   # name, device, fallback, profile, ...: the engine's
        return getattr(self.engine, name)

    def mic(self, points, weights, *, exact=True):
        m = self.engine.mic(points, weights, exact=exact)
        if exact:
            check_against_exact(points, weights, self.engine.domain, m.radii, m.empty)
        return m

    def centroids(self, points, weights, density):
        return self.engine.centroids(points, weights, density)


def make_stipple_engine(domain, shape, backend="auto", device=None, profile=False):
    """The stippling engine for `backend` (``opencl``, ``exact`` or ``auto``).

    ``auto`` takes the exact engine when no OpenCL device exists, unless a
    `device` was asked for (then the :class:`diskpack_cl.NoOpenCLError` is
    raised).  The engine's ``fallback`` is None or why ``auto`` chose exact.
    `profile` times the OpenCL engine's kernels (the exact engine has none).

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> make_stipple_engine(Domain.rect(8, 8), (16, 16), "exact").name
    'exact'
    """
    from ._device import NoOpenCLError

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "exact":
        return ExactStippleEngine(domain, shape)
    try:
        return OpenCLStippleEngine(domain, shape, device=device, profile=profile)
    except NoOpenCLError as exc:
        if backend == "opencl" or device is not None:
            raise
        return ExactStippleEngine(domain, shape, fallback=f"no OpenCL device ({exc})")
