"""Command line interface: ``diskpack <subcommand> ...``.

The CLI is thin: it parses arguments, reads and writes files and calls the
public Python API. Heavy modules are imported inside the subcommand functions,
so ``diskpack --help`` stays fast.

Adding a subcommand means adding two functions to this module:

* ``_add_NAME(subparsers)`` creates the parser with
  ``subparsers.add_parser("NAME", ...)`` and calls
  ``parser.set_defaults(run=_run_NAME)``;
* ``_run_NAME(args) -> int`` does the work and returns the exit status.

Every function named ``_add_*`` is registered, in the order of definition.
Raise ``ValueError``/``OSError`` for user errors: :func:`main` prints
``diskpack: error: ...`` and returns 1 (2 for :class:`_UsageError`, 130 on
Ctrl-C, 143 on SIGTERM, 129 on SIGHUP). Check outputs with
:func:`diskpack_cl.io.check_writable` before the work and write them with the
atomic writers of :mod:`diskpack_cl.io` after it, all in one
:func:`diskpack_cl.io.atomic_writes`, so that a failed or interrupted run
writes no output and leaves every earlier file as it was.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from diskpack_cl.batch import json_default

__all__ = ["main"]

PROG = "diskpack"


# ----------------------------------------------------------------- arguments

def _checked(convert, test, want):
    """An argparse type: convert the text, then require ``test(value)``."""
    what = "an integer" if convert is int else "a number"

    def parse(text):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
        if not test(value):
            raise argparse.ArgumentTypeError(f"must be {want}, got {text}")
        return value

    return parse


_positive_int = _checked(int, lambda v: v >= 1, "at least 1")
_nonnegative_int = _checked(int, lambda v: v >= 0, "at least 0")
_unit_open = _checked(float, lambda v: 0.0 < v < 1.0, "in (0, 1)")
_unit_half_open = _checked(float, lambda v: 0.0 < v <= 1.0, "in (0, 1]")
_unit_closed = _checked(float, lambda v: 0.0 <= v <= 1.0, "in [0, 1]")
_unit_half_open_zero = _checked(float, lambda v: 0.0 <= v < 1.0, "in [0, 1)")
_positive_float = _checked(float, lambda v: 0.0 < v < float("inf"), "a finite number > 0")


def _point_count(text):
    value = _positive_int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"need at least 2 points, got {value}")
    return value


def _dot_count(text):
    return text if text == "tone" else _point_count(text)


def _device_options(p):
    p.add_argument("--device", metavar="D", default=None,
                   help="OpenCL device: 'P' or 'P:D' indices (as in PYOPENCL_CTX) or a name "
                        "substring ('pocl', 'nvidia', 'gpu', 'cpu'); default: DISKPACK_DEVICE, "
                        "then PYOPENCL_CTX, then a GPU, else the first CPU device")


class _Once(argparse.Action):
    """An option that may be given once: a second one is a usage error."""

    def __call__(self, parser, namespace, values, option_string=None):
        first = getattr(namespace, self.dest, None)
        if first is not None:
            parser.error(f"{option_string} given twice ({first} and {values}): this command "
                         f"writes one point file (several sets: --count K with a template "
                         f"such as -o sets/{{i:04d}}.npz)")
        setattr(namespace, self.dest, values)


def _output_options(p):
    p.add_argument("-o", "--output", required=True, metavar="OUT", action=_Once,
                   help="output point file (.npz, .npy, .csv, .txt, .xy); written atomically; "
                        "given once")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bar and no summary on stderr")
    p.add_argument("--json", action="store_true",
                   help="print one JSON summary line on stdout at the end")


def _relax_options(p):
    p.add_argument("--eps", type=_unit_open, default=0.8,
                   help="stop when the normalized radius rho reaches EPS (default 0.8)")
    p.add_argument("--max-iter", type=_nonnegative_int, default=None, metavar="N",
                   help="iteration cap (default 1000)")
    p.add_argument("--backend", choices=("auto", "opencl", "exact"), default="auto",
                   help="opencl: MICs on the OpenCL device, checked in float64; exact: scipy only; "
                        "auto (default): opencl when a device exists, else exact")
    p.add_argument("--grid", type=_positive_int, default=None, metavar="G",
                   help="raster size G x G of the raster route (devices without float64; "
                        "default: automatic)")
    p.add_argument("--verify", action="store_true",
                   help="check every iteration against scipy (exact MICs, KD-tree rho); slow")
    p.add_argument("--profile", action="store_true",
                   help="time the OpenCL kernels with events (--json stage_seconds.kernel)")
    p.add_argument("--allow-unreached", action="store_true",
                   help=f"exit 0 when rho stops short of EPS (default: the set is written and "
                        f"the exit status is {UNREACHED})")
    p.add_argument("--box", default=None, metavar="WxH",
                   help="a box [0,W] x [0,H] with walls instead of the unit torus, e.g. 2x1")
    _device_options(p)


#: Exit status of a run whose rho (or distance) stopped short of its goal.
UNREACHED = 3


def _unreached(args, what):
    """Exit status for a result short of its goal: UNREACHED, or 0 with --allow-unreached."""
    if args.allow_unreached:
        return 0
    print(f"{PROG}: error: {what}; the set was written (--allow-unreached: exit 0)",
          file=sys.stderr)
    return UNREACHED


def _batch_options(p):
    g = p.add_argument_group(
        "batch (several inputs, a folder, --count, an output template, or any of these)",
        "Output templates: {stem} {name} {parent} (of the input), {n}, {seed}, {i} (item "
        "index, e.g. {i:04d}). Each item writes its outputs atomically, then one line of the "
        "manifest; a rerun of the same command skips the items done.")
    g.add_argument("--jobs", "-j", type=_positive_int, default=None, metavar="N",
                   help="worker processes (spawned; PoCL threads per worker capped to "
                        "cores/N; default: one per --device listed, else one per core)")
    g.add_argument("--manifest", default=None, metavar="PATH",
                   help="manifest file (default: manifest.jsonl in the folder of the first -o)")
    g.add_argument("--overwrite", action="store_true",
                   help="redo every item, also those the manifest records as done")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="send the items to this dask.distributed scheduler (default: "
                        "DASK_SCHEDULER_ADDRESS when set); needs pip install "
                        "\"diskpack_cl[dask]\"")
    g.add_argument("--collect", action="store_true",
                   help="with --scheduler: workers return the outputs' bytes and this "
                        "command writes them (no shared output folder needed)")
    return g


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors add "did you mean" for a mistyped choice or option."""

    def error(self, message):
        super().error(message + _did_you_mean(self, message))


def _did_you_mean(parser, message):
    """``"; did you mean X?"`` for the closest subcommand/choice or option, else ``""``."""
    import difflib
    import re

    choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if choice:
        words = [choice.group(1)]
        known = [c.strip(" '") for c in choice.group(2).split(",")]
    else:
        extra = re.search(r"unrecognized arguments: (.*)", message)
        words = [w.split("=")[0] for w in extra.group(1).split() if w.startswith("-")] if extra else []
        known = _option_strings(parser)
    close = [m for w in words for m in difflib.get_close_matches(w, known, n=1, cutoff=0.6)]
    return f"; did you mean {' '.join(close)}?" if close else ""


def _option_strings(parser):
    """Every option string of ``parser`` and of its subcommands."""
    out = []
    for action in parser._actions:
        out += action.option_strings
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out += _option_strings(sub)
    return out


# --------------------------------------------------------------- shared runs

def _max_iter(args):
    return 1000 if args.max_iter is None else args.max_iter


def _bar(args, desc, unit, total=None, *, leave=False):
    """A tqdm bar on stderr when it is a terminal and not ``--quiet``, else None."""
    if args.quiet or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True,
                leave=leave)


def _progress(args, label):
    """Return (callback, close) feeding a tqdm bar on a terminal, or no-ops."""
    bar = _bar(args, label, "it", _max_iter(args) or None)
    if bar is None:
        return None, lambda: None

    def callback(iteration, rho):
        bar.set_postfix_str(f"rho={rho:.4f}", refresh=False)
        bar.update(iteration - bar.n)

    return callback, bar.close


