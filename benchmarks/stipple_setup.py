"""The stippling's setup stage at scale: the fields of n dots on a size x size picture.

Usage: python benchmarks/stipple_setup.py [--size 8192] [--n 1000000] [--repeat 3]

The picture is :func:`stipple_large.picture` (the sample photograph scaled
up).  Times :func:`diskpack_cl.stipple.make_stage` as :func:`~diskpack_cl.stipple.stipple`
runs it (the default schedule's plan, the engine's device blur, the fields'
pages touched first and freed pages kept, the picture's bands not consumed
so that it serves every repeat), and in the same run an anchor of one core:
scipy's ``gaussian_filter`` of the darkness at sigma 2 (one of the stage's
four blurs, on the host).  Prints the medians of the repeats and their ratio,
which a busy machine stretches less than either figure; the goal (issue 47):
the stage at 1M on 8192 x 8192 in at most 2 s.
"""

import argparse
import importlib
import time

import numpy as np
from scipy import ndimage

from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.image import to_gray
from diskpack_cl.memory import PageReserve, freed_memory_kept
from stipple_large import picture

stipple_module = importlib.import_module("diskpack_cl.stipple")   # (the package's name is the function)


def setup_seconds(gray, n):
    """Seconds of one :func:`make_stage` of `gray` for `n` dots, as a run makes it."""
    H, W = gray.shape
    opt = stipple_module.StippleOptions().plan(n, W, H, ink=float(gray.size - gray.sum()))
    engine = make_engine(Domain.rect(W, H), opt.n, grid=opt.grid_shape(W, H))
    with freed_memory_kept():
        PageReserve(stipple_module.RESERVED_BYTES_PER_PIXEL * W * H).release()
        t = time.perf_counter()
        stipple_module.make_stage(gray, opt, engine)
        return time.perf_counter() - t


def anchor_seconds(gray):
    """Seconds of scipy's Gaussian blur (sigma 2, "reflect") of the picture's darkness."""
    darkness = 1.0 - gray
    t = time.perf_counter()
    ndimage.gaussian_filter(darkness, 2.0, mode="reflect")
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1000000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    gray = to_gray(picture(args.size), allow_large=True)
    setup, anchor = [], []
    for _ in range(args.repeat):
        setup.append(setup_seconds(gray, args.n))
        anchor.append(anchor_seconds(gray))
    s, a = float(np.median(setup)), float(np.median(anchor))
    print(f"setup of {args.n} dots on {args.size} x {args.size}: {s:.2f} s (median of {args.repeat}: "
          + " ".join(f"{x:.2f}" for x in setup) + ")")
    print(f"anchor, scipy gaussian_filter sigma 2 of the darkness: {a:.2f} s")
    print(f"setup / anchor: {s / a:.2f}")


if __name__ == "__main__":
    main()
