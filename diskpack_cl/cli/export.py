"""``diskpack export``: draw a finished stippling again."""

from __future__ import annotations

import argparse
import sys
import time

from ._common import PROG, checked_outputs
from ._drawing import drawing_options, write_and_report
from ._help import lead_with, with_examples
from diskpack_cl.options import from_namespace


def add_export(subparsers):
    p = subparsers.add_parser(
        "export", help="draw a finished stippling again, for another paper, pen or dot size",
        usage="%(prog)s STIPPLING -o OUT [options]",
        description=with_examples(
            "Draw a stippling that 'diskpack stipple' wrote (.npz; its .csv and .svg are read "
            "too) again without recomputing it: another paper (--page), size, pen (--pen-mm), "
            "dot size or pen path. The dots keep the size whose ink equals the image's "
            "darkness (stored in the .npz) unless --dot-mm or --dots packing is given.",
            ["diskpack export out.npz -o a4.svg --page a4 --plotter hp7475a --pen-mm 0.5",
             "diskpack export out.npz -o a3.svg -o a3.png --page a3 --landscape --margin-mm 20",
             "diskpack export out.csv -o big.svg --width-mm 400 --pen-path hilbert"]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="STIPPLING",
                   help="a stippling written by diskpack stipple (.npz, .csv or .svg)")
    p.add_argument("-o", "--output", action="append", required=True, metavar="OUT",
                   help="output file; repeat for several: .svg, .png, .npz, .csv")
    drawing_options(p, "n, the input, ")
    lead_with(p)
    p.set_defaults(run=_run_export)


def _run_export(args):
    from diskpack_cl.drawing.writers import WriteOptions, read_stipple  # not loaded at start-up
    from diskpack_cl.progress import stage_text

    write = from_namespace(WriteOptions, args)
    t0 = time.perf_counter()
    outputs = checked_outputs(args, [args.input])
    res = read_stipple(args.input)
    if res is None:
        raise ValueError(f"{args.input} is a point set, not a stippling (no radii, width and "
                         f"height)")
    write = write.replace(invert=write.invert or bool(res.params.get("invert", False)))
    summary = {"n": len(res.points), "width": res.width, "height": res.height,
               "input": str(args.input)}
    tail = write_and_report(args, write, res, outputs, summary, t0)
    if not args.quiet:
        times = stage_text(summary["stage_seconds"], whole=summary["seconds"])
        print(f"{PROG}: {len(res.points)} dots of {args.input}; {times}{tail}", file=sys.stderr)
    return 0
