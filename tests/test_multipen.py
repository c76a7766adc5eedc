"""Colour stippling (diskpack_cl.multipen), its writers and its command line."""

import csv
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl.cli import main
from diskpack_cl.drawing.writers import read_stipple, write_stipple
from diskpack_cl import multipen
from diskpack_cl.pens import PEN_SHARE_EXPONENT
from diskpack_cl.multipen import assign_pens, dots_per_pen, pen_counts, stipple_colors

SVG = "{http://www.w3.org/2000/svg}"
INK = "{http://www.inkscape.org/namespaces/inkscape}"
PENS3 = "black=#000,red=#c00,blue=#06c"


def _image(h=40, w=48):
    """Left half cyan-ish, right half magenta-ish, darker towards the bottom."""
    img = np.ones((h, w, 3))
    img[:, : w // 2, 0] = 0.2
    img[:, w // 2:, 1] = 0.2
    return img * np.linspace(1.0, 0.6, h)[:, None, None]


@pytest.fixture(scope="module")
def result():
    return stipple_colors(_image(), 300, "cmyk", seed=1)


def _disjoint(points, radii, W, H):
    """Brute force: every disk inside the rectangle, every pair apart."""
    d = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    inside = np.all(points - radii[:, None] >= 0) and np.all(points + radii[:, None] <= [W, H])
    return inside and np.all(d > radii[:, None] + radii[None, :])


def test_all_pens_in_one_certified_packing(result):
    assert result.n == 300 and result.certificate.valid
    assert _disjoint(result.points, result.radii, result.width, result.height)
    assert result.counts.tolist() == pen_counts(result.layers, 300, PEN_SHARE_EXPONENT).tolist()
    assert result.names == ("yellow", "cyan", "magenta", "black")


def test_each_pen_follows_its_layer(result):
    left = result.points[:, 0] < result.width / 2
    cyan, magenta = result.pen == 1, result.pen == 2
    assert np.count_nonzero(cyan & left) > 0.9 * np.count_nonzero(cyan)
    assert np.count_nonzero(magenta & ~left) > 0.9 * np.count_nonzero(magenta)


def test_given_counts_and_errors():
    res = stipple_colors(_image(), 200, PENS3, counts=[50, 100, 50], schedule=[("mix", 2, 0.5)])
    assert res.counts.tolist() == [50, 100, 50] and res.certificate.valid
    with pytest.raises(ValueError, match="counts must be 3 non-negative integers summing to n = 200"):
        stipple_colors(_image(), 200, PENS3, counts=[50, 100, 49])
    with pytest.raises(ValueError, match="cmyk is for white paper: on black paper give auto:N"):
        stipple_colors(_image(), 200, invert=True)
    with pytest.raises(ValueError, match="paper_tone is for one pen"):
        stipple_colors(_image(), 200, paper_tone=0.1)
    with pytest.raises(ValueError, match="nothing to stipple"):
        stipple_colors(np.ones((8, 8, 3)), 10)
    with pytest.raises(ValueError, match="every dot goes to a pen without ink"):
        stipple_colors(_image(), 200, "cmyk", counts=[200, 0, 0, 0])   # no yellow in it


@settings(max_examples=25)
@given(st.integers(1, 300), st.lists(st.floats(0.01, 1), min_size=1, max_size=5), st.integers(0, 9))
def test_assign_pens_gives_exact_counts(n, ink, seed):
    rng = np.random.default_rng(seed)
    x = rng.random((n, 2)) * 30
    share = rng.random((n, len(ink))) * ink
    share /= share.sum(axis=1, keepdims=True)
    counts = pen_counts(np.array(ink)[:, None], n)
    assert counts.sum() == n and np.all(np.abs(counts - n * np.array(ink) / sum(ink)) < 1)
    assert np.bincount(assign_pens(x, share, counts), minlength=len(ink)).tolist() == counts.tolist()


def test_dots_per_pen_by_name_the_rest_by_ink():
    layers = np.array([np.full((2, 2), 0.1), np.full((2, 2), 0.3), np.full((2, 2), 0.2)])
    names = ("cyan", "magenta", "black")
    assert dots_per_pen(names, layers, 100, {"cyan": 40}).tolist() == [40, 36, 24]
    assert dots_per_pen(names, layers, 100, {"cyan": 40, "magenta": 0}).tolist() == [40, 0, 60]
    assert dots_per_pen(names, layers, 90, dict(zip(names, (30, 30, 30)))).tolist() == [30] * 3
    assert dots_per_pen(names, layers, 60, None).tolist() == [10, 30, 20]
    for counts, match in (({"cyann": 5}, "counts name cyann, not one of the pens"),
                          ({"cyan": -5}, "non-negative integers"),
                          ({"cyan": 2.5}, "non-negative integers"),
                          ({"cyan": 101}, "sum to 101, but n = 100"),
                          (dict(zip(names, (30, 30, 30))), "sum to 90, but n = 100")):
        with pytest.raises(ValueError, match=match):
            dots_per_pen(names, layers, 100, counts)


def _uniform_share_points(n=2000, seed=3):
    x = np.random.default_rng(seed).random((n, 2)) * np.sqrt(n)
    return x, np.tile([0.5, 0.3, 0.2], (n, 1))


def test_assign_pens_spreads_each_pen_and_is_reproducible():
    from scipy.spatial import cKDTree

    x, share = _uniform_share_points()
    counts = np.array([1000, 600, 400])
    pen = assign_pens(x, share, counts)
    assert np.array_equal(pen, assign_pens(x, share, counts))
    # error diffusion: among each dot's 12 nearest, every pen near its share (a random
    # assignment of the same counts is off by more than 0.2 at 1 dot in 10)
    _, nbr = cKDTree(x).query(x, k=13)
    local = np.stack([np.mean(pen[nbr] == p, axis=1) for p in range(3)], axis=1)
    assert np.quantile(np.abs(local - share).max(axis=1), 0.9) < 0.2
    rand = np.random.default_rng(0).permutation(np.repeat(np.arange(3), counts))
    local = np.stack([np.mean(rand[nbr] == p, axis=1) for p in range(3)], axis=1)
    assert np.quantile(np.abs(local - share).max(axis=1), 0.9) >= 0.2


def test_assign_pens_works_in_waves_not_dot_by_dot(monkeypatch):
    calls = []
    take = multipen._take
    monkeypatch.setattr(multipen, "_take", lambda e, left: calls.append(len(e)) or take(e, left))
    x, share = _uniform_share_points(5000)
    pen = assign_pens(x, share, [2500, 1500, 1000])
    assert np.bincount(pen).tolist() == [2500, 1500, 1000]
    assert len(calls) <= multipen.SEGMENT and sum(calls) == 5000


def _sequential_pens(x, share, counts, k=6):
    """The oracle: Floyd-Steinberg on the dots one at a time along the Hilbert path, each
    dot's error to those of its k nearest not yet visited, else on to the next dot."""
    from scipy.spatial import cKDTree

    from diskpack_cl.drawing.pen_path import pen_path_order

    dist, nbr = cKDTree(x).query(x, k=list(range(2, k + 2)))
    left, err = np.array(counts), np.zeros_like(share)
    pen, carry = np.full(len(x), -1), np.zeros(share.shape[1])
    for i in pen_path_order(x, method="hilbert")[0]:
        e = carry + err[i] + share[i]
        pen[i] = np.argmax(np.where(left > 0, e, -np.inf))
        left[pen[i]] -= 1
        e[pen[i]] -= 1.0
        todo = pen[nbr[i]] < 0
        w = 1.0 / np.maximum(dist[i][todo], 1e-12)
        err[nbr[i][todo]] += (w / w.sum())[:, None] * e if todo.any() else 0.0
        carry = np.zeros_like(e) if todo.any() else e
    return pen


def test_assign_pens_in_one_piece_is_the_sequential_diffusion(monkeypatch):
    rng = np.random.default_rng(4)
    x = rng.random((600, 2)) * 25
    share = rng.random((600, 3)) ** 2
    share /= share.sum(axis=1, keepdims=True)
    counts = pen_counts(share.T[:, :, None], 600)
    monkeypatch.setattr(multipen, "SEGMENT", 600)   # one piece: the path walked dot by dot
    assert np.array_equal(assign_pens(x, share, counts), _sequential_pens(x, share, counts))


def test_same_seed_same_colour_stippling(result):
    again = stipple_colors(_image(), 300, "cmyk", seed=1)
    assert np.array_equal(again.points, result.points) and np.array_equal(again.pen, result.pen)


def test_npz_csv_round_trip(tmp_path, result):
    write_stipple(tmp_path / "c.npz", result)
    back = read_stipple(tmp_path / "c.npz")
    assert np.array_equal(back.pen, result.pen) and back.names == result.names
    assert np.array_equal(back.points, result.points) and np.allclose(back.colors, result.colors)
    write_stipple(tmp_path / "again.svg", back)          # what was read writes again
    write_stipple(tmp_path / "c.csv", result)
    with open(tmp_path / "c.csv") as fh:
        assert fh.readline().startswith("# diskpack_cl stippling ")
        rows = list(csv.DictReader(fh))
    assert [r["pen"] for r in rows] == [result.names[p] for p in result.pen]
    assert np.array_equal([float(r["x"]) for r in rows], result.points[:, 0])
    back = read_stipple(tmp_path / "c.csv")
    assert np.array_equal(back.pen, result.pen) and back.names == result.names
    assert np.array_equal(back.points, result.points) and np.allclose(back.colors, result.colors)
    write_stipple(tmp_path / "again.png", back)          # one tone size for all pens


def test_svg_one_layer_per_pen(tmp_path, result):
    import vpype

    write_stipple(tmp_path / "c.svg", result, width_mm=100)
    root = ET.parse(tmp_path / "c.svg").getroot()
    layers = [g for g in root.iter(SVG + "g") if g.get(INK + "groupmode") == "layer"]
    assert [g.get(INK + "label") for g in layers] == ["yellow", "cyan", "magenta", "black"]
    assert [g.get("stroke") for g in layers] == ["#ffff00", "#00ffff", "#ff00ff", "#000000"]
    assert [len(g.findall(SVG + "circle")) for g in layers] == result.counts.tolist()
    doc = vpype.read_multilayer_svg(str(tmp_path / "c.svg"), 0.05)
    assert len(doc.layers) == np.count_nonzero(result.counts)   # vpype drops an empty layer
    assert sum(len(lc) for lc in doc.layers.values()) == 300
    back = read_stipple(tmp_path / "c.svg")            # the dots of every layer, with their pens
    assert back.names == result.names and np.allclose(back.colors, result.colors)
    assert np.bincount(back.pen, minlength=4).tolist() == result.counts.tolist()
    # border dots move inside the page by less than their drawn radius
    reach = result.pen_radius.max() + 1e-3
    assert np.allclose(np.sort(back.points[:, 0]), np.sort(result.points[:, 0]), atol=reach)
    write_stipple(tmp_path / "o.svg", result, pen_order=["black", "cyan", "magenta", "yellow"])
    root = ET.parse(tmp_path / "o.svg").getroot()
    assert [g.get(INK + "label") for g in root.iter(SVG + "g")][0] == "black"
    with pytest.raises(ValueError, match="pen order must name every pen once"):
        write_stipple(tmp_path / "x.svg", result, pen_order=["black"])


def test_png_preview_composites_the_inks(tmp_path, result):
    write_stipple(tmp_path / "c.png", result, png_scale=2)
    im = np.asarray(Image.open(tmp_path / "c.png"))
    assert im.shape == (80, 96, 3)
    left, right = im[:, :48].reshape(-1, 3).mean(0), im[:, 48:].reshape(-1, 3).mean(0)
    assert left[0] < left[1] and right[1] < right[0]      # cyan on the left, magenta on the right


def test_cli_colors_and_pens(tmp_path, capsys):
    Image.fromarray(np.round(_image() * 255).astype(np.uint8)).save(tmp_path / "in.png")
    svg, npz = str(tmp_path / "c.svg"), str(tmp_path / "c.npz")
    assert main(["stipple", str(tmp_path / "in.png"), "--colors", "cmy", "-n", "200", "-o", svg,
                 "-o", npz, "-o", str(tmp_path / "c.png"), "--pen-order", "magenta,cyan,yellow",
                 "--json", "-q"]) == 0
    assert '"pens"' in capsys.readouterr().out
    back = read_stipple(npz)
    assert back.names == ("yellow", "cyan", "magenta") and len(back.pen) == 200
    assert main(["stipple", str(tmp_path / "in.png"), "--pens", PENS3, "-n", "150", "-o", svg,
                 "--clean-white", "0.05", "-q"]) == 0
    assert main(["stipple", str(tmp_path / "in.png"), "--colors", "cmyk", "-n", "100", "-o", svg,
                 "--invert", "-q"]) == 2
    assert main(["stipple", str(tmp_path / "in.png"), "--colors", "cmyk", "-n", "tone",
                 "--dot-mm", "0.5", "-o", svg, "-q"]) == 2


def test_cli_pen_dots_reach_the_result(tmp_path, capsys):
    Image.fromarray(np.round(_image() * 255).astype(np.uint8)).save(tmp_path / "in.png")
    head = ["stipple", str(tmp_path / "in.png"), "--colors", "cmy", "-n", "200",
            "-o", str(tmp_path / "c.npz"), "-q", "--schedule", "classic"]
    assert main([*head, "--pen-dots", "cyan=50,yellow=30"]) == 0
    back = read_stipple(tmp_path / "c.npz")
    assert np.bincount(back.pen, minlength=3).tolist() == [30, 50, 120]   # magenta: the rest
    assert back.params["counts"] == [30, 50, 120]
    capsys.readouterr()
    for extra, message in (
            (["--pen-dots", "cyann=50"], "--pen-dots names cyann, not one of the pens"),
            (["--pen-dots", "cyan=-5"], "the dots of pen cyan must be >= 0, got -5"),
            (["--pen-dots", "cyan=5x"], "the dots of pen cyan must be an integer"),
            (["--pen-dots", "cyan=300"], "--pen-dots gives 300 dots, more than the 200 in all"),
            (["--pen-dots", "cyan=50,yellow=30,magenta=100"], "gives 180 dots, not the 200")):
        assert main([*head, *extra]) == 2, extra
        assert message in capsys.readouterr().err
    assert main(["stipple", str(tmp_path / "in.png"), "-n", "200", "-o", str(tmp_path / "m.npz"),
                 "--pen-dots", "cyan=5", "-q"]) == 2
    assert "--pen-dots needs the pens: give --colors or --pens" in capsys.readouterr().err


def test_cli_analyze_colour_npz_and_csv(tmp_path, capsys):
    import json

    from diskpack_cl.color_measures import color_measures
    from diskpack_cl.image import load_rgb
    from diskpack_cl.separation import separate

    src = tmp_path / "in.png"
    Image.fromarray(np.round(_image() * 255).astype(np.uint8)).save(src)
    npz, csv_ = str(tmp_path / "c.npz"), str(tmp_path / "c.csv")
    assert main(["stipple", str(src), "--colors", "cmyk", "-n", "300", "--black-generation", "0.5",
                 "-o", npz, "-o", csv_, "-q"]) == 0
    capsys.readouterr()
    assert main(["analyze", npz, "--image", str(src), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    res = read_stipple(npz)
    want = color_measures(res.points, res.pen, separate(src, "cmyk", black_generation=0.5).layers,
                          res.colors, load_rgb(src))
    assert got["reference"] == "image" and got["delta_e"] == pytest.approx(want["delta_e"])
    assert [p["p01"] for p in got["pens"]] == pytest.approx(want["p01"])
    assert [p["ssim"] for p in got["pens"]] == pytest.approx(want["ssim"])
    assert got["p01_joint"] == pytest.approx(want["p01_joint"])
    assert [p["n"] for p in got["pens"]] == np.bincount(res.pen, minlength=4).tolist()
    assert got["certificate"]["valid"]
    for path in (npz, csv_):   # without the image: against the dots' own density
        assert main(["analyze", path, "--json"]) == 0
        alone = json.loads(capsys.readouterr().out)
        assert alone["reference"] == "dots" and alone["certificate"]["valid"]
        assert [p["name"] for p in alone["pens"]] == ["yellow", "cyan", "magenta", "black"]
        assert 0.3 < alone["p01_joint"] < 1.2 and "delta_e" not in alone
    assert main(["analyze", csv_, "-o", str(tmp_path / "r.png")]) == 1
    assert "colour stippling: its numbers print with --json" in capsys.readouterr().err


def _two_images(folder):
    folder.mkdir()
    for name, img in (("a", _image()), ("b", _image()[::-1])):
        Image.fromarray(np.round(img * 255).astype(np.uint8)).save(folder / f"{name}.png")
    return folder


def test_cli_batch_of_colour_images(tmp_path):
    images = _two_images(tmp_path / "in")
    out = tmp_path / "out"
    out.mkdir()
    assert main(["stipple", str(images), "--colors", "cmy", "-n", "120", "--schedule", "classic",
                 "-o", str(out / "{stem}.svg"), "-o", str(out / "{stem}.npz"), "-q"]) == 0
    for stem in ("a", "b"):
        back = read_stipple(out / f"{stem}.npz")
        assert back.names == ("yellow", "cyan", "magenta") and len(back.pen) == 120
        assert [len(g) for g in _svg_layers(out / f"{stem}.svg")] == np.bincount(
            back.pen, minlength=3).tolist()


def _svg_layers(path):
    root = ET.parse(path).getroot()
    return [g.findall(SVG + "circle") for g in root.iter(SVG + "g")
            if g.get(INK + "groupmode") == "layer"]


def test_dask_colour_batch_matches_one_process(tmp_path):
    distributed = pytest.importorskip("distributed")
    from diskpack_cl.jobs.batch import stipple_many

    images = [str(p) for p in sorted(_two_images(tmp_path / "in").iterdir())]
    # one engine on both sides: Dask workers do not see the test run's OpenCL patch
    opts = dict(n=100, color={"colors": PENS3}, schedule=[("mix", 3, 0.5)], manifest=False,
                backend="exact")
    local = list(stipple_many(images, [str(tmp_path / "local" / "{stem}.npz")], jobs=1, **opts))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as lc, distributed.Client(lc) as client:
        dask = list(stipple_many(images, [str(tmp_path / "dask" / "{stem}.npz")], client=client,
                                 **opts))
    assert [r["status"] for r in local + dask] == ["ok"] * 4
    for stem in ("a", "b"):
        a, b = (read_stipple(tmp_path / d / f"{stem}.npz") for d in ("local", "dask"))
        assert np.array_equal(a.points, b.points) and np.array_equal(a.pen, b.pen)


def test_the_pen_steps_are_the_one_pen_loop():
    """The class-aware steps run in the one schedule loop (stipple.run_schedule with a hook):
    without a pull they move the dots as the joint steps do, and the history
    counts on across the two parts."""
    img = _image(32, 40)
    sched = [("mix", 6, 0.5), ("pack", 2)]
    joint = stipple_colors(img, 120, "cmy", schedule=sched, joint=1.0, seed=2, backend="exact")
    split = stipple_colors(img, 120, "cmy", schedule=sched, joint=0.5, pen_pull=0.0, seed=2,
                           backend="exact")
    assert np.array_equal(split.points, joint.points)
    assert [e["iteration"] for e in split.history] == list(range(8))
    assert [e["kind"] for e in split.history] == ["mix"] * 6 + ["pack"] * 2
    assert all("pens_s" in e for e in split.history[4:])


def test_colour_line_art_keeps_its_dots_on_the_ink(ctx):
    """The colour plan, like the one-pen plan, sizes its raster and centroid
    blur by the joint ink (3000 dots on 940 inked pixels): with the page's
    (supersample 3, blur 0.5 px) the lines' dots spill onto the paper.
    (OpenCL: the exact engine takes a minute for these two runs.)"""
    from diskpack_cl.picture_measures import edge_fidelity, stray_dots
    from test_stipple_support import rings

    g = rings()
    rgb = np.ones(g.shape + (3,))
    left = np.arange(g.shape[1])[None, :] < g.shape[1] // 2
    rgb[(g < 0.5) & left] = (1.0, 0.0, 0.0)
    rgb[(g < 0.5) & ~left] = (0.0, 0.0, 1.0)
    res = stipple_colors(rgb, 3000, "cmy", seed=1)
    page = stipple_colors(rgb, 3000, "cmy", seed=1, supersample=3, density_sigma=0.5)
    assert res.certificate.valid and res.params["supersample"] == 4
    stray = [stray_dots(r.points, 1.0 - g).per_10k for r in (res, page)]
    edge = [edge_fidelity(r.points, 1.0 - g) for r in (res, page)]
    assert stray[0] < 0.1 * stray[1] and edge[0] > edge[1] + 0.01


def _largest_remainders(weights, n):
    """n split in proportion to `weights`, the floors topped up by the largest remainders."""
    share = [n * w / sum(weights) for w in weights]
    out = [int(s) for s in share]
    for p in sorted(range(len(share)), key=lambda p: out[p] - share[p])[: n - sum(out)]:
        out[p] += 1
    return out


def test_pen_share_exponent_shares_dots_by_ink_to_that_power():
    img = _image() * 0.5   # dark: black has most of the ink
    short = dict(schedule=[("mix", 2, 0.5)], seed=1)
    by_ink = stipple_colors(img, 300, "cmyk", pen_share_exponent=1.0, **short)
    res = stipple_colors(img, 300, "cmyk", pen_share_exponent=0.5, **short)
    ink = [float(a.sum()) for a in res.layers]
    assert res.counts.tolist() == _largest_remainders([i ** 0.5 if i > 0 else 0.0 for i in ink], 300)
    assert by_ink.counts.tolist() == _largest_remainders(ink, 300)
    assert res.counts[3] < by_ink.counts[3] and res.params["pen_share_exponent"] == 0.5
    assert res.certificate.valid
    with pytest.raises(ValueError, match=r"pen_share_exponent must be in \[0, 1\], got 1.5"):
        stipple_colors(img, 300, "cmyk", pen_share_exponent=1.5)


def test_cli_pen_share_exponent_reaches_the_result(tmp_path):
    Image.fromarray(np.round(_image() * 128).astype(np.uint8)).save(tmp_path / "in.png")
    head = ["stipple", str(tmp_path / "in.png"), "--colors", "cmyk", "-n", "200", "-q",
            "--schedule", "classic", "-o", str(tmp_path / "c.npz")]
    assert main([*head, "--pen-share-exponent", "0.5"]) == 0
    back = read_stipple(tmp_path / "c.npz")
    ink = [float(a.sum()) for a in multipen.separate(tmp_path / "in.png", "cmyk").layers]
    assert np.bincount(back.pen, minlength=4).tolist() == _largest_remainders(
        [i ** 0.5 if i > 0 else 0.0 for i in ink], 200)
    assert back.params["pen_share_exponent"] == 0.5
    assert main([*head, "--pen-share-exponent", "2"]) == 2


def _drawn_ink(points, r, size, scale=4):
    """Paper of a `size` px square image covered by dots of radius `r`, overlaps counted
    once (drawn at `scale` times the image's resolution)."""
    from diskpack_cl.picture_measures import render_dots

    side = size * scale
    return np.minimum(render_dots(points * scale, r * scale, (side, side)), 1.0).sum() / scale**2


def test_each_pens_drawn_ink_is_its_layers_ink():
    """Dark photographs: black's dots overlap, so drawn at the tone radius they would
    lose ink where they overlap; at the pen's radius each pen covers its layer's ink."""
    from diskpack_cl.pen_radii import pen_tone_radii

    img = _image(64, 64) * 0.5   # black covers 0.86 of the paper
    for exponent in (1.0, 0.5):
        res = stipple_colors(img, 1200, "cmyk", pen_share_exponent=exponent, seed=2)
        for p, layer in enumerate(res.layers):
            x = res.points[res.pen == p]
            if len(x) >= 20:
                assert _drawn_ink(x, res.pen_radius[p], 64) == pytest.approx(layer.sum(), rel=0.01)
        tone = pen_tone_radii(res.layers, res.counts)[3]   # black at the tone radius: 6 to 12 % lost
        assert _drawn_ink(res.points[res.pen == 3], tone, 64) < 0.95 * res.layers[3].sum()
