"""``--plotter NAME``: the picture inside the part of the page vpype's device profile plots."""

import io
import json
import os
import re
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import vpype

from diskpack_cl.cli import main
from diskpack_cl.drawing.plotters import plotting_area

PX_PER_MM = 96 / 25.4


def _hpgl_pen_downs(doc, **page):
    """vpype's own HPGL writer, as ``vpype write --device hp7475a --page-size a4`` runs it."""
    out = io.StringIO()
    vpype.write_hpgl(out, doc, page_size="a4", center=False, device="hp7475a", velocity=None,
                     quiet=True, **page)
    return len(re.findall("PD", out.getvalue()))


@pytest.mark.parametrize("landscape", [False, True])
def test_the_area_is_what_vpype_keeps(landscape):
    """Ticks just inside each side of the area survive vpype's crop; just outside they go."""
    page = (297.0, 210.0) if landscape else (210.0, 297.0)
    x0, y0, x1, y1 = plotting_area("hp7475a", page)
    mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    for inset, kept in ((0.2, 4), (-0.2, 0)):
        ticks = [(x0 + inset, my), (x1 - inset, my), (mx, y0 + inset), (mx, y1 - inset)]
        doc = vpype.Document(page_size=(page[0] * PX_PER_MM, page[1] * PX_PER_MM))
        for x, y in ticks:
            doc.add(vpype.LineCollection([np.array([complex(x, y), complex(x + 0.01, y)])
                                          * PX_PER_MM]), 1)
        assert _hpgl_pen_downs(doc, landscape=landscape) == kept


def _dots_after_vpype(tmp_path, *plotter):
    out = tmp_path / "photo.svg"
    assert main(["stipple", "sample", "-n", "3000", "--page", "a4", *plotter, "-o", str(out),
                 "-q"]) == 0
    return _hpgl_pen_downs(vpype.read_multilayer_svg(str(out), 0.1 * PX_PER_MM),
                           landscape=False)


def test_the_readme_pipeline_keeps_every_dot_with_the_plotter(tmp_path):
    assert _dots_after_vpype(tmp_path) < 3000   # the default margins reach past its area
    assert _dots_after_vpype(tmp_path, "--plotter", "hp7475a") == 3000


def test_an_unknown_plotter_is_refused_with_the_known_ones(capsys):
    assert main(["stipple", "sample", "-n", "100", "--page", "a4", "--plotter", "hp9999",
                 "-o", "x.svg"]) == 2
    assert "hp7475a" in capsys.readouterr().err


def test_each_pen_has_its_plot_time_and_they_add_up(tmp_path, capsys):
    from PIL import Image

    img = np.zeros((24, 32, 3), np.uint8)
    img[:, :16] = (220, 30, 30)
    img[:, 16:] = (30, 60, 200)
    Image.fromarray(img).save(tmp_path / "two.png")
    assert main(["stipple", str(tmp_path / "two.png"), "-n", "300", "--colors", "cmyk",
                 "--pen-mm", "0.5", "--page", "a5", "-o", str(tmp_path / "c.svg"), "--json"]) == 0
    out, err = capsys.readouterr()
    plot = json.loads(out.splitlines()[-1])["plot"]
    assert sum(layer["plot_seconds"] for layer in plot["layers"]) == pytest.approx(
        plot["plot_seconds"], rel=1e-12)
    assert all(f"{layer['name']} " in err.split("plot about")[1] for layer in plot["layers"])


PROFILE = """
[device.foo]
name = "foo"
plotter_unit_length = "{unit}"
{pens}
[[device.foo.paper]]
name = "a4"
paper_size = ["210mm", "297mm"]
y_axis_up = false
origin_location = ["0mm", "0mm"]
x_range = {x_range}
y_range = [0, 11000]
"""


@pytest.mark.parametrize("profile, message", [
    ("[device.foo\n", r"vpype's profiles in \S+/\.vpype\.toml are not valid TOML: Expected ']'"),
    (PROFILE.format(unit="0.025mm", pens="", x_range="[0, 8000]"),
     r"profile of the plotter 'foo' in \S+/\.vpype\.toml is unreadable: it has no 'pen_count'"),
    (PROFILE.format(unit="0.025mm", pens="pen_count = 1", x_range='["a", 8000]'),
     r"profile of the plotter 'foo' in \S+/\.vpype\.toml is unreadable: its paper 'a4' has "
     r"x_range \('a', 8000\)"),
    (PROFILE.format(unit="-0.025mm", pens="pen_count = 1", x_range="[0, 8000]"),
     r"profile of the plotter 'foo' in \S+/\.vpype\.toml leaves no plotting area on a 210x297 "
     r"mm page \(x 0 to 0 mm.*plotter_unit_length -0.0944882 px\)"),
    (PROFILE.format(unit="0.025mm", pens="pen_count = 1", x_range="[0, 10]"),
     r"the 10 mm margins and the plotting area of foo \(x 0 to 0.3 mm, y 0 to 275 mm\) leave "
     r"no room on the 210x297 mm page"),
])
def test_a_bad_profile_is_named_with_its_file_and_area(tmp_path, profile, message):
    (tmp_path / ".vpype.toml").write_text(profile)
    done = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", "export",
                           str(_stippling(tmp_path)), "--page", "a4", "--plotter", "foo",
                           "-o", str(tmp_path / "x.svg")],
                          env={**os.environ, "HOME": str(tmp_path)}, capture_output=True, text=True)
    assert done.returncode in (1, 2) and re.search(message, done.stderr), done.stderr
    assert not (tmp_path / "x.svg").exists()


def test_a_picture_too_large_names_the_plotting_area(tmp_path, capsys):
    assert main(["export", str(_stippling(tmp_path)), "--page", "a4", "--plotter", "hp7475a",
                 "--width-mm", "300", "-o", str(tmp_path / "x.svg")]) == 1
    assert ("does not fit inside the 10 mm margins of the 210x297 mm page and the plotting area "
            "of hp7475a (x 4 to 196.1 mm, y 10 to 284.7 mm)") in capsys.readouterr().err


def _stippling(folder):
    from diskpack_cl.drawing.writers import write_stipple

    path = folder / "dots.npz"
    write_stipple(path, SimpleNamespace(points=np.array([[10.0, 10.0], [30.0, 20.0]]),
                                        radii=np.array([2.0, 2.0]), width=40, height=30,
                                        k=0.5, tone_radius=1.0))
    return path


@pytest.mark.parametrize("margin, shown", [([], "got 10 (the default)"),
                                           (["--margin-mm", "7"], "got 7 (given)")])
def test_a_margin_too_wide_for_the_page_shows_the_margin_used(tmp_path, capsys, margin, shown):
    assert main(["export", str(_stippling(tmp_path)), "--page", "10x10mm", *margin,
                 "-o", str(tmp_path / "x.svg")]) == 1
    assert f"--margin-mm must be in [0, 5) on a 10x10 mm page, {shown}" in capsys.readouterr().err
