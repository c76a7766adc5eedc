"""``vpype diskpack``: the stippling inside vpype's pipeline, through vpype's own command line."""

import argparse
import re
import subprocess
import sys

import numpy as np
import pytest
import vpype
import vpype_cli
from click.testing import CliRunner
from PIL import Image

from diskpack_cl import load_gray, sample_image_path, stipple, write_stipple
from diskpack_cl.pens import ColorOptions
from diskpack_cl.drawing.writers import WriteOptions
from diskpack_cl.image import ToneOptions
from diskpack_cl.options import add_arguments, flag_name
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.vpype_plugin import diskpack

PX_PER_MM = 96 / 25.4


def _vpype(args):
    result = CliRunner().invoke(vpype_cli.cli, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return result


def _pen_downs(path):
    return len(re.findall(r"PD", path.read_text()))


def test_the_readme_pipeline_writes_every_dot_to_hpgl(tmp_path):
    """The installed ``vpype`` command, as a user runs it (vpype's ``write`` leaves its file
    to the interpreter's exit to close)."""
    out = tmp_path / "out.hpgl"
    subprocess.run([sys.executable, "-m", "vpype_cli", "diskpack", str(sample_image_path()),
                    "-n", "1000", "--pen-mm", "0.5", "layout", "a4", "linesort", "write",
                    "--device", "hp7475a", str(out)], check=True, capture_output=True)
    assert _pen_downs(out) == 1000


def _color_image(path):
    """Red, green, blue and dark grey quarters: every pen of CMYK has dots."""
    img = np.zeros((48, 64, 3), np.uint8)
    img[:24, :32] = (220, 30, 30)
    img[:24, 32:] = (30, 200, 40)
    img[24:, :32] = (40, 40, 210)
    img[24:, 32:] = (60, 60, 60)
    Image.fromarray(img).save(path)
    return path


def test_one_layer_per_pen_one_path_per_dot_on_the_page(tmp_path):
    image = _color_image(tmp_path / "quarters.png")
    doc = vpype_cli.execute(f"diskpack {image} -n 600 --colors cmyk --page a4 --pen-mm 0.5")
    names = [layer.property(vpype.METADATA_FIELD_NAME) for layer in doc.layers.values()]
    assert sorted(names) == ["black", "cyan", "magenta", "yellow"]
    assert sum(len(layer) for layer in doc.layers.values()) == 600
    assert doc.page_size == vpype.convert_page_size("a4")   # exactly: vpype's HPGL writer
                                                             # finds the paper by it


def test_dots_are_drawn_as_the_svg_draws_them(tmp_path):
    """A dot wider than the pen: rings whose outermost has radius (dot - pen) / 2."""
    doc = vpype_cli.execute("diskpack sample -n 300 --width-mm 100 --dot-mm 2 --pen-mm 0.5")
    (layer,) = doc.layers.values()
    assert len(layer) == 300
    for line in list(layer)[:20]:
        centre = 0.5 * (line.real.min() + line.real.max()) + 0.5j * (line.imag.min() + line.imag.max())
        reach = np.abs(line - centre).max() / PX_PER_MM
        assert reach == pytest.approx(0.75, abs=0.01)


def test_options_after_the_image_and_values_named_like_commands():
    """``--method diskpack``: a value, not the next command; ``stat`` is vpype's."""
    result = _vpype(["diskpack", "sample", "--method", "diskpack", "-n", "200", "stat"])
    assert "Path count: 200" in result.output


def _argparse_options(*classes):
    parser = argparse.ArgumentParser()
    groups = {}
    for cls in classes:
        add_arguments(parser, cls, groups=groups)
    return {o for a in parser._actions for o in a.option_strings if o.startswith("--")}


def test_the_options_are_those_of_diskpack_stipple():
    classes = (StippleOptions, ToneOptions, WriteOptions, ColorOptions)
    mine = {o for p in diskpack.params for o in p.opts if o.startswith("--")}
    assert mine == _argparse_options(*classes) - {"--help", flag_name("png_scale"),
                                                  flag_name("preview")}


def test_a_bad_value_is_refused_as_diskpack_stipple_refuses_it():
    result = CliRunner().invoke(vpype_cli.cli, ["diskpack", "sample", "-n", "100",
                                                "--black-point", "2"])
    assert result.exit_code == 2
    assert "--black-point': must be in [0, 1], got 2.0" in result.output


def test_help_leads_with_the_everyday_options_and_examples():
    """The options of diskpack stipple's first groups come first, in their order."""
    import click

    from diskpack_cl.cli import LEADING

    leading = [d for _, group in LEADING for d, _ in group]
    names = [p.name for p in diskpack.params if isinstance(p, click.Option)]
    first = names[:len(set(names) & set(leading))]
    assert set(first) <= set(leading) and first == sorted(first, key=leading.index)
    text = _vpype(["diskpack", "--help"]).output
    assert "at most 2 s" not in " ".join(text.split())
    assert "--plotter" in text.partition("Examples:")[2].partition("Options:")[0]


def test_every_example_of_the_help_parses():
    """Each example's diskpack tokens parse, and what follows is a vpype command."""
    import click
    import shlex

    block = diskpack.help.partition("Examples:")[2].replace("\\\n", " ")
    examples = [shlex.split(line)[1:] for line in block.splitlines()
                if line.strip().startswith("vpype ")]
    assert examples
    parent = click.Context(vpype_cli.cli)
    for args in examples:
        assert args[0] == "diskpack"
        ctx = diskpack.make_context("diskpack", args[1:], parent=parent)
        assert ctx.params["n"] == 20000 and ctx.args[0] in vpype_cli.cli.commands, args


def test_a_note_is_diskpack_s_not_the_root_logger_s(tmp_path):
    """A note says 'diskpack: note:' on stderr, as diskpack stipple does (not WARNING:root:)."""
    image = tmp_path / "g.png"
    Image.fromarray(np.tile(np.linspace(0, 255, 24), (24, 1)).astype(np.uint8)).save(image)
    run = subprocess.run([sys.executable, "-m", "vpype_cli", "diskpack", str(image), "-n", "200",
                          "--width-mm", "60", "--pen-mm", "5", "--schedule", "pack", "stat"],
                         capture_output=True, text=True, check=True)
    assert "diskpack: note: " in run.stderr and "will look darker" in run.stderr
    assert "WARNING:root" not in run.stderr


@pytest.mark.parametrize("variable", ["DISKPACK_DEVICE", "PYOPENCL_CTX"])
def test_a_device_asked_for_that_does_not_exist_is_an_error(ctx, tmp_path, monkeypatch, variable):
    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.setenv(variable, "no-such-device")
    out = tmp_path / "x.svg"
    result = CliRunner().invoke(vpype_cli.cli, ["diskpack", "sample", "-n", "100", "write",
                                                str(out)])
    assert result.exit_code == 2
    assert (f"{variable}=no-such-device: no OpenCL device matches 'no-such-device'"
            in result.output)
    assert not out.exists()


@pytest.mark.parametrize("field, value", [("black_point", 0.3), ("white_point", 0.6),
                                          ("tone_gamma", 2.5)])
def test_each_tone_option_reaches_the_stippling(tmp_path, field, value):
    """The drawing of ``vpype diskpack`` with a tone option is that of the Python API's
    stippling of the image with that tone, and not the default tone's."""
    gray = load_gray(sample_image_path())
    api = tmp_path / "api.svg"
    write_stipple(api, stipple(ToneOptions(**{field: value}).adjust(gray), 150), width_mm=100)
    expected = vpype.read_multilayer_svg(str(api), vpype.convert_length("0.1mm"))
    doc = vpype_cli.execute(f"diskpack sample -n 150 --width-mm 100 {flag_name(field)} {value}")
    plain = vpype_cli.execute("diskpack sample -n 150 --width-mm 100")
    lines = [list(d.layers[1]) for d in (doc, expected, plain)]
    assert len(lines[0]) == len(lines[1])
    assert all(np.allclose(a, b) for a, b in zip(lines[0], lines[1]))
    assert not all(a.shape == b.shape and np.allclose(a, b) for a, b in zip(lines[0], lines[2]))
