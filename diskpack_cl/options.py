"""Options as data: each option is one dataclass field with its default, range, unit and help.

:func:`option` declares a field; :func:`check_fields` validates an instance
against its fields' ranges and choices (the dataclasses call it from
``__post_init__``); :func:`add_arguments` builds the argparse options of a
dataclass and :func:`from_namespace` reads them back, so that a new field
reaches the command line, the checks and the library at once.

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Size:
...     width_mm: float = option(None, "picture width", unit="mm", lo=0, lo_open=True)
...     def __post_init__(self):
...         check_fields(self)
>>> Size(width_mm=-1)
Traceback (most recent call last):
...
ValueError: width_mm must be > 0, got -1.0
>>> describe(Size)["width_mm"]["unit"]
'mm'
"""

from __future__ import annotations

import argparse
import dataclasses
import math

__all__ = ["option", "check_fields", "describe", "add_arguments", "cli_fields", "from_namespace",
           "NamedOptionError", "OptionConflict", "flag_name", "changed"]


class NamedOptionError(ValueError):
    """An error about options, named in its message.

    The message is a template whose ``{}`` are option names; :meth:`render`
    spells them, as Python names (``str``) or as command-line flags.

    Examples
    --------
    >>> exc = NamedOptionError("{} must be at most 1", "k_quantile")
    >>> str(exc), exc.render(flag_name)
    ('k_quantile must be at most 1', '--k-quantile must be at most 1')
    """

    def __init__(self, template, *names):
        self.template, self.names = template, names
        super().__init__(self.render(str))

    def render(self, spell):
        """The message with each option name spelled by ``spell(name)``."""
        return self.template.format(*(spell(n) for n in self.names))


class OptionConflict(NamedOptionError):
    """Options that contradict each other (the CLI exits with status 2).

    Examples
    --------
    >>> exc = OptionConflict("{} must be below {}", "black_point", "white_point")
    >>> str(exc), exc.render(flag_name)
    ('black_point must be below white_point', '--black-point must be below --white-point')
    """


def flag_name(name):
    """The command-line flag of a field: ``k_quantile`` -> ``--k-quantile``.

    Examples
    --------
    >>> flag_name("k_quantile"), flag_name("n")
    ('--k-quantile', '-n')
    """
    return ("-" if len(name) == 1 else "--") + name.replace("_", "-")


def option(default, help, *, unit=None, lo=None, hi=None, lo_open=False, hi_open=False,
           integer=False, choices=None, check=None, metavar=None, cli=True, group=None,
           cli_choices=None, cli_type=None, flag=None):
    """A dataclass field with what the checks, ``--help`` and the docs need to know.

    Parameters
    ----------
    default
        The default; ``None`` means "decided later" (the schedule's, say).
    help : str
        One sentence or two: what the option does.
    unit : str, optional
        Unit of the value (``"mm"``, ``"px"``).
    lo, hi : float, optional
        Range of the value; ``lo_open``/``hi_open`` exclude the bound.
    integer : bool
        The value is an integer.
    choices : tuple, optional
        The values allowed.
    check : callable, optional
        Called with the value; raises ValueError when it is bad.
    metavar : str, optional
        The argument's name in ``--help``.
    cli : bool
        Whether the command line offers it.
    group : str, optional
        Title of the ``--help`` group (default: the command's).
    cli_choices, cli_type : optional
        What the command line takes where the library takes more (a
        schedule name, not a list of phases; a seed, not a generator).
    flag : str, optional
        The command line's flag where it is not :func:`flag_name`'s (``-n``).

    Examples
    --------
    >>> from dataclasses import dataclass, fields
    >>> @dataclass(frozen=True)
    ... class Pen:
    ...     width_mm: float = option(0.5, "pen width", unit="mm", lo=0, lo_open=True)
    >>> m = fields(Pen)[0].metadata
    >>> m["unit"], m["help"], Pen().width_mm
    ('mm', 'pen width', 0.5)
    """
    meta = dict(help=help, unit=unit, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open,
                integer=integer, choices=choices, check=check, metavar=metavar, cli=cli,
                group=group, cli_choices=cli_choices, cli_type=cli_type, flag=flag)
    return dataclasses.field(default=default, metadata=meta)


