"""``diskpack stipple``: stipple images."""

from __future__ import annotations

import argparse
import sys
import time

from ._batches import batch_mode, batch_options, batch_run, report_batch
from ._common import (PROG, UsageError, terminal_bar, checked_outputs, device_options, image_path,
                      command_run, note_fallbacks, where_ran)
from ._drawing import drawing_options, write_and_report
from diskpack_cl.image import ToneOptions
from diskpack_cl.memory import share_main_arena
from ._help import lead_with, with_examples
from diskpack_cl.options import add_arguments, changed, flag_name, from_namespace

#: The examples of ``diskpack stipple --help``, a plotter's first.
EXAMPLES = (
    "diskpack stipple photo.jpg -n 20000 -o plot.svg -o plot.png \\\n"
    "      --page a4 --plotter hp7475a --pen-mm 0.5",
    "diskpack stipple sample -n 20000 -o out.svg -o out.png",
    "diskpack stipple photo.jpg -n 20000 --colors cmyk -o colour.svg --page a3",
    "diskpack stipple photo.png -n 20000 -o base.npz --method lloyd --json",
    "diskpack stipple photos/ --density 80000 -o out/{stem}.svg -o out/{stem}.png",
)

#: How the stippling works, for the end of its --help.
ABOUT = ("Stipple an image with N dots by unequal disk packing on power diagrams. "
         "From an error-diffusion start, the default schedule moves every dot "
         "towards the centre of the largest circle inside its power cell (pack) "
         "and part-way to the cell's centroid (mix), with radii from the image's "
         "density; its phases follow the dot spacing (see --schedule; --schedule "
         "paper runs the paper's Algorithm 2 loop). The disks are certified inside "
         "the image and pairwise disjoint (exact float64); the outputs draw every "
         "dot at one size whose ink equals the image's darkness (--dots), as the "
         "plotter's pen draws it with --pen-mm. Every output path is checked before "
         "the computation; the outputs are written together after it, so a failed "
         "or interrupted run writes nothing and leaves earlier files as they were.")


def _phase_text(phase):
    kind, it = phase[0], phase[1]
    return f"{kind} {it}" + (f" (blend {phase[2]})" if len(phase) > 2 else "")


def _default_schedule_text():
    """The default schedule's bands, for --help."""
    from diskpack_cl.schedule import SPACING_BANDS  # not loaded at start-up

    parts, lo = [], 0.0
    for bound, phases, options in SPACING_BANDS:
        where = f"s < {bound:g}" if lo == 0 else (f"s >= {lo:g}" if bound == float("inf")
                                                  else f"{lo:g} <= s < {bound:g}")
        extra = ", ".join(f"{k} {v}" for k, v in options.items())
        parts.append(f"{where}: " + ", ".join(_phase_text(ph) for ph in phases) + f" ({extra})")
        lo = bound
    return "default = by the dot spacing s = sqrt(W*H/n) px: " + "; ".join(parts)


def _schedules_text():
    """Each schedule's phases, for --help."""
    from diskpack_cl.schedule import SCHEDULES  # not loaded at start-up

    return (_default_schedule_text() + "; "
            + "; ".join(f"{name} = " + ", ".join(_phase_text(ph) for ph in phases)
                        for name, phases in sorted(SCHEDULES.items())))


