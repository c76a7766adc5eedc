"""Two or more versions of the cell_mic kernel, timed against each other in one process.

    python benchmarks/kernel_ab.py OLD.cl NEW.cl [MORE.cl ...] [--n 1000000] [--rounds 8]
        [--box | --stipple SIZE] [--include DIR] [--warm]

Each file is built as :class:`diskpack_cl.device.cells.CellMIC` builds
``kernels/cells.cl`` (with ``kernels/`` on the include path, or
``--include``; a ``FILE.cl@DIR`` argument takes its own).  A dart-throwing
start of ``--n`` points moved once and twice to its MIC centres
(Algorithm 1's moves) are solved with each version in turn, the order
rotating every round, so that the load of a shared machine falls on all
versions alike.  ``--stipple SIZE`` solves power cells on a SIZE x SIZE
rectangle instead: the points and weights of the last two steps of a short
stippling of ``--n`` dots (the sample photograph at that size, the first
phase of the default schedule's band, cut to four steps), as a whole run's
steps pass them.  Printed per version: the median device seconds of the
kernel, and the medians (and quartiles) of its CPU seconds and kernel
seconds over the first version's, call by call; and whether its MICs
(centres, radii, nearest-neighbour distances, flag counts) are the first
version's bit for bit.  ``--warm`` adds, after each version, the same
kernel started warm (``CellMIC.solve(..., warm=True)``): before each round
it solves the set before the timed ones (the third last step, or the start
set moved once more), so that every timed solve starts from the bases of the
step before it, as a whole run's steps do; its largest differences from the
first version's centres and radii are printed.  Separate processes timed one after the
other move by 10-15 % with the load on the development VM; these ratios by
a few percent.
"""

import argparse
import hashlib
import pathlib
import time

import numpy as np

from diskpack_cl.device.cells import MAXC, MAXNEAR, CellMIC
from diskpack_cl.domain import Domain
from diskpack_cl.parallel_darts import parallel_darts
from diskpack_cl.schedule import default_band
from diskpack_cl.stipple import stipple
from stipple_large import picture
from diskpack_cl.device.programs import inline_math, kernel_dir


def build(solver, spec, include, periodic):
    """The cell_mic kernel of the source `spec` (``FILE`` or ``FILE@INCLUDE_DIR``)."""
    import pyopencl as cl

    path, _, inc = spec.partition("@")
    defines = {"INLINE_MATH": inline_math(solver.ctx), "PERIODIC": int(periodic), "MAXC": MAXC,
               "MAXNEAR": MAXNEAR}
    opts = ["-I", inc or include] + [f"-D{k}={v}" for k, v in sorted(defines.items())]
    return cl.Program(solver.ctx, pathlib.Path(path).read_text()).build(options=opts).cell_mic


def sets(n, domain):
    """The start set and the set after one and two moves to the MIC centres (Algorithm
    1's), as ``(points, None)`` (the timed sets: the last two)."""
    X = parallel_darts(n, rel_radius=0.72, seed=2)
    if not domain.periodic:
        X = X * (domain.width, domain.height)
    solver, out = CellMIC(domain), [(X, None)]
    for _ in range(2):
        X = solver.solve(X, certify=False).centers
        out.append((X, None))
    return out


def stipple_sets(n, size, steps=4):
    """``(points, weights)`` of the MIC solves of the last three of `steps` stippling steps
    of `n` dots on the sample photograph at `size` x `size` (the default band's first
    phase, cut short), as the stippling passed them to :meth:`CellMIC.solve`."""
    phases, options = default_band(size / np.sqrt(n))
    kind, _, *blend = phases[0]
    seen = []
    solve = CellMIC.solve

    def record(self, points, weights=None, **kw):
        seen.append((np.array(points), np.array(weights)))
        return solve(self, points, weights, **kw)

    CellMIC.solve = record
    try:
        stipple(picture(size), n, schedule=[(kind, steps, *blend)], backend="opencl", **options)
    finally:
        CellMIC.solve = solve
    return seen[steps - 3:steps]


def rotate(solver, kernels, points, rounds):
    """Each ``(kernel, warm)`` of `kernels` on each set but the first (with `warm`, after
    a warm solve of the first), the order rotating every round: per version its CPU
    seconds and kernel seconds call by call, a digest of its MICs and its answers of
    the last round."""
    cpu = [[] for _ in kernels]
    dev = [[] for _ in kernels]
    digest = [hashlib.sha256() for _ in kernels]
    last = [None for _ in kernels]
    for r in range(rounds):
        for k in np.roll(np.arange(len(kernels)), r):
            solver._kernel, warm = kernels[k]
            if warm:
                solver.solve(*points[0], certify=False, warm=True)
            last[k] = []
            for X, w in points[1:]:
                mark, c0 = solver.timings.mark(), time.process_time()
                res = solver.solve(X, w, certify=False, warm=warm)
                cpu[k].append(time.process_time() - c0)
                dev[k].append(solver.timings.since(mark)["kernel"])
                stats = {s: v for s, v in res.stats.items() if not s.startswith("bytes")}
                digest[k].update(res.centers.tobytes() + res.radii.tobytes() + res.nn.tobytes()
                                 + repr(sorted(stats.items())).encode())
                last[k].append(res)
    return cpu, dev, [d.hexdigest() for d in digest], last


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sources", nargs="+")
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--box", action="store_true", help="a 2 x 1 box instead of the torus")
    ap.add_argument("--stipple", type=int, metavar="SIZE",
                    help="power cells of a stippling on SIZE x SIZE instead of the torus")
    ap.add_argument("--include", default=str(kernel_dir()))
    ap.add_argument("--warm", action="store_true", help="each version also started warm")
    args = ap.parse_args()
    if args.stipple:
        domain = Domain.rect(float(args.stipple), float(args.stipple))
        points = stipple_sets(args.n, args.stipple)
    else:
        domain = Domain.rect(2.0, 1.0) if args.box else Domain.torus()
        points = sets(args.n, domain)
    solver = CellMIC(domain, profile=True)
    kernels, names = [], []
    for s in args.sources:
        kernel = build(solver, s, args.include, domain.periodic)
        for warm in (False, True) if args.warm else (False,):
            kernels.append((kernel, warm))
            names.append(s + (" warm" if warm else ""))
    cpu, dev, digest, last = rotate(solver, kernels, points, args.rounds)
    for k, spec in enumerate(names):
        rc, rd = np.array(cpu[k]) / cpu[0], np.array(dev[k]) / dev[0]
        q1, q3 = np.percentile(rc, [25, 75])
        dc = max(np.abs(a.centers - b.centers).max() for a, b in zip(last[k], last[0]))
        dr = max(np.abs(a.radii - b.radii).max() for a, b in zip(last[k], last[0]))
        print(f"{spec}: kernel {np.median(dev[k]):.3f} s; cpu / first {np.median(rc):.3f} "
              f"({q1:.3f}-{q3:.3f}), kernel / first {np.median(rd):.3f}; "
              f"same MICs: {digest[k] == digest[0]} (largest differences: centres {dc:.2g}, "
              f"radii {dr:.2g})")


if __name__ == "__main__":
    main()
