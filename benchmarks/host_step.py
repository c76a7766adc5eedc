"""Host seconds of one stippling step at a million dots, replayed without the device.

Usage: python benchmarks/host_step.py [--picture PNG] [--size 8192] [--n 1000000] [--steps 3]
                                      [--repeats 7]

The stage of the default run is made for the picture (``--picture``, else the sample
photograph scaled up to ``--size``, as :mod:`stipple_large` makes it), and ``--steps``
mix steps of the default schedule's first phase run from the error-diffusion start, so
that the dots have moved as a run's have. The engine's answers and inputs of the last
step are kept, and its host work is then timed ``--repeats`` times, each time beside the
anchor:

- ``stipple``: :func:`~diskpack_cl.stipple.pack_step`'s own work (radii, ink factors,
  blend, reseating, ``k``), against an engine that gives the kept MICs and centroids at once;
- ``cells``: the MIC stage's host work (the sites sorted into buckets, the kernel's packed
  inputs, the answers put in order; :class:`~diskpack_cl.device.cells.CellMIC`);
- ``raster``: the centroids' pass host work (the sites sorted and lent, the sums become
  centroids; :class:`~diskpack_cl.device.raster.PowerRaster`), which a helper thread
  does beside the MICs' own;
- ``anchor``: ``np.sort`` of a million uniform float64 numbers (seed 0).

It prints the median seconds of each (and CPU seconds, of all the process's threads), and
the median of each part's ratio to the anchor of its own repeat (a shared machine's load
moves both; the lookups run on every core, the anchor on one). The seconds of the real steps are
printed too (device and host together). Run it once on the tree before a change and once
after, on a quiet machine, and compare the ratios.
"""

import argparse
import dataclasses
import time

import numpy as np
from PIL import Image

from diskpack_cl.dithering import error_diffusion
from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import StippleState, make_stage, pack_step


class Replay:
    """An engine that gives the answers of a recorded step at once."""

    def __init__(self, engine, mic, power):
        self.timings, self._mic, self._power = engine.timings, mic, power

    def mic(self, points, weights=None, **kw):
        return self._mic

    def start_centroids(self, points, weights, density):
        return lambda: self._power

    def centroids(self, points, weights, density):
        return self._power


class Recorder:
    """:func:`pack_step` on the real engine, the engine's inputs and answers of the step kept."""

    def __init__(self, engine):
        self.engine = engine

    def step(self, state, stage, blend):
        eng = self.engine
        mic0, start0 = eng.mic, eng.start_centroids

        def mic(points, weights=None, **kw):
            self.cells_in = (np.array(points), np.array(weights))
            self.mic = mic0(points, weights, **kw)
            return self.mic

        def start(points, weights, density):
            self.raster_in = (np.array(points), np.array(weights))
            done = start0(points, weights, density)

            def finish():
                self.power = done()
                return self.power
            return finish
        eng.mic, eng.start_centroids = mic, start
        try:
            return pack_step(state, stage, blend)
        finally:
            del eng.mic, eng.start_centroids


def cells_host(cells, X, w):
    """The host work of ``CellMIC.solve(X, w, certify=False, warm=True)`` less the device's:
    buckets, packed inputs, the answers (kept from the real call) put in order."""
    w = w - w.min()
    order, start, bwmax, grid = cells._buckets(X, w)
    pos, rows = np.arange(len(X), dtype=np.int32), order
    # a warm step's inputs (the run's steps are warm): with the moves of the sorted
    # positions where this sort moved the last one's
    up, _ = cells._inputs(X, w, order, start, bwmax, grid, pos, rows, 3 if cells._perm is not None else 2)
    return up, pos, rows


def raster_host(raster, pts, w, acc):
    """The host work of the centroids' pass: the sites sorted, lent, the sums to centroids."""
    raster._upload_sites(pts, w)
    _, _, _, b_acc = raster._sums_buffers(pts, np.zeros(raster.shape, np.float32))
    raster.release_lent()
    return raster._sums_to_centroids(acc, b_acc, pts)


def picture(size):
    gray = load_gray(sample_image_path())
    img = Image.fromarray((gray * 255).astype(np.uint8)).resize((size, size), Image.LANCZOS)
    return np.asarray(img, np.float64) / 255.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--picture", default=None)
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    gray = load_gray(args.picture) if args.picture else picture(args.size)
    H, W = gray.shape
    opt = StippleOptions().plan(args.n, W, H)
    engine = make_engine(Domain.rect(W, H), opt.n, grid=opt.grid_shape(W, H))
    stage = make_stage(gray, opt, engine)
    state = StippleState(error_diffusion(gray, opt.n, seed=opt.seed), float(opt.k0))
    del gray
    kind, _, blend = opt.phases[0]
    rec = Recorder(engine)
    real = []
    for _ in range(args.steps):
        t = time.perf_counter()
        last, (state, _) = state, rec.step(state, stage, blend)
        real.append(time.perf_counter() - t)
    replay = dataclasses.replace(stage, engine=Replay(engine, rec.mic, rec.power))
    X, w = rec.cells_in
    # fixed-point sums of a run's size (a cell of ~64 pixels, 2^24 a unit): the division's
    # cost, not 0 / 0's
    acc = np.random.default_rng(0).integers(1, 2 ** 31, (opt.n, 3))
    sorted_ = np.random.default_rng(0).random(1_000_000)
    parts = {"anchor": lambda: np.sort(sorted_),
             "stipple": lambda: pack_step(last, replay, blend),
             "cells": lambda: cells_host(engine.cells, X, w),
             "raster": lambda: raster_host(engine.raster, *rec.raster_in, acc)}
    secs, cpu = ({name: [] for name in parts} for _ in range(2))
    for _ in range(args.repeats):
        for name, f in parts.items():
            t, c = time.perf_counter(), time.process_time()
            f()
            secs[name].append(time.perf_counter() - t)
            cpu[name].append(time.process_time() - c)
    anchor = np.array(secs["anchor"])
    print(f"n={args.n} image={W}x{H}: {args.steps} real {kind} steps (blend {blend}), "
          f"seconds {', '.join(f'{s:.2f}' for s in real)}")
    total, total_cpu = np.zeros(args.repeats), np.zeros(args.repeats)
    for name, s in secs.items():
        s, c = np.array(s), np.array(cpu[name])
        if name != "anchor":
            total, total_cpu = total + s, total_cpu + c
        print(f"  {name:8s} median {np.median(s) * 1e3:7.1f} ms (CPU {np.median(c) * 1e3:7.1f} ms), "
              f"ratio to the anchor {np.median(s / anchor):.3f}")
    print(f"  {'host':8s} median {np.median(total) * 1e3:7.1f} ms (CPU {np.median(total_cpu) * 1e3:7.1f} "
          f"ms), ratio to the anchor {np.median(total / anchor):.3f} (stipple + cells + raster)")


if __name__ == "__main__":
    main()