def _relax_and_write(points, args, *, extra_summary=None):
    """Relax `points`, write ``args.output``, report; return the exit status."""
    from diskpack_cl.io import write_points
    from diskpack_cl.poisson import as_box
    from diskpack_cl.relax import relax_poisson

    callback, close = _progress(args, "relax")
    try:
        res = relax_poisson(points, args.eps, max_iter=_max_iter(args), backend=args.backend,
                            grid=args.grid, device=args.device, callback=callback,
                            verify=args.verify, profile=args.profile, domain=as_box(args.box))
    finally:
        close()
    extra = {}
    if args.output.lower().endswith(".npz"):
        extra = {"rho": res.rho, "eps": args.eps}
    write_points(args.output, res.points, **extra)
    stages = {k: float(v) for k, v in res.timings.items()}
    summary = {
        "n": int(len(res.points)),
        "iterations": int(res.iterations),
        "rho_start": float(res.rho[0]),
        "rho_final": float(res.rho[-1]),
        "eps": args.eps,
        "seconds": float(res.seconds),
        "seconds_per_iteration": float(res.seconds / res.iterations) if res.iterations else None,
        "stage_seconds": stages,
        "backend": res.backend,
        "device": res.device,
        "stop_reason": res.stop_reason,
        "output": str(args.output),
        # raster estimate error and how often the exact stage widened its set
        "refinement": {k: (v if isinstance(v, (int, list, str)) else float(v))
                       for k, v in res.stats.items()},
    }
    if extra_summary:
        summary.update(extra_summary)
    if res.stats.get("fallback") and not args.quiet:
        print(f"{PROG}: note: {res.stats['fallback']}: used the exact backend "
              f"(--backend auto)", file=sys.stderr)
    if not args.quiet:
        print(f"{PROG}: {summary['n']} points, rho {summary['rho_start']:.4f} -> "
              f"{summary['rho_final']:.4f} in {summary['iterations']} iterations "
              f"({summary['seconds']:.3g} s, {res.backend} on {res.device}, "
              f"stop: {res.stop_reason}); wrote {args.output}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary), flush=True)
    if res.stop_reason != "eps":
        return _unreached(args, f"rho {res.rho[-1]:.4f} did not reach --eps {args.eps:g} "
                                f"(stop: {res.stop_reason})")
    return 0


# ---------------------------------------------------------------- subcommands

def _add_devices(subparsers):
    p = subparsers.add_parser("devices", help="list OpenCL platforms and devices",
                              description="List OpenCL platforms and devices and say which "
                                          "one diskpack would use.")
    _device_options(p)
    p.set_defaults(run=_run_devices)


def _run_devices(args):
    from diskpack_cl import describe, get_context, list_devices

    rows = list_devices()
    for index, platform, device, kind in rows:
        print(f"{index:>5}  {platform}  |  {device}  [{kind}]")
    if not rows:
        print("(no OpenCL devices)")
    print(f"using: {describe(get_context(args.device))}")
    return 0


def _add_poisson(subparsers):
    p = subparsers.add_parser(
        "poisson", help="make a Poisson disk set on the unit torus, in a box, 2D or 3D",
        description="Make a start set (dart throwing, uniform random or a file) on the unit "
                    "torus (or in a --box, or in 3D with --dim 3) and relax it by disk packing "
                    "until rho >= EPS (paper Algorithm 1). Exit status 3 when rho stops short "
                    "of EPS (the set is written; --allow-unreached: 0).")
    count = p.add_mutually_exclusive_group()
    count.add_argument("-n", type=_point_count, default=None, metavar="N",
                       help="number of points (default 1024; with --init FILE: the file's count)")
    count.add_argument("--min-distance", type=_positive_float, default=None, metavar="D",
                       help="instead of -n: the smallest distance between points (scipy's "
                            "radius; twice the paper's radius R): as many points as D allows at "
                            "rho <= --rho-max, relaxed once until they reach it")
    count.add_argument("--radius", type=_radius, default=None, metavar="R",
                       help="instead of -n: find the largest n whose relaxation reaches Poisson "
                            "disk radius R (half the minimum distance, 0 < R < 0.25; the paper's "
                            "Fig. 7) and write that set; --eps is not used, --max-iter caps each "
                            "trial (default 300)")
    p.add_argument("--init", default="dart", metavar="dart|random|FILE",
                   help="start set: dart throwing (default), uniform random, or a point file")
    p.add_argument("--dart-radius", type=_unit_open, default=0.74, metavar="R",
                   help="relative radius of the dart-throwing start (default 0.74)")
    p.add_argument("--seed", type=_nonnegative_int, default=None, help="random seed (default: a fresh one, printed in the --json summary)")
    p.add_argument("--dim", type=int, choices=(2, 3), default=2,
                   help="3: points in the unit 3-torus or a box WxHxD, relaxed to the centres of "
                        "the largest spheres in their 3D Voronoi cells (rho against FCC)")
    p.add_argument("--rho-max", type=_unit_open, default=0.8, metavar="RHO",
                   help="with --min-distance: the largest rho D may ask for (default 0.8)")
    p.add_argument("--mask", default=None, metavar="IMAGE",
                   help="points only where the image is light (> 0.5 gray; the image spans "
                        "--box, default: the image's aspect, longer side 1)")
    p.add_argument("--density", default=None, metavar="IMAGE",
                   help="variable spacing: more points where the image is dark (unequal disk "
                        "packing; needs -n)")
    _output_options(p)
    _relax_options(p)
    g = _batch_options(p)
    g.add_argument("--count", type=_positive_int, default=None, metavar="K",
                   help="make K independent sets, seeds derived from --seed "
                        "(numpy SeedSequence.spawn; each set's seed is in the manifest and "
                        "recreates it alone), e.g. -o sets/{i:04d}.npz")
    p.set_defaults(run=_run_poisson)


_radius = _checked(float, lambda v: 0.0 < v < 0.25, "in (0, 0.25)")


def _run_poisson_radius(args):
    """``poisson --radius R``: the most points that relaxation brings to radius R."""
    from diskpack_cl.io import write_points
    from diskpack_cl.relax import max_points_for_radius

    if args.init not in ("dart", "random"):
        raise ValueError("--radius chooses n itself: use --init dart or random, not a file")
    bar = _bar(args, "radius search", "trial")
    callback = None
    if bar is not None:
        def callback(trial):
            bar.set_postfix_str(f"n={trial['n']} {'reached' if trial['reached'] else 'missed'}",
                                refresh=False)
            bar.update(1)
    try:
        res = max_points_for_radius(args.radius, start=args.init,
                                    seed=0 if args.seed is None else args.seed,
                                    backend=args.backend, grid=args.grid, device=args.device,
                                    max_iter=300 if args.max_iter is None else args.max_iter,
                                    callback=callback)
    except RuntimeError as exc:
        raise ValueError(str(exc)) from None
    finally:
        if bar is not None:
            bar.close()
    extra = {}
    if args.output.lower().endswith(".npz"):
        extra = {"radius": res.radius, "rho": res.rho}
    write_points(args.output, res.points, **extra)
    summary = {
        "n": int(res.n), "radius": float(res.radius),
        "achieved_radius": float(res.achieved_radius), "rho": float(res.rho),
        "trials": res.trials, "seconds": float(res.seconds), "init": args.init,
        "output": str(args.output),
    }
    _report(args, f"{res.n} points reach radius {res.radius:g} (achieved "
                  f"{res.achieved_radius:.6g}, rho {res.rho:.4f}) after {len(res.trials)} trials "
                  f"({res.seconds:.3g} s); wrote {args.output}", summary)
    return 0


def _report(args, line, summary):
    """The summary line on stderr (unless --quiet) and the JSON line on stdout (--json)."""
    if not args.quiet:
        print(f"{PROG}: {line}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary, default=json_default), flush=True)


def _run_poisson(args):
    import warnings

    from diskpack_cl.io import check_points_path, read_points
    from diskpack_cl.sampling import DartThrowingWarning, dart_throwing, random_points

    if _batch_mode(args, [], [args.output]):
        return _run_poisson_batch(args)
    check_points_path(args.output, for_writing=True)
    if args.radius is not None:
        return _run_poisson_radius(args)
    if args.min_distance is not None or args.mask or args.density or args.dim == 3 or (
            args.box is not None and args.init in ("dart", "random")):
        return _run_poisson_set(args)
    t0 = time.perf_counter()
    if args.seed is None:
        import numpy as np

        # a fresh seed, reported in the summary so the run can be repeated
        args.seed = int(np.random.SeedSequence().entropy % 2**31)
    info = {"init": args.init, "seed": args.seed}
    if args.init == "dart":
        n = 1024 if args.n is None else args.n
        with warnings.catch_warnings():
            warnings.simplefilter("always", DartThrowingWarning)
            # printed as they come: a saturated radius is said at once
            warnings.showwarning = lambda message, *_a, **_k: None if args.quiet else print(
                f"{PROG}: warning: {message}", file=sys.stderr, flush=True)
            points, dart = dart_throwing(n, rel_radius=args.dart_radius, seed=args.seed,
                                         full_output=True)
        info["dart_rel_radius"] = dart["rel_radius"]
    elif args.init == "random":
        points = random_points(1024 if args.n is None else args.n, seed=args.seed)
    else:
        points = read_points(args.init)
        if args.n is not None and args.n != len(points):
            raise ValueError(f"-n {args.n} does not match the {len(points)} points "
                             f"of {args.init}; leave -n out")
    if len(points) < 2:
        raise ValueError(f"need at least 2 points, got {len(points)}")
    info["init_seconds"] = time.perf_counter() - t0
    return _relax_and_write(points, args, extra_summary=info)


def _field_image(args, path):
    """``(array, box)`` of a --mask or --density image: light 1, dark 0; the box by default
    has the image's aspect, longer side 1."""
    from diskpack_cl.image import load_gray

    gray = load_gray(_image_path(path))
    if args.box is not None:
        return gray, args.box
    h, w = gray.shape
    return gray, (w / max(w, h), h / max(w, h))


def _run_poisson_set(args):
    """``poisson`` with a box, a minimum distance, a mask or a density (:func:`poisson_disk`)."""
    from diskpack_cl.io import write_points
    from diskpack_cl.poisson import poisson_disk

    if args.init not in ("dart", "random"):
        raise ValueError("--box, --min-distance, --mask and --density make their own start set: "
                         "leave --init out")
    box, mask, density = args.box, None, None
    if args.mask:
        mask, box = _field_image(args, args.mask)
    if args.density:
        density, box = _field_image(args, args.density)
        density = 1.0 - density
    n = 1024 if args.n is None and args.min_distance is None else args.n
    callback, close = _progress(args, "relax")
    try:
        res = poisson_disk(n, min_distance=args.min_distance, box=box, mask=mask, density=density,
                           seed=args.seed, eps=args.eps, rho_max=args.rho_max,
                           backend=args.backend, device=args.device, max_iter=_max_iter(args),
                           callback=callback, dim=args.dim)
    finally:
        close()
    write_points(args.output, res.points)
    summary = {"n": int(len(res.points)), "box": res.domain.size.tolist(), "dim": args.dim,
               "torus": res.domain.periodic, "rho": res.rho, "min_distance": res.min_distance,
               "reached": res.reached, "stop_reason": res.stop_reason, "iterations": res.iterations,
               "seconds": res.seconds, "init_seconds": res.start_seconds, "seed": args.seed,
               "output": str(args.output)}
    _report(args, f"{summary['n']} points, min distance {res.min_distance:.6g}, rho "
                  f"{res.rho:.4f} in {res.iterations} iterations ({res.seconds:.3g} s, stop: "
                  f"{res.stop_reason}); wrote {args.output}", summary)
    if not res.reached:
        goal = (f"--min-distance {args.min_distance:g}" if args.min_distance is not None
                else f"--eps {args.eps:g}")
        return _unreached(args, f"the set did not reach {goal} (stop: {res.stop_reason})")
    return 0


def _add_relax(subparsers):
    p = subparsers.add_parser(
        "relax", help="relax a point file on the unit torus",
        description="Relax a point set on the unit torus by disk packing until rho >= EPS. "
                    "Points outside [0,1)^2 are wrapped onto the torus.")
    p.add_argument("inputs", nargs="+", metavar="IN",
                   help="point file (.npz, .npy, .csv, .txt, .xy); several make a batch "
                        "(-o a template such as out/{stem}.npz)")
    p.add_argument("--columns", type=_columns, default=None, metavar="A,B",
                   help="the two columns to read: header names (x,y) or indices (0,1); needed "
                        "where a file has more coordinates (a z column)")
    _output_options(p)
    _relax_options(p)
    _batch_options(p)
    p.set_defaults(run=_run_relax)


def _columns(text):
    parts = [t.strip() for t in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise argparse.ArgumentTypeError(f"need two columns A,B, got {text!r}")
    return tuple(int(t) if t.isdigit() else t for t in parts)


def _run_relax(args):
    from diskpack_cl.io import check_points_path, read_points

    if _batch_mode(args, args.inputs, [args.output]):
        return _run_relax_batch(args)
    check_points_path(args.output, for_writing=True)
    points = read_points(args.inputs[0], min_points=2, columns=args.columns)
    return _relax_and_write(points, args, extra_summary={"input": str(args.inputs[0])})


SAMPLE = "sample"


def _image_path(text):
    """The word ``sample`` names the bundled sample photograph; anything else is a path."""
    if text == SAMPLE:
        from diskpack_cl.image import sample_image_path

        return sample_image_path()
    return text


def _phase_text(phase):
    kind, it = phase[0], phase[1]
    return f"{kind} {it}" + (f" (blend {phase[2]})" if len(phase) > 2 else "")


def _default_schedule_text():
    """The default schedule's bands, for --help."""
    from diskpack_cl.schedule import SPACING_BANDS

    parts, lo = [], 0.0
    for bound, phases, options in SPACING_BANDS:
        where = f"s < {bound:g}" if lo == 0 else (f"s >= {lo:g}" if bound == float("inf")
                                                  else f"{lo:g} <= s < {bound:g}")
        extra = ", ".join(f"{k} {v}" for k, v in options.items())
        parts.append(f"{where}: " + ", ".join(_phase_text(ph) for ph in phases) + f" ({extra})")
        lo = bound
    return "default = by the dot spacing s = sqrt(W*H/n) px: " + "; ".join(parts)


def _add_stipple(subparsers):
    from diskpack_cl.schedule import SCHEDULE_NAMES, SCHEDULES

    p = subparsers.add_parser(
        "stipple", help="stipple an image with N dots (paper Algorithm 2)",
        description="Stipple an image with N dots by unequal disk packing on power diagrams. "
                    "From an error-diffusion start, the default schedule moves every dot "
                    "towards the centre of the largest circle inside its power cell (pack) "
                    "and part-way to the cell's centroid (mix), with radii from the image's "
                    "density; its phases follow the dot spacing (see --schedule; --schedule "
                    "paper runs the paper's Algorithm 2 loop). The disks are certified inside "
                    "the image and pairwise disjoint (exact float64); the outputs draw every "
                    "dot at one size whose ink equals the image's darkness (--dots), as the "
                    "plotter's pen draws it with --pen-mm. Every output path is checked before "
                    "the computation; the outputs are written together after it, so a failed "
                    "or interrupted run writes nothing and leaves earlier files as they were.",
        epilog="examples:\n"
               "  diskpack stipple sample -n 20000 -o out.svg -o out.png\n"
               "  diskpack stipple photo.jpg -n 50000 -o plot.svg --width-mm 200 --dot-mm 0.5\n"
               "  diskpack stipple photo.png -n 20000 -o base.npz --method lloyd --json\n"
               "  diskpack stipple photos/ --density 80000 -o out/{stem}.svg -o out/{stem}.png",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("images", nargs="+", metavar="IMAGE",
                   help="image file Pillow reads (PNG, JPEG, TIFF, ...; colour is converted to "
                        "luminance), or the word 'sample' for the bundled 512x512 sample "
                        "photograph (use ./sample for a file of that name); several files or "
                        "folders make a batch")
    count = p.add_mutually_exclusive_group(required=True)
    count.add_argument("-n", type=_dot_count, default=None, metavar="N",
                       help="number of dots (at least 2), or 'tone' with --dot-mm or --pen-mm: "
                            "as many dots as give the image's ink on the paper")
    count.add_argument("--density", type=_positive_float, default=None, metavar="D",
                       help="instead of -n: D dots per megapixel of each image")
    count.add_argument("--dots-per-cm2", type=_positive_float, default=None, metavar="D",
                       help="instead of -n: D dots per cm^2 of the print (needs --width-mm, "
                            "--height-mm or --dpi)")
    p.add_argument("-o", "--output", action="append", required=True, metavar="OUT",
                   help="output file; repeat for several: .svg (pen plotters, Inkscape), .png "
                        "(anti-aliased preview), .npz (points, radii, k, width, height), .csv "
                        "(x,y,r in pixels)")
    g = p.add_argument_group("stippling (the paper's parameters)")
    g.add_argument("--gamma", type=_positive_float, default=None,
                   help="gamma: contrast exponent of the gray radius mapping, base radius "
                        "r_i = max(gray, FLOOR)^(gamma/2) (default 3.0); only --radii gray has "
                        "it (the paper, pack and lloyd schedules), so the default schedule's "
                        "density radii refuse it")
    g.add_argument("--floor", type=_unit_half_open, default=None,
                   help="floor of the radius mapping, so that black (gray) or white (density) "
                        "regions keep a finite radius (default: the schedule's, 0.1 for paper, "
                        "pack and lloyd, 0.01 for default)")
    g.add_argument("--radii", choices=("gray", "density"), default=None,
                   help="radius mapping: gray = the paper's r_i = max(gray, FLOOR)^(gamma/2); "
                        "density = r_i ~ darkness^(-1/2), the density Lloyd aims at "
                        "(default: the schedule's, density for default)")
    g.add_argument("--blend", type=_unit_closed, default=None,
                   help="mix phases move to MIC + BLEND * (centroid - MIC) (default: the "
                        "schedule's)")
    g.add_argument("--features", choices=("none", "detail"), default=None,
                   help="detail: feature-aware mix steps, where the image holds detail finer "
                        "than the dot spacing dots move further towards their cell's centroid "
                        "and the radii follow the detail (more tone, slightly less even "
                        "spacing); default: the schedule's (detail for --schedule detail, and "
                        "for the default where the dot spacing is 3 px or more)")
    g.add_argument("--capacity", type=_unit_closed, default=None, metavar="GAIN",
                   help="equal ink per dot: after each step every dot's radius is scaled by "
                        "(mean ink / its power cell's ink)^GAIN, as in capacity-constrained "
                        "stippling; more tone, closer pairs across tone edges (default: the "
                        "schedule's, 0.1 for default, 0 = off for the others)")
    g.add_argument("--support", type=_unit_closed, default=None, metavar="S",
                   help="keep dots on the ink: a dot whose largest empty disk leaves its cell's "
                        "ink moves towards the cell's centroid instead, by S times how far it "
                        "left (default: the schedule's, 1 for default, 0 for the others; 0 "
                        "lets edge dots drift onto white paper)")
    g.add_argument("--paper-tone", type=_unit_half_open_zero, default=0.0, metavar="T",
                   help="darkness T added under the whole image, so that white paper gets "
                        "sparse dots too (default 0: white stays white)")
    g.add_argument("--k-quantile", type=_unit_half_open_zero, default=None,
                   help="during iterations, k is this quantile of R_i/r_i (0 = the paper's "
                        "minimum; the output always uses the largest certified k)")
    g.add_argument("--schedule", choices=SCHEDULE_NAMES, default=None,
                   help="named schedule of disk-packing (pack) and Lloyd phases: "
                        + _default_schedule_text() + "; "
                        + "; ".join(f"{name} = " + ", ".join(_phase_text(ph) for ph in phases)
                                    for name, phases in sorted(SCHEDULES.items()))
                        + " (default: default; classic was the default before the spacing "
                          "bands; paper is the paper's loop)")
    g.add_argument("--beta", type=_nonnegative_int, default=None,
                   help="beta: disk-packing iterations per round; with --lloyd and --rounds it "
                        "replaces --schedule (missing ones: the paper's beta 40, lloyd 10, "
                        "rounds 3; the last round is half as long)")
    g.add_argument("--lloyd", type=_nonnegative_int, default=None, metavar="L",
                   help="Lloyd iterations between rounds (paper: 10); with --method lloyd: the "
                        "number of Lloyd iterations (default 50)")
    g.add_argument("--rounds", type=_positive_int, default=None,
                   help="number of disk-packing rounds (paper: 3)")
    g.add_argument("--method", choices=("diskpack", "lloyd"), default="diskpack",
                   help="diskpack (default): the paper's disk packing; lloyd: weighted Voronoi "
                        "stippling (Secord 2002), the baseline, from the same start")
    g.add_argument("--supersample", type=_positive_int, default=None, metavar="S",
                   help="raster cells per image pixel side (default: automatic, about 16 cells "
                        "per dot, at most 8)")
    g.add_argument("--refine-every", type=_nonnegative_int, default=1, metavar="R",
                   help="refine the raster MIC estimate exactly every R disk-packing iterations "
                        "(default 1 = always; 0 = never); the output is always certified")
    g.add_argument("--verify", action="store_true",
                   help="check every MIC step against scipy (exact_mic); slow, for testing "
                        "(single inputs)")
    g.add_argument("--profile", action="store_true",
                   help="time the OpenCL kernels with events (--json timings.kernel and "
                        "timings.kernel_<name>: device seconds, all and per kernel; single inputs)")
    g.add_argument("--seed", type=_nonnegative_int, default=0,
                   help="seed of the error-diffusion start (default 0; same seed, same result)")
    g.add_argument("--invert", action="store_true",
                   help="stipple the light parts (light dots on a dark ground)")
    t = p.add_argument_group("tone (before stippling, on every schedule; in --json params.tone)")
    t.add_argument("--black-point", type=_unit_closed, default=0.0, metavar="B",
                   help="gray levels at or below B (0 black .. 1 white) get full ink "
                        "(default 0)")
    t.add_argument("--white-point", type=_unit_closed, default=1.0, metavar="W",
                   help="gray levels at or above W are blank paper, no dots (default 1)")
    t.add_argument("--tone-gamma", type=_positive_float, default=1.0, metavar="G",
                   help="contrast: the levels between the points are raised to G (above 1: "
                        "darker mid-tones, below 1: lighter; default 1)")
    g.add_argument("--allow-large", action="store_true",
                   help="lift Pillow's decompression-bomb limit (about 89 Mpixel) for trusted "
                        "large images")
    _device_options(g)
    _drawing_options(p, "the result summary (n, k, radii, certificate, timings, params), ")
    _batch_options(p).add_argument("--recursive", "-r", action="store_true",
                                   help="a folder given as IMAGE contributes the images of "
                                        "its subfolders too")
    p.set_defaults(run=_run_stipple)


def _page(text):
    from diskpack_cl.export import paper_size

    try:
        paper_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


_nonnegative_float = _checked(float, lambda v: 0.0 <= v < float("inf"), "a finite number >= 0")


def _drawing_options(p, summary):
    """The options of how the dots are drawn (SVG, PNG), of ``stipple`` and ``export``."""
    from diskpack_cl.export import DEFAULT_MARGIN_MM, PAPERS, PEN_LIFT_S, PLOT_SPEED_MM_S
    from diskpack_cl.pen_path import PEN_PATHS

    o = p.add_argument_group("output")
    o.add_argument("--width-mm", type=_positive_float, default=None, metavar="MM",
                   help="picture width in mm (with --height-mm: fit inside the box)")
    o.add_argument("--height-mm", type=_positive_float, default=None, metavar="MM",
                   help="picture height in mm")
    o.add_argument("--dpi", type=_positive_float, default=None,
                   help="picture size from the image's pixels at DPI (default 96 when no mm "
                        "size and no --page)")
    o.add_argument("--page", type=_page, default=None, metavar="PAPER",
                   help=f"the SVG's page is this paper: {', '.join(PAPERS)} or WxHmm (e.g. "
                        f"300x200mm), portrait; the picture is centred on it and, without a "
                        f"size, fitted inside the margins")
    o.add_argument("--landscape", action="store_true", help="turn the --page paper")
    o.add_argument("--margin-mm", type=_nonnegative_float, default=None, metavar="MM",
                   help=f"margin around the picture on the --page paper (default "
                        f"{DEFAULT_MARGIN_MM:g})")
    o.add_argument("--dots", choices=("tone", "packing"), default=None,
                   help="dot size in SVG and PNG: tone (default) = one size for all dots, "
                        "chosen so that the total ink equals the image's total darkness; "
                        "packing = each dot its certified packing disk (large where the image "
                        "is light: it shows the packing, not the tone)")
    o.add_argument("--dot-mm", type=_positive_float, default=None, metavar="MM",
                   help="fixed dot diameter in mm instead of --dots; the PNG preview shows "
                        "the same dots")
    o.add_argument("--pen-mm", type=_positive_float, default=None, metavar="W",
                   help="plotter pen width in mm: the SVG draws each dot as the pen draws it, "
                        "one path per dot: a dot not wider than the pen is one pen touch, a "
                        "wider one is filled by concentric rings W apart (the outermost of "
                        "radius (dot diameter - W)/2); the PNG preview shows the same ink "
                        "(default: filled circles, which a plotter traces W wider)")
    o.add_argument("--radius-scale", type=_positive_float, default=1.0, metavar="F",
                   help="factor on the dot radii of --dots in SVG and PNG (default 1.0)")
    o.add_argument("--pen-path", choices=PEN_PATHS, default="auto",
                   help="SVG dot order: auto (default) = the shorter of greedy and Hilbert, "
                        "then 2-opt for at most 2 s (measured shortest, benchmarks/pen_path.py); "
                        "hilbert = Hilbert curve; greedy = nearest neighbour; none = as computed")
    o.add_argument("--png-scale", type=_positive_float, default=None, metavar="F",
                   help="PNG pixels per image pixel (default 2.0, at most "
                        "a 4096 px long side)")
    o.add_argument("--plot-speed-mm-s", type=_positive_float, default=PLOT_SPEED_MM_S,
                   metavar="V", help=f"plot-time estimate: pen speed V mm/s drawing and "
                                     f"travelling, plus {PEN_LIFT_S:g} s to lower and raise the "
                                     f"pen per dot (default {PLOT_SPEED_MM_S:g})")
    o.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bar and no summary on stderr")
    o.add_argument("--json", action="store_true",
                   help=f"print one JSON line on stdout at the end: {summary}each output's "
                        f"info, plot (pen-down count, pen-up travel before and after the "
                        f"pen path, plot time) and seconds")
    return o


def _resolve_drawing_options(args):
    """Refuse contradicting drawing options (:class:`_UsageError`); default --dots."""
    if args.dot_mm is not None and args.dots is not None:
        raise _UsageError(f"--dot-mm {args.dot_mm:g} and --dots {args.dots} both set the dot "
                          f"size; give one")
    if args.dpi is not None and (args.width_mm is not None or args.height_mm is not None):
        raise _UsageError("give the SVG size either by --width-mm/--height-mm or by --dpi, "
                          "not both")
    for name in ("margin_mm", "landscape"):
        if getattr(args, name) not in (None, False) and args.page is None:
            raise _UsageError(f"--{name.replace('_', '-')} is for a --page paper: give --page "
                              f"too (e.g. --page a4)")
    args.dots = args.dots or "tone"


def _stipple_progress(args, total):
    """Return (callback, close): a tqdm bar (iteration, phase kind, k) on a terminal."""
    bar = _bar(args, "stipple", "it", total or None)
    if bar is None:
        return None, lambda: None

    def callback(entry):
        post = f"{entry.get('kind', '?')} k={entry.get('k', float('nan')):.4g}"
        if entry.get("empty"):
            post += f" empty={entry['empty']}"
        bar.set_postfix_str(post, refresh=False)
        bar.update(int(entry.get("iteration", bar.n)) + 1 - bar.n)

    return callback, bar.close


class _UsageError(ValueError):
    """Options that contradict each other: :func:`main` returns 2, as argparse does."""


def _resolve_stipple_options(args):
    """Refuse contradicting stipple options, then fill in the defaults left open.

    Raises
    ------
    _UsageError
        Naming both options: those of :func:`_resolve_drawing_options`, ``--method lloyd``
        with ``--schedule`` or ``--beta/--rounds``, ``--schedule`` with
        ``--beta/--lloyd/--rounds``, and ``--gamma`` where the radius mapping
        has no gamma (density radii).
    """
    from diskpack_cl.schedule import SCHEDULE_OPTIONS

    _resolve_drawing_options(args)
    if not args.black_point < args.white_point:
        raise _UsageError(f"--black-point {args.black_point:g} must be below --white-point "
                          f"{args.white_point:g}")
    if args.method == "lloyd" and args.schedule is not None:
        raise _UsageError(f"--method lloyd runs Lloyd iterations only (--lloyd L), so "
                          f"--schedule {args.schedule} would be ignored; give one")
    built = [f"--{k}" for k in ("beta", "rounds") if getattr(args, k) is not None]
    if args.method == "lloyd" and built:
        raise _UsageError(f"--method lloyd runs Lloyd iterations only (--lloyd L), so "
                          f"{'/'.join(built)} would be ignored; give one")
    if args.method == "diskpack" and args.lloyd is not None:
        built.append("--lloyd")
    if built and args.schedule is not None:
        raise _UsageError(f"{'/'.join(built)} build the schedule the paper's way, so "
                          f"--schedule {args.schedule} would be ignored; give one")
    if args.method == "lloyd":
        radii = SCHEDULE_OPTIONS["lloyd"]["radii"]
    elif built:
        radii = SCHEDULE_OPTIONS["paper"]["radii"]
    else:
        radii = SCHEDULE_OPTIONS[args.schedule or "default"]["radii"]
    radii = args.radii or radii
    if args.gamma is not None and radii != "gray":
        which = f"--radii {args.radii}" if args.radii else (
            f"the {args.schedule or 'default'} schedule's {radii} radii")
        raise _UsageError(f"--gamma has no effect with {which} (r ~ darkness^(-1/2)); it is "
                          f"the exponent of --radii gray, which the paper, pack and lloyd "
                          f"schedules use (e.g. --schedule paper --gamma {args.gamma:g}); "
                          f"--tone-gamma sets the contrast on every schedule")
    args.gamma = 3.0 if args.gamma is None else args.gamma
    args.schedule = args.schedule or "default"


# Peak memory measured per unit (diskpack stipple, default schedule; PNG writer)
HOST_BYTES_PER_CELL = 64       # one raster cell: maps, density, centroid sums
DEVICE_BYTES_PER_CELL = 12     # labels, distances, neighbours (4 bytes each)
HOST_BYTES_PER_PNG_PIXEL = 32  # ink coverage, gray values, the encoded image


def _available_memory():
    """Bytes of memory the machine has available now (MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_sizes(args, width, height, n, outputs):
    """Refuse, before the work, a raster or a PNG that memory cannot hold.

    The raster (``--supersample``) is checked against the machine's available
    memory and the OpenCL device's largest buffer and global memory; each PNG
    (``--png-scale``) against the machine's memory. The message names the
    option to lower and the largest value that fits.
    """
    import math

    from diskpack_cl import NoOpenCLError, get_context
    from diskpack_cl.schedule import auto_supersample

    def gib(b):
        return f"{b / 2**30:.3g} GiB"

    free = _available_memory()
    s = args.supersample or auto_supersample(n, width, height)
    cells = (s * width) * (s * height)
    limits = []  # (bytes per raster cell, bytes available, what)
    if free is not None:
        limits.append((HOST_BYTES_PER_CELL, free, "memory available on this machine"))
    try:
        dev = get_context(args.device).devices[0]
    except NoOpenCLError:
        dev = None
    if dev is not None:
        limits += [(4, dev.max_mem_alloc_size, "the OpenCL device's largest buffer"),
                   (DEVICE_BYTES_PER_CELL, dev.global_mem_size, "the OpenCL device's memory")]
    for per_cell, have, what in limits:
        if cells * per_cell > have:
            fit = math.isqrt(int(have // (per_cell * width * height)))
            lower = (f"lower --supersample (at most {fit} here)" if fit >= 1 else
                     "the image is too large even at --supersample 1: downscale it")
            raise ValueError(f"supersample {s} makes a {s * width}x{s * height} raster "
                             f"needing {gib(cells * per_cell)}, more than {what} "
                             f"({gib(have)}): {lower}")
    if free is None or not any(o.lower().endswith(".png") for o in outputs):
        return
    pw, ph = max(1, round(width * args.png_scale)), max(1, round(height * args.png_scale))
    if pw * ph * HOST_BYTES_PER_PNG_PIXEL > free:
        fit = math.sqrt(free / HOST_BYTES_PER_PNG_PIXEL / (width * height))
        raise ValueError(f"--png-scale {args.png_scale:g} makes a {pw}x{ph} PNG needing "
                         f"{gib(pw * ph * HOST_BYTES_PER_PNG_PIXEL)}, more than the memory "
                         f"available ({gib(free)}): lower --png-scale (at most "
                         f"{math.floor(fit * 10) / 10:g} here)")


def _write_options(args):
    """The options of :func:`diskpack_cl.batch.write_stipple_outputs` from the arguments."""
    return dict(dots=args.dots, dot_mm=args.dot_mm, radius_scale=args.radius_scale,
                pen_path=args.pen_path, png_scale=args.png_scale, invert=args.invert,
                pen_mm=args.pen_mm, plot_speed_mm_s=args.plot_speed_mm_s,
                **_layout_options(args))


def _layout_options(args):
    """Where the picture goes on paper: the options of :func:`diskpack_cl.export.svg_layout`."""
    return dict(width_mm=args.width_mm, height_mm=args.height_mm, dpi=args.dpi, page=args.page,
                landscape=args.landscape, margin_mm=args.margin_mm)


def _tone(args):
    """The tone controls of :func:`diskpack_cl.image.adjust_tone` from the arguments."""
    return dict(black=args.black_point, white=args.white_point, gamma=args.tone_gamma)


def _stipple_options(args):
    """The keyword arguments of :func:`diskpack_cl.stipple` from the arguments."""
    return dict(gamma=args.gamma, floor=args.floor, schedule=args.schedule, beta=args.beta,
                lloyd=args.lloyd, rounds=args.rounds, supersample=args.supersample,
                method=args.method, invert=args.invert, refine_every=args.refine_every,
                radii=args.radii, blend=args.blend, k_quantile=args.k_quantile,
                features=args.features, capacity=args.capacity, support=args.support,
                paper_tone=args.paper_tone)


def _checked_outputs(args):
    """The ``-o`` paths, each checked (extension, folder) and given once, before any work."""
    from diskpack_cl.export import check_output_path

    outputs = [str(o) for o in args.output]
    seen = set()
    for out in outputs:
        check_output_path(out)
        key = os.path.realpath(out)
        if key in seen:
            raise ValueError(f"output given twice: {out}")
        seen.add(key)
    return outputs


def _tone_count(args, gray, n):
    """With --dot-mm/--pen-mm: the dots whose ink is the image's (a note when far from n).

    Returns ``(n, info)``: ``n`` itself unless it is ``"tone"``, and the
    ``tone_n`` summary (None without a pen or dot size).
    """
    from diskpack_cl.export import svg_layout, tone_dot_count

    dot = args.dot_mm or args.pen_mm
    if dot is None:
        if n == "tone":
            raise _UsageError("-n tone needs the dot size: give --dot-mm or --pen-mm")
        return n, None
    h, w = gray.shape
    scale = svg_layout(w, h, **_layout_options(args))["scale"]
    tone = tone_dot_count(gray if args.invert else 1.0 - gray, scale, dot)
    if isinstance(n, int) and not 2 / 3 <= n / tone <= 3 / 2 and not args.quiet:
        print(f"{PROG}: note: {tone} dots of {dot:g} mm give the image's ink on this paper; "
              f"-n {n} will look {'darker' if n > tone else 'lighter'} (-n tone uses {tone})",
              file=sys.stderr)
    return (tone if n == "tone" else n), {"n": tone, "dot_mm": dot}


def _write_bar(args, n, outputs):
    """Return (callback, close): a bar over the dots the PNG previews stamp."""
    pngs = sum(o.lower().endswith(".png") for o in outputs)
    bar = _bar(args, "write", "dot", n * pngs) if pngs else None
    return (None, lambda: None) if bar is None else (bar.update, bar.close)


def _plot_summary(written, speed):
    """Plot figures of the first SVG output, and their text for the summary line."""
    svg = next((w for w in written if w["format"] == "svg"), None)
    if svg is None:
        return None, ""
    plot = {k: svg[k] for k in ("pen_downs", "draw_mm", "travel_before_mm", "travel_after_mm",
                                "plot_seconds")}
    plot["plot_speed_mm_s"] = speed
    hours, minutes = divmod(round(plot["plot_seconds"] / 60), 60)
    return plot, (f"; pen-up travel {plot['travel_before_mm']:.0f} -> "
                  f"{plot['travel_after_mm']:.0f} mm, plot about {hours} h {minutes:02d} min "
                  f"at {speed:g} mm/s")


def _write_and_report(args, res, gray, outputs, summary, t0):
    """Write the outputs, add their figures to ``summary`` (and ``seconds`` since ``t0``),
    print it with --json; return the tail of the summary line."""
    from diskpack_cl.batch import write_stipple_outputs

    t_write = time.perf_counter()
    progress, close = _write_bar(args, len(res.points), outputs)
    try:
        dot_mm, written = write_stipple_outputs(res, gray, outputs, progress=progress,
                                                **_write_options(args))
    finally:
        close()
    plot, text = _plot_summary(written, args.plot_speed_mm_s)
    summary.update(dot_mm=dot_mm, outputs=written, plot=plot,
                   write_seconds=time.perf_counter() - t_write,
                   seconds=time.perf_counter() - t0)
    if args.json:
        print(json.dumps(summary, default=json_default), flush=True)
    return f"{text}; wrote " + ", ".join(outputs)


def _run_stipple(args):
    from diskpack_cl.batch import dots_for_image
    from diskpack_cl.export import preview_scale
    from diskpack_cl.image import adjust_tone, load_gray
    from diskpack_cl.schedule import StippleOptions
    from diskpack_cl.stipple import stipple

    _resolve_stipple_options(args)
    if _batch_mode(args, args.images, args.output):
        if args.n == "tone":
            raise _UsageError("-n tone is for one image; give -n N or --density for a batch")
        return _run_stipple_batch(args)
    t0 = time.perf_counter()
    # everything that can be refused is refused before the computation
    outputs = _checked_outputs(args)
    image = _image_path(args.images[0])
    gray = adjust_tone(load_gray(image, allow_large=args.allow_large), **_tone(args))
    n, tone_n = _tone_count(args, gray, args.n)
    n = dots_for_image(gray.shape[1], gray.shape[0], n=n, density=args.density,
                       dots_per_cm2=args.dots_per_cm2, **_layout_options(args))
    args.png_scale = preview_scale(gray.shape[1], gray.shape[0], args.png_scale)
    _check_sizes(args, gray.shape[1], gray.shape[0], n, outputs)
    # the phases (for the progress total) follow n and the image size
    opt = StippleOptions.resolve(n, gray.shape[1], gray.shape[0], seed=args.seed,
                                 **_stipple_options(args))

    callback, close = _stipple_progress(args, sum(ph[1] for ph in opt.phases))
    try:
        res = stipple(gray, n, seed=args.seed, device=args.device, callback=callback,
                      verify=args.verify, profile=args.profile, **_stipple_options(args))
    finally:
        close()
    if not getattr(res.certificate, "valid", False):
        raise ValueError(f"the result failed its certificate ({res.certificate}); nothing written")
    res.params["tone"] = _tone(args)  # recorded in the .npz and the --json params
    summary = res.summary()
    summary.update(image=str(image), tone_n=tone_n)
    tail = _write_and_report(args, res, gray, outputs, summary, t0)
    if res.engine == "exact" and not args.quiet:
        print(f"{PROG}: note: no OpenCL device: stippled with the exact (scipy) engine",
              file=sys.stderr)
    if not args.quiet:
        cert = res.certificate
        print(f"{PROG}: {res.n} dots on {res.width}x{res.height} px, k = {res.k:.4g}, "
              f"radii {summary['min_radius']:.3g}..{summary['max_radius']:.3g} px, "
              f"certified {'valid' if cert.valid else 'INVALID'} (min gap {cert.min_gap:.3g} px), "
              f"{summary['iterations']} iterations in {summary['seconds']:.3g} s{tail}",
              file=sys.stderr)
    return 0


def _add_export(subparsers):
    p = subparsers.add_parser(
        "export", help="draw a finished stippling again, for another paper, pen or dot size",
        description="Draw a stippling that 'diskpack stipple' wrote (.npz; its .csv and .svg "
                    "are read too) again without recomputing it: another paper (--page), "
                    "size, pen (--pen-mm), dot size or pen path. The dots keep the size whose "
                    "ink equals the image's darkness (stored in the .npz) unless --dot-mm or "
                    "--dots packing is given.",
        epilog="examples:\n"
               "  diskpack export out.npz -o a4.svg --page a4 --pen-mm 0.5\n"
               "  diskpack export out.npz -o a3.svg -o a3.png --page a3 --landscape "
               "--margin-mm 20",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="STIPPLING",
                   help="a stippling written by diskpack stipple (.npz, .csv or .svg)")
    p.add_argument("-o", "--output", action="append", required=True, metavar="OUT",
                   help="output file; repeat for several: .svg, .png, .npz, .csv")
    p.add_argument("--invert", action="store_true",
                   help="light dots on dark paper (default: as the stippling was made)")
    _drawing_options(p, "n, the input, ")
    p.set_defaults(run=_run_export)


def _run_export(args):
    from diskpack_cl.export import read_stipple

    _resolve_drawing_options(args)
    t0 = time.perf_counter()
    outputs = _checked_outputs(args)
    res = read_stipple(args.input)
    if res is None:
        raise ValueError(f"{args.input} is a point set, not a stippling (no radii, width and "
                         f"height)")
    args.invert = args.invert or bool(res.params.get("invert", False))
    summary = {"n": len(res.points), "width": res.width, "height": res.height,
               "input": str(args.input)}
    tail = _write_and_report(args, res, None, outputs, summary, t0)
    if not args.quiet:
        print(f"{PROG}: {len(res.points)} dots of {args.input}{tail}", file=sys.stderr)
    return 0


def _add_analyze(subparsers):
    p = subparsers.add_parser(
        "analyze", help="spectra and measures of point sets or of a stippling, as a figure",
        description="Point sets on the unit torus (.npz, .npy, .csv, .txt, .xy): one figure "
                    "with the points, the mean periodogram (averaged over all files, as "
                    "realizations), the radial mean power and the anisotropy in dB, with n, "
                    "rho and the mean nearest-neighbour rho. A stippling (.npz written by "
                    "'diskpack stipple', with --image): the rendering beside the input, both "
                    "blurred with the tone SSIM, the spacing histogram and the certificate "
                    "(re-checked from the file). Figures need matplotlib: "
                    "pip install \"diskpack_cl[plot]\".",
        epilog="examples:\n"
               "  diskpack analyze a.npz b.npz c.npz -o report.png --json\n"
               "  diskpack analyze stipple.npz --image sample -o stipple_report.png",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("inputs", nargs="+", metavar="POINTS",
                   help="point files (realizations of one process), or one stippling .npz")
    p.add_argument("-o", "--output", default=None, metavar="REPORT",
                   help="figure file (.png, .pdf or .svg); written atomically")
    p.add_argument("--json", action="store_true",
                   help="print the numbers as one JSON line on stdout")
    p.add_argument("--image", default=None, metavar="IMAGE",
                   help="for a stippling: the input image ('sample' for the bundled one)")
    p.add_argument("--invert", action="store_true",
                   help="for a stippling: the image was stippled with --invert (default: as "
                        "recorded in the .npz)")
    p.add_argument("--allow-large", action="store_true",
                   help="lift Pillow's decompression-bomb limit for --image")
    p.add_argument("--sigma", type=_positive_float, default=3.0,
                   help="for a stippling: Gaussian blur in pixels for tone and spacing "
                        "(default 3)")
    p.add_argument("--kmax", type=_positive_int, default=None,
                   help="for point sets: periodogram frequency range (default: automatic)")
    p.add_argument("--title", default=None, help="figure title")
    p.set_defaults(run=_run_analyze)


_PLOT_HINT = 'figures need matplotlib: pip install "diskpack_cl[plot]"'


def _have_matplotlib():
    import importlib.util

    try:
        return importlib.util.find_spec("matplotlib.figure") is not None
    except (ImportError, ValueError):
        return False


def _run_analyze(args):
    import numpy as np

    from diskpack_cl import read_stipple
    from diskpack_cl.io import read_points
    from diskpack_cl.measures import nearest_neighbor_distances

    if args.output is None and not args.json:
        raise ValueError("nothing to do: give -o REPORT.png for a figure and/or --json")
    plot = args.output is not None
    if plot:
        from diskpack_cl.io import check_writable
        from diskpack_cl.plots import figure_format

        figure_format(args.output)
        check_writable(args.output)
        if not _have_matplotlib() and not args.json:
            raise ValueError(f"{_PLOT_HINT} (the numbers print without it with --json)")
    stipplings = [(path, read_stipple(path) if str(path).lower().endswith(".npz") else None)
                  for path in args.inputs]
    kinds = {s is not None for _, s in stipplings}
    if True in kinds:
        if len(args.inputs) != 1:
            raise ValueError("a stippling .npz (with radii, width, height) is analyzed alone; "
                             "give one file")
        from diskpack_cl.geometry import Domain, certify_disks
        from diskpack_cl.image import load_gray

        path, st = stipplings[0]
        points, radii, width, height, params = st.points, st.radii, st.width, st.height, st.params
        if args.image is None:
            raise ValueError(f"{path} is a stippling: give its input image with --image IMAGE "
                             f"(or --image {SAMPLE})")
        if points.ndim != 2 or points.shape[1:] != (2,) or radii.shape != (len(points),):
            raise ValueError(f"{path}: points must be (n, 2) and radii (n,)")
        invert = bool(params.get("invert", False)) or args.invert
        gray = load_gray(_image_path(args.image), invert=invert, allow_large=args.allow_large)
        if gray.shape != (height, width):
            raise ValueError(f"the image is {gray.shape[1]}x{gray.shape[0]} px but {path} is a "
                             f"stippling of a {width}x{height} px image")
        darkness = 1.0 - gray
        cert = certify_disks(points, radii, Domain.rect(width, height))
        if plot and _have_matplotlib():
            from diskpack_cl.plots import stipple_report

            numbers = stipple_report(points, radii, darkness, args.output, certificate=cert,
                                     sigma=args.sigma, title=args.title)
        else:
            from diskpack_cl.plots import stipple_numbers

            numbers = stipple_numbers(points, radii, darkness, cert, sigma=args.sigma)
    else:
        if args.image is not None:
            raise ValueError("--image is for a stippling .npz; these are point sets")
        sets = []
        for path in args.inputs:
            pts = read_points(path, min_points=2)
            if np.any(pts < 0) or np.any(pts > 1):
                raise ValueError(f"{path}: points must lie on the unit torus [0,1)^2 (a "
                                 f"stippling in pixels is analyzed through its .npz with "
                                 f"--image)")
            same = nearest_neighbor_distances(pts) == 0
            if same.any():
                raise ValueError(f"{path}: {int(same.sum())} of {len(pts)} points coincide "
                                 f"with another (first: row {int(np.argmax(same))}); rho, the "
                                 f"spectra and the hexatic order need distinct points")
            sets.append(pts)
        if plot and _have_matplotlib():
            from diskpack_cl.plots import point_set_report

            numbers = point_set_report(sets, args.output, title=args.title, kmax=args.kmax)
        else:
            from diskpack_cl.plots import point_set_numbers

            numbers = point_set_numbers(sets, kmax=args.kmax)
    if args.json:
        print(json.dumps(numbers, default=json_default), flush=True)
    if plot and not _have_matplotlib():
        raise ValueError(f"{_PLOT_HINT}; no figure written")
    if plot:
        print(f"{PROG}: wrote {args.output}", file=sys.stderr)
    return 0


# -------------------------------------------------------------------- batches

def _batch_mode(args, inputs, outputs):
    """Whether the command is a batch (else it runs exactly as for one input).

    Raises _UsageError for a batch with --verify or --profile, which apply
    to one input.
    """
    batch = (len(inputs) > 1 or any(os.path.isdir(x) for x in inputs)
             or any("{" in str(o) for o in outputs) or "," in (args.device or "")
             or any(getattr(args, k, None) for k in ("jobs", "manifest", "overwrite",
                                                      "scheduler", "collect", "count")))
    single = [f"--{k}" for k in ("verify", "profile") if getattr(args, k, False)]
    if batch and single:
        verb = "apply" if len(single) > 1 else "applies"
        raise _UsageError(f"{' and '.join(single)} {verb} to one input; this command is a batch "
                          "(several inputs, a folder, a template or a batch option)")
    return batch


def _batch_run(args):
    """Keyword arguments of the batch functions for where and how items run."""
    devices = [d.strip() for d in args.device.split(",") if d.strip()] if args.device else None
    scheduler = args.scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    if args.collect and scheduler is None:
        raise ValueError("--collect is for a Dask cluster: give --scheduler ADDRESS too")
    if scheduler is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            from diskpack_cl.batch import DASK_HINT

            raise ValueError(f"--scheduler: {DASK_HINT}") from None
    from diskpack_cl.batch import default_jobs

    return dict(manifest=args.manifest, overwrite=args.overwrite, devices=devices,
                jobs=args.jobs or default_jobs(devices), client=scheduler,
                collect=args.collect)


class _Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP during a batch."""


def _raise_terminated(signum, frame):
    raise _Terminated(signum)


def _report_batch(args, batch):
    """Run a planned batch with a progress bar / log lines / JSON; the exit status.

    :func:`main` turns SIGTERM and SIGHUP into :class:`_Terminated`; an
    interrupted batch says how far it came and how to resume.
    """
    total = len(batch)
    bar = _bar(args, args.command, "item", total, leave=True)
    counts = {"ok": 0, "failed": 0, "skipped": 0}
    failures = []
    t0 = time.perf_counter()

    def tally():
        return f"ok {counts['ok']} failed {counts['failed']} skipped {counts['skipped']}"

    def on_iteration(item, iteration, text):
        bar.set_postfix_str(f"{tally()} | {os.path.basename(item.input or item.outputs[0])} "
                            f"it {iteration} {text}")

    if bar is not None:
        batch.progress = on_iteration
    try:
        for rec in batch:
            counts[rec["status"]] += 1
            name = rec.get("input") or rec["outputs"][0]
            if rec["status"] == "failed":
                failures.append({"input": name, "error": rec.get("error")})
            if args.json:
                print(json.dumps(rec, default=json_default), flush=True)
            if bar is not None:
                bar.set_postfix_str(tally(), refresh=False)
                bar.update(1)
            elif not args.quiet:
                done = sum(counts.values())
                took = f" ({rec['seconds']:.3g} s)" if rec["status"] != "skipped" else ""
                error = f": {rec['error']}" if rec["status"] == "failed" else ""
                print(f"{PROG}: [{done}/{total}] {rec['status']} {name}{took}{error}",
                      file=sys.stderr, flush=True)
    except KeyboardInterrupt as exc:
        if bar is not None:
            bar.close()
        done = sum(counts.values())
        print(f"{PROG}: error: interrupted after {done} of {total} items; the finished ones "
              f"are in {batch.manifest}: rerun the same command to resume", file=sys.stderr)
        return 128 + exc.args[0] if isinstance(exc, _Terminated) else 130
    if bar is not None:
        bar.close()
    seconds = time.perf_counter() - t0
    ran = counts["ok"] + counts["failed"]
    summary = {"summary": True, "items": total, **counts, "seconds": seconds,
               "items_per_minute": 60.0 * ran / seconds if ran and seconds > 0 else None,
               "manifest": batch.manifest, "failures": failures}
    if args.json:
        print(json.dumps(summary), flush=True)
    if not args.quiet:
        print(f"{PROG}: {counts['ok']} done, {counts['failed']} failed, {counts['skipped']} "
              f"skipped (already done) of {total} in {seconds:.3g} s; manifest "
              f"{batch.manifest}", file=sys.stderr)
        for f in failures:
            print(f"{PROG}: failed: {f['error']}", file=sys.stderr)
    return 1 if failures else 0


def _run_stipple_batch(args):
    from diskpack_cl.batch import stipple_many

    batch = stipple_many([_image_path(x) for x in args.images], [str(o) for o in args.output],
                         n=args.n, density=args.density, dots_per_cm2=args.dots_per_cm2,
                         seed=args.seed, recursive=args.recursive,
                         allow_large=args.allow_large, write=_write_options(args),
                         tone=_tone(args), **_batch_run(args), **_stipple_options(args))
    return _report_batch(args, batch)


def _run_poisson_batch(args):
    from diskpack_cl.batch import poisson_many

    if args.radius is not None or args.min_distance is not None:
        raise ValueError("--radius and --min-distance make one set; they do not combine with "
                         "--count or a batch")
    _single_only(args, "box", "mask", "density")
    batch = poisson_many(args.count or 1, 1024 if args.n is None else args.n, [args.output],
                         seed=args.seed, init=args.init, dart_radius=args.dart_radius,
                         eps=args.eps, max_iter=_max_iter(args), backend=args.backend,
                         grid=args.grid, **_batch_run(args))
    return _report_batch(args, batch)


def _single_only(args, *names):
    """Refuse options that batches do not take."""
    given = [f"--{n}" for n in names if getattr(args, n, None) is not None]
    if given:
        raise ValueError(f"{', '.join(given)} make(s) one set: not with --count or a batch")


def _run_relax_batch(args):
    from diskpack_cl.batch import relax_many

    _single_only(args, "box", "columns")
    batch = relax_many(args.inputs, [args.output], eps=args.eps, max_iter=_max_iter(args),
                       backend=args.backend, grid=args.grid, **_batch_run(args))
    return _report_batch(args, batch)


# ----------------------------------------------------------------------- main

_SUBCOMMANDS = (_add_devices, _add_poisson, _add_relax, _add_stipple, _add_export,
                _add_analyze)


def build_parser():
    """The argument parser, with the subcommands of :data:`_SUBCOMMANDS`."""
    parser = _Parser(
        prog=PROG, description="Poisson disk sampling and image stippling by disk packing.")
    try:
        from importlib.metadata import version

        parser.add_argument("--version", action="version", version=f"%(prog)s {version('diskpack_cl')}")
    except Exception:  # pragma: no cover - not installed
        pass
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in _SUBCOMMANDS:
        add(subparsers)
    return parser


def _terminate_handlers():
    """Make SIGTERM and SIGHUP raise :class:`_Terminated`, as Ctrl-C raises
    KeyboardInterrupt, so that a killed run cleans up like an interrupted
    one; return the handlers to restore (none off the main thread)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}
    handlers = {}
    for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None and signal.getsignal(sig) is signal.SIG_DFL:
            handlers[sig] = signal.signal(sig, _raise_terminated)
    return handlers


def _stdout_closed():
    """After a BrokenPipeError (``diskpack ... --json | head``): end quietly.

    Point the stdout descriptor at /dev/null so that the interpreter's final
    flush does not raise again; return 141, the status of a SIGPIPE death.
    """
    with open(os.devnull, "wb") as null:
        try:
            os.dup2(null.fileno(), sys.stdout.fileno())
        except (OSError, ValueError):  # stdout is no real file (tests)
            pass
    return 128 + 13


def _os_error_text(exc):
    """``path: reason`` for an OSError, without the raw ``[Errno N]`` prefix."""
    reason = exc.strerror or str(exc)
    return f"{exc.filename}: {reason}" if exc.filename else reason


def main(argv=None):
    """Run the CLI; return the exit status.

    0 ok, 1 error, 2 usage error, 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP (an
    interrupted run writes none of its outputs and leaves earlier files as
    they were), 141 when stdout was closed.
    """
    import signal

    from diskpack_cl import NoOpenCLError

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 1
    handlers = _terminate_handlers()
    try:
        device = getattr(args, "device", None)
        if device and "," not in device:  # an explicit device must exist, on every command
            from diskpack_cl import get_context

            get_context(device)
        return int(args.run(args) or 0)
    except _UsageError as exc:
        print(f"{PROG} {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        how = (signal.Signals(exc.args[0]).name if isinstance(exc, _Terminated)
               else "interrupted")
        print(f"{PROG}: error: {how}, nothing written", file=sys.stderr)
        return 128 + exc.args[0] if isinstance(exc, _Terminated) else 130
    except BrokenPipeError:
        return _stdout_closed()
    except (ValueError, NoOpenCLError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # a write failed: read-only, full, gone
        print(f"{PROG}: error: {_os_error_text(exc)}; nothing written", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"{PROG}: error: out of memory, nothing written", file=sys.stderr)
        return 1
    except Exception as exc:
        if type(exc).__module__.split(".")[0] != "pyopencl":
            raise
        print(f"{PROG}: error: OpenCL failed ({type(exc).__name__}: {exc}); try another "
              f"--device (see 'diskpack devices'); nothing written", file=sys.stderr)
        return 1
    finally:
        for sig, old in handlers.items():
            signal.signal(sig, old)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
