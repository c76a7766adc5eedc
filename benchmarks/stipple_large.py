"""A large stippling within the machine's memory: n = 1M dots on an 8192 x 8192 image.

Usage: python benchmarks/stipple_large.py [--size 8192] [--n 1000000] [--mix 3] [--full] [--before]
                                         [--command [--label TEXT]] [--json rows.jsonl]

The image is the bundled sample photograph scaled up (Lanczos).  Runs a few
iterations of the default schedule's step ("mix", with the default's
options), or with --full the whole default schedule, and prints seconds per
iteration by stage, the time to the certified result, and the peak resident
memory of the process.  ``--command`` times the whole default run as a user
gets it instead: ``diskpack stipple PICTURE.png -n N -o OUT.npz`` in a child
process (the package's bytecode compiled first, as ``pip install .`` leaves
it; the picture saved as a PNG in the temporary folder first), from
the interpreter's start to its exit (loading, the start, every step, the
certificate, writing the ``.npz``), its peak resident memory (``wait4``'s
``ru_maxrss`` of the child), where the time goes (the run's stages from its
``--json`` line; ``read``: the command line reading the picture and
planning; ``write``: writing the ``.npz``; ``outside``: starting the
interpreter, imports, reading the arguments and exiting), and in the same run
scipy's ``Voronoi`` of n uniform random points (seed 0) for scale.
The row also holds the CPU seconds of both (``cpu_s``, ``voronoi_cpu_s``),
which a busy machine stretches less than the wall clock, and ``ratio_cpu``,
the command's wall seconds over Voronoi's CPU seconds: Voronoi runs on one
core, so its CPU seconds are its wall clock on a quiet machine, and another
job beside it does not lower that ratio.
``--json`` appends the run as a row with the context of :mod:`perf_rows`;
:func:`summary` makes the docs' table of them.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.spatial import Voronoi

from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.schedule import SCHEDULE_OPTIONS
from diskpack_cl.stipple import stipple
from perf_rows import append, count, installed_bytecode, medians, num

#: The engine's stages of the steps (their sum per step is the table's s/iter of a command row).
ENGINE_STAGES = ("buckets", "device", "refine", "fallback", "raster_labels", "mic_estimate", "exact",
                 "centroids")

#: Names the table gives the stages (``load`` is loading the image, not the load average).
STAGE_NAMES = {"load": "loading the image", "device": "MIC kernel", "refine": "MIC host check",
               "raster_labels": "labels", "write": "writing the .npz",
               "read": "reading the picture (command line)",
               "outside": "interpreter, imports and exit", "rest": "the rest of the run"}


def summary(rows):
    """``(header, rows)`` of the docs' table: medians per image, n and schedule, with the run's stages."""
    # "total" is the seconds column again
    stages = list(dict.fromkeys(k for r in rows for k in r if k.startswith("stage_") and k != "stage_total"))
    values = ["seconds", "iterations", "s_per_iter", "peak_rss_gib", "voronoi_s", "ratio", "ratio_cpu",
              "cpu_s", "voronoi_cpu_s", *stages]
    runs = medians(rows, ("size", "n", "schedule"), values)
    header = ["image", "n", "schedule", "runs", "steps",
              "seconds (to the certified result; the whole command: start to exit)",
              "s/iter (median; the whole command: its engine stages a step)",
              "Voronoi(n) in the same run (s)", "ratio to Voronoi",
              "ratio to Voronoi's CPU seconds", "CPU seconds, run / Voronoi", "peak resident memory",
              "stages (s)"]
    return header, [[f"{r['size']} x {r['size']}", count(r["n"]), r["schedule"], r["repeats"],
                     num(r["iterations"]), num(r["seconds"]), num(r["s_per_iter"]), num(r["voronoi_s"]),
                     num(r["ratio"]), num(r["ratio_cpu"]),
                     f"{num(r['cpu_s'])} / {num(r['voronoi_cpu_s'])}" if r["cpu_s"] else "",
                     num(r["peak_rss_gib"], " GiB"),
                     ", ".join(f"{STAGE_NAMES.get(k[6:], k[6:])} {num(r[k])}"
                               for k in stages if (r[k] or 0) >= 0.05)] for r in runs]


def picture(size):
    """The sample photograph scaled up to `size` x `size` (Lanczos): an 8-bit Pillow image."""
    gray = load_gray(sample_image_path())
    return Image.fromarray((gray * 255).astype(np.uint8)).resize((size, size), Image.LANCZOS)


def voronoi_seconds(n, seed=0):
    """Wall and CPU seconds of scipy's ``Voronoi`` of `n` uniform random points in the unit square."""
    pts = np.random.default_rng(seed).random((n, 2))
    t, cpu = time.perf_counter(), time.process_time()
    Voronoi(pts)
    return time.perf_counter() - t, time.process_time() - cpu


