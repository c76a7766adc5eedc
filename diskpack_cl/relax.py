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
from dataclasses import dataclass, field

import numpy as np

from .geometry import Domain, coincident_pairs, exact_mic, normalized_radius

__all__ = ["relax_poisson", "RelaxResult", "BACKENDS"]

BACKENDS = ("opencl", "exact", "auto")


@dataclass
class RelaxResult:
    """Outcome of :func:`relax_poisson`.

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
        Seconds per stage, summed over iterations: ``raster_labels``,
        ``mic_estimate``, ``exact_refine``, ``rho``.
    backend, device : str
    stats : dict
        Raster estimate errors and how often the exact stage widened its
        constraint set.
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


def _check_points(points):
    X = np.array(points, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {X.shape}")
    if len(X) < 2:
        raise ValueError(f"need at least 2 points, got {len(X)}")
    bad = ~np.all(np.isfinite(X), axis=1)
    if bad.any():
        raise ValueError(f"{bad.sum()} point(s) have NaN or infinite coordinates (first: row {np.argmax(bad)})")
    X = Domain.torus().wrap(X)
    dup = coincident_pairs(X)
    if len(dup):
        shown = ", ".join(f"{i}={j}" for i, j in dup[:5])
        raise ValueError(f"{len(dup)} pair(s) of coincident points on the torus (rows {shown}); "
                         "remove duplicates first")
    return X


def _engine(backend, n, grid, device):
    """Return (raster or None, backend name, device description)."""
    from ._device import NoOpenCLError

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "exact":
        return None, "exact", "cpu (scipy)"
    from .raster import PowerRaster, auto_grid

    dom = Domain.torus()
    shape = auto_grid(n, dom) if grid is None else (int(grid), int(grid))
    try:
        pr = PowerRaster(dom, shape, device=device)
    except NoOpenCLError:
        if backend == "auto":
            return None, "exact", "cpu (scipy)"
        raise
    return pr, "opencl", pr.device_name


def relax_poisson(points, eps=0.8, *, max_iter=1000, backend="auto", grid=None, device=None,
                  callback=None, patience=100):
    """Relax a point set on the unit torus by disk packing until rho >= eps.

    Parameters
    ----------
    points : (n, 2) array_like
        Start set; coordinates outside [0, 1) are wrapped onto the torus.
    eps : float
        Target normalized Poisson disk radius, in (0, 1).  The paper uses 0.8.
    max_iter : int
        Iteration cap.
    backend : {"auto", "opencl", "exact"}
        ``opencl``: raster MIC estimates in OpenCL, refined exactly;
        ``exact``: scipy only (the exact stage starts from the sites);
        ``auto``: opencl when a device exists, else exact.  Both give the
        same iterates (to rounding): the exact stage certifies its result
        whatever its start.
    grid : int, optional
        Raster size (grid x grid); default about 64 grid cells per point.
    device : str, optional
        OpenCL device (see :func:`diskpack_cl._device.get_context`).
    callback : callable, optional
        ``callback(iteration, rho)`` after each iteration.
    patience : int
        Stop as ``"stalled"`` when rho has not grown for this many iterations.

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
    """
    X = _check_points(points)
    if not (0.0 < eps < 1.0):
        raise ValueError(f"eps must be in (0, 1), got {eps}")
    if int(max_iter) < 0:
        raise ValueError(f"max_iter must be >= 0, got {max_iter}")
    n = len(X)
    dom = Domain.torus()
    raster, used, devname = _engine(backend, n, grid, device)
    timings = {"raster_labels": 0.0, "mic_estimate": 0.0, "exact_refine": 0.0, "rho": 0.0}
    stats = {"cells_widened": 0, "cells_grown": 0, "linprog_fallbacks": 0, "exact_rounds_max": 0,
             "estimate_radius_error_max": 0.0, "estimate_center_error_max": 0.0}
    if raster is not None:
        stats["grid"] = list(raster.shape)
    rho = [normalized_radius(X)]
    best_at = 0
    reason = "eps" if rho[0] >= eps else "max_iter"
    t_start = time.perf_counter()
    it = 0
    while rho[-1] < eps and it < max_iter:
        it += 1
        estimate = None
        if raster is not None:
            est = raster.compute(X)
            for k, v in est.timings.items():
                timings[k] += v
            estimate = (est.centers, est.radii)
        t0 = time.perf_counter()
        mic = exact_mic(X, None, dom, estimate=estimate)
        t1 = time.perf_counter()
        timings["exact_refine"] += t1 - t0
        X = mic.centers
        rho.append(normalized_radius(X))
        timings["rho"] += time.perf_counter() - t1
        s = mic.stats
        stats["cells_widened"] += s["widened"]
        stats["cells_grown"] += s["grown"]
        stats["linprog_fallbacks"] += s["linprog"]
        stats["exact_rounds_max"] = max(stats["exact_rounds_max"], s["rounds"])
        for key in ("estimate_radius_error_max", "estimate_center_error_max"):
            stats[key] = max(stats[key], s.get(key, 0.0))
        if callback is not None:
            callback(it, rho[-1])
        if rho[-1] > rho[best_at] + 1e-12:
            best_at = it
        if rho[-1] >= eps:
            reason = "eps"
        elif it - best_at >= patience:
            reason = "stalled"
            break
    seconds = time.perf_counter() - t_start
    if raster is not None:
        h = 1.0 / raster.shape[1]
        stats["estimate_radius_error_max_cells"] = stats["estimate_radius_error_max"] / h
        stats["estimate_center_error_max_cells"] = stats["estimate_center_error_max"] / h
    stats["cells_widened_per_iteration"] = stats["cells_widened"] / max(it, 1) / n
    return RelaxResult(X, np.array(rho), it, reason, seconds, timings, used, devname, stats)
