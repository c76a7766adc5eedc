"""A large stippling within the machine's memory: n = 1M dots on an 8192 x 8192 image.

Usage: python benchmarks/stipple_large.py [--size 8192] [--n 1000000] [--mix 3] [--full] [--before]

The image is the bundled sample photograph scaled up (Lanczos).  Runs a few
iterations of the default schedule's step ("mix", with the default's
options), or with --full the whole default schedule, and prints seconds per
iteration by stage, the time to the certified result, and the peak resident
memory of the process.
"""

import argparse
import resource
import time

import numpy as np
from PIL import Image

from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.schedule import SCHEDULE_OPTIONS
from diskpack_cl.stipple import stipple


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--mix", type=int, default=3)
    ap.add_argument("--full", action="store_true", help="the whole default schedule")
    ap.add_argument("--before", action="store_true",
                    help="the default as before issue 17: no support rule, no capacity")
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


if __name__ == "__main__":
    main()
