"""Tests of diskpack_cl.plots: the reports write readable figures and return their numbers."""

import dataclasses
import json
import math
import sys

import numpy as np
import pytest
from PIL import Image

from diskpack_cl import analysis, picture_measures, plots

pytest.importorskip("matplotlib")


def test_point_set_report_writes_png_and_returns_numbers(tmp_path):
    rng = np.random.default_rng(0)
    sets = list(rng.random((3, 300, 2)))
    copies = [s.copy() for s in sets]
    out = tmp_path / "report.png"
    numbers = plots.point_set_report(sets, out, title="uniform random")
    for s, c in zip(sets, copies):
        np.testing.assert_array_equal(s, c)
    with Image.open(out) as im:
        im.load()
        assert im.format == "PNG"
        assert 900 <= im.size[0] <= 1100 and 250 <= im.size[1] <= 350  # about 10 x 3 in at 100 dpi
    assert out.stat().st_size < 300_000
    assert not [p for p in tmp_path.iterdir() if p.name != "report.png"]  # no temporary left behind
    assert numbers["n"] == 300 and numbers["realizations"] == 3
    assert numbers["kmax"] == math.ceil(2 * math.sqrt(300))
    assert numbers["rho"] == pytest.approx(analysis.normalized_radius(sets[0]))
    assert numbers["rho_min"] <= numbers["rho_mean"]
    assert numbers["mean_rho"] == pytest.approx(np.mean([analysis.mean_normalized_radius(s) for s in sets]))
    assert numbers["anisotropy_reference_db"] == pytest.approx(-10 * math.log10(3))
    freqs, P = analysis.periodogram(sets)
    _, power = analysis.radial_power(P, freqs)
    np.testing.assert_allclose(numbers["radial_power"], power)
    assert len(numbers["radial_frequency"]) == len(numbers["anisotropy_db"]) == numbers["kmax"]
    json.dumps(numbers, allow_nan=False)  # what `diskpack analyze --json` prints


def test_point_set_report_of_one_set_and_other_formats(tmp_path):
    pts = np.random.default_rng(1).random((128, 2))
    numbers = plots.point_set_report(pts, tmp_path / "one.svg", kmax=10)
    assert numbers["realizations"] == 1 and numbers["kmax"] == 10
    assert (tmp_path / "one.svg").read_text().lstrip().startswith("<?xml")
    with pytest.raises(ValueError, match=r"unknown figure extension '\.jpg' \(use \.png, \.pdf or \.svg\)"):
        plots.point_set_report(pts, tmp_path / "x.jpg")
    with pytest.raises(FileNotFoundError, match="output directory does not exist"):
        plots.point_set_report(pts, tmp_path / "missing" / "x.png")


@dataclasses.dataclass
class FakeCertificate:
    valid: bool
    min_gap: float
    pairs_checked: int


def test_stipple_report_writes_png_and_returns_numbers(tmp_path):
    rng = np.random.default_rng(2)
    ny, nx = 96, 128
    yy, xx = np.mgrid[0:ny, 0:nx]
    darkness = 0.15 + 0.7 * np.exp(-((xx - 64) ** 2 + (yy - 48) ** 2) / 800.0)
    # rejection sampling: density proportional to darkness
    cand = rng.random((3000, 2)) * [nx, ny]
    dark_at = darkness[cand[:, 1].astype(int), cand[:, 0].astype(int)]
    pts = cand[rng.random(3000) < dark_at]
    radii = np.full(len(pts), 0.8)
    out = tmp_path / "stipple.png"
    cert = FakeCertificate(True, 0.0123, 4567)
    numbers = plots.stipple_report(pts, radii, darkness, out, certificate=cert, title="test")
    with Image.open(out) as im:
        im.load()
        assert im.format == "PNG"
    assert out.stat().st_size < 300_000
    measures = picture_measures.stipple_measures(pts, darkness)
    for key, value in measures.items():
        assert numbers[key] == (None if np.isnan(value) else pytest.approx(value))
    assert numbers["tone_radius"] == pytest.approx(picture_measures.tone_radius(len(pts), darkness))
    assert numbers["radius_min"] == numbers["radius_max"] == pytest.approx(0.8)
    assert numbers["certificate"] == {"valid": True, "min_gap": 0.0123, "pairs_checked": 4567}
    json.dumps(numbers, allow_nan=False)


def test_stipple_report_without_radii_or_certificate(tmp_path):
    rng = np.random.default_rng(3)
    darkness = np.full((40, 40), 0.4)
    pts = rng.random((200, 2)) * 40
    numbers = plots.stipple_report(pts, None, darkness, tmp_path / "s.png", certificate={"valid": False})
    assert "radius_min" not in numbers
    assert numbers["certificate"] == {"valid": False}
    with pytest.raises(ValueError, match=r"radii must have shape \(200,\), got \(3,\)"):
        plots.stipple_report(pts, [1, 2, 3], darkness, tmp_path / "t.png")
    assert not (tmp_path / "t.png").exists()


def test_missing_matplotlib_says_how_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    pts = np.random.default_rng(4).random((50, 2))
    with pytest.raises(ImportError, match=r'plots need matplotlib: \.venv/bin/pip install "\.\[plot\]"'):
        plots.point_set_report(pts, tmp_path / "r.png")
    assert not (tmp_path / "r.png").exists()
