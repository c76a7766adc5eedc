"""``diskpack poisson``: make Poisson disk sets on the unit torus."""

from __future__ import annotations

import json
import sys
import time

from diskpack_cl.batch import json_default

from ._batches import _batch_mode, _batch_run, _report_batch
from ._common import PROG, _bar, _batch_options, _checked, _nonnegative_int, _output_options, _point_count, _positive_int, _unit_open
from .relax import _relax, _relax_and_write, _relax_options


def _add_poisson(subparsers):
    p = subparsers.add_parser(
        "poisson", help="make a Poisson disk set on the unit torus",
        description="Make a start set (dart throwing, uniform random or a file) on the unit "
                    "torus and relax it by disk packing until rho >= EPS (paper Algorithm 1).")
    count = p.add_mutually_exclusive_group()
    count.add_argument("-n", type=_point_count, default=None, metavar="N",
                       help="number of points (default 1024; with --init FILE: the file's count)")
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
    if not args.quiet:
        print(f"{PROG}: {res.n} points reach radius {res.radius:g} (achieved "
              f"{res.achieved_radius:.6g}, rho {res.rho:.4f}) after {len(res.trials)} trials "
              f"({res.seconds:.3g} s); wrote {args.output}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary, default=json_default), flush=True)
    return 0


def _run_poisson(args):
    import warnings

    from diskpack_cl.io import check_points_path, read_points
    from diskpack_cl.sampling import DartThrowingWarning, dart_throwing, random_points

    if _batch_mode(args, [], [args.output]):
        return _run_poisson_batch(args)
    check_points_path(args.output, for_writing=True)
    if args.radius is not None:
        return _run_poisson_radius(args)
    t0 = time.perf_counter()
    if args.seed is None:
        import numpy as np

        # a fresh seed, reported in the summary so the run can be repeated
        args.seed = int(np.random.SeedSequence().entropy % 2**31)
    info = {"init": args.init, "seed": args.seed}
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


def _run_poisson_batch(args):
    from diskpack_cl.batch import poisson_many

    if args.radius is not None:
        raise ValueError("--radius makes one set; it does not combine with --count or a batch")
    batch = poisson_many(args.count or 1, 1024 if args.n is None else args.n, [args.output],
                         _relax(args), seed=args.seed, init=args.init,
                         dart_radius=args.dart_radius, **_batch_run(args))
    return _report_batch(args, batch)
