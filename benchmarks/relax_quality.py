"""Relaxation quality figures: iterations to rho 0.80 and the highest rho.

Usage: python benchmarks/relax_quality.py [--seeds 5] [--converge-iter 3000] [--backend exact]

Prints, for n = 1024: iterations from a dart-throwing start (rho ~ 0.74) and
from a uniform random start to reach rho >= 0.80 (median, min, max over
seeds); and, for n = 1024 and 4096, the highest rho reached when run to
convergence (eps 0.99, stopping when rho has not grown for `patience`
iterations or at --converge-iter).  The backends give the same iterates, so
the fast one is the default.
"""

import argparse
import time

import numpy as np

from diskpack_cl.relax import relax_poisson
from diskpack_cl.sampling import dart_throwing, random_points


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--converge-iter", type=int, default=3000)
    ap.add_argument("--patience", type=int, default=300)
    ap.add_argument("--backend", default="exact")
    args = ap.parse_args()
    n = 1024
    for name, make in (("dart", lambda s: dart_throwing(n, seed=s)), ("random", lambda s: random_points(n, seed=s))):
        its, rho0 = [], []
        for s in range(args.seeds):
            pts = make(s)
            res = relax_poisson(pts, 0.8, backend=args.backend, max_iter=500)
            assert np.all(np.diff(res.rho) >= -1e-12), "rho decreased"
            its.append(res.iterations)
            rho0.append(res.rho[0])
        print(f"n={n} start={name:6s} rho_start={np.median(rho0):.3f} iterations to 0.80: "
              f"median {int(np.median(its))} (min {min(its)}, max {max(its)})", flush=True)
    for n in (1024, 4096):
        t = time.perf_counter()
        res = relax_poisson(dart_throwing(n, seed=0), 0.99, backend=args.backend,
                            max_iter=args.converge_iter, patience=args.patience)
        best = int(np.argmax(res.rho))
        print(f"n={n} converge: highest rho {res.rho.max():.4f} at iteration {best}, "
              f"stopped {res.stop_reason} after {res.iterations} ({time.perf_counter() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
