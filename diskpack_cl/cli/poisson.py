"""``diskpack poisson``: make Poisson disk sets on the unit torus, in a box, 2D or 3D."""

from __future__ import annotations

import argparse
import json
import sys

from diskpack_cl.io import (check_not_inputs, check_points_path, json_default, read_points,
                            write_points)
from diskpack_cl.options import add_arguments, changed, from_namespace
from diskpack_cl.poisson import SIZE, STARTS, PoissonOptions, PoissonSetOptions, poisson_job
from diskpack_cl.relax import TRIAL_RELAX, max_points_for_radius

from ._batches import batch_mode, batch_options, batch_run, report_batch
from ._common import (PROG, terminal_bar, image_path, output_options, positive_int, note_fallbacks,
                      where_ran)
from ._help import with_examples
from .relax import relax_progress, relax_options_of, relax_and_write, add_relax_options, unreached_status


def add_poisson(subparsers):
    p = subparsers.add_parser(
        "poisson", help="make a Poisson disk set on the unit torus, in a box, 2D or 3D",
        usage="%(prog)s -n N -o OUT [options]",
        description=with_examples(
            "Make a start set (dart throwing, uniform random or a file) on the unit torus (or "
            "in a --box, or in 3D with --dim 3) and relax it by disk packing until rho >= EPS "
            "(paper Algorithm 1). Exit status 3 when rho stops short of EPS (the set is "
            "written; --allow-unreached: 0).",
            ["diskpack poisson -n 4096 -o points.npz",
             "diskpack poisson -n 20000 --eps 0.9 -o points.csv --json",
             "diskpack poisson --min-distance 0.02 --box 2x1 -o box.npz",
             "diskpack poisson -n 3000 --mask shape.png -o shape.npz",
             "diskpack poisson -n 1000 --count 16 --seed 7 -o sets/{i:04d}.npz"]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p, PoissonSetOptions, groups={SIZE: p.add_mutually_exclusive_group()})
    add_arguments(p, PoissonOptions)
    output_options(p)
    add_relax_options(p)
    g = batch_options(p)
    g.add_argument("--count", type=positive_int, default=None, metavar="K",
                   help="make K independent sets, seeds derived from --seed "
                        "(numpy SeedSequence.spawn; each set's seed is in the manifest and "
                        "recreates it alone), e.g. -o sets/{i:04d}.npz")
    p.set_defaults(run=_run_poisson)


def _run_poisson_radius(args):
    """``poisson --radius R``: the most points that relaxation brings to radius R."""
    if args.init not in ("dart", "random"):
        raise ValueError("--radius chooses n itself: use --init dart or random, not a file")
    bar = terminal_bar(args, "radius search", "trial")
    callback = None
    if bar is not None:
        def show(trial):
            bar.set_postfix_str(f"n={trial['n']} {'reached' if trial['reached'] else 'missed'}",
                                refresh=False)
            bar.update(1)

        callback = show
    try:
        # each trial: the search's relaxation, with the relaxation's flags given
        res = max_points_for_radius(args.radius, TRIAL_RELAX.replace(**changed(relax_options_of(args))),
                                    start=args.init, seed=0 if args.seed is None else args.seed,
                                    device=args.device, callback=callback)
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
    if batch_mode(args, [], [args.output]):
        return _run_poisson_batch(args)
    check_points_path(args.output, for_writing=True)
    start_file = args.init not in STARTS
    check_not_inputs([args.output], [args.mask, args.density, args.init if start_file else None])
    if args.radius is not None:
        return _run_poisson_radius(args)
    if start_file:
        return _run_poisson_file(args)
    return _run_poisson_set(args)


def _run_poisson_file(args):
    """``--init FILE``: the file's points relaxed, as ``diskpack relax`` relaxes them."""
    if args.min_distance is not None or args.mask or args.density or args.dim == 3:
        raise ValueError("--min-distance, --mask, --density and --dim 3 make their own start "
                         "set: leave --init out")
    if args.n is not None:
        count = len(read_points(args.init))
        if count != args.n:
            raise ValueError(f"-n {args.n} does not match the {count} points of {args.init}; "
                             f"leave -n out")
    from diskpack_cl.jobs.items import plan_relax   # the jobs load the stippling stack: not at start-up

    (item,) = plan_relax([args.init], [args.output], relax_options_of(args), box=args.box,
                         make_folders=False)
    return relax_and_write(item, args, extra_summary={"init": args.init, "seed": args.seed})


def _field_image(args, path):
    """``(array, box)`` of a --mask or --density image: light 1, dark 0; the box by default
    has the image's aspect, longer side 1."""
    from diskpack_cl.image import load_gray  # not loaded at start-up: --mask and --density only

    gray = load_gray(image_path(path))
    if args.box is not None:
        return gray, args.box
    h, w = gray.shape
    return gray, (w / max(w, h), h / max(w, h))


def _where(args):
    """The keyword arguments of :func:`~diskpack_cl.poisson.poisson_job` that say where the
    points go: a box, a minimum distance, a mask or a density."""
    where = {"box": args.box, "min_distance": args.min_distance}
    if args.mask:
        where["mask"], where["box"] = _field_image(args, args.mask)
    if args.density:
        density, where["box"] = _field_image(args, args.density)
        where["density"] = 1.0 - density
    return where


def _run_poisson_set(args):
    """One set (:func:`~diskpack_cl.poisson.poisson_job`, the route of a batch item and of
    :func:`~diskpack_cl.poisson.poisson_disk`)."""
    options = from_namespace(PoissonOptions, args)
    n = 1024 if args.n is None and args.min_distance is None else args.n
    callback, close = relax_progress(args, "relax")
    try:
        res, summary = poisson_job(n, [args.output], options, seed=args.seed, device=args.device,
                                   callback=callback, verify=args.verify, profile=args.profile,
                                   **_where(args))
    finally:
        close()
    summary["output"] = str(args.output)
    rho = ("variable spacing" if summary["rho_final"] is None
           else f"rho {res.rho_start:.4f} -> {res.rho:.4f}")
    where = where_ran(res.stages)
    if args.mask:   # a set of the box cut by the mask: n is the count it aims at
        summary["n_asked"] = n
    inside = f" inside the mask (-n {n}: about that many)" if args.mask else ""
    _report(args, f"{summary['n']} points{inside}, min distance {res.min_distance:.6g}, {rho} in "
                  f"{res.iterations} iterations ({res.seconds:.3g} s{' ' + where if where else ''}, "
                  f"stop: {res.stop_reason}); wrote {args.output}", summary)
    note_fallbacks(args, res.stages)
    if not res.reached:
        goal = (f"--min-distance {args.min_distance:g}" if args.min_distance is not None
                else f"--eps {args.eps:g}")
        return unreached_status(args, f"the set did not reach {goal} (stop: {res.stop_reason})")
    return 0


def _single_only(args, *names):
    """Refuse options that batches do not take."""
    given = [f"--{n}" for n in names if getattr(args, n, None) is not None]
    if given:
        raise ValueError(f"{', '.join(given)} make(s) one set: not with --count or a batch")


def _run_poisson_batch(args):
    if args.radius is not None or args.min_distance is not None:
        raise ValueError("--radius and --min-distance make one set; they do not combine with "
                         "--count or a batch")
    _single_only(args, "box", "mask", "density")
    from diskpack_cl.jobs.batch import poisson_many   # loads the stippling stack: not at start-up

    batch = poisson_many(args.count or 1, 1024 if args.n is None else args.n, [args.output],
                         from_namespace(PoissonOptions, args), seed=args.seed, **batch_run(args))
    return report_batch(args, batch)