def run_command(size, n):
    """``(wall seconds, CPU seconds, peak RSS GiB, --json summary)`` of ``diskpack stipple`` on the
    :func:`picture` saved as a PNG, in a child process timed from its start to its exit."""
    folder = Path(tempfile.gettempdir())
    png = folder / f"stipple_large_{size}.png"
    if not png.exists():
        picture(size).save(png)
    out = folder / f"stipple_large_{size}_{n}.npz"
    cmd = [sys.executable, "-m", "diskpack_cl.cli", "stipple", str(png), "-n", str(n), "-o", str(out),
           "--json", "-q"]
    with tempfile.TemporaryFile("w+") as log, tempfile.TemporaryFile("w+") as err:
        t = time.perf_counter()
        child = subprocess.Popen(cmd, stdout=log, stderr=err)
        _, status, usage = os.wait4(child.pid, 0)   # this child's own peak memory
        wall = time.perf_counter() - t
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode:
            err.seek(0)
            raise RuntimeError(f"{' '.join(cmd)} failed: {err.read()}")
        log.seek(0)
        line = log.read().splitlines()[-1]
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 2**20, json.loads(line)


def command_row(size, n, label=None):
    """The row of one :func:`run_command` with :func:`voronoi_seconds` of n points before it
    (`label`: a few words the table adds to the schedule, such as the code measured)."""
    vor, vor_cpu = voronoi_seconds(n)
    wall, cpu, peak, res = run_command(size, n)
    t = res["timings"]
    stages = {f"stage_{k}": v for k, v in t.items()}
    steps = sum(t.get(k, 0.0) for k in ENGINE_STAGES)
    # what no stage times: the steps' host work (and the setup, where the run does not time it)
    stages.update(stage_rest=max(t["total"] - sum(v for k, v in t.items() if k != "total"), 0.0),
                  stage_read=res["seconds"] - t["total"] - res["write_seconds"],
                  stage_write=res["write_seconds"], stage_outside=wall - res["seconds"])
    print(f"n={n} image={size}x{size}: the whole command {wall:.1f} s, Voronoi({n}) {vor:.1f} s, "
          f"ratio {wall / vor:.2f} (CPU time {cpu:.1f} s against {vor_cpu:.1f} s), peak RSS "
          f"{peak:.2f} GiB, certified valid: "
          f"{res['certificate']['valid']}\n  stages: { {k[6:]: round(v, 2) for k, v in stages.items()} }")
    schedule = "default, the whole command" + (f", {label}" if label else "")
    return {"size": size, "n": n, "schedule": schedule, "seconds": wall,
            "iterations": res["iterations"], "s_per_iter": steps / res["iterations"],
            "voronoi_s": vor, "ratio": wall / vor, "ratio_cpu": wall / vor_cpu, "cpu_s": cpu,
            "voronoi_cpu_s": vor_cpu,
            "peak_rss_gib": peak,
            "valid": bool(res["certificate"]["valid"]), **stages}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--mix", type=int, default=3)
    ap.add_argument("--full", action="store_true", help="the whole default schedule")
    ap.add_argument("--before", action="store_true",
                    help="the default without the support rule and capacity")
    ap.add_argument("--command", action="store_true",
                    help="the whole default run through the command line, against Voronoi(n)")
    ap.add_argument("--label", default=None,
                    help="with --command: words the table adds to the schedule (the code measured)")
    ap.add_argument("--json", default=None, help="append the run as a JSON line to this file")
    args = ap.parse_args()
    if args.command:
        installed_bytecode()
        append(args.json, command_row(args.size, args.n, args.label))
        return
    gray = np.asarray(picture(args.size), np.float64) / 255.0
    t = time.perf_counter()
    kw = {} if args.full else dict(SCHEDULE_OPTIONS["default"], schedule=[("mix", args.mix)])
    if args.before:
        kw.update(support=0.0, capacity=0.0)
    res = stipple(gray, args.n, seed=0, **kw)
    total = time.perf_counter() - t
    peak_gib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    by_kind = {}
    for h in res.history:
        by_kind.setdefault(h["kind"], []).append(h)
    print(f"n={args.n} image={args.size}x{args.size} total {total:.1f} s, peak RSS {peak_gib:.2f} GiB, "
          f"certified valid: {res.certificate.valid}")
    for kind, rows in by_kind.items():
        keys = ["seconds"] + sorted({k for r in rows for k in r if k.endswith("_s")})
        parts = ", ".join(f"{k} {np.median([r.get(k, 0.0) for r in rows]):.2f}" for k in keys)
        print(f"  {kind}: {len(rows)} iterations, median seconds: {parts}")
    print(f"  timings: { {k: round(v, 2) for k, v in res.timings.items()} }")
    schedule = ("default" if args.full else f"{args.mix} mix steps") + (" without support and capacity" if args.before else "")
    per_iter = float(np.median([h["seconds"] for h in res.history]))
    append(args.json, {"size": args.size, "n": args.n, "schedule": schedule, "seconds": total,
                       "iterations": len(res.history), "s_per_iter": per_iter,
                       "peak_rss_gib": peak_gib, "valid": bool(res.certificate.valid),
                       **{f"stage_{k}": v for k, v in res.timings.items()}})


if __name__ == "__main__":
    main()
