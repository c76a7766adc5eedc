"""Seconds per relaxation iteration (Algorithm 1): every engine, and a plain scipy code.

Usage: python benchmarks/bench_relax.py [--sizes 1024,20000,100000,1000000] [--iters 5]
                                        [--plain-up-to 20000] [--profile]

Each size starts from a dart-throwing set (rho ~ 0.74) and runs `iters`
iterations of Algorithm 1 with each engine in the same process, so that
ratios compare like with like on a noisy machine.  Prints the median
seconds per iteration and its stages:

- ``cells``: the float64 per-cell OpenCL kernel, checked on the host (the
  default ``opencl`` backend on devices with float64);
- ``raster``: the float32 raster estimate refined by ``exact_mic`` (the
  route for devices without float64);
- ``exact``: ``exact_mic`` alone (``--backend exact``);
- ``plain``: an independent plain scipy implementation (Voronoi neighbours
  from ``scipy.spatial.Delaunay`` of the points and their periodic images,
  each cell's Chebyshev LP by enumerating its neighbours' triples), run up
  to ``--plain-up-to`` points.

Every engine's iterate is checked against ``exact``'s (max centre difference).
"""

import argparse
import time
from itertools import combinations

import numpy as np

from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.measures import normalized_radius
from diskpack_cl.sampling import dart_throwing


def plain_scipy_step(X, block=4000):
    """One iteration of Algorithm 1 in plain numpy/scipy, independent of the package.

    Every Voronoi neighbour of a point is a Delaunay neighbour, so each cell's
    constraint set is complete; the least R over the dual-feasible triples
    of a complete set is the LP optimum (weak and strong duality).
    """
    from scipy.spatial import Delaunay

    n = len(X)
    margin = 4.0 / np.sqrt(n)
    shifts = np.array([(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1) if (sx, sy) != (0, 0)])
    P = [X] + [X + s for s in shifts]
    P = np.concatenate([P[0]] + [q[np.all((q > -margin) & (q < 1 + margin), axis=1)] for q in P[1:]])
    indptr, nbrs = Delaunay(P).vertex_neighbor_vertices
    deg = np.diff(indptr[: n + 1])
    D = int(deg.max())
    slot = np.minimum(np.arange(D)[None, :], deg[:, None] - 1)     # pad with the last neighbour
    nb = nbrs[indptr[:n, None] + slot]
    T = np.array(list(combinations(range(D), 3)))
    out = np.empty_like(X)
    for lo in range(0, n, block):
        i = np.arange(lo, min(lo + block, n))
        a = P[nb[i]] - X[i, None, :]
        L = np.hypot(a[..., 0], a[..., 1])
        rows = np.concatenate([a / L[..., None], np.ones(L.shape + (1,))], -1)[:, T]   # (m, t, 3, 3)
        beta = (L / 2)[:, T]
        r0, r1, r2 = rows[..., 0, :], rows[..., 1, :], rows[..., 2, :]
        c0, c1, c2 = np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)
        det = np.einsum("...k,...k", r0, c0)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (c0 * beta[..., :1] + c1 * beta[..., 1:2] + c2 * beta[..., 2:]) / det[..., None]
            feasible = (np.abs(det) > 1e-14) & (c0[..., 2] / det >= -1e-9) & (c1[..., 2] / det >= -1e-9) \
                & (c2[..., 2] / det >= -1e-9)
        best = np.argmin(np.where(feasible, z[..., 2], np.inf), axis=1)
        out[i] = X[i] + z[np.arange(len(i)), best, :2]
    return np.mod(out, 1.0)


def run_engine(points, name, iters, profile):
    dom = Domain.torus()
    eng = make_engine(dom, len(points), "exact" if name == "exact" else "opencl",
                      route="auto" if name == "exact" else name,
                      profile=profile)
    eng.mic(points)    # build and warm outside the timing
    X, rows, stages = points.copy(), [], []
    for _ in range(iters):
        t0, mark = time.perf_counter(), eng.timings.mark()
        step = eng.mic(X)
        X = step.centers
        rho = 0.5 * step.nn.min() / np.sqrt(1 / (2 * np.sqrt(3) * len(X))) if step.nn is not None \
            else normalized_radius(X)
        rows.append(time.perf_counter() - t0)
        stages.append(eng.timings.since(mark))
    med = {k: float(np.median([s.get(k, 0.0) for s in stages])) for k in stages[0]}
    return float(np.median(rows)), med, X, rho


def run_plain(points, iters):
    X, rows = points.copy(), []
    for _ in range(iters):
        t0 = time.perf_counter()
        X = plain_scipy_step(X)
        normalized_radius(X)
        rows.append(time.perf_counter() - t0)
    return float(np.median(rows)), {}, X, normalized_radius(X)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1024,20000,100000,1000000")
    ap.add_argument("--iters", type=int, default=5)
    ap.add_argument("--plain-up-to", type=int, default=20000)
    ap.add_argument("--profile", action="store_true", help="OpenCL event times (stage 'kernel')")
    args = ap.parse_args()
    print(f"{'n':>8} {'engine':>7} {'s/iter':>9} {'x exact':>8} {'max |dx|':>9}  stages (median s)")
    for n in (int(s) for s in args.sizes.split(",")):
        pts = dart_throwing(n, seed=1)
        res = {}
        for name in ("exact", "cells", "raster"):
            res[name] = run_engine(pts, name, args.iters, args.profile)
        if n <= args.plain_up_to:
            res["plain"] = run_plain(pts, args.iters)
        ref_x = res["exact"][2]
        for name, (sec, stages, X, rho) in res.items():
            d = X - ref_x
            d -= np.round(d)
            st = " ".join(f"{k}={v:.4f}" for k, v in stages.items())
            print(f"{n:>8} {name:>7} {sec:9.4f} {sec / res['exact'][0]:8.3f} {np.abs(d).max():9.1e}  {st}",
                  flush=True)
        if "plain" in res:
            print(f"{n:>8} cells / plain scipy = {res['cells'][0] / res['plain'][0]:.3f}", flush=True)


if __name__ == "__main__":
    main()
