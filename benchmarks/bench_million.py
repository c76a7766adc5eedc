"""A million points at rho >= 0.8 in 2D, beside scipy's Delaunay of the same points, and analyze.

Usage: python benchmarks/bench_million.py [--n 1000000] [--repeat 3] [--no-analyze] [--json rows.jsonl]

Times, in one process, `--repeat` runs of ``poisson_disk(n, seed=r)`` and
prints each run and the medians: the start set (parallel dart throwing),
the relaxation (global iterations on the device, then local ones) with the
engine's stages, and the whole call (wall, and ``cpu``: the CPU time of
all the process's threads, PoCL's included, which the load moves least);
then ``scipy.spatial.Delaunay`` of the relaxed points (the yardstick the
issue set: the set should take under a third of it); then the numbers of
``diskpack analyze`` (periodogram by the non-uniform FFT, rho, mean rho,
psi6) of the last set.  The load average
is printed with each run: on a shared machine, compare ratios within a run.
``--json`` appends a row per run and one for analyze, with the context of
:mod:`perf_rows`; :func:`summary` makes the docs' table of them.
"""

import argparse
import os
import statistics
import time

from scipy.spatial import Delaunay

from diskpack_cl.plots import point_set_numbers
from diskpack_cl.poisson import poisson_disk
from perf_rows import append, count, medians, num


def one_run(n, seed):
    """One timed run: a dict of seconds and counts."""
    load = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    res = poisson_disk(n, seed=seed)
    total, cpu = time.perf_counter() - t0, time.process_time() - c0
    t0 = time.perf_counter()
    Delaunay(res.points)
    row = {"load": load, "total": total, "cpu": cpu, "start": res.start_seconds,
           "relax": res.seconds, "delaunay": time.perf_counter() - t0, "iterations": res.iterations, "rho": res.rho}
    row.update(res.timings)
    return row, res


#: The keys of a run's row that are not the engine's stages.
RESULT_KEYS = ("total", "start", "relax", "delaunay", "iterations", "rho")


def summary(rows):
    """``(header, rows)`` of the docs' table: per n, medians over the runs (the ratio: median of each run's)."""
    runs = [dict(r, ratio=r["total"] / r["delaunay"]) for r in rows if r["kind"] == "run"]
    analyze = {r["n"]: r["seconds"] for r in medians([r for r in rows if r["kind"] == "analyze"], ("n",),
                                                       ["seconds"])}
    header = ["n", "runs", "poisson_disk total", "start set", "relaxation", "iterations", "rho",
              "scipy Delaunay of the set", "total / Delaunay", "analyze numbers"]
    return header, [[count(r["n"]), str(r["repeats"]), num(r["total"], " s"), num(r["start"], " s"),
                     num(r["relax"], " s"), num(r["iterations"]), f"{r['rho']:.3f}", num(r["delaunay"], " s"),
                     num(r["ratio"]), num(analyze.get(r["n"]), " s")]
                    for r in medians(runs, ("n",), ["total", "start", "relax", "iterations", "rho", "delaunay",
                                                    "ratio"])]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-analyze", action="store_true")
    ap.add_argument("--json", default=None, help="append one JSON line per run to this file")
    args = ap.parse_args()
    poisson_disk(50_000, seed=1)   # builds every kernel a large run uses (1000 points throw no darts on the device)
    rows = []
    for seed in range(args.repeat):
        row, res = one_run(args.n, seed)
        rows.append(row)
        # the load is the context's; the stages are prefixed, one of them is named "device"
        append(args.json, {"kind": "run", "n": args.n, "seed": seed,
                           **{k if k in RESULT_KEYS else f"stage_{k}": v for k, v in row.items() if k != "load"}})
        print(" ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()),
              flush=True)
    keys = [k for k in rows[0] if all(k in r for r in rows)]
    print("median: " + " ".join(f"{k} {statistics.median(r[k] for r in rows):.3f}" for k in keys))
    if not args.no_analyze:
        t0 = time.perf_counter()
        numbers = point_set_numbers(res.points)
        append(args.json, {"kind": "analyze", "n": args.n, "seconds": time.perf_counter() - t0,
                           "kmax": numbers["kmax"], "peak_power": numbers["peak_power"],
                           "psi6_mean": numbers["psi6_mean"]})
        print(f"analyze numbers: {time.perf_counter() - t0:.2f} s (kmax {numbers['kmax']}, peak "
              f"{numbers['peak_power']:.2f} at {numbers['peak_frequency']:g}, psi6 "
              f"{numbers['psi6_mean']:.3f})")


if __name__ == "__main__":
    main()
