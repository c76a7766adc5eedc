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
Raise ``ValueError``/``FileNotFoundError`` for user errors: :func:`main` prints
``diskpack: error: ...`` and returns 1 (130 on Ctrl-C). Write outputs with the
atomic writers of :mod:`diskpack_cl.io`, after all the computation, so that a
failed run leaves no output file.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

__all__ = ["main"]

PROG = "diskpack"


# ----------------------------------------------------------------- arguments

def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _point_count(text):
    value = _positive_int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"need at least 2 points, got {value}")
    return value


def _nonnegative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, got {value}")
    return value


def _unit_open(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {text}")
    return value


def _device_options(p):
    p.add_argument("--device", metavar="D", default=None,
                   help="OpenCL device: 'P' or 'P:D' indices (as in PYOPENCL_CTX) or a name "
                        "substring ('pocl', 'nvidia', 'gpu', 'cpu'); default: DISKPACK_DEVICE, "
                        "then PYOPENCL_CTX, then a GPU, else the first CPU device")


def _output_options(p):
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="output point file (.npz, .npy, .csv, .txt, .xy); written atomically")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bar and no summary on stderr")
    p.add_argument("--json", action="store_true",
                   help="print one JSON summary line on stdout at the end")


def _relax_options(p):
    p.add_argument("--eps", type=_unit_open, default=0.8,
                   help="stop when the normalized radius rho reaches EPS (default 0.8)")
    p.add_argument("--max-iter", type=_nonnegative_int, default=1000, metavar="N",
                   help="iteration cap (default 1000)")
    p.add_argument("--backend", choices=("auto", "opencl", "exact"), default="auto",
                   help="opencl: OpenCL raster estimate + exact refinement; exact: scipy only; "
                        "auto (default): opencl when a device exists, else exact")
    p.add_argument("--grid", type=_positive_int, default=None, metavar="G",
                   help="raster size G x G for the opencl backend (default: automatic)")
    _device_options(p)


# --------------------------------------------------------------- shared runs

def _progress(args, label):
    """Return (callback, close) feeding a tqdm bar on a terminal, or no-ops."""
    if args.quiet or not sys.stderr.isatty():
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=args.max_iter or None, desc=label, unit="it", file=sys.stderr,
               dynamic_ncols=True, leave=False)

    def callback(iteration, rho):
        bar.set_postfix_str(f"rho={rho:.4f}", refresh=False)
        bar.update(iteration - bar.n)

    return callback, bar.close


def _relax_and_write(points, args, *, extra_summary=None):
    """Relax `points`, write ``args.output``, report; return the exit status."""
    from diskpack_cl.io import write_points
    from diskpack_cl.relax import relax_poisson

    callback, close = _progress(args, "relax")
    try:
        res = relax_poisson(points, args.eps, max_iter=args.max_iter, backend=args.backend,
                            grid=args.grid, device=args.device, callback=callback)
    finally:
        close()
    extra = {}
    if args.output.lower().endswith(".npz"):
        extra = {"rho": res.rho, "eps": args.eps}
    write_points(args.output, res.points, **extra)
    stages = {k: float(res.timings.get(k, 0.0))
              for k in ("raster_labels", "mic_estimate", "exact_refine")}
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
    }
    if extra_summary:
        summary.update(extra_summary)
    if not args.quiet:
        print(f"{PROG}: {summary['n']} points, rho {summary['rho_start']:.4f} -> "
              f"{summary['rho_final']:.4f} in {summary['iterations']} iterations "
              f"({summary['seconds']:.3g} s, {res.backend} on {res.device}, "
              f"stop: {res.stop_reason}); wrote {args.output}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary), flush=True)
    return 0


# ---------------------------------------------------------------- subcommands

def _add_devices(subparsers):
    p = subparsers.add_parser("devices", help="list OpenCL platforms and devices",
                              description="List OpenCL platforms and devices and say which "
                                          "one diskpack would use.")
    _device_options(p)
    p.set_defaults(run=_run_devices)


def _run_devices(args):
    from diskpack_cl._device import describe, get_context, list_devices

    rows = list_devices()
    for index, platform, device, kind in rows:
        print(f"{index:>5}  {platform}  |  {device}  [{kind}]")
    if not rows:
        print("(no OpenCL devices)")
    print(f"using: {describe(get_context(args.device))}")
    return 0


def _add_poisson(subparsers):
    p = subparsers.add_parser(
        "poisson", help="make a Poisson disk set on the unit torus",
        description="Make a start set (dart throwing, uniform random or a file) on the unit "
                    "torus and relax it by disk packing until rho >= EPS (paper Algorithm 1).")
    p.add_argument("-n", type=_point_count, default=None, metavar="N",
                   help="number of points (default 1024; with --init FILE: the file's count)")
    p.add_argument("--init", default="dart", metavar="dart|random|FILE",
                   help="start set: dart throwing (default), uniform random, or a point file")
    p.add_argument("--dart-radius", type=_unit_open, default=0.74, metavar="R",
                   help="relative radius of the dart-throwing start (default 0.74)")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: fresh entropy)")
    _output_options(p)
    _relax_options(p)
    p.set_defaults(run=_run_poisson)


def _run_poisson(args):
    import warnings

    from diskpack_cl.io import check_points_path, read_points
    from diskpack_cl.sampling import DartThrowingWarning, dart_throwing, random_points

    check_points_path(args.output, for_writing=True)
    t0 = time.perf_counter()
    info = {"init": args.init}
    if args.init == "dart":
        n = 1024 if args.n is None else args.n
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", DartThrowingWarning)
            points, dart = dart_throwing(n, rel_radius=args.dart_radius, seed=args.seed,
                                         full_output=True)
        for w in caught:
            if not args.quiet:
                print(f"{PROG}: warning: {w.message}", file=sys.stderr)
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


def _add_relax(subparsers):
    p = subparsers.add_parser(
        "relax", help="relax a point file on the unit torus",
        description="Relax a point set on the unit torus by disk packing until rho >= EPS. "
                    "Points outside [0,1)^2 are wrapped onto the torus.")
    p.add_argument("input", metavar="IN", help="point file (.npz, .npy, .csv, .txt, .xy)")
    _output_options(p)
    _relax_options(p)
    p.set_defaults(run=_run_relax)


def _run_relax(args):
    from diskpack_cl.io import check_points_path, read_points

    check_points_path(args.output, for_writing=True)
    points = read_points(args.input, min_points=2)
    return _relax_and_write(points, args, extra_summary={"input": str(args.input)})


# ----------------------------------------------------------------------- main

def build_parser():
    """The argument parser, with every ``_add_*`` subcommand of this module."""
    parser = argparse.ArgumentParser(
        prog=PROG, description="Poisson disk sampling and image stippling by disk packing.")
    try:
        from importlib.metadata import version

        parser.add_argument("--version", action="version", version=f"%(prog)s {version('diskpack_cl')}")
    except Exception:  # pragma: no cover - not installed
        pass
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, func in list(globals().items()):
        if name.startswith("_add_") and callable(func):
            func(subparsers)
    return parser


def main(argv=None):
    """Run the CLI; return the exit status (0 ok, 1 error, 2 usage, 130 interrupted)."""
    from diskpack_cl._device import NoOpenCLError

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 1
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"{PROG}: error: interrupted, nothing written", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, IsADirectoryError, PermissionError,
            NoOpenCLError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
