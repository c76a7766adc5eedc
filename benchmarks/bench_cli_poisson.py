"""`diskpack poisson -n N` as a whole process, beside scipy's Delaunay of N random points.

Usage: python benchmarks/bench_cli_poisson.py [--n 1000000] [--repeat 3] [--json rows.jsonl]

The package's bytecode is compiled first (as ``pip install .`` leaves it) and
one warm-up run builds the kernels (PoCL caches them on disk); then each of
`--repeat` rounds times ``diskpack poisson -n N --seed 1 --json -o m.npz``
as a whole process (interpreter start, imports, device set-up, start set,
relaxation, writing) and ``scipy.spatial.Delaunay`` of N uniform random
points in this process, one after the other, so that both see the same
load.  It prints each round and the medians of the times and of the
per-round ratio, and where each process's time went, from the summary it
printed: the start set (``init_seconds``), the global iterations
(``seconds`` less the local route's ``stage_seconds``), the local steps with
the last rho, and the rest (interpreter, imports, device and programs, the
input check, writing, exit: the process's wall time less those), and what
the process used: its CPU seconds (all threads, PoCL's included), the
system's part of them, and its page faults (each first touch of a page of
fresh memory).  It checks
that the file holds the points of ``poisson_disk(N, seed=1)`` (computed in a fresh process, so that the
comparison is of the doors, not of a warm cache).  ``--json`` appends a row
per round with the context of :mod:`perf_rows`.
"""

import argparse
import json
import os
import resource
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


#: The stages of a process, as :func:`cli_run` names them, in their order.
STAGES = ("start", "global", "local", "rest")

#: What a process used, as :func:`cli_run` names it.
USAGE = ("cpu", "system", "faults")


def cli_run(n, out):
    """Wall seconds of one whole ``diskpack poisson`` process, its stages' seconds
    (:data:`STAGES`) from the summary it prints with ``--json``, and what it used
    (:data:`USAGE`: CPU and system seconds of all its threads, page faults)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run = subprocess.run([*DISKPACK, "poisson", "-n", str(n), "--seed", "1", "-q", "--json",
                          "-o", out], check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)   # this child's alone: one at a time
    told = json.loads(run.stdout)
    local = told["stage_seconds"].get("local", 0.0)
    parts = {"start": told["init_seconds"], "global": told["seconds"] - local, "local": local}
    parts["rest"] = wall - told["init_seconds"] - told["seconds"]
    parts["system"] = after.ru_stime - before.ru_stime
    parts["cpu"] = after.ru_utime - before.ru_utime + parts["system"]
    parts["faults"] = after.ru_minflt - before.ru_minflt
    return wall, parts


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


def stages(rows):
    """``(header, rows)`` of the docs' table of where a process's time goes: per n, the
    median seconds of each of :data:`STAGES` and of the whole process, and of what it
    used (:data:`USAGE`, empty where no round recorded it), over the rounds that
    recorded the stages."""
    runs = [r for r in rows if r["kind"] == "cli_poisson" and "start" in r]
    header = ["n", "rounds", "start set (darts)", "global iterations",
              "local steps and last rho", "the rest of the process", "whole process",
              "CPU (all threads)", "system CPU", "page faults"]
    return header, [[count(r["n"]), str(r["repeats"]), *(num(r[k], " s") for k in (*STAGES, "cli")),
                     num(r["cpu"], " s"), num(r["system"], " s"), count(r["faults"])]
                    for r in medians(runs, ("n",), [*STAGES, "cli", *USAGE])]


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None, help="append one JSON line per round to this file")
    args = ap.parse_args()
    installed_bytecode()
    with tempfile.TemporaryDirectory(prefix="diskpack-cli-poisson-") as tmp:   # (16 MB at 1M)
        rounds(args, str(Path(tmp) / "m.npz"))


def rounds(args, out):
    """The warm-up and the timed rounds of :func:`main`, each writing the file `out`."""
    cli_run(args.n, out)   # builds the kernels
    rows = []
    for r in range(args.repeat):
        load = os.getloadavg()[0]
        wall, parts = cli_run(args.n, out)
        row = {"cli": wall, "delaunay": delaunay_seconds(args.n, r), **parts}
        row["ratio"] = row["cli"] / row["delaunay"]
        rows.append(row)
        append(args.json, {"kind": "cli_poisson", "n": args.n, "round": r, **row})
        print(f"round {r}: load {load:.2f} diskpack poisson {row['cli']:.2f} s, "
              f"Delaunay {row['delaunay']:.2f} s, ratio {row['ratio']:.3f}; "
              + ", ".join(f"{k} {row[k]:.2f} s" for k in STAGES) + "; " + used(row), flush=True)
    med = {k: statistics.median(row[k] for row in rows) for k in rows[0]}
    print(f"median: diskpack poisson {med['cli']:.2f} s, Delaunay {med['delaunay']:.2f} s, "
          f"ratio {med['ratio']:.3f}; " + ", ".join(f"{k} {med[k]:.2f} s" for k in STAGES)
          + "; " + used(med))
    same = same_as_library(args.n, out)
    append(args.json, {"kind": "cli_poisson_same", "n": args.n, "same": same})
    print("same points as poisson_disk(n, seed=1):", same)


def used(row):
    """What a round's process used (:data:`USAGE`), as a round's line prints it."""
    return f"CPU {row['cpu']:.2f} s (system {row['system']:.2f} s), {row['faults']:.0f} page faults"


if __name__ == "__main__":
    main()
