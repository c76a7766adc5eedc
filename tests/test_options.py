"""Every option is one dataclass field: the command line offers it and its value reaches the library."""

import dataclasses
import importlib

import numpy as np
import pytest

from diskpack_cl import cli, poisson
from diskpack_cl.jobs import items as jobs
from diskpack_cl.pens import ColorOptions
from diskpack_cl.drawing.writers import WriteOptions, write_npz
from diskpack_cl.image import ToneOptions
from diskpack_cl.options import OptionConflict, describe, flag_name
from diskpack_cl.relax import RELAX_FIELDS, RelaxOptions
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import stipple

IMAGE_MODULE = importlib.import_module("diskpack_cl.image")

#: Options another option needs to be valid with it.
COMPANIONS = {"gamma": ["--radii", "gray"], "margin_mm": ["--page", "a4"],
              "landscape": ["--page", "a4"], "pen_order": ["--colors", "cmy"],
              "plotter": ["--page", "a4"]}


def _cli_fields(cls):
    return [f for f in dataclasses.fields(cls) if f.metadata.get("cli")]


def _example(f):
    """A valid value other than the field's default, and the arguments that give it."""
    m = f.metadata
    if isinstance(f.default, bool):
        return True, [flag_name(f.name)]
    choices = m["cli_choices"] or m["choices"]
    if choices is not None:
        value = [c for c in choices if c != f.default][-1]
    elif f.name == "page":
        value = "a4"
    elif f.name == "plotter":
        value = "hp7475a"
    elif f.name == "pens":
        value = "black=#000,red=#c00"
    elif f.name == "colors":
        value = "auto:3"
    elif f.name == "pen_order":
        return ["cyan", "yellow", "magenta"], ["--pen-order", "cyan,yellow,magenta"]
    elif f.name == "pen_dots":
        return {"cyan": 20, "yellow": 5}, ["--pen-dots", "cyan=20,yellow=5"]
    elif f.name == "seed":
        value = 7
    elif m["integer"]:
        value = (m["lo"] or 0) + 2
    elif m["hi"] is not None:
        value = 0.5 * (m["lo"] + m["hi"])
    else:
        value = (m["lo"] or 0) + 0.5
    return value, [flag_name(f.name), str(value)]


def _cases(*classes):
    return [pytest.param(f, id=f.name) for cls in classes for f in _cli_fields(cls)]


class Stop(Exception):
    """Raised by a fake library function once it has recorded its arguments."""


@pytest.fixture(scope="module")
def small_result():
    gray = np.tile(np.linspace(0.0, 1.0, 24), (16, 1))
    return stipple(gray, 20, schedule=[("pack", 1)], backend="exact")


def _run(argv):
    try:
        cli.main(argv)
    except Stop:
        pass


@pytest.mark.parametrize("f", _cases(StippleOptions, ToneOptions))
def test_every_stipple_option_reaches_stipple(f, monkeypatch, tmp_path):
    value, argv = _example(f)
    seen = {}

    def fake(image, n, options=None, **kwargs):
        seen["options"] = options
        raise Stop

    def tone(gray, copy=True, **kwargs):   # copy: whether the loaded picture is adjusted in place
        seen["tone"] = kwargs
        return np.asarray(gray, dtype=np.float64)

    monkeypatch.setattr(jobs, "stipple", fake)
    monkeypatch.setattr(IMAGE_MODULE, "adjust_tone", tone)
    _run(["stipple", "sample", "-n", "50", "-o", str(tmp_path / "o.svg"), *argv,
          *COMPANIONS.get(f.name, [])])
    if f.name in describe(ToneOptions):
        assert seen["tone"] == ToneOptions(**{f.name: value}).params()
    else:
        assert getattr(seen["options"], f.name) == value


@pytest.mark.parametrize("f", _cases(StippleOptions, ToneOptions, WriteOptions))
def test_every_stipple_option_reaches_a_batch_item(f, monkeypatch, tmp_path):
    value, argv = _example(f)
    seen = []

    def fake(item, device, progress):
        seen.append((StippleOptions(**item.params["options"]),
                     ToneOptions(**item.params["tone"]), WriteOptions(**item.write)))
        raise Stop

    monkeypatch.setitem(jobs._KINDS, "stipple", fake)
    _run(["stipple", "sample", "-n", "50", "-o", str(tmp_path / "{stem}.svg"), "--manifest",
          str(tmp_path / "m.jsonl"), *argv, *COMPANIONS.get(f.name, [])])
    (objects,) = seen
    owner = next(o for o in objects if f.name in describe(type(o)))
    assert getattr(owner, f.name) == value


class _OnePen:
    """A mono result dressed as a colour one (``names``, ``pen``: one pen), for the fakes."""

    def __init__(self, result):
        self._result, self.names, self.pen = result, ("black",), np.zeros(result.n, dtype=int)

    def __getattr__(self, name):
        return getattr(self._result, name)


