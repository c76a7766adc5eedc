"""diskpack against other Poisson disk samplers, 2D and 3D, torus and box.

Usage: python benchmarks/bench_peers.py [--sizes 1000,10000,100000] [--dim 2] [--timeout 600]
                                        [--json out.jsonl]

Every sampler runs in its own worker process of one process pool (one at a
time, so they do not compete), asked for about n points; the parent measures
each set independently:

- ``n``: points produced; ``seconds``: wall time of the call in the worker;
- ``rho``: half the minimum distance (scipy KD-tree, periodic on the torus)
  over the densest packing's radius (hexagonal in 2D, FCC in 3D);
- 2D only, from the periodogram at integer frequencies on the unit square
  (:func:`diskpack_cl.analysis.periodogram`): ``low`` the mean radial power
  over ``1 <= |k| <= sqrt(n) / 2`` (the blue-noise dip; 1 is white noise) and
  ``peak`` the largest radial mean power (the ring).

Peers: ``scipy.stats.qmc.PoissonDisk`` (d = 2, 3), ``bridson`` (pure Python,
2D) and ``poisson_disc`` (numpy, any d), all in the unit box; they have no
torus.  Each peer's radius is set from its packing density so that it
returns about n points (in 2D scipy and poisson_disc reach rho ~0.72,
bridson ~0.66 with its default k = 5; in 3D about 0.755).  diskpack relaxes
to its default eps 0.8 in both; its time includes building the kernel in
the fresh worker (about 1 s on PoCL).  A peer that passes ``--timeout`` is
stopped and listed as such.  ``--json`` appends a row per run (a stopped one
with ``stopped_after``) with the context of :mod:`perf_rows`; :func:`summary`
makes the docs' tables of them.
"""

import argparse
import math
import time
from concurrent.futures import ProcessPoolExecutor, TimeoutError

import numpy as np

from perf_rows import append, count, medians, num

#: rho each peer reaches (measured), to ask it for about n points, by dimension.
PEER_RHO = {2: {"scipy": 0.72, "poisson_disc": 0.72, "bridson": 0.66},
            3: {"scipy": 0.755, "poisson_disc": 0.755}}


def _r_max(n, dim):
    """Radius of the densest packing of n disks (hexagonal) or spheres (FCC) in the unit cube."""
    return math.sqrt(1 / (2 * math.sqrt(3) * n)) if dim == 2 else (1 / (4 * math.sqrt(2) * n)) ** (1 / 3)


def _min_distance(n, dim, rho):
    """The minimum distance at which a sampler of normalized radius rho gives n points."""
    return 2 * rho * _r_max(n, dim)


def run_sampler(name, n, dim, torus, seed):
    """Points of one sampler (in the worker process) and its seconds."""
    t0 = time.perf_counter()
    if name == "diskpack":
        from diskpack_cl.poisson import poisson_disk

        box = None if torus else (1.0,) * dim
        pts = poisson_disk(n, box=box, seed=seed, dim=dim).points
    elif name == "scipy":
        from scipy.stats import qmc

        pts = qmc.PoissonDisk(dim, radius=_min_distance(n, dim, PEER_RHO[dim][name]), seed=seed).fill_space()
    elif name == "poisson_disc":
        from poisson_disc import Bridson_sampling

        np.random.seed(seed)
        pts = Bridson_sampling(np.ones(dim), radius=_min_distance(n, dim, PEER_RHO[dim][name]))
    else:
        import random

        from bridson import poisson_disc_samples

        random.seed(seed)
        pts = np.array(poisson_disc_samples(1.0, 1.0, _min_distance(n, dim, PEER_RHO[dim][name])))
    return np.asarray(pts, dtype=np.float64), time.perf_counter() - t0


def measures(pts, dim, torus):
    """rho (against the densest packing) and, in 2D, the low-frequency power and ring peak."""
    from scipy.spatial import cKDTree

    n = len(pts)
    X = np.mod(pts, 1.0) if torus else pts
    d, _ = cKDTree(X, boxsize=1.0 if torus else None).query(X, k=2)
    out = {"n": n, "rho": 0.5 * float(d[:, 1].min()) / _r_max(n, dim)}
    if dim == 2:
        from diskpack_cl.analysis import periodogram, radial_power

        freqs, P = periodogram(pts, kmax=int(math.ceil(1.5 * math.sqrt(n))))
        k, power = radial_power(P, freqs)
        out["low"] = float(power[k <= 0.5 * math.sqrt(n)].mean())
        out["peak"] = float(power.max())
    return out


#: How the tables name the samplers.
SHOWN = {"diskpack": "diskpack", "scipy": "scipy PoissonDisk", "poisson_disc": "`poisson_disc`",
         "bridson": "`bridson`"}


def summary(rows, dim=2):
    """``(header, rows)`` of the docs' table for ``dim``: medians per size, domain and sampler."""
    values = ["n", "seconds", "rho", "stopped_after"] + (["low", "peak"] if dim == 2 else [])
    header = ["n", "domain", "sampler", "n produced", "seconds", "rho"] + (["low", "peak"] if dim == 2 else [])
    out = []
    for r in medians([r for r in rows if r["dim"] == dim], ("asked", "domain", "sampler"), values):
        if r["seconds"] is None:
            seconds = f"> {r['stopped_after']:g} (stopped)"
        else:
            seconds = num(r["seconds"])
        tail = [num(r["low"]), num(r["peak"])] if dim == 2 else []
        out.append([count(r["asked"]), r["domain"], SHOWN[r["sampler"]], count(r["n"]), seconds,
                    "" if r["rho"] is None else f"{r['rho']:.3f}", *tail])
    return header, out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="1000,10000,100000")
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--samplers", default=None, help="comma list (default: all for the dim)")
    ap.add_argument("--json", default=None, help="append one JSON line per run to this file")
    args = ap.parse_args()
    names = (args.samplers.split(",") if args.samplers else
             ["diskpack", "scipy", "poisson_disc"] + (["bridson"] if args.dim == 2 else []))
    print("| d | n asked | domain | sampler | n | seconds | rho |" + (" low | peak |" if args.dim == 2 else ""))
    for n in (int(s) for s in args.sizes.split(",")):
        for torus in (True, False):
            for name in names:
                if torus and name != "diskpack":
                    continue
                with ProcessPoolExecutor(max_workers=1) as pool:
                    fut = pool.submit(run_sampler, name, n, args.dim, torus, 1)
                    try:
                        pts, sec = fut.result(timeout=args.timeout)
                    except TimeoutError:
                        for p in pool._processes.values():   # a peer past the timeout is stopped
                            p.terminate()
                        print(f"| {args.dim} | {n} | box | {name} | - | > {args.timeout:g} | - |")
                        append(args.json, {"dim": args.dim, "asked": n, "domain": "box", "sampler": name,
                                           "stopped_after": args.timeout})
                        continue
                row = {"dim": args.dim, "asked": n, "domain": "torus" if torus else "box",
                       "sampler": name, "seconds": sec, **measures(pts, args.dim, torus)}
                extra = f" {row['low']:.3f} | {row['peak']:.2f} |" if args.dim == 2 else ""
                print(f"| {args.dim} | {n} | {row['domain']} | {name} | {row['n']} | {sec:.3g} | "
                      f"{row['rho']:.3f} |{extra}", flush=True)
                append(args.json, row)


if __name__ == "__main__":
    main()
