"""A large stippling within the machine's memory: n = 1M dots on an 8192 x 8192 image.

Usage: python benchmarks/stipple_large.py [--size 8192] [--n 1000000] [--mix 3] [--full] [--before]
                                         [--json rows.jsonl]

The image is the bundled sample photograph scaled up (Lanczos).  Runs a few
iterations of the default schedule's step ("mix", with the default's
options), or with --full the whole default schedule, and prints seconds per
iteration by stage, the time to the certified result, and the peak resident
memory of the process.  ``--json`` appends the run as a row with the
context of :mod:`perf_rows`; :func:`summary` makes the docs' table of them.
"""

import argparse
import resource
import time

import numpy as np
from PIL import Image

from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.schedule import SCHEDULE_OPTIONS
from diskpack_cl.stipple import stipple
from perf_rows import append, count, medians, num

#: Names the table gives the stages (``load`` is loading the image, not the load average).
STAGE_NAMES = {"load": "loading the image", "device": "MIC kernel", "refine": "MIC host check",
               "raster_labels": "labels"}


def summary(rows):
    """``(header, rows)`` of the docs' table: medians per image, n and schedule, with the run's stages."""
    # "total" is the seconds column again
    stages = list(dict.fromkeys(k for r in rows for k in r if k.startswith("stage_") and k != "stage_total"))
    values = ["seconds", "iterations", "s_per_iter", "peak_rss_gib", *stages]
    runs = medians(rows, ("size", "n", "schedule"), values)
    header = ["image", "n", "schedule", "steps", "seconds to the certified result", "median s/iter",
              "peak resident memory", "stages (s)"]
    return header, [[f"{r['size']} x {r['size']}", count(r["n"]), r["schedule"], num(r["iterations"]),
                     num(r["seconds"]), num(r["s_per_iter"]), num(r["peak_rss_gib"], " GiB"),
                     ", ".join(f"{STAGE_NAMES.get(k[6:], k[6:])} {num(r[k])}"
                               for k in stages if (r[k] or 0) >= 0.05)] for r in runs]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--mix", type=int, default=3)
    ap.add_argument("--full", action="store_true", help="the whole default schedule")
    ap.add_argument("--before", action="store_true",
                    help="the default without the support rule and capacity")
    ap.add_argument("--json", default=None, help="append the run as a JSON line to this file")
    args = ap.parse_args()
    gray = load_gray(sample_image_path())
    img = Image.fromarray((gray * 255).astype(np.uint8)).resize((args.size, args.size), Image.LANCZOS)
    gray = np.asarray(img, np.float64) / 255.0
    del img
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
    schedule = ("default" if args.full else f"{args.mix} mix steps") + (" before issue 17" if args.before else "")
    per_iter = float(np.median([h["seconds"] for h in res.history]))
    append(args.json, {"size": args.size, "n": args.n, "schedule": schedule, "seconds": total,
                       "iterations": len(res.history), "s_per_iter": per_iter,
                       "peak_rss_gib": peak_gib, "valid": bool(res.certificate.valid),
                       **{f"stage_{k}": v for k, v in res.timings.items()}})


if __name__ == "__main__":
    main()
