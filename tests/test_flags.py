"""Every flag of every subcommand comes from an options field, or is a flag of the run;
each option's default is defined once."""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import pkgutil

import pytest

import diskpack_cl
from diskpack_cl.cli import build_parser
from diskpack_cl.cli._common import RUN_FLAGS
from diskpack_cl.cli import one_line_help
from diskpack_cl.pens import ColorOptions
from diskpack_cl.domain import DomainOptions
from diskpack_cl.drawing.writers import WriteOptions
from diskpack_cl.image import ToneOptions
from diskpack_cl.options import add_arguments
from diskpack_cl.poisson import PoissonOptions, PoissonSetOptions
from diskpack_cl.relax import RelaxOptions
from diskpack_cl.reports import AnalyzeOptions
from diskpack_cl.schedule import StippleCount, StippleOptions
from diskpack_cl.jobs.tiles import TileOptions

#: The options dataclasses each subcommand builds from its arguments.
CLASSES = {
    "devices": (),
    "analyze": (AnalyzeOptions,),
    "export": (WriteOptions,),
    "relax": (RelaxOptions, DomainOptions),
    "poisson": (PoissonSetOptions, PoissonOptions, DomainOptions),
    "stipple": (StippleCount, StippleOptions, ToneOptions, WriteOptions, ColorOptions, TileOptions),
}

#: Names of two options that are not one: a stippling's seed is 0 unless given (the same
#: image and options give the same dots), a Poisson set's is drawn afresh and printed.
DISTINCT = {"seed": {"StippleOptions": 0, "PoissonSetOptions": None}}


def _subparsers():
    action = next(a for a in build_parser()._actions
                  if isinstance(a, argparse._SubParsersAction))
    return action.choices


def _generated(classes):
    """The actions :func:`~diskpack_cl.options.add_arguments` makes for `classes`, by dest."""
    parser = argparse.ArgumentParser()
    for cls in classes:
        add_arguments(parser, cls)
    return {a.dest: a for a in parser._actions if a.dest != "help"}


def _signature(action, help=None):
    """What an action takes and shows (`help`: instead of its help); its type by name
    (each parser makes its own)."""
    kind = getattr(action.type, "__qualname__", action.type)
    return (type(action), action.option_strings, action.default, help or action.help,
            action.metavar, action.choices, action.const, kind)


def test_every_subcommand_is_covered():
    assert set(_subparsers()) == set(CLASSES)


@pytest.mark.parametrize("command", sorted(CLASSES))
def test_every_flag_comes_from_an_options_field_or_is_a_run_flag(command):
    generated = _generated(CLASSES[command])
    assert not set(generated) & RUN_FLAGS
    handmade = []
    for action in _subparsers()[command]._actions:
        if action.dest == "help" or action.dest in RUN_FLAGS:
            continue
        field = generated.get(action.dest)
        # a leading option's --help is one line of its own (diskpack_cl.cli.LEADING)
        shown = field.help if field and action.help == one_line_help(action.dest) else None
        if field and _signature(action, shown) == _signature(field):
            continue
        handmade.append(action.option_strings[0] if action.option_strings else action.dest)
    assert handmade == [], f"{command}: flags written by hand, not from an options field"


def _options_classes():
    """Every dataclass of the package with option fields (those of :func:`options.option`)."""
    found = set()
    for info in pkgutil.walk_packages(diskpack_cl.__path__, "diskpack_cl."):
        if info.name.endswith("__main__"):
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:   # an optional extra that is not installed (vpype)
            continue
        for value in vars(module).values():
            if (isinstance(value, type) and dataclasses.is_dataclass(value)
                    and any("help" in f.metadata for f in dataclasses.fields(value))):
                found.add(value)
    return found


def test_an_option_in_two_classes_has_one_default():
    classes = _options_classes()
    assert set().union(*CLASSES.values()) <= classes
    defaults = {}
    for cls in sorted(classes, key=lambda c: c.__qualname__):
        for f in dataclasses.fields(cls):
            if "help" in f.metadata:
                defaults.setdefault(f.name, {})[cls.__qualname__] = f.default
    differ = {name: by_class for name, by_class in defaults.items()
              if len({repr(d) for d in by_class.values()}) > 1}
    assert differ == DISTINCT
