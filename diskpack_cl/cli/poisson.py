"""``diskpack poisson``: make Poisson disk sets on the unit torus, in a box, 2D or 3D."""

from __future__ import annotations

import json
import sys
import time

from diskpack_cl.jobs import json_default

from ._batches import _batch_mode, _batch_options, _batch_run, _report_batch
from ._common import (PROG, _bar, _checked, _image_path, _nonnegative_int,
                      _output_options, _point_count, _positive_float, _positive_int, _unit_open)
from .relax import _progress, _relax, _relax_and_write, _relax_options, _unreached


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
    from diskpack_cl.io import check_not_inputs, check_points_path

    if _batch_mode(args, [], [args.output]):
        return _run_poisson_batch(args)
    check_points_path(args.output, for_writing=True)
    check_not_inputs([args.output], [args.mask, args.density, args.init if args.init not in
                                     ("dart", "random") else None])
    if args.radius is not None:
        return _run_poisson_radius(args)
    if args.min_distance is not None or args.mask or args.density or args.dim == 3 or (
            args.box is not None and args.init in ("dart", "random")):
        return _run_poisson_set(args)
    return _run_poisson_one(args)


def _run_poisson_one(args):
    """A start set relaxed on the torus (or a file's in a --box): a one-item plan without a
    manifest, run here (:func:`~diskpack_cl.jobs.poisson_start`, then ``relax_item``)."""
    from diskpack_cl.jobs import plan_poisson, poisson_start

    drawn = args.init in ("dart", "random")
    (item,) = plan_poisson(1, 1024 if args.n is None and drawn else args.n, [args.output],
                           _relax(args), seed=args.seed, init=args.init,
                           dart_radius=args.dart_radius, derive=False,
                           box=None if drawn else args.box, make_folders=False)
    t0 = time.perf_counter()
    # printed as they come: a saturated radius is said at once
    points, start = poisson_start(item, warn=None if args.quiet else lambda text: print(
        f"{PROG}: warning: {text}", file=sys.stderr, flush=True))
    # the seed (a fresh one without --seed) in the summary, so that the run can be repeated
    info = {"init": args.init, "seed": item.seed, **start,
            "init_seconds": time.perf_counter() - t0}
    return _relax_and_write(item, args, points, extra_summary=info)


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
    from diskpack_cl.io import box_record, write_points
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
    relax = _relax(args).kwargs()
    callback, close = _progress(args, "relax")
    try:
        res = poisson_disk(n, min_distance=args.min_distance, box=box, mask=mask, density=density,
                           seed=args.seed, eps=relax["eps"], rho_max=args.rho_max,
                           backend=relax["backend"], device=args.device,
                           max_iter=relax["max_iter"], callback=callback, dim=args.dim)
    finally:
        close()
    write_points(args.output, res.points, **box_record(args.output, res.domain))
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


def _single_only(args, *names):
    """Refuse options that batches do not take."""
    given = [f"--{n}" for n in names if getattr(args, n, None) is not None]
    if given:
        raise ValueError(f"{', '.join(given)} make(s) one set: not with --count or a batch")


def _run_poisson_batch(args):
    from diskpack_cl.batch import poisson_many

    if args.radius is not None or args.min_distance is not None:
        raise ValueError("--radius and --min-distance make one set; they do not combine with "
                         "--count or a batch")
    _single_only(args, "box", "mask", "density")
    batch = poisson_many(args.count or 1, 1024 if args.n is None else args.n, [args.output],
                         _relax(args), seed=args.seed, init=args.init,
                         dart_radius=args.dart_radius, **_batch_run(args))
    return _report_batch(args, batch)