def add_stipple(subparsers):
    from diskpack_cl.pens import ColorOptions  # not loaded at start-up
    from diskpack_cl.schedule import STIPPLING_GROUP, COUNT, StippleCount, StippleOptions  # not loaded at start-up
    from diskpack_cl.jobs.tiles import TileOptions  # not loaded at start-up

    p = subparsers.add_parser(
        "stipple", help="stipple an image with N dots (paper Algorithm 2)",
        usage="%(prog)s IMAGE -n N -o OUT [options]",
        description=with_examples(
            "Stipple IMAGE with N dots by disk packing: an SVG for a pen plotter, a PNG "
            "preview, the points (.npz, .csv). How it works: at the end.", EXAMPLES),
        epilog=ABOUT + "\n\nschedules (--schedule): " + _schedules_text(),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("images", nargs="+", metavar="IMAGE",
                   help="image files or folders, or 'sample' (the bundled photograph)")
    add_arguments(p, StippleCount, groups={COUNT: p.add_mutually_exclusive_group(required=True)})
    p.add_argument("-o", "--output", action="append", required=True, metavar="OUT",
                   help="output file; repeat for several: .svg (pen plotters, Inkscape), .png "
                        "(anti-aliased preview), .npz (points, radii, k, width, height), .csv "
                        "(x,y,r in pixels)")
    groups = add_arguments(p, StippleOptions)
    g = p.add_argument_group("device and checks")
    g.add_argument("--verify", action="store_true",
                   help="check every MIC step against scipy (exact_mic); slow, for testing "
                        "(single inputs)")
    g.add_argument("--profile", action="store_true",
                   help="time the OpenCL kernels with events (--json timings.kernel and "
                        "timings.kernel_<name>: device seconds, all and per kernel; single inputs)")
    g.add_argument("--allow-large", action="store_true",
                   help="lift Pillow's decompression-bomb limit (about 89 Mpixel) for trusted "
                        "large images")
    add_arguments(p, ToneOptions, groups=groups)
    device_options(g)
    drawing_options(p, "the result summary (n, k, radii, certificate, timings, params), ")
    add_arguments(p, ColorOptions)
    add_arguments(p, TileOptions)
    batch_options(p).add_argument("--recursive", "-r", action="store_true",
                                   help="a folder given as IMAGE contributes the images of "
                                        "its subfolders too")
    lead_with(p, last=("device and checks", STIPPLING_GROUP))
    p.set_defaults(run=_run_stipple)


def _stipple_objects(args):
    """The options of the arguments: ``(StippleOptions, ToneOptions, WriteOptions, ColorOptions)``.

    Raises :class:`~diskpack_cl.options.OptionConflict` (status 2) for options
    that contradict each other.
    """
    from diskpack_cl.pens import ColorOptions  # not loaded at start-up
    from diskpack_cl.drawing.writers import WriteOptions  # not loaded at start-up
    from diskpack_cl.schedule import StippleOptions  # not loaded at start-up

    return (from_namespace(StippleOptions, args), from_namespace(ToneOptions, args),
            from_namespace(WriteOptions, args),
            from_namespace(ColorOptions, args))


def _count(args):
    """The dot count's keyword arguments (:class:`~diskpack_cl.schedule.StippleCount`)."""
    from diskpack_cl.schedule import StippleCount  # not loaded at start-up

    return from_namespace(StippleCount, args).kwargs()


def _refuse_mixed(args, options, tone, write, separation):
    """Usage errors of options that do not go together: one pen's with several, a palette
    for white paper on black (--invert), a pen order without pens, -n tone without a dot size."""
    from diskpack_cl.pens import check_paper  # not loaded at start-up

    if separation is not None:
        mono = [flag_name("paper_tone")] if options.paper_tone else []
        mono += [flag_name(k) for k in changed(tone)] + (["-n tone"] if args.n == "tone" else [])
        if mono:
            raise UsageError(f"{', '.join(mono)}: for one pen, not with --colors/--pens")
        try:
            check_paper(separation["colors"], options.invert)
        except ValueError as exc:
            raise UsageError(f"--invert: {exc}") from None
    elif write.pen_order is not None:
        raise UsageError("--pen-order orders the pens of --colors or --pens")
    if args.n == "tone" and write.dot_mm is None and write.pen_mm is None:
        raise UsageError("-n tone needs the dot size: give --dot-mm or --pen-mm")


def _run_stipple(args):
    share_main_arena()   # before the OpenCL driver's threads: the steps' arrays reuse their pages
    options, tone, write, color = _stipple_objects(args)
    separation = color.separation()
    _refuse_mixed(args, options, tone, write, separation)
    if isinstance(args.n, int):   # with --density each image has its own n, checked there
        color.check_pen_dots(args.n)
        _warn_long_plot(args)
    if args.tiles is not None:
        return _run_stipple_tiled(args, options, tone, write, separation)
    if batch_mode(args, args.images, args.output):
        if args.n == "tone":
            raise UsageError("-n tone is for one image; give -n N or --density for a batch")
        return _run_stipple_batch(args, options, tone, write, separation)
    return _run_stipple_one(args, options, tone, write, separation)


def _warn_long_plot(args):
    """Before the work: say so when the SVG of -n dots takes more than a working day to plot."""
    from diskpack_cl.drawing.page import long_plot  # not loaded at start-up

    slow = long_plot(args.n, pen_lift_s=args.pen_lift_s)
    if slow and not args.quiet and any(str(o).lower().endswith(".svg") for o in args.output):
        print(f"{PROG}: warning: {slow}", file=sys.stderr)


def _run_stipple_one(args, options, tone, write, separation):
    """One input: a one-item plan, run here (:func:`diskpack_cl.jobs.items.stipple_item`)
    without a manifest; every refusal comes before the computation."""
    from diskpack_cl.jobs.items import plan_stipple, stipple_item  # not loaded at start-up
    from diskpack_cl.progress import stage, stage_text  # not loaded at start-up

    t0 = time.perf_counter()
    with command_run(args) as run:   # one bar per stage, and their seconds in the summary
        with stage("load"):
            (item,) = plan_stipple([image_path(args.images[0])], [str(o) for o in args.output],
                                   options, **_count(args), allow_large=args.allow_large,
                                   write=write, tone=tone, color=separation, make_folders=False)
        res, summary = stipple_item(item, device=args.device, verify=args.verify,
                                    profile=args.profile, note=None if args.quiet else _note,
                                    callback=_step_note(run.hook))
        tail = write_and_report(args, write, res, list(item.outputs), summary, t0)
    if not args.quiet:
        times = stage_text(summary["stage_seconds"], summary["iterations"], summary["seconds"])
        print(f"{PROG}: {_result_text(res, summary)}; {times}{_where(res)}{tail}", file=sys.stderr)
    note_fallbacks(args, res.stages)
    return 0


def _step_note(bars):
    """``callback(entry, total)`` writing each step's kind, k and empty cells beside the
    iterations' bar (:meth:`~diskpack_cl.progress.StageBars.note`); None without bars."""
    if bars is None:
        return None

    def callback(entry, total):
        text = f"{entry.get('kind', '?')} k={entry.get('k', float('nan')):.4g}"
        bars.note(text + (f" empty={entry['empty']}" if entry.get("empty") else ""))

    return callback


def _run_stipple_tiled(args, options, tone, write, separation):
    """One large input in tiles (:func:`diskpack_cl.jobs.tiles.stipple_tiled`), on --jobs workers
    or a Dask cluster; the outputs as for one input."""
    from diskpack_cl.drawing.writers import check_preview_memory  # not loaded at start-up
    from diskpack_cl.image import image_size
    from diskpack_cl.jobs.tiles import TileOptions, stipple_tiled

    if separation is not None or len(args.images) > 1 or not isinstance(args.n, int) \
            or any(getattr(args, k) for k in ("verify", "profile", "manifest", "collect")):
        raise UsageError("--tiles stipples one image with one pen and -n N (no --colors/--pens, "
                          "-n tone, --density, --verify, --profile, --manifest or --collect)")
    t0 = time.perf_counter()
    image = image_path(args.images[0])
    outputs = checked_outputs(args, [image])
    size = image_size(image, allow_large=args.allow_large)
    if size is not None:   # the whole picture's PNG is made after the tiles: refused before
        check_preview_memory(write, *size, outputs)
    tiling = from_namespace(TileOptions, args)
    if tiling.work_dir is None:
        tiling = tiling.replace(work_dir=outputs[0] + ".tiles")
    run = batch_run(args)
    bar = terminal_bar(args, "tiles", "part", None)
    done = {}

    def write_outputs(res):   # before the work folder goes: a signal here leaves it to resume
        if bar is not None:
            bar.close()
        done["summary"] = summary = dict(
            res.summary(), image=image, tone_n=None, parts=res.history,
            iterations=max(h["steps"] for h in res.history),
            peak_rss_mib=max(h["peak_rss_mib"] or 0 for h in res.history))
        done["tail"] = write_and_report(args, write, res, outputs, summary, t0)

    try:
        res = stipple_tiled(image, args.n, options, tiling, tone=tone, jobs=run["jobs"],
                            client=run["client"], devices=run["devices"],
                            allow_large=args.allow_large, progress=_tile_progress(bar),
                            finish=write_outputs, note=_note)
    finally:
        if bar is not None:
            bar.close()
    summary, tail = done["summary"], done["tail"]
    if not args.quiet:
        print(f"{PROG}: {_result_text(res, summary)}, {res.params['tiles']} tiles "
              f"({len(res.history)} parts, largest part {summary['peak_rss_mib'] / 1024:.2f} GiB) "
              f"in {summary['seconds']:.3g} s{_where(res)}{tail}", file=sys.stderr)
    note_fallbacks(args, res.stages)
    return 0


def _tile_progress(bar):
    """``progress(phase, done, total)`` on a tqdm bar (None: no bar)."""
    if bar is None:
        return None

    def progress(phase, done, total):
        bar.set_postfix_str(f"{phase} {done}/{total}", refresh=False)
        bar.update(1)
    return progress


def _note(text):
    print(f"{PROG}: note: {text}", file=sys.stderr)


def _where(res):
    """`` on OpenCL (device)`` or `` on the host (exact engine)`` for the summary line
    (nothing for a tiled run whose parts left no record)."""
    where = where_ran(res.stages)
    return f" {where}" if where else ""


def _result_text(res, summary):
    """What the summary line says of the result: dots, pens, size, certificate."""
    cert = res.certificate
    if "pens" in summary:
        pens = ", ".join(f"{p['name']} {p['n']}" for p in summary["pens"])
        return (f"{res.n} dots ({pens}) on {res.width}x{res.height} px, certified valid over "
                f"all pens (min gap {cert.min_gap:.3g} px)")
    return (f"{res.n} dots on {res.width}x{res.height} px, k = {res.k:.4g}, radii "
            f"{summary['min_radius']:.3g}..{summary['max_radius']:.3g} px, certified "
            f"{'valid' if cert.valid else 'INVALID'} (min gap {cert.min_gap:.3g} px)")


def _run_stipple_batch(args, options, tone, write, color=None):
    from diskpack_cl.jobs.batch import stipple_many  # not loaded at start-up

    batch = stipple_many([image_path(x) for x in args.images], [str(o) for o in args.output],
                         options, **_count(args), recursive=args.recursive,
                         allow_large=args.allow_large, write=write, tone=tone, color=color,
                         **batch_run(args))
    return report_batch(args, batch)