def _range_text(m):
    lo, hi = m["lo"], m["hi"]
    unit = "an integer " if m["integer"] else ""
    if lo is not None and hi is not None:
        return (f"in {'(' if m['lo_open'] else '['}{lo:g}, {hi:g}"
                f"{')' if m['hi_open'] else ']'}")
    if lo is not None:
        return f"{unit}{'>' if m['lo_open'] else '>='} {lo:g}"
    return f"{unit}{'<' if m['hi_open'] else '<='} {hi:g}"


def _in_range(value, m):
    lo, hi = m["lo"], m["hi"]
    if lo is not None and not (value > lo if m["lo_open"] else value >= lo):
        return False
    return hi is None or (value < hi if m["hi_open"] else value <= hi)


def check_value(name, value, meta, *, custom=True):
    """Check one value against its field's metadata; return it, converted.

    Raises
    ------
    ValueError
        ``NAME must be ..., got VALUE``.
    """
    if meta["choices"] is not None:
        if value not in meta["choices"]:
            shown = " or ".join(repr(c) for c in meta["choices"])
            raise ValueError(f"{name} must be {shown}, got {value!r}")
        return value
    ranged = meta["lo"] is not None or meta["hi"] is not None
    if meta["integer"]:
        if isinstance(value, bool) or int(value) != value:
            raise ValueError(f"{name} must be {_range_text(meta)}, got {value!r}")
        value = int(value)
    elif ranged:
        value = float(value)
    if ranged and not (math.isfinite(value) and _in_range(value, meta)):
        raise ValueError(f"{name} must be {_range_text(meta)}, got {value}")
    if custom and meta["check"] is not None:
        meta["check"](value)
    return value


def check_fields(obj):
    """Validate every field of the frozen dataclass ``obj`` (None passes where it is the default).

    Converts in place: integers to int, ranged numbers to float, flags to bool.

    Examples
    --------
    ``ToneOptions`` calls it from ``__post_init__``:

    >>> from diskpack_cl import ToneOptions
    >>> ToneOptions(black_point=2)
    Traceback (most recent call last):
    ...
    ValueError: black_point must be in [0, 1], got 2.0
    """
    for f in dataclasses.fields(obj):
        if "help" not in f.metadata:
            continue
        value = getattr(obj, f.name)
        if value is None and f.default is None:
            continue
        if isinstance(f.default, bool):
            value = bool(value)
        else:
            value = check_value(f.name, value, f.metadata)
        object.__setattr__(obj, f.name, value)


def describe(cls):
    """``{name: {default, help, unit, range, choices}}`` of the options of ``cls``.

    Examples
    --------
    >>> from diskpack_cl import ToneOptions
    >>> d = describe(ToneOptions)
    >>> list(d), d["black_point"]["range"]
    (['black_point', 'white_point', 'tone_gamma'], 'in [0, 1]')
    """
    out = {}
    for f in dataclasses.fields(cls):
        m = f.metadata
        if "help" not in m:
            continue
        rng = _range_text(m) if m["lo"] is not None or m["hi"] is not None else None
        out[f.name] = {"default": f.default, "help": m["help"], "unit": m["unit"],
                       "range": rng, "choices": m["choices"]}
    return out


def _argparse_type(name, meta):
    """Parse the text, check it like the dataclass does, report as argparse does."""
    want = "an integer" if meta["integer"] else "a number"
    convert = int if meta["integer"] else (float if meta["lo"] is not None
                                           or meta["hi"] is not None else str)

    def parse(text):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {want}: {text!r}") from None
        try:
            value = check_value(name, value, meta, custom=False)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc).replace(f"{name} ", "", 1)) from None
        try:
            if meta["check"] is not None:
                meta["check"](value)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return value

    return parse


