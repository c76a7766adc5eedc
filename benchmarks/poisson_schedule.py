"""Poisson schedules against the default one: start radius, over-relaxation, when to go local.

Usage: python benchmarks/poisson_schedule.py [--n 1000000] [--seeds 0,1,2] [--repeat 2]
       [--schedule NAME=START:OMEGAS:SHARE:SOON ...] [--json rows.jsonl]

Each schedule sets the start set's dart radius (``poisson_disk(dart_radius=)``),
the factors of the over-relaxed global moves (:data:`diskpack_cl.relax.OVER_RELAX`,
comma-separated) and the shares of bad points at which the set goes local and
at which the next iterate gets its nearest neighbours alone
(:data:`diskpack_cl.relax_local.LOCAL_SHARE`, :data:`~diskpack_cl.relax_local.LOCAL_SOON`).
The schedules run in interleaved rounds on the same seeds in one process
(one warm-up call first), and each call prints its wall and CPU seconds (the
CPU time of all the process's threads, PoCL's included, which the load moves
least), the start's and the local steps' seconds and the global and local
iterations; then, per schedule, the medians and the median CPU ratio against
the first schedule on the same seed and round (the anchor: today's default).
Every call must reach rho >= 0.8 (measured exactly), and the constants are put
back after each call.  The quality of a schedule's sets is measured apart
(``diskpack analyze``, :func:`diskpack_cl.plots.point_set_numbers`).
"""

import argparse
import statistics
import time

from diskpack_cl import relax, relax_local
from diskpack_cl.poisson import START_RADIUS, poisson_disk
from perf_rows import append

DEFAULT = f"default={START_RADIUS}:{','.join(map(str, relax.OVER_RELAX))}:" \
          f"{relax_local.LOCAL_SHARE}:{relax_local.LOCAL_SOON}"


def parse(text):
    """``(name, dart radius, over-relaxation factors, local share, soon share)`` of
    ``NAME=START:OMEGAS:SHARE:SOON``."""
    name, spec = text.split("=")
    start, omegas, share, soon = spec.split(":")
    return name, float(start), tuple(float(w) for w in omegas.split(",")), float(share), float(soon)


def one_call(n, seed, schedule):
    """One timed ``poisson_disk(n, seed=seed)`` under `schedule`: a dict of seconds and counts."""
    _, start, omegas, share, soon = schedule
    kept = relax.OVER_RELAX, relax_local.LOCAL_SHARE, relax_local.LOCAL_SOON
    relax.OVER_RELAX, relax_local.LOCAL_SHARE, relax_local.LOCAL_SOON = omegas, share, soon
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        res = poisson_disk(n, seed=seed, dart_radius=start)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        relax.OVER_RELAX, relax_local.LOCAL_SHARE, relax_local.LOCAL_SOON = kept
    if res.rho < 0.8:
        raise SystemExit(f"seed {seed}: rho {res.rho} under 0.8")
    local = res.stats.get("local_iterations", 0)
    return {"wall": wall, "cpu": cpu, "start": res.start_seconds,
            "local": res.timings.get("local", 0.0), "global_iterations": res.iterations - local,
            "local_iterations": local, "rho": float(res.rho)}


def report(schedules, rows):
    """Per schedule: medians over its calls and the median CPU ratio against the first."""
    anchor = {(r["seed"], r["round"]): r["cpu"] for r in rows if r["schedule"] == schedules[0][0]}
    for name, *_ in schedules:
        mine = [r for r in rows if r["schedule"] == name]
        med = {k: statistics.median(r[k] for r in mine) for k in ("wall", "cpu", "start", "local")}
        ratio = statistics.median(r["cpu"] / anchor[r["seed"], r["round"]] for r in mine)
        print(f"{name}: median wall {med['wall']:.3f} s, cpu {med['cpu']:.3f} s (x{ratio:.3f} of "
              f"{schedules[0][0]}), start {med['start']:.3f} s, local {med['local']:.3f} s, "
              f"global iterations {sorted({r['global_iterations'] for r in mine})}")


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--schedule", action="append", default=[],
                    help="NAME=START:OMEGAS:SHARE:SOON, e.g. three=0.72:1.8,1.2,1.0:0.01:0.02")
    ap.add_argument("--json", default=None, help="append one JSON line per call to this file")
    args = ap.parse_args()
    schedules = [parse(s) for s in [DEFAULT, *args.schedule]]
    poisson_disk(args.n, seed=99)   # builds the kernels, touches the pages
    rows = []
    for r in range(args.repeat):
        for seed in (int(s) for s in args.seeds.split(",")):
            for schedule in schedules:
                row = {"schedule": schedule[0], "n": args.n, "seed": seed, "round": r,
                       **one_call(args.n, seed, schedule)}
                rows.append(row)
                append(args.json, {"kind": "poisson_schedule", **row})
                print(" ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                               for k, v in row.items()), flush=True)
    report(schedules, rows)


if __name__ == "__main__":
    main()
