"""A million points at rho >= 0.8 in 2D, beside scipy's Delaunay of the same points, and analyze.

Usage: python benchmarks/bench_million.py [--n 1000000] [--no-analyze]

Times, in one process: the start set, the relaxation and the whole
``poisson_disk(n)`` call; then ``scipy.spatial.Delaunay`` of the relaxed
points (the yardstick the issue set: the set should take under a third of
it); then the numbers of ``diskpack analyze`` (periodogram by the
non-uniform FFT, rho, mean rho, psi6).
"""

import argparse
import time

from scipy.spatial import Delaunay

from diskpack_cl.plots import point_set_numbers
from diskpack_cl.poisson import poisson_disk


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--no-analyze", action="store_true")
    args = ap.parse_args()
    poisson_disk(1000, seed=1)   # build and warm the kernel
    t0 = time.perf_counter()
    res = poisson_disk(args.n, seed=0)
    total = time.perf_counter() - t0
    print(f"poisson_disk({args.n}): {total:.2f} s (start {res.start_seconds:.2f} s, relaxation "
          f"{res.seconds:.2f} s, {res.iterations} iterations), rho {res.rho:.4f}", flush=True)
    t0 = time.perf_counter()
    Delaunay(res.points)
    print(f"scipy Delaunay of the same points: {time.perf_counter() - t0:.2f} s", flush=True)
    if not args.no_analyze:
        t0 = time.perf_counter()
        numbers = point_set_numbers(res.points)
        print(f"analyze numbers: {time.perf_counter() - t0:.2f} s (kmax {numbers['kmax']}, peak "
              f"{numbers['peak_power']:.2f} at {numbers['peak_frequency']:g}, psi6 "
              f"{numbers['psi6_mean']:.3f})")


if __name__ == "__main__":
    main()
