"""`diskpack poisson -n N` as a whole process, beside scipy's Delaunay of N random points.

Usage: python benchmarks/bench_cli_poisson.py [--n 1000000] [--repeat 3] [--json rows.jsonl]

The package's bytecode is compiled first (as ``pip install .`` leaves it) and
one warm-up run builds the kernels (PoCL caches them on disk); then each of
`--repeat` rounds times ``diskpack poisson -n N --seed 1 -o m.npz`` as a
whole process (interpreter start, imports, device set-up, start set,
relaxation, writing) and ``scipy.spatial.Delaunay`` of N uniform random
points in this process, one after the other, so that both see the same
load.  It prints each round and the medians of the times and of the
per-round ratio, and checks that the file holds the points of
``poisson_disk(N, seed=1)`` (computed in a fresh process, so that the
comparison is of the doors, not of a warm cache).  ``--json`` appends a row
per round with the context of :mod:`perf_rows`.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay

from perf_rows import append, count, installed_bytecode, medians, num

DISKPACK = [sys.executable, "-m", "diskpack_cl.cli"]


def cli_seconds(n, out):
    """Wall seconds of one whole ``diskpack poisson`` process."""
    t0 = time.perf_counter()
    subprocess.run([*DISKPACK, "poisson", "-n", str(n), "--seed", "1", "-q", "-o", out],
                   check=True)
    return time.perf_counter() - t0


def delaunay_seconds(n, seed):
    points = np.random.default_rng(seed).random((n, 2))
    t0 = time.perf_counter()
    Delaunay(points)
    return time.perf_counter() - t0


def same_as_library(n, out):
    """Whether the file holds ``poisson_disk(n, seed=1).points``, computed in a fresh process."""
    code = ("import sys, numpy as np; from diskpack_cl import poisson_disk; "
            f"p = poisson_disk({n}, seed=1).points; "
            f"sys.exit(0 if np.array_equal(np.load({out!r})['points'], p) else 1)")
    return subprocess.run([sys.executable, "-c", code]).returncode == 0


def summary(rows):
    """``(header, rows)`` of the docs' table: per n, medians over the rounds (the ratio: median of
    each round's) and whether the file held the library's points."""
    same = {r["n"]: r["same"] for r in rows if r["kind"] == "cli_poisson_same"}
    runs = [r for r in rows if r["kind"] == "cli_poisson"]
    header = ["n", "rounds", "diskpack poisson (whole process)", "scipy Delaunay",
              "process / Delaunay", "points of poisson_disk(n, seed=1)"]
    return header, [[count(r["n"]), str(r["repeats"]), num(r["cli"], " s"), num(r["delaunay"], " s"),
                     num(r["ratio"]), {True: "yes", False: "no"}.get(same.get(r["n"]), "")]
                    for r in medians(runs, ("n",), ["cli", "delaunay", "ratio"])]


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None, help="append one JSON line per round to this file")
    args = ap.parse_args()
    out = str(Path(tempfile.mkdtemp()) / "m.npz")
    installed_bytecode()
    cli_seconds(args.n, out)   # builds the kernels
    rows = []
    for r in range(args.repeat):
        load = os.getloadavg()[0]
        row = {"cli": cli_seconds(args.n, out), "delaunay": delaunay_seconds(args.n, r)}
        row["ratio"] = row["cli"] / row["delaunay"]
        rows.append(row)
        append(args.json, {"kind": "cli_poisson", "n": args.n, "round": r, **row})
        print(f"round {r}: load {load:.2f} diskpack poisson {row['cli']:.2f} s, "
              f"Delaunay {row['delaunay']:.2f} s, ratio {row['ratio']:.3f}", flush=True)
    med = {k: statistics.median(row[k] for row in rows) for k in rows[0]}
    print(f"median: diskpack poisson {med['cli']:.2f} s, Delaunay {med['delaunay']:.2f} s, "
          f"ratio {med['ratio']:.3f}")
    same = same_as_library(args.n, out)
    append(args.json, {"kind": "cli_poisson_same", "n": args.n, "same": same})
    print("same points as poisson_disk(n, seed=1):", same)


if __name__ == "__main__":
    main()
