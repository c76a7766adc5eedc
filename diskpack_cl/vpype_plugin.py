"""The ``diskpack`` command of vpype: a stippling as vpype geometry, one layer per pen.

Installed with the ``vpype`` extra (``.venv/bin/pip install ".[vpype]"`` in the repository),
vpype finds it through its ``vpype.plugins`` entry point::

    vpype diskpack photo.jpg -n 20000 --pen-mm 0.5 layout a4 linesort write out.svg

The command stipples the image as ``diskpack stipple`` does, draws the
dots as its SVG draws them (:func:`diskpack_cl.jobs.items.write_stipple_outputs`:
a filled dot's outline, or with ``--pen-mm`` a pen touch or concentric
rings) and adds that drawing to vpype's document: one layer per pen, the
page the SVG's page. Its stippling options are generated from the same
dataclasses as those of ``diskpack stipple`` (:func:`click_options`).
"""

from __future__ import annotations

import argparse
import logging
import os
import tempfile
from pathlib import Path

import click
import vpype
import vpype_cli

from diskpack_cl.device.context import NoOpenCLError, check_requested_device
from diskpack_cl.cli import LEADING, one_line_help
from diskpack_cl.pens import ColorOptions
from diskpack_cl.drawing.writers import WriteOptions
from diskpack_cl.image import ToneOptions, sample_image_path
from diskpack_cl.jobs.items import plan_stipple, stipple_item, write_stipple_outputs
from diskpack_cl.options import NamedOptionError, cli_fields, flag_name
from diskpack_cl.progress import stage_text, with_bars
from diskpack_cl.schedule import StippleOptions

__all__ = ["click_options", "diskpack", "QUANTIZATION_MM"]

#: Longest segment (mm) of the polylines vpype makes of the dots' circles.
QUANTIZATION_MM = 0.1

# the PNG preview's scale and extent have nothing to draw in vpype
_NOT_IN_VPYPE = ("png_scale", "preview")


class _Parsed(click.ParamType):
    """A click type that reads the text as ``diskpack stipple`` does (its checks, its messages)."""

    def __init__(self, name, parse):
        self.name, self._parse = name, parse

    def convert(self, value, param, ctx):
        if not isinstance(value, str):
            return value
        try:
            return self._parse(value)
        except (argparse.ArgumentTypeError, ValueError) as exc:
            self.fail(str(exc), param, ctx)


#: Place of each leading option (diskpack stipple's first groups) in vpype's --help.
_LEADING_ORDER = {dest: i for i, (dest, _) in enumerate(e for _, group in LEADING for e in group)}


def _help(field):
    """The option's help in vpype's --help: its one-line help where it leads, else its own."""
    text = one_line_help(field.name)
    return field.metadata["help"] if text is None else text % {"default": field.default}


def _click_option(field, choices, parse):
    m, flag = field.metadata, flag_name(field.name)
    if isinstance(field.default, bool):
        return click.option(flag, is_flag=True, help=_help(field))
    if choices is not None:
        kind = click.Choice([str(c) for c in choices])
        if parse is not None:   # choices that are not strings: the text is checked, then read
            kind = _Parsed(field.name, lambda text, c=kind: parse(c.convert(text, None, None)))
        return click.option(flag, type=kind, default=field.default, help=_help(field))
    return click.option(flag, type=_Parsed(field.name, parse), default=field.default,
                        metavar=m["metavar"] or "X", help=_help(field))


def click_options(*classes, skip=()):
    """A decorator adding a click option for every command-line field of ``classes``.

    The options are those :func:`diskpack_cl.options.add_arguments` gives
    ``diskpack stipple``: same flags, defaults, choices, checks and help. A
    field of two classes is added once. The options of
    :data:`diskpack_cl.cli.LEADING` come first, in its order and with
    its one-line helps, as ``diskpack stipple --help`` shows them.

    Examples
    --------
    >>> @click.command()
    ... @click_options(ToneOptions)
    ... def show(**kw):
    ...     click.echo(ToneOptions(**kw))
    >>> from click.testing import CliRunner
    >>> CliRunner().invoke(show, ["--tone-gamma", "2"]).output
    'ToneOptions(black_point=0.0, white_point=1.0, tone_gamma=2.0)\\n'
    >>> CliRunner().invoke(show, ["--black-point", "2"]).output.splitlines()[-1]
    "Error: Invalid value for '--black-point': must be in [0, 1], got 2.0"
    """
    specs, seen = [], set(skip)
    for cls in classes:
        for spec in cli_fields(cls, skip=seen):
            specs.append(spec)
            seen.add(spec[0].name)
    specs.sort(key=lambda spec: _LEADING_ORDER.get(spec[0].name, len(_LEADING_ORDER)))

    def decorate(fn):
        for spec in reversed(specs):
            fn = _click_option(*spec)(fn)
        return fn

    return decorate


