"""Seconds per relaxation iteration, per stage, for both backends (issue 2).

Usage: python benchmarks/bench_relax.py [--sizes 1024,20000,100000,1000000] [--iters 3]

Each size starts from a dart-throwing set (rho ~ 0.74), which is the typical
input, and runs a few iterations of Algorithm 1 with each backend in the
same process, so that the ratio opencl/exact compares like with like on a
noisy machine.  Prints medians over the iterations.
"""

import argparse
import time

import numpy as np

from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
from diskpack_cl.measures import normalized_radius
from diskpack_cl.raster import PowerRaster, auto_grid
from diskpack_cl.sampling import dart_throwing


def run(points, backend, iters):
    dom = Domain.torus()
    X = points.copy()
    pr = PowerRaster(dom, auto_grid(len(X), dom)) if backend == "opencl" else None
    if pr is not None:
        pr.compute(X)   # build and warm the kernels outside the timing
    rows = []
    for _ in range(iters):
        t0 = time.perf_counter()
        est = None
        lab = mic_est = 0.0
        if pr is not None:
            r = pr.compute(X)
            lab, mic_est = r.timings["raster_labels"], r.timings["mic_estimate"]
            est = (r.centers, r.radii)
        t1 = time.perf_counter()
        mic = exact_mic(X, None, dom, estimate=est)
        t2 = time.perf_counter()
        X = mic.centers
        normalized_radius(X)
        t3 = time.perf_counter()
        rows.append((t3 - t0, lab, mic_est, t2 - t1, t3 - t2))
    return np.median(np.array(rows), axis=0), X


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1024,20000,100000,1000000")
    ap.add_argument("--iters", type=int, default=3)
    args = ap.parse_args()
    print(f"{'n':>8} {'backend':>7} {'s/iter':>8} {'labels':>8} {'mic_est':>8} {'exact':>8} "
          f"{'rho_s':>7} {'us/(n log2 n)':>13}")
    for n in (int(s) for s in args.sizes.split(",")):
        pts = dart_throwing(n, seed=1)
        res = {}
        for backend in ("opencl", "exact"):
            (tot, lab, est, ex, rho_t), X = run(pts, backend, args.iters)
            res[backend] = tot
            print(f"{n:>8} {backend:>7} {tot:8.4f} {lab:8.4f} {est:8.4f} {ex:8.4f} "
                  f"{rho_t:7.4f} {1e6 * tot / (n * np.log2(n)):13.3f}", flush=True)
        print(f"{n:>8} ratio opencl/exact = {res['opencl'] / res['exact']:.2f}", flush=True)


if __name__ == "__main__":
    main()