def add_arguments(parser, cls, *, groups=None, skip=()):
    """Add an argparse option for every command-line field of ``cls`` not in ``skip``.

    ``groups`` maps a field's ``group`` title to an argument group (created
    on ``parser`` when missing; a mutually exclusive group the caller made
    takes fields that exclude each other, ``-n`` and ``--density``). A field
    already on the parser (``invert`` of two dataclasses) is added once.
    Every default is the field's.

    Examples
    --------
    >>> from diskpack_cl import ToneOptions
    >>> parser = argparse.ArgumentParser()
    >>> _ = add_arguments(parser, ToneOptions)
    >>> parser.parse_args(["--black-point", "0.1"]).black_point
    0.1
    >>> parser.parse_args([]).white_point
    1.0
    """
    groups = {} if groups is None else groups
    have = {a.dest for a in parser._actions}
    for f, choices, parse in cli_fields(cls, skip=(*skip, *have)):
        m = f.metadata
        title = m["group"]
        target = parser if title is None else groups.setdefault(
            title, parser.add_argument_group(title))
        flag = m["flag"] or flag_name(f.name)
        if isinstance(f.default, bool):
            target.add_argument(flag, dest=f.name, action="store_true", help=m["help"])
            continue
        kw = dict(dest=f.name, default=f.default, help=m["help"], metavar=m["metavar"], type=parse)
        if choices is not None:
            kw.update(choices=choices)
            kw.pop("metavar")
        target.add_argument(flag, **kw)
    return groups


def cli_fields(cls, *, skip=()):
    """The command-line fields of ``cls`` not in ``skip``, each with what it takes.

    Yields ``(field, choices, parse)``: a flag (a bool field) takes neither;
    a choice its ``choices`` and, for choices that are not strings, their
    ``parse``; any other field the ``parse`` that reads the text and checks
    it as the dataclass does (raising ``argparse.ArgumentTypeError``). Every
    command line built from the dataclasses (argparse's, the vpype plugin's
    click options) goes through it.

    Examples
    --------
    >>> from diskpack_cl import ToneOptions
    >>> [(f.name, parse("0.5")) for f, _, parse in cli_fields(ToneOptions)][0]
    ('black_point', 0.5)
    """
    for f in dataclasses.fields(cls):
        m = f.metadata
        if "help" not in m or not m["cli"] or f.name in skip:
            continue
        choices = m["cli_choices"] or m["choices"]
        if isinstance(f.default, bool):
            yield f, None, None
        elif choices is not None:
            yield f, tuple(choices), m["cli_type"]   # choices that are not strings (--dim 3)
        else:
            yield f, None, m["cli_type"] or _argparse_type(f.name, m)


def changed(obj):
    """``{name: value}`` of the fields of ``obj`` that differ from their defaults (JSON-ready
    when the values are); ``type(obj)(**changed(obj)) == obj``.

    Examples
    --------
    >>> from diskpack_cl import ToneOptions
    >>> changed(ToneOptions(tone_gamma=1.5))
    {'tone_gamma': 1.5}
    """
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)
            if getattr(obj, f.name) != f.default}


def from_namespace(cls, args, **overrides):
    """An instance of ``cls`` from the parsed ``args`` (its command-line fields).

    Examples
    --------
    >>> from diskpack_cl import ToneOptions
    >>> parser = argparse.ArgumentParser()
    >>> _ = add_arguments(parser, ToneOptions)
    >>> from_namespace(ToneOptions, parser.parse_args(["--tone-gamma", "2"]))
    ToneOptions(black_point=0.0, white_point=1.0, tone_gamma=2.0)
    """
    values = {f.name: getattr(args, f.name) for f in dataclasses.fields(cls)
              if f.metadata.get("cli") and hasattr(args, f.name)}
    values.update(overrides)
    return cls(**values)
