"""diskpack's PoissonDisk next to scipy's, both through ``fill_space()``, in the unit square and cube.

Usage: python benchmarks/bench_qmc.py [--seeds 0] [--probes 1048576] [--json out.jsonl]

For each radius (0.05, 0.02, 0.01, 0.005 in 2D; 0.1, 0.05 in 3D) and seed,
both engines fill the box with ``PoissonDisk(d, radius=r, rng=seed).fill_space()``
and the set is measured:

- ``n``: points; ``min_distance``: the smallest distance between two of
  them (scipy KD-tree), to compare with the radius;
- ``uncovered``: the share of the box farther than the radius from every
  point, estimated from uniform random probes (the same probes for both
  engines; a KD-tree query); where a point could still be added;
- ``seconds``: wall time of construction and ``fill_space()``.  diskpack's
  OpenCL kernels are built (and its device chosen) by a small fill before
  the first measurement.

The table prints as Markdown; ``--json`` appends a row per set with the
context of :mod:`perf_rows`, and :func:`summary` makes the docs' table of them.
"""

import argparse
import time

import numpy as np

from perf_rows import append, count, medians, num

#: (d, radius) of every measurement.
CASES = [(2, 0.05), (2, 0.02), (2, 0.01), (2, 0.005), (3, 0.1), (3, 0.05)]


def engine(name):
    """The PoissonDisk class of ``name``: diskpack's or scipy's."""
    if name == "diskpack":
        from diskpack_cl import PoissonDisk
    else:
        from scipy.stats.qmc import PoissonDisk
    return PoissonDisk


def measure(name, d, radius, seed, probes):
    """One filled box of engine ``name`` and what it measures (see the module docstring)."""
    from scipy.spatial import cKDTree

    t0 = time.perf_counter()
    pts = engine(name)(d, radius=radius, rng=seed).fill_space()
    seconds = time.perf_counter() - t0
    tree = cKDTree(pts)
    nearest = tree.query(pts, k=2)[0][:, 1]
    far = np.isinf(tree.query(probes, distance_upper_bound=radius)[0])
    return {"engine": name, "d": d, "radius": radius, "seed": seed, "n": len(pts),
            "min_distance": float(nearest.min()), "uncovered": float(far.mean()),
            "seconds": seconds}


def summary(rows):
    """``(header, rows)`` of the docs' table: per (d, radius), diskpack / scipy, medians over seeds."""
    med = {(r["engine"], r["d"], r["radius"]): r
           for r in medians(rows, ("engine", "d", "radius"), ("n", "min_distance", "uncovered", "seconds"))}
    header = ["d", "radius", "points diskpack / scipy", "smallest distance diskpack / scipy",
              "share farther than radius diskpack / scipy", "seconds diskpack / scipy", "seeds"]
    table = []
    for d, radius in dict.fromkeys((r["d"], r["radius"]) for r in rows):
        ours, theirs = med[("diskpack", d, radius)], med[("scipy", d, radius)]
        table.append([str(d), f"{radius:g}", f"{count(ours['n'])} / {count(theirs['n'])}",
                      f"{ours['min_distance']:.5f} / {theirs['min_distance']:.5f}",
                      f"{100 * ours['uncovered']:.3f} % / {100 * theirs['uncovered']:.3f} %",
                      f"{num(ours['seconds'])} / {num(theirs['seconds'])}", str(ours["repeats"])])
    return header, table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0", help="comma-separated seeds")
    ap.add_argument("--probes", type=int, default=2 ** 20, help="random probes per box")
    ap.add_argument("--json", help="append one row per set to this .jsonl file")
    args = ap.parse_args(argv)
    engine("diskpack")(2, radius=0.1, rng=0).fill_space()   # builds the kernels
    rows = []
    for d, radius in CASES:
        probes = np.random.default_rng(12345).random((args.probes, d))
        for seed in (int(s) for s in args.seeds.split(",")):
            for name in ("diskpack", "scipy"):
                row = measure(name, d, radius, seed, probes)
                append(args.json, row)
                rows.append(row)
                print(row, flush=True)
    header, table = summary(rows)
    print("| " + " | ".join(header) + " |\n|" + "---|" * len(header))
    for r in table:
        print("| " + " | ".join(r) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
