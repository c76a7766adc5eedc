"""Pen-up travel and time of the pen-path orders at 2k, 20k and 100k dots.

The dots are the error-diffusion start of the stippling of the sample
photograph (:func:`diskpack_cl.error_diffusion`, dots spread like its
darkness), on a 190 mm wide drawing, the pen starting at the origin as in
the SVG. Orders: Hilbert curve, greedy nearest neighbour, each improved by
:func:`diskpack_cl.drawing.pen_path.two_opt` for the default's rounds
(:func:`diskpack_cl.drawing.pen_path.two_opt_rounds`, or ``--rounds``), and the default
(``method="auto"``). Each row: travel in mm, its ratio to Hilbert, seconds,
and the plot time (:func:`diskpack_cl.drawing.writers.plot_time`, every dot one pen
touch). ``--markdown`` prints the table rows of docs/guide/plotters.md.

    python benchmarks/pen_path.py [-n 2000 20000 100000] [--rounds R] [--json out.json]
        [--markdown]
"""

from __future__ import annotations

import argparse
import json
import time


from diskpack_cl import error_diffusion, load_gray, sample_image_path
from diskpack_cl.drawing.page import plot_time
from diskpack_cl.drawing.pen_path import (greedy_order, hilbert_order, path_travel, pen_path_order, two_opt,
                                          two_opt_rounds)

WIDTH_MM = 190.0


def dots(n, seed=0):
    """``n`` dots spread like the sample photograph's darkness, in mm."""
    gray = load_gray(sample_image_path())
    return error_diffusion(gray, n, seed=seed) * (WIDTH_MM / gray.shape[1])


def measure(p, rounds=None):
    """Rows (order name, travel mm, seconds) for one point set."""
    rows = []
    t = time.perf_counter()
    hil = hilbert_order(p)
    rows.append(("hilbert", hil, time.perf_counter() - t))
    t = time.perf_counter()
    gre = greedy_order(p, (0.0, 0.0))
    rows.append(("greedy", gre, time.perf_counter() - t))
    for name, base, took in list(rows):
        t = time.perf_counter()
        better = two_opt(p, base, rounds=two_opt_rounds(len(p)) if rounds is None else rounds)
        rows.append((f"{name}+2opt", better, took + time.perf_counter() - t))
    t = time.perf_counter()
    auto, _, _ = pen_path_order(p, rounds=rounds)
    rows.append(("auto (default)", auto, time.perf_counter() - t))
    return [(name, path_travel(p, order), s) for name, order, s in rows]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, nargs="+", default=[2000, 20000, 100000])
    ap.add_argument("--rounds", type=int, default=None, help="2-opt rounds (default: the default's)")
    ap.add_argument("--json", default=None, help="also write the rows here")
    ap.add_argument("--markdown", action="store_true", help="print the table rows of docs/guide/plotters.md")
    args = ap.parse_args(argv)
    out, table = [], []
    for n in args.n:
        p = dots(n)
        rows = measure(p, args.rounds)
        ref = rows[0][1]
        print(f"n = {n}: unordered {path_travel(p):.0f} mm")
        cells = {}
        for name, travel, s in rows:
            hours = plot_time(n, 0.01 * n, travel) / 3600
            print(f"  {name:16s} {travel:10.0f} mm  {travel / ref:6.3f}  {s:7.2f} s  "
                  f"{hours:6.2f} h plot")
            out.append({"n": n, "order": name, "travel_mm": travel, "seconds": s,
                        "plot_hours": hours})
            cells[name] = f"{travel:.0f} mm, {hours:.2f} h ({s:.2g} s)"
        table.append(f"| {n} | {cells['greedy']} | {cells['hilbert']} | "
                     f"{cells['auto (default)']} |")
    if args.markdown:
        print("\n".join(table))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
