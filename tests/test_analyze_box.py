"""``diskpack analyze`` of box sets: the box from the .npz that ``poisson --box`` and
``relax --box`` write, or ``--box``; no wrap, the windowed periodogram."""

import json

import numpy as np
import pytest

import reference as ref
from diskpack_cl import cli
from diskpack_cl.domain import Domain
from diskpack_cl.io import write_points
from diskpack_cl.reports import analyze_point_sets, point_file_box


def _json(capsys):
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_poisson_box_records_its_box_and_analyze_reads_it(tmp_path, capsys):
    out = tmp_path / "box.npz"
    assert cli.main(["poisson", "-n", "600", "--box", "2x1", "--seed", "3", "--backend", "exact",
                     "-o", str(out), "--quiet"]) == 0
    assert point_file_box(out) == (2.0, 1.0)
    assert cli.main(["analyze", str(out), "--json"]) == 0
    got = _json(capsys)
    pts = np.load(out)["points"]
    dmin = ref.min_distance_ref(pts, Domain.rect(2.0, 1.0))   # no wrap, brute force
    assert got["box"] == [2.0, 1.0] and got["window"] == "hann"
    assert got["rho"] == pytest.approx(0.5 * dmin / np.sqrt(2.0 / (2 * np.sqrt(3) * 600)), abs=1e-12)


def test_the_flag_gives_the_box_of_a_plain_file_and_a_torus_reading_differs(tmp_path, capsys):
    # two points near opposite walls: close through the wrap, far in the box
    pts = np.array([[0.02, 0.5], [1.98, 0.5], [1.0, 0.1], [1.0, 0.9], [0.5, 0.5], [1.5, 0.5]])
    f = tmp_path / "p.csv"
    write_points(f, pts)
    assert cli.main(["analyze", str(f), "--json", "--box", "2x1", "--kmax", "4"]) == 0
    box = _json(capsys)
    assert box["rho"] == pytest.approx(0.5 * 0.48 / np.sqrt(2.0 / (2 * np.sqrt(3) * 6)))
    with pytest.raises(ValueError, match="unit torus"):
        analyze_point_sets([f])   # without the box the points are off the unit torus


def test_relax_box_records_its_box(tmp_path):
    src, out = tmp_path / "s.csv", tmp_path / "r.npz"
    write_points(src, np.random.default_rng(0).random((100, 2)) * (3, 1))
    assert cli.main(["relax", str(src), "-o", str(out), "--box", "3x1", "--backend", "exact",
                     "--eps", "0.7", "--quiet"]) == 0
    assert point_file_box(out) == (3.0, 1.0)


def test_files_with_different_boxes_or_points_outside_are_refused(tmp_path):
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    pts = np.random.default_rng(1).random((20, 2))
    np.savez(a, points=pts, box=[1.0, 1.0])
    np.savez(b, points=pts, box=[2.0, 1.0])
    with pytest.raises(ValueError, match="different boxes"):
        analyze_point_sets([a, b])
    with pytest.raises(ValueError, match=r"in the box \[0, 0.5\] x \[0, 1\]"):
        analyze_point_sets([a], box=(0.5, 1.0))
    np.savez(b, points=pts, box=[2.0, -1.0])
    with pytest.raises(ValueError, match="'box' must be two positive sizes"):
        point_file_box(b)
