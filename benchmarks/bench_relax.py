"""Seconds per relaxation iteration (Algorithm 1): every engine, and a plain scipy code.

Usage: python benchmarks/bench_relax.py [--sizes 1024,20000,100000,1000000] [--iters 5]
                                        [--plain-up-to 20000] [--calls 20] [--calls-up-to 20000]
                                        [--profile] [--json rows.jsonl]

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
  to ``--plain-up-to`` points;
- ``call``: ``relax_poisson(start, 0.8)`` as a user calls it, the whole call
  (engine, MICs, moves, the final rho's check) over its iterations, one row a
  call of ``--calls`` up to ``--calls-up-to`` points: what a batch of small
  sets pays an iteration.

Every engine's iterate is checked against ``exact``'s (max centre difference).
With ``--json`` every iteration is appended as a row (n, engine, seconds,
stages, that max difference, and the context of :mod:`perf_rows`);
:func:`summary` makes the docs' table of them.
"""

import argparse
import time
from itertools import combinations

import numpy as np

from diskpack_cl import relax_poisson
from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.measures import normalized_radius
from diskpack_cl.sampling import dart_throwing
from perf_rows import append, count, medians, num

#: The stages of the ``cells`` engine the table shows, and their column names.
CELL_STAGES = {"stage_buckets": "buckets", "stage_device": "device", "stage_refine": "host check"}


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
    X, seconds, stages = points.copy(), [], []
    for _ in range(iters):
        t0, mark = time.perf_counter(), eng.timings.mark()
        step = eng.mic(X)
        X = step.centers
        rho = 0.5 * step.nn.min() / np.sqrt(1 / (2 * np.sqrt(3) * len(X))) if step.nn is not None \
            else normalized_radius(X)
        seconds.append(time.perf_counter() - t0)
        stages.append(eng.timings.since(mark))
    return seconds, stages, X, rho


def run_plain(points, iters):
    X, seconds = points.copy(), []
    for _ in range(iters):
        t0 = time.perf_counter()
        X = plain_scipy_step(X)
        normalized_radius(X)
        seconds.append(time.perf_counter() - t0)
    return seconds, [{}] * iters, X, normalized_radius(X)


def run_calls(points, calls):
    """``calls`` whole ``relax_poisson(points, 0.8)`` calls: each call's seconds per
    iteration and its iterations."""
    relax_poisson(points, 0.8)   # programs built outside the timing
    out = []
    for _ in range(calls):
        t0 = time.perf_counter()
        res = relax_poisson(points, 0.8)
        out.append(((time.perf_counter() - t0) / max(res.iterations, 1), res.iterations))
    return out


def summary(rows):
    """``(header, rows)`` of the docs' table: per n, each engine's median seconds per iteration and ratios."""
    med = {(r["n"], r["engine"]): r for r in medians(rows, ("n", "engine"), ["seconds", *CELL_STAGES])}
    header = ["n", "cells (opencl default)", "exact (scipy)", "raster route", "plain scipy",
              "cells / exact", "cells / plain", "cells stages: " + " / ".join(CELL_STAGES.values()),
              "max centre difference from exact", "relax_poisson call, per iteration"]
    out = []
    for n in dict.fromkeys(r["n"] for r in rows):
        s = {e: med[n, e]["seconds"] if (n, e) in med else None for e in ("cells", "exact", "raster", "plain")}
        ratio = {e: num(s["cells"] / s[e]) if s[e] else "" for e in ("exact", "plain")}
        stages = " / ".join(num(med[n, "cells"][k]) for k in CELL_STAGES)
        dx = max(r["max_dx"] for r in rows if r["n"] == n and "max_dx" in r)
        call = num(med[n, "call"]["seconds"]) if (n, "call") in med else ""
        out.append([count(n), *(num(s[e]) for e in s), ratio["exact"], ratio["plain"], stages, f"{dx:.1e}",
                    call])
    return header, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1024,20000,100000,1000000")
    ap.add_argument("--iters", type=int, default=5)
    ap.add_argument("--plain-up-to", type=int, default=20000)
    ap.add_argument("--calls", type=int, default=20, help="whole relax_poisson calls a size")
    ap.add_argument("--calls-up-to", type=int, default=20000)
    ap.add_argument("--profile", action="store_true", help="OpenCL event times (stage 'kernel')")
    ap.add_argument("--json", default=None, help="append one JSON line per iteration to this file")
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
        sec_exact = np.median(res["exact"][0])
        for name, (seconds, stages, X, rho) in res.items():
            d = X - ref_x
            d -= np.round(d)
            dx = float(np.abs(d).max())
            for it, (sec, st) in enumerate(zip(seconds, stages)):
                append(args.json, {"n": n, "engine": name, "iteration": it, "seconds": sec,
                                   **{f"stage_{k}": v for k, v in st.items()}, "max_dx": dx, "rho": float(rho)})
            med = {k: float(np.median([s.get(k, 0.0) for s in stages])) for k in stages[0]}
            st = " ".join(f"{k}={v:.6f}" for k, v in med.items())
            sec = np.median(seconds)
            print(f"{n:>8} {name:>7} {sec:9.6f} {sec / sec_exact:8.3f} {dx:9.1e}  {st}", flush=True)
        if "plain" in res:
            print(f"{n:>8} cells / plain scipy = {np.median(res['cells'][0]) / np.median(res['plain'][0]):.3f}",
                  flush=True)
        if n <= args.calls_up_to and args.calls:
            calls = run_calls(pts, args.calls)
            for k, (sec, its) in enumerate(calls):
                append(args.json, {"n": n, "engine": "call", "iteration": k, "seconds": sec, "iterations": its})
            print(f"{n:>8} {'call':>7} {np.median([c[0] for c in calls]):9.6f}  s an iteration of a whole "
                  f"relax_poisson call ({calls[0][1]} iterations)", flush=True)


if __name__ == "__main__":
    main()