class _PipelineCommand(click.Command):
    """A vpype command that takes its options after its argument too.

    vpype chains its commands, and click's chain ends a command's options at
    its first argument; this command's own tokens run up to the first name
    of a vpype command that is no option's value, and the rest is vpype's.
    """

    def parse_args(self, ctx, args):
        end = self._own_tokens(ctx, args)
        ctx.allow_interspersed_args = True
        super().parse_args(ctx, args[:end])
        ctx.args = [*ctx.args, *args[end:]]
        return ctx.args

    def _own_tokens(self, ctx, args):
        commands = set(getattr(ctx.parent.command, "commands", ())) if ctx.parent else set()
        valued = {opt for p in self.params if isinstance(p, click.Option) and not p.is_flag
                  for opt in p.opts}
        i, seen_argument = 0, False
        while i < len(args):
            if args[i] in valued:
                i += 2
                continue
            if not args[i].startswith("-"):
                if seen_argument and args[i] in commands:
                    return i
                seen_argument = True
            i += 1
        return len(args)


def _dot_count(text):
    if text == "tone":
        return text
    try:
        n = int(text)
    except ValueError:
        raise click.BadParameter(f"not an integer or 'tone': {text!r}") from None
    if n < 2:
        raise click.BadParameter(f"need at least 2 dots, got {n}")
    return n


def _of(cls, kw):
    return cls(**{k: v for k, v in kw.items() if k in cls.__dataclass_fields__})


def _note(text):
    """A note of the stippling on stderr, as ``diskpack stipple`` prints it."""
    click.echo(f"diskpack: note: {text}", err=True)


def _stippling_document(image, n, kw):
    """Stipple ``image`` as ``diskpack stipple`` does; the SVG it writes, read by vpype."""
    write, color = _of(WriteOptions, kw), _of(ColorOptions, kw)
    separation = color.separation()
    if isinstance(n, int):
        color.check_pen_dots(n)
    with tempfile.TemporaryDirectory() as tmp:
        svg = os.path.join(tmp, "stippling.svg")
        (item,) = plan_stipple([sample_image_path() if image == "sample" else image], [svg],
                               _of(StippleOptions, kw), n=n, write=write,
                               tone=_of(ToneOptions, kw), color=separation, make_folders=False)
        with with_bars() as run:   # a bar per stage on stderr, as diskpack stipple draws them
            result, summary = stipple_item(item, note=_note)
            _, (info,) = write_stipple_outputs(result, None, [svg], write)
        times = stage_text(run.by_stage(), summary["iterations"], run.elapsed())
        logging.info(f"diskpack: {result.n} dots; {times}; plot about "
                     f"{info['plot_seconds'] / 60:.0f} min, {info['touching_share']:.1%} of the "
                     "drawn dots touch")
        doc = vpype.read_multilayer_svg(svg, vpype.convert_length(f"{QUANTIZATION_MM}mm"))
    # the page in vpype's exact pixels (the SVG reader rounds its mm), which vpype's HPGL
    # writer matches with its papers
    doc.page_size = tuple(v * vpype.convert_length("1mm") for v in info["page_mm"])
    source = Path(item.input).resolve()   # not the SVG, gone with its folder
    doc.set_property(vpype.METADATA_FIELD_SOURCE, source)
    doc.sources = {source}
    return doc


@click.command(cls=_PipelineCommand)
@click.argument("image", metavar="IMAGE")
@click.option("-n", "n", type=_dot_count, required=True, metavar="N", help=one_line_help("n"))
@click_options(StippleOptions, ToneOptions, WriteOptions, ColorOptions, skip=_NOT_IN_VPYPE)
@vpype_cli.global_processor
def diskpack(document, image, n, **kw):
    """Stipple IMAGE by disk packing: one layer per pen, dots as the plotter draws them.

    IMAGE is an image file, or the word 'sample' for the bundled sample
    photograph. The options are those of `diskpack stipple`; the page is
    the stippling's SVG page (--page, --plotter, --width-mm, ...).

    \b
    Examples:
      vpype diskpack photo.jpg -n 20000 --page a4 --plotter hp7475a \\
          --pen-mm 0.5 write --device hp7475a --page-size a4 out.hpgl
      vpype diskpack sample -n 20000 --page a4 --pen-mm 0.5 write out.svg
      vpype diskpack photo.jpg -n 20000 --colors cmyk --page a3 \\
          --pen-mm 0.5 write colour.svg
    """
    try:
        check_requested_device()   # DISKPACK_DEVICE, PYOPENCL_CTX: as diskpack stipple does
        document.extend(_stippling_document(image, n, kw))
    except NamedOptionError as exc:
        raise click.UsageError(exc.render(flag_name)) from None
    except (OSError, ValueError, NoOpenCLError) as exc:
        raise click.UsageError(str(exc)) from None
    return document


diskpack.help_group = "Plugins"
