"""``diskpack analyze``: spectra and measures of point sets or of a stippling."""

from __future__ import annotations

import argparse
import json
import sys

from diskpack_cl.extras import install_command
from diskpack_cl.io import check_not_inputs, check_writable, json_default
from diskpack_cl.options import add_arguments, from_namespace
from diskpack_cl.reports import AnalyzeOptions, PLOT_HINT, analyze, have_matplotlib

from ._common import PROG, GivenOnce, image_path
from ._help import with_examples


def add_analyze(subparsers):
    p = subparsers.add_parser(
        "analyze", help="spectra and measures of point sets or of a stippling, as a figure",
        description=with_examples(
            "Point sets on the unit torus (.npz, .npy, .csv, .txt, .xy): one figure "
            "with the points, the mean periodogram (averaged over all files, as "
            "realizations), the radial mean power and the anisotropy in dB, with n, "
            "rho and the mean nearest-neighbour rho. A stippling (.npz written by "
            "'diskpack stipple', with --image): the rendering beside the input, both "
            "blurred with the tone SSIM, the spacing histogram and the certificate "
            "(re-checked from the file). A colour stippling (.npz or .csv with a pen "
            "column, written by 'diskpack stipple --colors/--pens'; --json): the "
            "spacing P01 of each pen and of all dots, against the layers of --image "
            "separated again (with the CIELAB Delta E of the drawing and the SSIM of "
            "each layer), or without --image against the dots' own density; and the "
            "certificate over all dots. Figures need matplotlib: "
            + install_command("plot") + ".",
            ["diskpack analyze a.npz b.npz c.npz -o report.png --json",
             "diskpack analyze stipple.npz --image sample -o stipple_report.png",
             "diskpack analyze colour.npz --image photo.png --json"]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("inputs", nargs="+", metavar="POINTS",
                   help="point files (realizations of one process), or one stippling .npz "
                        "(or a colour stippling's .csv)")
    p.add_argument("-o", "--output", default=None, metavar="REPORT", action=GivenOnce,
                   help="figure file (.png, .pdf or .svg); written atomically")
    p.add_argument("--json", action="store_true",
                   help="print the numbers as one JSON line on stdout")
    p.add_argument("--image", default=None, metavar="IMAGE",
                   help="for a stippling: the input image ('sample' for the bundled one)")
    p.add_argument("--allow-large", action="store_true",
                   help="lift Pillow's decompression-bomb limit for --image")
    add_arguments(p, AnalyzeOptions)
    p.set_defaults(run=_run_analyze)


def _run_analyze(args):
    if args.output is None and not args.json:
        raise ValueError("nothing to do: give -o REPORT.png for a figure and/or --json")
    plot = args.output is not None
    if plot:
        from diskpack_cl.plots import figure_format  # not loaded at start-up

        figure_format(args.output)
        check_not_inputs([args.output], [*args.inputs, args.image])
        check_writable(args.output)
        if not have_matplotlib() and not args.json:
            raise ValueError(f"{PLOT_HINT} (the numbers print without it with --json)")
    image = None if args.image is None else image_path(args.image)
    numbers = analyze(args.inputs, from_namespace(AnalyzeOptions, args), image=image,
                      output=args.output, allow_large=args.allow_large)
    if args.json:
        print(json.dumps(numbers, default=json_default), flush=True)
    if plot and not have_matplotlib():
        raise ValueError(f"{PLOT_HINT}; no figure written")
    if plot:
        print(f"{PROG}: wrote {args.output}", file=sys.stderr)
    return 0
