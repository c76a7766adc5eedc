"""What ``--help`` shows first: the everyday options, with one-line helps, and examples.

``diskpack stipple --help`` and ``export --help`` (:func:`lead_with`) and
``vpype diskpack --help`` (:func:`diskpack_cl.vpype_plugin.click_options`,
which reads :data:`LEADING` from :mod:`diskpack_cl.cli`) list the options
of :data:`LEADING` first, in its order and with its one-line helps; the
algorithm's parameters come last. An option's whole help stays in its
dataclass (the options reference of the docs shows it).
"""

from __future__ import annotations

__all__ = ["LEADING", "EVERYDAY", "PLOTTER", "one_line_help", "lead_with", "with_examples"]

#: Title of the first group of options (what most runs set).
EVERYDAY = "everyday options"
#: Title of the second group: where the picture goes on paper and how the pen draws it.
PLOTTER = "page, pen and plotter"

#: ``(title, ((dest, one-line help or None to keep the option's own), ...))``, first
#: shown first; ``%(default)s`` is the option's default.
LEADING = (
    (EVERYDAY, (
        ("help", None),
        ("n", "number of dots, or 'tone': as many as give the ink"),
        ("density", None),
        ("dots_per_cm2", "instead of -n: D dots per cm^2 of the print"),
        ("output", "output .svg, .png, .npz or .csv; repeat for several"),
        ("colors", "pen layers: cmyk, cmy, or auto:N (black and N - 1 hues)"),
        ("pens", "any pens, e.g. black=#000,red=#c00,blue=#06c"),
        ("seed", "seed of the start (default %(default)s; same seed, same dots)"),
        ("quiet", None),
        ("json", "print one JSON summary line on stdout at the end"),
    )),
    (PLOTTER, (
        ("page", "SVG page: a3, a4, a5, letter or WxHmm; picture centred"),
        ("landscape", None),
        ("margin_mm", "margin around the picture on the --page paper"),
        ("plotter", "vpype device (e.g. hp7475a): dots inside its reach"),
        ("pen_mm", "pen width W in mm: dots drawn as this pen draws them"),
        ("dot_mm", "dot diameter in mm (default: one size for the tone)"),
        ("width_mm", "picture width (with --height-mm: fit in the box)"),
        ("height_mm", None),
        ("dpi", "picture size from the image's pixels at DPI"),
        ("plot_speed_mm_s", "plot-time estimate: pen speed (default %(default)s)"),
        ("pen_lift_s", "plot-time estimate: s a pen lift (default %(default)s)"),
    )),
)


def one_line_help(dest):
    """The one-line help :data:`LEADING` gives option `dest`, or None (its own help).

    Examples
    --------
    >>> one_line_help("output")
    'output .svg, .png, .npz or .csv; repeat for several'
    >>> one_line_help("gamma") is None
    True
    """
    return next((text for _, entries in LEADING for name, text in entries if name == dest), None)


def lead_with(parser, *, last=()):
    """Show the options of :data:`LEADING` that `parser` has first, in groups of their
    own after the positional arguments, with their one-line helps; the groups titled
    in `last` go last, in that order. Only ``--help`` changes: no option's name or behaviour.

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser(prog="x")
    >>> _ = p.add_argument_group("tuning").add_argument("--gamma")
    >>> _ = p.add_argument("-o", "--output")
    >>> lead_with(p)
    >>> [g.title for g in p._action_groups if g._group_actions]
    ['everyday options', 'tuning']
    """
    actions = {a.dest: a for a in parser._actions}
    made = []
    for title, entries in LEADING:
        moved = [(actions[dest], text) for dest, text in entries if dest in actions]
        if not moved:
            continue
        group = parser.add_argument_group(title)
        for action, text in moved:
            for other in parser._action_groups:
                if action in other._group_actions and other is not group:
                    other._group_actions.remove(action)
            group._group_actions.append(action)
            action.help = text or action.help
        made.append(group)
    rest = [g for g in parser._action_groups if g not in made and g is not parser._positionals]
    parser._action_groups[:] = [parser._positionals, *made,
                                *[g for g in rest if g.title not in last],
                                *[g for title in last for g in rest if g.title == title]]


def with_examples(text, examples):
    """`text`, then ``examples:`` and one indented command a line (a long one continued
    with `` \\`` on indented lines), for a description or a help that keeps them.

    Examples
    --------
    >>> print(with_examples("Do it.", ["diskpack devices"]))
    Do it.
    <BLANKLINE>
    examples:
      diskpack devices
    """
    return f"{text}\n\nexamples:\n" + "\n".join(f"  {line}" for line in examples)

