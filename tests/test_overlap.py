"""``--no-overlap``: drawn dots that never touch, checked on the SVG as vpype reads it."""

import json

import numpy as np
import pytest
import vpype
from scipy.spatial import cKDTree

from diskpack_cl.cli import main

PEN_MM = 0.5
PX_PER_MM = 96 / 25.4


@pytest.fixture(scope="module")
def stippling(tmp_path_factory):
    path = tmp_path_factory.mktemp("overlap") / "s.npz"
    assert main(["stipple", "sample", "-n", "3000", "-o", str(path), "-q"]) == 0
    return path


def _export(path, capsys, *extra):
    out = path.with_name(f"out{len(extra)}.svg")
    assert main(["export", str(path), "-o", str(out), "--width-mm", "70", "--pen-mm", str(PEN_MM),
                 "--json", *extra]) == 0
    return out, json.loads(capsys.readouterr().out.splitlines()[-1])["plot"]


def _ink_as_vpype_reads_it(svg):
    """Each path's centre and the reach of its ink (its farthest point plus half the pen), mm."""
    doc = vpype.read_multilayer_svg(str(svg), 0.01 * PX_PER_MM)
    lines = [line / PX_PER_MM for layer in doc.layers.values() for line in layer]
    lo = np.array([(ln.real.min(), ln.imag.min()) for ln in lines])
    hi = np.array([(ln.real.max(), ln.imag.max()) for ln in lines])
    centres = 0.5 * (lo + hi)
    reach = np.array([np.abs(ln - complex(*c)).max() for ln, c in zip(lines, centres)])
    return centres, reach + 0.5 * PEN_MM


def _touching_share(centres, ink):
    """Every pair closer than the two inks' reach, by brute force over the k-d tree's pairs."""
    pairs = cKDTree(centres).query_pairs(2 * ink.max(), output_type="ndarray")
    d = np.hypot(*(centres[pairs[:, 0]] - centres[pairs[:, 1]]).T)
    touching = np.unique(pairs[d <= ink[pairs[:, 0]] + ink[pairs[:, 1]]])
    return len(touching) / len(centres)


def test_without_no_overlap_the_share_reported_is_the_drawn_one(stippling, capsys):
    svg, plot = _export(stippling, capsys)
    share = _touching_share(*_ink_as_vpype_reads_it(svg))
    assert share > 0.2   # the tone dots are wider than the packing where it is dense
    assert plot["touching_share"] == pytest.approx(share, abs=2 / 3000)
    assert 0 < plot["no_overlap_ink"] < 1


def test_with_no_overlap_no_two_drawn_dots_touch(stippling, capsys):
    svg, plot = _export(stippling, capsys, "--no-overlap")
    centres, ink = _ink_as_vpype_reads_it(svg)
    assert len(centres) == 3000
    assert _touching_share(centres, ink) == 0
    assert plot["touching_share"] == 0 and plot["touching_share_uncapped"] > 0.2


def test_dots_that_exactly_touch_count_as_touching():
    """A gap of exactly 0 is touching: for the share reported and for --no-overlap."""
    from diskpack_cl.drawing.overlap import check_apart, touching

    centres = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]])
    assert touching(centres, np.full(3, 0.5)).tolist() == [True, True, False]
    # capped below their disks, but the pen inks each dot 0.5 around its centre
    with pytest.raises(ValueError, match=r"2 of the 3 drawn dots would touch"):
        check_apart(centres, np.full(3, 0.4), np.full(3, 0.5), pen=1.0)
    check_apart(centres, np.full(3, 0.4), np.full(3, 0.5), pen=0.999)


@pytest.mark.parametrize("options, words", [
    (["--width-mm", "70", "--pen-mm", "5"], ["is wider than the smallest packing disk",
                                             "of the 3000 drawn dots would touch"]),
    (["--width-mm", "20", "--pen-mm", "0.5"], ["is wider than the smallest packing disk"]),
])
@pytest.mark.parametrize("ext", ["svg", "png"])
def test_no_overlap_that_cannot_hold_is_refused(stippling, capsys, options, words, ext):
    """A pen wider than the packing disks inks them past their disks whatever their radius:
    refused with the figures (it exited 0 with 1608 to 4429 touching dots)."""
    out = stippling.with_name(f"refused.{ext}")
    assert main(["export", str(stippling), "-o", str(out), "--no-overlap", "-q", *options]) == 1
    err = capsys.readouterr().err
    assert all(word in err for word in words) and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_no_overlap_of_an_svg_input_is_refused(stippling, capsys):
    """An .svg holds the drawn dots (the tone radii), not the packing disks: capped at
    themselves they still touch, so --no-overlap is refused, saying why."""
    svg, _ = _export(stippling, capsys)
    out = svg.with_name("again.svg")
    assert main(["export", str(svg), "-o", str(out), "--no-overlap", "-q"]) == 1
    err = capsys.readouterr().err
    assert "an .svg holds the drawn dots, not the packing disks" in err, err
    assert not out.exists()
