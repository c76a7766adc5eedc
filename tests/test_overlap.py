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
