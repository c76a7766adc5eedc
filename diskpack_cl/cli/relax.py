"""``diskpack relax``: relax point files on the unit torus (and the relaxation shared with ``poisson``)."""

from __future__ import annotations

import json
import sys
import argparse

from ._batches import batch_mode, batch_options, batch_run, report_batch
from ._common import PROG, terminal_bar, device_options, output_options, note_fallbacks, where_ran
from ._help import with_examples
from diskpack_cl.domain import DomainOptions
from diskpack_cl.options import add_arguments, from_namespace
from diskpack_cl.relax import RelaxOptions, relax_summary


def add_relax_options(p):
    add_arguments(p, RelaxOptions)
    p.add_argument("--verify", action="store_true",
                   help="check every iteration against scipy (exact MICs, KD-tree rho); slow")
    p.add_argument("--profile", action="store_true",
                   help="time the OpenCL kernels with events (--json stage_seconds.kernel)")
    p.add_argument("--allow-unreached", action="store_true",
                   help=f"exit 0 when rho stops short of EPS (default: the set is written and "
                        f"the exit status is {UNREACHED})")
    add_arguments(p, DomainOptions)
    device_options(p)


#: Exit status of a run whose rho (or distance) stopped short of its goal.
UNREACHED = 3


def unreached_status(args, what):
    """Exit status for a result short of its goal: UNREACHED, or 0 with --allow-unreached."""
    if args.allow_unreached:
        return 0
    print(f"{PROG}: error: {what}; the set was written (--allow-unreached: exit 0)",
          file=sys.stderr)
    return UNREACHED


def relax_options_of(args):
    """The :class:`~diskpack_cl.relax.RelaxOptions` of the arguments."""
    return from_namespace(RelaxOptions, args)


def relax_progress(args, label):
    """Return (callback, close) feeding a tqdm bar on a terminal, or no-ops."""
    bar = terminal_bar(args, label, "it", relax_options_of(args).kwargs()["max_iter"] or None)
    if bar is None:
        return None, lambda: None

    def callback(iteration, rho):
        bar.set_postfix_str(f"rho={rho:.4f}", refresh=False)
        bar.update(iteration - bar.n)

    return callback, bar.close


def relax_and_write(item, args, points=None, *, extra_summary=None):
    """Relax and write a one-item plan (:func:`diskpack_cl.jobs.items.relax_item`), report;
    return the exit status."""
    from diskpack_cl.jobs.items import relax_item  # not loaded at start-up

    callback, close = relax_progress(args, "relax")
    try:
        res = relax_item(item, points, device=args.device, callback=callback,
                         verify=args.verify, profile=args.profile)
    finally:
        close()
    summary = {
        **relax_summary(res, args.eps),
        "seconds_per_iteration": float(res.seconds / res.iterations) if res.iterations else None,
        "output": str(args.output),
        # raster estimate error and how often the exact stage widened its set
        "refinement": {k: (v if isinstance(v, (int, list, str)) else float(v))
                       for k, v in res.stats.items()},
    }
    if extra_summary:
        summary.update(extra_summary)
    if not args.quiet:
        print(f"{PROG}: {summary['n']} points, rho {summary['rho_start']:.4f} -> "
              f"{summary['rho_final']:.4f} in {summary['iterations']} iterations "
              f"({summary['seconds']:.3g} s {where_ran(res.stages)}, "
              f"stop: {res.stop_reason}); wrote {args.output}", file=sys.stderr)
    note_fallbacks(args, res.stages)
    if args.json:
        print(json.dumps(summary), flush=True)
    if res.stop_reason != "eps":
        return unreached_status(args, f"rho {res.rho[-1]:.4f} did not reach --eps {args.eps:g} "
                                f"(stop: {res.stop_reason})")
    return 0


def add_relax(subparsers):
    p = subparsers.add_parser(
        "relax", help="relax a point file on the unit torus",
        usage="%(prog)s IN -o OUT [options]",
        description=with_examples(
            "Relax a point set on the unit torus by disk packing until rho >= EPS. Points "
            "outside [0,1)^2 are wrapped onto the torus.",
            ["diskpack relax points.npz -o relaxed.npz --eps 0.9",
             "diskpack relax scan.csv --columns x,y -o relaxed.csv --json",
             "diskpack relax sets/*.npz -o relaxed/{stem}.npz"]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("inputs", nargs="+", metavar="IN",
                   help="point file (.npz, .npy, .csv, .txt, .xy); several make a batch "
                        "(-o a template such as out/{stem}.npz)")
    p.add_argument("--columns", type=_columns, default=None, metavar="A,B",
                   help="the two columns to read: header names (x,y) or indices (0,1); needed "
                        "where a file has more coordinates (a z column)")
    output_options(p)
    add_relax_options(p)
    batch_options(p)
    p.set_defaults(run=_run_relax)


def _columns(text):
    parts = [t.strip() for t in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise argparse.ArgumentTypeError(f"need two columns A,B, got {text!r}")
    return tuple(int(t) if t.isdigit() else t for t in parts)


def _run_relax(args):
    """One input: a one-item plan without a manifest, run here; else a batch."""
    from diskpack_cl.jobs.batch import relax_many  # not loaded at start-up
    from diskpack_cl.jobs.items import plan_relax  # not loaded at start-up

    where = dict(box=args.box, columns=args.columns)
    if batch_mode(args, args.inputs, [args.output]):
        return report_batch(args, relax_many(args.inputs, [args.output], relax_options_of(args), **where,
                                              **batch_run(args)))
    (item,) = plan_relax(args.inputs[:1], [args.output], relax_options_of(args), **where,
                         make_folders=False)
    return relax_and_write(item, args, extra_summary={"input": str(args.inputs[0])})
