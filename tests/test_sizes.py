"""Drawn sizes: a warning when the dots are drawn far wider than their spacing."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

from diskpack_cl import cli
from diskpack_cl.drawing import CROWDED_RATIO
from diskpack_cl.export import write_stipple, write_svg

SVG = "{http://www.w3.org/2000/svg}"


def _grid(w=60, h=40, step=8.0, r=2.0):
    """Disjoint disks on a grid of a ``w x h`` px picture, the outer ones on its edge."""
    gx, gy = np.meshgrid(np.arange(r, w - r + 1e-9, step), np.arange(r, h - r + 1e-9, step))
    points = np.column_stack([gx.ravel(), gy.ravel()])
    return SimpleNamespace(points=points, radii=np.full(len(points), r), width=w, height=h,
                           k=0.5, tone_radius=1.0)


# ------------------------------------------------------------ dots drawn far wider than their spacing

def test_dots_far_wider_than_their_spacing_are_warned_of(capsys, tmp_path):
    rc = cli.main(["stipple", "sample", "-n", "2000", "--dot-mm", "50", "-o",
                   str(tmp_path / "x.svg")])
    err = capsys.readouterr().err
    assert rc == 0
    assert re.search(r"warning: dots of 50 mm overlap their neighbours: median spacing of "
                     r"their centres on paper [0-9.]+ mm \(warned above 2 x\); see --no-overlap",
                     err), err


def test_the_default_dots_of_a_photograph_are_not_warned_of(capsys, tmp_path):
    assert cli.main(["stipple", "sample", "-n", "2000", "-o", str(tmp_path / "x.svg")]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("flags, warned", [
    ([], False),
    (["--dot-mm", "4.5"], True),     # grid spacing 2.12 mm: 4.5 > 2 x 2.12
    (["--dot-mm", "4"], False),      # 4 < 2 x 2.12: neighbours overlap, centres stay clear
    (["--dot-mm", "4.5", "--no-overlap"], False),
    (["--dot-mm", "4.5", "--quiet"], False),
])
def test_export_warns_of_dots_wider_than_twice_their_spacing(tmp_path, capsys, monkeypatch,
                                                             flags, warned):
    monkeypatch.chdir(tmp_path)
    write_stipple("dots.npz", _grid(240, 160))
    assert cli.main(["export", "dots.npz", "-o", "a.svg", "--dpi", "96", *flags]) == 0
    assert ("warning: dots of" in capsys.readouterr().err) == warned


def test_the_svg_reports_the_spacing_and_the_ink_width(tmp_path):
    info = write_svg(tmp_path / "a.svg", _grid(), width_mm=60, dot_mm=3.0)
    assert info["median_spacing_mm"] == pytest.approx(8.0)
    assert info["median_ink_mm"] == pytest.approx(3.0)
    assert CROWDED_RATIO == 2
