"""How the dots are drawn, for ``stipple`` and ``export``: the output options, writing and the report."""

from __future__ import annotations

import json
import sys
import time

from diskpack_cl.io import json_default

from ._common import PROG, command_run
from diskpack_cl.options import add_arguments


def drawing_options(p, summary):
    """The options of how the dots are drawn (SVG, PNG), of ``stipple`` and ``export``."""
    from diskpack_cl.drawing.writers import WriteOptions  # not loaded at start-up

    o = add_arguments(p, WriteOptions)["output"]
    o.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bar and no summary on stderr")
    o.add_argument("--json", action="store_true",
                   help=f"print one JSON line on stdout at the end: {summary}each output's "
                        f"info, plot (pen-down count, pen-up travel before and after the "
                        f"pen path, plot time) and seconds")
    return o


def _plot_summary(written, write):
    """Plot figures of the first SVG output, and their text for the summary line."""
    svg = next((w for w in written if w["format"] == "svg"), None)
    if svg is None:
        return None, ""
    plot = {k: svg[k] for k in ("pen_downs", "draw_mm", "travel_before_mm", "travel_after_mm",
                                "plot_seconds", "touching_share", "touching_share_uncapped",
                                "no_overlap_ink", "median_spacing_mm", "median_ink_mm")}
    speed = plot["plot_speed_mm_s"] = write.plot_speed_mm_s
    plot["pen_lift_s"] = write.pen_lift_s
    pens = ""
    if "layers" in svg:   # a colour stippling: each pen's plot time too
        plot["layers"] = [{k: layer[k] for k in ("name", "n", "plot_seconds")}
                          for layer in svg["layers"]]
        pens = " (" + ", ".join(f"{layer['name']} {_duration(layer['plot_seconds'])}"
                                for layer in svg["layers"]) + ")"
    return plot, (f"; pen-up travel {plot['travel_before_mm']:.0f} -> "
                  f"{plot['travel_after_mm']:.0f} mm, plot about "
                  f"{_duration(plot['plot_seconds'])}{pens} at {speed:g} mm/s and "
                  f"{write.pen_lift_s:g} s a pen lift; "
                  f"{_touching_text(plot, write.no_overlap)}")


def _duration(seconds):
    hours, minutes = divmod(round(seconds / 60), 60)
    return f"{hours} h {minutes:02d} min"


def _touching_text(plot, no_overlap):
    """What the summary line says of the drawn dots that touch, and of --no-overlap's ink."""
    share, ink = 100 * plot["touching_share"], 100 * plot["no_overlap_ink"]
    if no_overlap:
        return (f"{share:.1f} % of the drawn dots touch (without --no-overlap "
                f"{100 * plot['touching_share_uncapped']:.1f} %), {ink:.0f} % of their ink kept")
    return f"{share:.1f} % of the drawn dots touch (--no-overlap keeps {ink:.0f} % of the ink)"


def _warn_crowded(args, plot):
    """Say so when the SVG's dots are drawn far wider than the spacing of their centres."""
    from diskpack_cl.drawing.page import crowded_dots  # not loaded at start-up

    crowded = plot and crowded_dots(plot["median_ink_mm"], plot["median_spacing_mm"])
    if crowded and not args.quiet:
        print(f"{PROG}: warning: {crowded}", file=sys.stderr)


def write_and_report(args, write, res, outputs, summary, t0):
    """Write the outputs in the command's run (:func:`~._common.command_run`), add their
    figures to ``summary`` (``seconds`` since ``t0``, and ``stage_seconds``: the run's seconds
    per stage), print it with --json; return the tail of the summary line."""
    from diskpack_cl.jobs.items import write_stipple_outputs  # not loaded at start-up

    t_write = time.perf_counter()
    with command_run(args) as run:
        dot_mm, written = write_stipple_outputs(res, None, outputs, write)
    plot, text = _plot_summary(written, write)
    _warn_crowded(args, plot)
    summary.update(dot_mm=dot_mm, outputs=written, plot=plot,
                   write_seconds=time.perf_counter() - t_write,
                   seconds=time.perf_counter() - t0, stage_seconds=run.by_stage())
    if args.json:
        print(json.dumps(summary, default=json_default), flush=True)
    return f"{text}; wrote " + ", ".join(outputs)
