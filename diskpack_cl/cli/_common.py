"""Shared parts of the subcommands: argument types, common options, the parser, progress bars."""

from __future__ import annotations

import argparse
import os
import sys


PROG = "diskpack"

#: The flags about the run, not the job: the inputs and how to read them, the outputs,
#: what is printed, where and how the job runs, which checks it makes. Every other flag
#: of a subcommand is generated from a field of an options dataclass
#: (:func:`diskpack_cl.options.add_arguments`); ``tests/test_flags.py`` holds them to it.
RUN_FLAGS = frozenset({
    "images", "inputs", "input", "image", "columns", "recursive", "allow_large",
    "output", "quiet", "json",
    "jobs", "manifest", "overwrite", "scheduler", "collect", "count", "device",
    "verify", "profile", "allow_unreached",
})


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


def _bar(args, desc, unit, total=None, *, leave=False):
    """A tqdm bar on stderr when it is a terminal and not ``--quiet``, else None."""
    if args.quiet or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True,
                leave=leave)


SAMPLE = "sample"


def _image_path(text):
    """The word ``sample`` names the bundled sample photograph; anything else is a path."""
    if text == SAMPLE:
        from diskpack_cl.image import sample_image_path

        return sample_image_path()
    return text


class _UsageError(ValueError):
    """Options that contradict each other: :func:`main` returns 2, as argparse does."""


def _checked_outputs(args, inputs):
    """The ``-o`` paths, each checked (extension, folder), given once and none of the
    `inputs`, before any work."""
    from diskpack_cl.export import check_output_path
    from diskpack_cl.io import check_not_inputs

    outputs = [str(o) for o in args.output]
    seen = set()
    for out in outputs:
        check_output_path(out)
        key = os.path.realpath(out)
        if key in seen:
            raise ValueError(f"output given twice: {out}")
        seen.add(key)
    check_not_inputs(outputs, inputs)
    return outputs
