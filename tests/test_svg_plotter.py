"""The SVG as a pen plotter sees it: read back with vpype (the plotter toolkit).

vpype's reader crops paths to the page, so a dot sticking out past an edge
becomes two paths; the page size it reports is the document's physical size.
"""

import numpy as np
import pytest
import vpype
from types import SimpleNamespace

from diskpack_cl import cli
from diskpack_cl.drawing.writers import write_svg

PX_PER_MM = 96 / 25.4


def _read(path):
    doc = vpype.read_multilayer_svg(str(path), 0.005)
    lines = [line for layer in doc.layers.values() for line in layer]
    return doc.page_size, lines


def _border_result(n=400, r=0.6, size=(64, 48)):
    """Equal dots, half of them centred within a radius of an edge."""
    rng = np.random.default_rng(5)
    W, H = size
    pts = np.column_stack([rng.uniform(0, W, n), rng.uniform(0, H, n)])
    edge = rng.integers(0, 4, n // 2)
    at = np.where(edge < 2, 0.0, 1.0)
    k = np.arange(n // 2)
    pts[k, edge % 2] = at * np.array([W, H])[edge % 2] + (0.5 - at) * rng.uniform(0, r, n // 2)
    return SimpleNamespace(points=pts, radii=np.full(n, r), width=W, height=H)


def _inside(lines, page):
    xy = np.concatenate(lines)
    w, h = page
    return (xy.real.min() >= 0 and xy.imag.min() >= 0 and xy.real.max() <= w
            and xy.imag.max() <= h)


@pytest.mark.parametrize("size", [dict(dpi=96.0), dict(width_mm=150.0), dict(dpi=300.0)])
def test_every_dot_one_path_inside_the_exact_page(tmp_path, size):
    res = _border_result()
    out = tmp_path / "a.svg"
    info = write_svg(out, res, dot_mm=0.5, **size)
    page, lines = _read(out)
    assert len(lines) == len(res.points)
    # vpype's own mm factor is rounded to 8 digits
    assert page == pytest.approx((info["width_mm"] * PX_PER_MM, info["height_mm"] * PX_PER_MM),
                                 rel=1e-6)
    assert _inside(lines, page)
    assert info["moved_inside"] > 0


def test_default_dpi_page_is_the_image_size_in_pixels(tmp_path):
    res = _border_result(size=(512, 512))
    out = tmp_path / "a.svg"
    write_svg(out, res, dot_mm=0.5)
    page, _ = _read(out)
    assert page == (512.0, 512.0)


def test_pen_width_makes_the_traced_dot_its_size(tmp_path):
    res = _border_result()
    res.radii = np.where(np.arange(len(res.radii)) % 2 == 0, 0.6, 0.2)  # 1.2 and 0.4 mm wide
    out = tmp_path / "p.svg"
    info = write_svg(out, res, dpi=25.4, pen_mm=0.5, dots="packing")  # 1 px = 1 mm
    page, lines = _read(out)
    assert len(lines) == len(res.points) and _inside(lines, page)
    assert info["pen_touches"] == len(res.points) // 2  # 0.4 mm dots: narrower than the pen
    widths = np.sort([np.ptp(line.real) / PX_PER_MM for line in lines])
    # a touch is 0.01 mm long; a 1.2 mm dot is traced on a circle of diameter 1.2 - 0.5
    assert widths[: len(widths) // 2] == pytest.approx(0.01, abs=1e-6)
    assert widths[len(widths) // 2:] == pytest.approx(0.7, abs=2e-3)


def test_cli_pen_mm_svg_reads_as_n_paths(ctx, tmp_path, capsys):
    from PIL import Image

    Image.fromarray(np.tile(np.linspace(0, 255, 40), (30, 1)).astype(np.uint8)).save(
        tmp_path / "g.png")
    for extra in ([], ["--pen-mm", "0.3"]):
        out = tmp_path / "s.svg"
        rc = cli.main(["stipple", str(tmp_path / "g.png"), "-n", "120", "--schedule", "pack",
                       "-q", "--width-mm", "80", "-o", str(out), *extra])
        assert rc == 0, capsys.readouterr().err
        page, lines = _read(out)
        assert len(lines) == 120 and _inside(lines, page)
        assert page == pytest.approx((80 * PX_PER_MM, 60 * PX_PER_MM), rel=1e-6)


def _pen_ink(lines, pen_mm, shape, mm_per_px):
    """Ink fraction of a pen ``pen_mm`` wide tracing ``lines`` (vpype, CSS px), sampled at
    the centres of an image of ``shape`` pixels of ``mm_per_px``: a pen simulation."""
    from scipy.spatial import cKDTree

    xy = np.concatenate(lines) / PX_PER_MM
    tree = cKDTree(np.column_stack([xy.real, xy.imag]))
    gy, gx = np.mgrid[: shape[0], : shape[1]]
    centres = (np.column_stack([gx.ravel(), gy.ravel()]) + 0.5) * mm_per_px
    dist, _ = tree.query(centres, distance_upper_bound=0.5 * pen_mm)
    return float(np.mean(np.isfinite(dist)))


def _png_ink(path, invert=False):
    from PIL import Image

    with Image.open(path) as im:
        a = np.asarray(im.convert("L"), dtype=float) / 255.0
    return float(np.mean(a if invert else 1.0 - a))


@pytest.fixture(scope="module")
def big_dots(ctx, tmp_path_factory):
    """Dots several mm wide (190 mm print) drawn with a 0.5 mm pen."""
    from PIL import Image

    d = tmp_path_factory.mktemp("pen")
    Image.fromarray(np.tile(np.linspace(0, 255, 40), (30, 1)).astype(np.uint8)).save(d / "g.png")
    rc = cli.main(["stipple", str(d / "g.png"), "-n", "300", "--schedule", "pack", "-q",
                   "--width-mm", "190", "--pen-mm", "0.5", "--png-scale", "8",
                   "-o", str(d / "s.svg"), "-o", str(d / "s.png")])
    assert rc == 0
    return d


def test_pen_fills_wide_dots_one_path_each(big_dots):
    page, lines = _read(big_dots / "s.svg")
    assert len(lines) == 300 and _inside(lines, page)
    # the preview (320 x 240 px of 190/320 mm) shows the ink the pen lays down
    pen = _pen_ink(lines, 0.5, (240, 320), 190 / 320)
    png = _png_ink(big_dots / "s.png")
    assert png > 0.3
    assert pen == pytest.approx(png, rel=0.03)


def test_rendered_svg_ink_matches_the_preview(big_dots, tmp_path):
    import shutil
    import subprocess

    if shutil.which("rsvg-convert") is None:
        pytest.skip("rsvg-convert (librsvg2-bin) is not installed")
    out = tmp_path / "r.png"
    subprocess.run(["rsvg-convert", "-w", "320", "-h", "240", "-b", "white", "-o", str(out),
                    str(big_dots / "s.svg")], check=True)
    assert _png_ink(out) == pytest.approx(_png_ink(big_dots / "s.png"), rel=0.03)


@pytest.mark.parametrize("opts", [
    dict(), dict(pen_mm=0.5), dict(invert=True), dict(invert=True, pen_mm=0.3),
    dict(page="a4", margin_mm=15), dict(page="a3", margin_mm=20, pen_mm=0.5),
    dict(page="a4", landscape=True, invert=True), dict(page="a3", width_mm=100, dot_mm=1.5),
])
def test_vpype_sees_exactly_n_dots_inside_the_page(tmp_path, opts):
    res = _border_result()
    res.tone_radius = 0.4
    out = tmp_path / "a.svg"
    info = write_svg(out, res, **opts)
    page, lines = _read(out)
    assert len(lines) == len(res.points) and _inside(lines, page)
    assert page == pytest.approx(tuple(v * PX_PER_MM for v in info["page_mm"]), rel=1e-6)
    if "page" in opts:
        from diskpack_cl.drawing.page import paper_size

        assert info["page_mm"] == pytest.approx(paper_size(opts["page"],
                                                           landscape=opts.get("landscape", False)))
        xy = np.concatenate(lines) / PX_PER_MM
        margin = opts.get("margin_mm", 10.0)
        assert min(xy.real.min(), xy.imag.min()) >= margin - 1e-6 or "width_mm" in opts
