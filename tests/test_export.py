"""Stippling writers: SVG, PNG, NPZ, CSV, pen path, atomicity."""

import csv
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl.drawing import writers as export
from diskpack_cl.domain import Domain
from diskpack_cl.drawing.writers import (
    check_output_path,
    path_travel,
    pen_path_order,
    read_stipple,
    write_csv,
    write_npz,
    write_png,
    write_stipple,
    write_svg,
)
from diskpack_cl.geometry import certify_disks

SVG = "{http://www.w3.org/2000/svg}"
INK = "{http://www.inkscape.org/namespaces/inkscape}"


@pytest.fixture
def result():
    rng = np.random.default_rng(3)
    W, H = 80, 60
    # a jittered 20 x 10 grid: disjoint disks inside the picture, as read_stipple demands
    gx, gy = np.meshgrid(2 + 4 * np.arange(20), 3 + 6 * np.arange(10))
    pts = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-0.5, 0.5, (200, 2))
    pts = pts[rng.permutation(200)]
    radii = rng.uniform(0.3, 1.0, 200)
    cert = certify_disks(pts, radii, Domain.rect(W, H))   # the real certificate type
    return SimpleNamespace(points=pts, radii=radii, k=0.5,
                           width=W, height=H, certificate=cert, tone_radius=0.6,
                           base_radii=np.ones(200), params={"n": 200})


def _svg_circles(path):
    root = ET.parse(path).getroot()
    layers = [g for g in root.iter(SVG + "g") if g.get(INK + "groupmode") == "layer"]
    assert len(layers) == 1
    return root, layers[0], layers[0].findall(SVG + "circle")


def test_svg_layer_circles_and_size(tmp_path, result):
    out = tmp_path / "a.svg"
    info = write_svg(out, result, width_mm=160.0)
    root, layer, circles = _svg_circles(out)
    assert len(circles) == 200
    assert root.get("width") == "160mm"
    assert root.get("height") == "120mm"  # aspect 80:60 kept
    assert root.get("viewBox") == "0 0 160 120"
    assert info["moved_inside"] == 0  # no dot near an edge
    assert info["travel_after_mm"] < info["travel_before_mm"]
    # the circles are the input dots (in some order), scaled to mm
    xy = np.array([[float(c.get("cx")), float(c.get("cy"))] for c in circles])
    key = lambda a: a[np.lexsort(a.T)]
    np.testing.assert_allclose(key(xy), key(result.points * 2.0), atol=1e-4)


def test_svg_dpi_and_fixed_dot(tmp_path, result):
    out = tmp_path / "b.svg"
    write_svg(out, result, dpi=25.4, dot_mm=0.5)  # 1 px = 1 mm
    root, _, circles = _svg_circles(out)
    # a size from dpi is exact in CSS pixels (96 per inch)
    assert root.get("width") == f"{80 / 25.4 * 96:.10g}px"
    assert root.get("height") == f"{60 / 25.4 * 96:.10g}px"
    assert root.get("viewBox") == "0 0 80 60"
    assert {c.get("r") for c in circles} == {"0.2500"}


def test_svg_box_fit_and_conflicts(tmp_path, result):
    out = tmp_path / "c.svg"
    info = write_svg(out, result, width_mm=100.0, height_mm=30.0)
    assert info["height_mm"] == pytest.approx(30.0) and info["width_mm"] == pytest.approx(40.0)
    with pytest.raises(ValueError, match="either by width_mm/height_mm or by dpi"):
        write_svg(out, result, width_mm=10, dpi=300)


def test_png_size_and_antialiasing(tmp_path, result):
    out = tmp_path / "a.png"
    info = write_png(out, result, png_scale=2.0)
    with Image.open(out) as im:
        assert im.size == (160, 120) == (info["width"], info["height"])
        a = np.asarray(im)
    assert a.min() < 64 and a.max() == 255
    assert len(np.unique(a)) > 3  # grey edge pixels: anti-aliased


