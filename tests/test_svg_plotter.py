"""The SVG as a pen plotter sees it: read back with vpype (the plotter toolkit).

vpype's reader crops paths to the page, so a dot sticking out past an edge
becomes two paths; the page size it reports is the document's physical size.
"""

import numpy as np
import pytest
import vpype
from types import SimpleNamespace

from diskpack_cl import cli
from diskpack_cl.export import write_svg

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
