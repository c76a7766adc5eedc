"""How far the warm-started MICs of a whole stippling are from cold starts, step by step.

    python benchmarks/warm_steps.py [--n 50000] [--size 512]

A default stippling of ``--n`` dots on the sample photograph at ``--size`` x
``--size`` (the OpenCL engine, whose per-cell kernel starts every step after
the first from the last step's bases), in which each MIC solve is repeated
cold by a second solver on the same sites.  Printed per solve: whether it was
warm, the largest differences of the centres and radii, how many cells'
centres or radii differ at all, and whether the flag counts are the same.
"""

import argparse

import numpy as np

from diskpack_cl.device.cells import CellMIC
from diskpack_cl.domain import Domain
from diskpack_cl.stipple import stipple
from stipple_large import picture


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50_000)
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args()
    cold = CellMIC(Domain.rect(float(args.size), float(args.size)))
    solve, rows = CellMIC.solve, []

    def compare(self, points, weights=None, **kw):
        got = solve(self, points, weights, **kw)
        if self is not cold:
            want = solve(cold, points, weights, **{k: v for k, v in kw.items() if k != "warm"})
            differ = np.any(got.centers != want.centers, axis=1) | (got.radii != want.radii)
            same_flags = all(got.stats[k] == want.stats[k] for k in got.stats if not k.startswith("bytes"))
            rows.append((kw.get("warm", False), np.abs(got.centers - want.centers).max(),
                         np.abs(got.radii - want.radii).max(), int(differ.sum()), same_flags))
        return got

    CellMIC.solve = compare
    try:
        stipple(picture(args.size), args.n, backend="opencl")
    finally:
        CellMIC.solve = solve
    for k, (warm, dc, dr, nd, flags) in enumerate(rows):
        print(f"solve {k:2d} warm {warm!s:5}: centres {dc:.2g}, radii {dr:.2g}, "
              f"cells differing {nd} of {args.n}, same flag counts: {flags}")
    print(f"largest: centres {max(r[1] for r in rows):.2g}, radii {max(r[2] for r in rows):.2g}, "
          f"cells differing {max(r[3] for r in rows)}")


if __name__ == "__main__":
    main()