def test_png_coverage_matches_ink(tmp_path):
    # one disk of radius 10 px: the ink equals its area within 1%
    res = SimpleNamespace(points=np.array([[32.3, 31.7]]), radii=np.array([10.0]),
                          width=64, height=64)
    out = tmp_path / "d.png"
    write_png(out, res, dots="packing", png_scale=1.0)
    ink = (255 - np.asarray(Image.open(out), dtype=float)).sum() / 255
    assert ink == pytest.approx(np.pi * 100, rel=0.01)


@settings(max_examples=40)
@given(seed=st.integers(0, 2**16), aa=st.integers(1, 5), n=st.integers(1, 30))
def test_ink_coverage_counts_the_samples_inside_each_disk(seed, aa, n):
    """The PNG's ink (:func:`~diskpack_cl.drawing.page.ink_coverage`) against brute force:
    every sample point of every pixel tested against every disk, dots of every size
    across the picture's edges too, the sum clipped at 1."""
    from diskpack_cl.drawing.page import ink_coverage

    rng = np.random.default_rng(seed)
    W, H = 23, 17
    c = rng.random((n, 2)) * [W + 8, H + 8] - 4
    r = rng.uniform(0.05, 6.0, n)
    s = (np.arange(aa) + 0.5) / aa
    X, Y = (np.arange(W)[:, None] + s).ravel(), (np.arange(H)[:, None] + s).ravel()
    want = np.zeros((H, W))
    for (cx, cy), R in zip(c, r):
        h2 = R * R - (Y - cy) ** 2
        inside = (h2[:, None] >= 0) & (np.abs(X[None, :] - cx) <= np.sqrt(np.maximum(h2, 0.0))[:, None])
        want += inside.reshape(H, aa, W, aa).sum(axis=(1, 3)) / aa ** 2
    np.testing.assert_allclose(ink_coverage(c, r, W, H, aa), np.minimum(want, 1.0), rtol=0, atol=1e-12)


def test_npz_round_trip(tmp_path, result):
    out = tmp_path / "a.npz"
    write_npz(out, result)
    with np.load(out) as z:
        np.testing.assert_array_equal(z["points"], result.points)
        np.testing.assert_array_equal(z["radii"], result.radii)
        assert float(z["k"]) == 0.5 and int(z["width"]) == 80 and int(z["height"]) == 60
        cert = result.certificate.as_dict()
        assert {k[len("certificate_"):] for k in z.files if k.startswith("certificate_")} == set(cert)
        for name, v in cert.items():
            assert z[f"certificate_{name}"].item() == v


def test_read_stipple_round_trips_write_stipple(tmp_path, result):
    out = tmp_path / "a.npz"
    write_stipple(out, result)
    back = read_stipple(out)
    np.testing.assert_array_equal(back.points, result.points)
    np.testing.assert_array_equal(back.radii, result.radii)
    np.testing.assert_array_equal(back.base_radii, result.base_radii)
    assert (back.k, back.width, back.height, back.params) == (0.5, 80, 60, {"n": 200})
    again = tmp_path / "b.npz"   # what it reads, write_stipple writes again
    write_stipple(again, back)
    with np.load(out) as z1, np.load(again) as z2:
        assert set(z2.files) == set(z1.files)
        for name in z2.files:
            np.testing.assert_array_equal(z2[name], z1[name])


@pytest.mark.parametrize("ext, opts", [
    ("npz", {}), ("csv", {}), ("svg", {}), ("svg", dict(pen_mm=0.5, width_mm=100)),
    ("svg", dict(dots="packing", pen_mm=0.3, page="a5", margin_mm=15)),
    ("svg", dict(dot_mm=0.7, invert=True, page="a4", landscape=True)),
])
def test_every_format_reads_back_and_writes_again_identically(tmp_path, result, ext, opts):
    out, again = tmp_path / f"a.{ext}", tmp_path / f"b.{ext}"
    write_stipple(out, result, **opts)
    back = read_stipple(out)
    assert (back.width, back.height, back.k) == (80, 60, 0.5)
    key = lambda a: a[np.lexsort(a.T)]   # the SVG holds the dots in pen-path order
    np.testing.assert_allclose(key(back.points), key(result.points), atol=1e-3)
    write_stipple(again, back, **opts)
    if ext == "npz":
        with np.load(out) as z1, np.load(again) as z2:
            assert set(z1.files) == set(z2.files)
            for name in z1.files:
                np.testing.assert_array_equal(z2[name], z1[name])
    else:
        assert again.read_text() == out.read_text()