@pytest.mark.parametrize("command", ["stipple", "export"])
@pytest.mark.parametrize("f", _cases(WriteOptions))
def test_every_write_option_reaches_the_writers(f, command, small_result, monkeypatch, tmp_path):
    value, argv = _example(f)
    seen = {}

    def fake(result, gray, outputs, options=None, **kwargs):
        seen["options"] = options
        raise Stop

    monkeypatch.setattr(jobs, "write_stipple_outputs", fake)
    monkeypatch.setattr(jobs, "stipple", lambda *a, **k: small_result)
    monkeypatch.setattr(jobs, "stipple_colors", lambda *a, **k: _OnePen(small_result))
    src = tmp_path / "in.npz"
    write_npz(src, small_result)
    head = (["stipple", "sample", "-n", "20"] if command == "stipple" else ["export", str(src)])
    extra = COMPANIONS.get(f.name, []) if command == "stipple" or f.name != "pen_order" else []
    _run([*head, "-o", str(tmp_path / "o.svg"), *argv, *extra])
    assert getattr(seen["options"], f.name) == value


@pytest.mark.parametrize("f", _cases(ColorOptions))
def test_every_color_option_reaches_stipple_colors(f, monkeypatch, tmp_path):
    value, argv = _example(f)
    seen = {}

    def fake(image, n, **kwargs):
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(jobs, "stipple_colors", fake)
    pens = [] if f.name in ("colors", "pens") else ["--colors", "cmy"]
    _run(["stipple", "sample", "-n", "50", "-o", str(tmp_path / "o.svg"), *argv, *pens])
    assert seen[{"pens": "colors", "pen_dots": "counts"}.get(f.name, f.name)] == value


@pytest.mark.parametrize("command", ["poisson", "relax"])
@pytest.mark.parametrize("f", _cases(RelaxOptions))
def test_every_relax_option_reaches_relax_poisson(f, command, monkeypatch, tmp_path):
    value, argv = _example(f)
    seen = {}

    def fake(points, eps=None, options=None, **kwargs):
        seen["options"] = (options or RelaxOptions()).replace(
            **({} if eps is None else {"eps": eps}),
            **{k: v for k, v in kwargs.items() if k in RELAX_FIELDS})
        raise Stop

    # relax runs it from the jobs, poisson's sets from poisson_disk
    monkeypatch.setattr(jobs if command == "relax" else poisson, "relax_poisson", fake)
    src = tmp_path / "in.npy"
    np.save(src, np.random.default_rng(0).random((16, 2)))
    head = ["poisson", "-n", "16", "--init", "random"] if command == "poisson" else \
        ["relax", str(src)]
    _run([*head, "-o", str(tmp_path / "o.npz"), *argv])
    assert getattr(seen["options"], f.name) == value


@pytest.mark.parametrize("cls", [StippleOptions, ToneOptions, WriteOptions, RelaxOptions,
                                 ColorOptions])
def test_every_field_has_help_and_a_checked_default(cls):
    for name, d in describe(cls).items():
        assert d["help"] and not d["help"].endswith(" "), name
    cls()  # the defaults pass their own checks


@pytest.mark.parametrize("argv, message, cls, kwargs", [
    (["--method", "lloyd", "--schedule", "paper"], "--method lloyd runs Lloyd iterations only",
     StippleOptions, dict(method="lloyd", schedule="paper")),
    (["--beta", "3", "--schedule", "paper"], "--beta build the schedule the paper's way",
     StippleOptions, dict(beta=3, schedule="paper")),
    (["--gamma", "2"], "--gamma = 2 has no effect with density radii", StippleOptions,
     dict(gamma=2.0)),
    (["--dot-mm", "1", "--dots", "packing"], "--dot-mm 1 and --dots packing both set",
     WriteOptions, dict(dot_mm=1.0, dots="packing")),
    (["--black-point", "0.6", "--white-point", "0.5"],
     "--black-point 0.6 must be below --white-point 0.5", ToneOptions,
     dict(black_point=0.6, white_point=0.5)),
])
def test_conflicts_are_refused_once_with_the_flag_names(argv, message, cls, kwargs, tmp_path,
                                                        capsys):
    assert cli.main(["stipple", "sample", "-n", "50", "-o", str(tmp_path / "o.svg"),
                     *argv]) == 2
    assert message in capsys.readouterr().err
    with pytest.raises(OptionConflict):   # the library refuses them the same way
        cls(**kwargs)


@pytest.mark.parametrize("phase, message", [
    (("pack", -5), "iterations must be an integer >= 0, got -5"),
    (("pack", 2.5), "iterations must be an integer >= 0, got 2.5"),
    (("pack", "3"), "iterations must be an integer >= 0, got '3'"),
    (("jump", 3), "kind must be 'pack', 'mix' or 'lloyd', got 'jump'"),
    (("lloyd", 3, 0.5), "only 'mix' takes a blend"),
    (("mix", 3, 1.5), r"blend must be in \[0, 1\], got 1.5"),
    ("pack", r"bad schedule phase 'pack': \(kind, iterations\)"),
])
def test_a_bad_schedule_phase_names_the_part_that_is_wrong(phase, message):
    with pytest.raises(ValueError, match=message):
        StippleOptions(schedule=[phase])
