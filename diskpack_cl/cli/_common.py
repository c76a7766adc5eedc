"""Shared parts of the subcommands: argument types, common options, the parser, progress bars."""

from __future__ import annotations

import argparse
import os
import sys
import re
import textwrap

from diskpack_cl.io import check_not_inputs


PROG = "diskpack"

#: The flags about the run, not the job: the inputs and how to read them, the outputs,
#: what is printed, where and how the job runs, which checks it makes. Every other flag
#: of a subcommand is generated from a field of an options dataclass
#: (:func:`diskpack_cl.options.add_arguments`); ``tests/test_flags.py`` holds them to it.
RUN_FLAGS = frozenset({
    "images", "inputs", "input", "image", "columns", "recursive", "allow_large",
    "output", "quiet", "json",
    "jobs", "manifest", "overwrite", "scheduler", "collect", "count", "device",
    "verify", "profile", "allow_unreached", "check", "recheck",
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


positive_int = _checked(int, lambda v: v >= 1, "at least 1")


def _records(record):
    """A stage's records: its one, or the list a tiled run gives where its parts differ."""
    return record if isinstance(record, list) else [record]


def device_name(description):
    """The device's name alone, without its platform.

    Examples
    --------
    >>> device_name("pthread-AMD EPYC 7B13 (Portable Computing Language)")
    'pthread-AMD EPYC 7B13'
    """
    name, sep, rest = description.rpartition(" (")
    return name if sep and rest.endswith(")") else description


def where_ran(stages):
    """A few words for a summary line: where the engine of a run's `stages` ran.

    Examples
    --------
    >>> where_ran({"engine": {"backend": "opencl", "device": "Tesla T4 (NVIDIA CUDA)"}})
    'on OpenCL (Tesla T4)'
    >>> where_ran({"engine": {"backend": "exact", "device": "cpu (scipy)"}})
    'on the host (exact engine)'
    """
    words = []
    for r in _records(stages.get("engine", [])):
        text = (f"OpenCL ({device_name(r['device'])})" if r["backend"] == "opencl"
                else "the host (exact engine)")
        if text not in words:
            words.append(text)
    return "on " + " and ".join(words) if words else ""


def brief(reason):
    """A fallback's reason on one short line: without asides inside its parentheses and
    what follows its first sentence (the summaries keep it whole).

    Examples
    --------
    >>> brief("no OpenCL device (none found; install a driver (e.g. PoCL) or a GPU's. "
    ...       "Both run without)")
    "no OpenCL device (none found; install a driver or a GPU's)"
    """
    kept, depth = [], 0
    for ch in reason:
        depth += ch == "("
        if depth < 2:
            kept.append(ch)
        depth -= ch == ")"
    text = re.sub(r"\s+([;,.)])", r"\1", re.sub(r"\s+", " ", "".join(kept)))
    head, sep, _ = text.partition(". ")
    return head + ")" * (head.count("(") - head.count(")")) if sep else text


def fallback_notes(stages):
    """One line per stage of `stages` that ran on the host for want of a device, and why.

    Examples
    --------
    >>> fallback_notes({"engine": {"backend": "opencl", "device": "gpu"},
    ...                 "blur": {"backend": "exact", "device": "cpu", "fallback": "no float64"}})
    ['blur ran on the host: no float64']
    """
    notes = []
    for name, record in stages.items():
        for r in _records(record):
            text = f"{name} ran on the host: {brief(r['fallback'])}" if r.get("fallback") else None
            if text and text not in notes:
                notes.append(text)
    return notes


#: Device notes already printed by :func:`show_device_notes` (the summary's notes skip them).
_SHOWN: list = []


def show_device_notes(quiet=False):
    """Print each :class:`~diskpack_cl.device.checks.DeviceWarning` as one line
    (``diskpack: note: ...``) instead of Python's two-line warning; ``quiet``: not at all.

    Examples
    --------
    >>> import warnings
    >>> from diskpack_cl.device.checks import DeviceWarning
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("always")
    ...     show_device_notes()
    ...     warnings.warn(DeviceWarning("cpu passed over: cell_mic: wrong"))
    """
    import warnings

    from diskpack_cl.device.checks import DeviceWarning  # not loaded at start-up

    python_way = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if not issubclass(category, DeviceWarning):
            return python_way(message, category, filename, lineno, file, line)
        if not quiet and str(message) not in _SHOWN:
            print(f"{PROG}: note: {message}", file=sys.stderr)
        _SHOWN.append(str(message))

    warnings.showwarning = show


def note_fallbacks(args, stages):
    """Print :func:`fallback_notes` on stderr (``diskpack: note: ...``), unless --quiet
    or a device note said it already."""
    if not args.quiet:
        for text in fallback_notes(stages):
            if not any(text.partition(": ")[2].partition(" (")[0] in shown for shown in _SHOWN):
                print(f"{PROG}: note: {text}", file=sys.stderr)


def device_options(p):
    p.add_argument("--device", metavar="D", default=None,
                   help="OpenCL device: 'P' or 'P:D' indices (as in PYOPENCL_CTX) or a name "
                        "substring ('pocl', 'nvidia', 'gpu', 'cpu'); default: DISKPACK_DEVICE, "
                        "then PYOPENCL_CTX, then a GPU, else the first CPU device")


class GivenOnce(argparse.Action):
    """An option that may be given once: a second one is a usage error (argparse would
    keep the last silently)."""

    hint = "; give it once"

    def __call__(self, parser, namespace, values, option_string=None):
        first = getattr(namespace, self.dest, None)
        if first is not None:
            parser.error(f"{option_string} given twice ({first} and {values}){self.hint}")
        setattr(namespace, self.dest, values)


class _Once(GivenOnce):
    """The one point file of ``poisson`` and ``relax``: a second ``-o`` is a usage error."""

    hint = (": this command writes one point file (several sets: --count K with a template "
            "such as -o sets/{i:04d}.npz)")


def output_options(p):
    p.add_argument("-o", "--output", required=True, metavar="OUT", action=_Once,
                   help="output point file (.npz, .npy, .csv, .txt, .xy); written atomically; "
                        "given once")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bar and no summary on stderr")
    p.add_argument("--json", action="store_true",
                   help="print one JSON summary line on stdout at the end")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Paragraphs of a description wrapped to the terminal; indented lines (examples) kept."""

    def _fill_text(self, text, width, indent):
        return "\n".join(
            line if line.startswith(" ") or len(line) <= width else
            textwrap.fill(line, width, initial_indent=indent, subsequent_indent=indent)
            for line in text.splitlines())


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: the error, "did you mean" for a
    mistyped choice or option, and where the help is (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}{_did_you_mean(self, message)} "
                     f"(see '{self.prog} --help')\n")

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but an unknown option is the subcommand's error, with its options."""
        args, extras = self.parse_known_args(args, namespace)
        if extras:
            _subcommand_parser(self, args).error(f"unrecognized arguments: {' '.join(extras)}")
        return args


def _subcommand_parser(parser, args):
    """The parser of the subcommand that `args` ran (`parser` itself without one)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices.get(getattr(args, action.dest, None), parser)
    return parser


def _did_you_mean(parser, message):
    """``"; did you mean X?"``: a near miss, else the options that share the mistyped
    one's first word (``--pen-width``: ``--pen-mm``, ``--pen-path``, ...), in the
    parser's order, else the closest subcommand,
    choice or option; ``""`` when none is close.

    Examples
    --------
    >>> p = Parser(prog="x")
    >>> for flag in ("--pen-mm", "--pen-path", "--page"):
    ...     _ = p.add_argument(flag)
    >>> _did_you_mean(p, "unrecognized arguments: --pen-width 3")
    '; did you mean one of --pen-mm, --pen-path?'
    """
    import difflib  # not loaded at start-up

    choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if choice:
        words = [choice.group(1)]
        known = [c.strip(" '") for c in choice.group(2).split(",")]
    else:
        extra = re.search(r"unrecognized arguments: (.*)", message)
        words = [w.split("=")[0] for w in extra.group(1).split() if w.startswith("-")] if extra else []
        known = _option_strings(parser)
    close = []
    for word in words:
        others = [k for k in known if k != word]
        stem = word.split("-")[2] + "-" if word.startswith("--") and word.count("-") > 2 else None
        family = [k for k in others if stem and k.startswith("--" + stem)]
        # a near miss (--pen-mn) is a typo; a farther one (--pen-width) lists the family;
        # a loose match (--max-iter: --clean-white at 0.6) names a wrong neighbour
        close += (difflib.get_close_matches(word, others, n=1, cutoff=0.8) or family
                  or difflib.get_close_matches(word, others, n=1, cutoff=0.75))
    if len(close) > 1:
        return f"; did you mean one of {', '.join(close)}?"
    return f"; did you mean {close[0]}?" if close else ""


def _option_strings(parser):
    """Every option string of ``parser`` and of its subcommands."""
    out = []
    for action in parser._actions:
        out += action.option_strings
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out += _option_strings(sub)
    return out


def terminal_bar(args, desc, unit, total=None, *, leave=False):
    """A tqdm bar on stderr when it is a terminal and not ``--quiet``, else None."""
    if args.quiet or not sys.stderr.isatty():
        return None
    from tqdm import tqdm  # not loaded at start-up

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True,
                leave=leave)


def command_run(args):
    """The command as one run (:func:`diskpack_cl.progress.with_bars`): a context yielding
    its :class:`~diskpack_cl.progress.RunProgress`, which draws a bar per stage on stderr (on
    a terminal, not with --quiet or --json); inside a run already going on, that run."""
    from diskpack_cl.progress import with_bars  # not loaded at start-up

    return with_bars(quiet=args.quiet or getattr(args, "json", False))


SAMPLE = "sample"


def image_path(text):
    """The word ``sample`` names the bundled sample photograph; anything else is a path."""
    if text == SAMPLE:
        # not loaded at start-up: the image module (25 ms) serves the picture commands only
        from diskpack_cl.image import sample_image_path

        return sample_image_path()
    return text


class UsageError(ValueError):
    """Options that contradict each other: :func:`main` returns 2, as argparse does."""


def checked_outputs(args, inputs):
    """The ``-o`` paths, each checked (extension, folder), given once and none of the
    `inputs`, before any work."""
    from diskpack_cl.drawing.writers import check_output_path  # not loaded at start-up

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


def open_closed_streams():
    """Point the standard streams that were closed at start (``2>&-``, some daemons) at the
    null device.

    Python makes a closed stream's ``sys.stderr`` None: the progress bar died on it with
    an AttributeError, and ``print`` to it wrote on stdout. The descriptor left free
    was also taken by the first file opened, which then received whatever C code (a
    driver) wrote to that stream.
    """
    for fd, name in ((0, "stdin"), (1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
        except OSError:   # closed: the lower ones are open, so os.open gives this one
            os.open(os.devnull, os.O_RDONLY if fd == 0 else os.O_WRONLY)
        if getattr(sys, name) is None:
            setattr(sys, name, open(fd, "r" if fd == 0 else "w", closefd=False))