def test_read_stipple_formats_without_dots(tmp_path, result):
    write_png(tmp_path / "a.png", result)
    with pytest.raises(ValueError, match=r"reads \.npz, \.csv, \.svg files; a \.png preview "
                                         r"holds no dots"):
        read_stipple(tmp_path / "a.png")
    (tmp_path / "other.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg"/>')
    with pytest.raises(ValueError, match="not written by diskpack_cl"):
        read_stipple(tmp_path / "other.svg")


def test_read_stipple_of_a_point_set_or_a_bad_file(tmp_path):
    from diskpack_cl.io import write_points

    write_points(tmp_path / "p.npz", np.random.default_rng(0).random((8, 2)))
    assert read_stipple(tmp_path / "p.npz") is None
    (tmp_path / "bad.npz").write_bytes(b"plain text")
    with pytest.raises(ValueError, match=r"bad\.npz: unreadable \.npz file"):
        read_stipple(tmp_path / "bad.npz")
    with pytest.raises(FileNotFoundError, match=r"nope\.npz: no such file"):
        read_stipple(tmp_path / "nope.npz")


def test_csv_round_trip(tmp_path, result):
    out = tmp_path / "a.csv"
    write_csv(out, result)
    with open(out, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["# diskpack_cl stippling width=80 height=60 k=0.5 tone_radius=0.6"]
    assert rows[1] == ["x", "y", "r"]
    a = np.array(rows[2:], dtype=float)
    np.testing.assert_array_equal(a[:, :2], result.points)
    np.testing.assert_array_equal(a[:, 2], result.radii)


def test_csv_records_light_dots_on_dark_paper(tmp_path, result):
    """A stippling made for dark paper says so in its CSV's first line, reads back with
    it (as from an .npz) and writes again the same; a bad value there is refused."""
    inverted = SimpleNamespace(**{**vars(result), "params": {"invert": True}})
    out, again = tmp_path / "a.csv", tmp_path / "b.csv"
    write_csv(out, inverted)
    assert out.read_text().splitlines()[0].endswith(" invert=1")
    back = read_stipple(out)
    assert back.params == {"invert": True}
    write_csv(again, back)
    assert again.read_text() == out.read_text()
    write_csv(again, result)   # white paper: nothing said, nothing read
    assert "invert" not in again.read_text().splitlines()[0] and read_stipple(again).params == {}
    out.write_text(out.read_text().replace("invert=1", "invert=2"))
    with pytest.raises(ValueError, match="invert must be 0 or 1, got 2"):
        read_stipple(out)


def test_dispatch_and_errors(tmp_path, result):
    for ext in ("svg", "png", "npz", "csv"):
        write_stipple(tmp_path / f"x.{ext.upper()}", result)
        assert (tmp_path / f"x.{ext.upper()}").stat().st_size > 0
    with pytest.raises(ValueError, match=r"unknown output extension '\.pdf'.*\.csv, \.npz, \.png, \.svg"):
        write_stipple(tmp_path / "x.pdf", result)
    with pytest.raises(FileNotFoundError, match="output directory does not exist"):
        write_stipple(tmp_path / "missing" / "x.svg", result)
    with pytest.raises(FileNotFoundError):
        check_output_path(tmp_path / "missing" / "x.png")
    assert not (tmp_path / "x.pdf").exists()


def test_failure_mid_write_leaves_nothing(tmp_path, result, monkeypatch):
    out = tmp_path / "a.svg"
    calls = []

    def boom(*a):
        calls.append(1)
        raise RuntimeError("disk full")

    monkeypatch.setattr(export, "svg_dots", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        write_svg(out, result)
    assert calls and list(tmp_path.iterdir()) == []
    # an existing file is left untouched
    out.write_text("old")
    with pytest.raises(RuntimeError):
        write_svg(out, result)
    assert out.read_text() == "old" and len(list(tmp_path.iterdir())) == 1


@pytest.mark.parametrize("method", ["greedy", "hilbert", "auto"])
def test_pen_path_permutation_and_shorter(method):
    p = np.random.default_rng(7).random((3000, 2)) * 100
    order, before, after = pen_path_order(p, method=method)
    np.testing.assert_array_equal(np.sort(order), np.arange(3000))
    assert after < 0.2 * before
    assert after == pytest.approx(path_travel(p, order))


def test_pen_path_small_and_bad():
    assert pen_path_order(np.zeros((0, 2)))[0].size == 0
    assert list(pen_path_order(np.ones((1, 2)))[0]) == [0]
    with pytest.raises(ValueError, match="pen path method"):
        pen_path_order(np.ones((3, 2)), method="tsp")


def test_python_writers_draw_what_the_cli_draws(ctx, tmp_path):
    """write_stipple(path, res) with no options: the CLI's equal-ink dots, byte for byte."""
    from diskpack_cl import cli, stipple

    gray = np.tile(np.linspace(0, 1, 40), (30, 1))
    Image.fromarray(np.round(gray * 255).astype(np.uint8)).save(tmp_path / "g.png")
    res = stipple(str(tmp_path / "g.png"), 150, schedule=[("pack", 3)], device=ctx)
    assert cli.main(["stipple", str(tmp_path / "g.png"), "-n", "150", "--beta", "3",
                     "--rounds", "1", "-q",
                     "-o", str(tmp_path / "cli.png"), "-o", str(tmp_path / "cli.svg")]) == 0
    for ext in ("png", "svg"):
        write_stipple(tmp_path / f"api.{ext}", res)
        assert (tmp_path / f"api.{ext}").read_bytes() == (tmp_path / f"cli.{ext}").read_bytes()
    # and the default is not the packing drawing
    write_stipple(tmp_path / "packing.png", res, dots="packing")
    assert (tmp_path / "packing.png").read_bytes() != (tmp_path / "api.png").read_bytes()


def test_tone_dots_need_a_tone_radius(tmp_path, result):
    del result.tone_radius
    with pytest.raises(ValueError, match="needs the result's tone_radius"):
        write_svg(tmp_path / "a.svg", result)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("points", ["uniform", "stippled"])
def test_auto_pen_path_is_shorter_than_either_order(points):
    from diskpack_cl import error_diffusion

    if points == "uniform":
        p = np.random.default_rng(1).random((3000, 2)) * 100
    else:  # dots spread like an image's darkness (a gradient)
        p = error_diffusion(np.tile(np.linspace(0, 1, 120), (90, 1)), 3000, seed=0)
    travel = {m: pen_path_order(p, method=m)[2] for m in ("hilbert", "greedy", "auto")}
    assert travel["auto"] < 0.95 * min(travel["hilbert"], travel["greedy"])


def test_two_opt_keeps_a_permutation_never_longer_and_a_zero_budget():
    from diskpack_cl.drawing.pen_path import two_opt

    p = np.random.default_rng(4).random((500, 2))
    start = np.random.default_rng(5).permutation(500)
    better = two_opt(p, start)
    np.testing.assert_array_equal(np.sort(better), np.arange(500))
    assert path_travel(p, better) < 0.5 * path_travel(p, start)
    np.testing.assert_array_equal(two_opt(p, start, rounds=0), start)


def test_two_opt_same_order_whatever_chunks_its_candidates_come_in(monkeypatch):
    """The moves are made for a few dots at a time and kept in the order of one pass:
    chunks of 7 dots give the order of one chunk of all of them."""
    import diskpack_cl.drawing.pen_path as pen_path

    p = np.random.default_rng(6).random((700, 2))
    start = np.random.default_rng(8).permutation(700)
    whole = pen_path.two_opt(p, start, rounds=6)
    monkeypatch.setattr(pen_path, "MOVE_CHUNK", 7)
    np.testing.assert_array_equal(pen_path.two_opt(p, start, rounds=6), whole)


def test_pen_path_does_not_depend_on_the_clock(monkeypatch):
    """The order is counted in rounds: a slow machine (a clock that races) gets the same SVG order."""
    import time

    from diskpack_cl.drawing.pen_path import two_opt, two_opt_rounds

    p = np.random.default_rng(7).random((3000, 2))
    calm = pen_path_order(p)[0]
    clock = iter(range(0, 10**9, 100))
    monkeypatch.setattr(time, "perf_counter", lambda: float(next(clock)))
    np.testing.assert_array_equal(pen_path_order(p)[0], calm)
    # the rounds are those of the work; one round alone is not enough on this set
    base = pen_path_order(p, rounds=0)[0]
    np.testing.assert_array_equal(two_opt(p, base, rounds=two_opt_rounds(len(p))), calm)
    assert path_travel(p, two_opt(p, base, rounds=1)) > path_travel(p, calm)


def test_png_preview_progress_and_default_size(tmp_path, result):
    from diskpack_cl.drawing.writers import preview_scale

    done = []
    write_png(tmp_path / "a.png", result, progress=done.append)
    assert sum(done) == 200
    assert preview_scale(80, 60) == 2.0 and preview_scale(12000, 8000) * 12000 == 4096


# -- each derived quantity in one place --------------------------------------

@pytest.mark.parametrize("radius_scale", [1.0, 0.7])
def test_the_tone_dot_is_the_same_size_through_every_writer_path(tmp_path, result, radius_scale):
    """The tone dot size comes from export.tone_dot_size alone: the writers without a
    dot size and write_stipple_outputs (which hands them one) draw the same dots; a
    second formula that forgot radius_scale or the factor 2 would differ."""
    from diskpack_cl.jobs.items import write_stipple_outputs

    a, b = tmp_path / "a.svg", tmp_path / "b.svg"
    write_svg(a, result, width_mm=160, radius_scale=radius_scale, pen_path="none")
    dot_mm, _ = write_stipple_outputs(result, None, [str(b)], width_mm=160,
                                      radius_scale=radius_scale, pen_path="none")
    assert dot_mm == export.tone_dot_size(result, 2.0, radius_scale)   # 160 mm / 80 px
    ra = {c.get("r") for c in _svg_circles(a)[2]}
    rb = {c.get("r") for c in _svg_circles(b)[2]}
    assert ra == rb and len(ra) == 1 and float(ra.pop()) == pytest.approx(0.6 * 2.0 * radius_scale,
                                                                          abs=1e-4)


def test_the_size_conflict_is_one_rule():
    """dpi against width/height: WriteOptions and mm_per_px refuse it with one message."""
    from diskpack_cl.options import OptionConflict

    with pytest.raises(OptionConflict) as by_options:
        export.WriteOptions(dpi=300, height_mm=100)
    with pytest.raises(OptionConflict) as by_layout:
        export.mm_per_px(10, 10, height_mm=100, dpi=300)
    assert str(by_options.value) == str(by_layout.value)
    assert by_options.value.render(lambda n: "--" + n.replace("_", "-")) == \
        "give the SVG size either by --width-mm/--height-mm or by --dpi, not both"


# -- every route reads back (issue 48) ---------------------------------------

def _colour(result, names=("cyan", "black"), colors=((0, 1, 1), (0, 0, 0)), invert=False):
    res = SimpleNamespace(**vars(result))
    res.pen = np.arange(len(result.points)) % 2
    res.names, res.colors = names, np.array(colors, float)
    res.pen_radius = np.array([0.5, 0.6])
    res.params = {"invert": invert}
    return res


@pytest.mark.parametrize("ext", ["csv", "svg"])
def test_a_colour_stippling_read_back_writes_to_npz(tmp_path, result, ext):
    """A colour .csv or .svg exported to .npz (it failed: AttributeError 'pen_radius')."""
    src = tmp_path / f"a.{ext}"
    write_stipple(src, _colour(result), **({"dots": "packing"} if ext == "svg" else {}))
    write_npz(tmp_path / "b.npz", read_stipple(src))
    back = read_stipple(tmp_path / "b.npz")
    assert back.names and sorted(back.names) == ["black", "cyan"] and len(back.pen) == 200
    assert (back.pen_radius is None) == (ext == "svg")   # an .svg does not hold it


@pytest.mark.parametrize("ext", ["csv", "svg", "npz"])
def test_white_paper_pens_are_not_drawn_on_black_from_any_file(tmp_path, result, ext):
    """export cmyk.csv --invert drew the white-paper pens on black with exit 0, where the
    same stippling as .npz or .svg was refused: every route refuses it."""
    from diskpack_cl.cli import main

    src = tmp_path / f"cmyk.{ext}"
    cmyk = _colour(result, ("yellow", "cyan", "magenta", "black"),
                   ((1, 1, 0), (0, 1, 1), (1, 0, 1), (0, 0, 0)))
    cmyk.pen, cmyk.pen_radius = np.arange(200) % 4, np.full(4, 0.5)
    write_stipple(src, cmyk, **({"dots": "packing"} if ext == "svg" else {}))
    for out in ("x.svg", "x.png"):
        assert main(["export", str(src), "-o", str(tmp_path / out), "--invert", "-q"]) == 1
        assert not (tmp_path / out).exists()
    with pytest.raises(ValueError, match="white paper"):
        write_stipple(tmp_path / "y.svg", read_stipple(src), invert=True)


def test_an_old_colour_csv_on_black_paper_is_refused_by_its_pens(tmp_path, result):
    """A CSV that does not say its paper (written before it did): CMYK pens are for white."""
    from diskpack_cl.drawing.color_writers import on_black

    cmyk = _colour(result, ("yellow", "cyan", "magenta", "black"),
                   ((1, 1, 0), (0, 1, 1), (1, 0, 1), (0, 0, 0)))
    cmyk.params = {}
    with pytest.raises(ValueError, match="cmyk is for white paper"):
        on_black(cmyk, True)
    assert on_black(cmyk, False) is False
    light = _colour(result, ("white", "red"), ((1, 1, 1), (1, 0, 0)))
    light.params = {}
    assert on_black(light, True) is True


def test_a_packing_svg_reads_back_certified(tmp_path):
    """Rounding to the SVG's 4 decimals never makes dots overlap: two disks that touch,
    whose centres round towards each other and whose radii round up to the nearest, were
    read back overlapping by 1e-4 mm; the radii are now rounded inward."""
    r = 0.999959999
    res = SimpleNamespace(points=np.array([[1.00006, 1.5], [1.00006 + 2 * r, 1.5]]),
                          radii=np.array([r, r * (1 - 1e-12)]), width=5, height=3)
    assert certify_disks(res.points, res.radii, Domain.rect(5, 3)).valid
    svg = tmp_path / "a.svg"
    write_stipple(svg, res, dpi=25.4, dots="packing")   # 1 px = 1 mm
    back = read_stipple(svg)
    assert np.all(back.radii <= res.radii)
    write_npz(tmp_path / "a.npz", back)
    assert len(read_stipple(tmp_path / "a.npz").points) == 2   # certified again as it is read


def test_a_picture_too_small_to_draw_is_refused(tmp_path, result):
    """--width-mm 1e-9 wrote circles with negative radii."""
    with pytest.raises(ValueError, match=r"the picture \(1e-09 x 7.5e-10 mm\) is too small"):
        write_svg(tmp_path / "a.svg", result, width_mm=1e-9)
    with pytest.raises(ValueError, match="finer than the SVG's 0.0001 mm"):
        write_svg(tmp_path / "a.svg", result, width_mm=1, dots="packing", radius_scale=1e-3)
    assert not (tmp_path / "a.svg").exists()


def test_a_pen_as_wide_as_the_picture_is_refused(tmp_path, result):
    """A pen exactly as wide as the picture's smaller side puts its ink off the picture."""
    with pytest.raises(ValueError, match=r"the pen \(60 mm\) is as wide as the 80 x 60 mm"):
        write_svg(tmp_path / "a.svg", result, dpi=25.4, pen_mm=60.0)
    with pytest.raises(ValueError, match=r"the pen \(120 px\) is as wide as the 160 x 120 px"):
        write_png(tmp_path / "a.png", result, png_scale=2.0, dpi=25.4, pen_mm=60.0)
