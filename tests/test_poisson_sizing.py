"""Poisson sets whose cost follows the number of points, and requests refused before the work."""

import re

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy.spatial import cKDTree

from diskpack_cl import parallel_darts as darts_module
from diskpack_cl.domain import Domain
from diskpack_cl.measures import hexagonal_radius
from diskpack_cl.memory import MemoryLimit
from diskpack_cl.poisson import poisson_disk, start_points


def test_a_long_box_throws_darts_in_proportion_to_its_points(monkeypatch):
    thrown = []
    real = darts_module.parallel_darts

    def counting(m, **kwargs):
        thrown.append(m)
        return real(m, **kwargs)

    monkeypatch.setattr(darts_module, "parallel_darts", counting)
    pts = start_points(3000, Domain.rect(300.0, 1.0), seed=0, device=False)
    assert len(pts) == 3000
    assert sum(thrown) <= 2 * 3000   # a square torus of side 300 took 90 times as many


@settings(max_examples=25)
@given(n=st.integers(100, 1500), aspect=st.floats(1.0, 60.0), tall=st.booleans(),
       seed=st.integers(0, 2**31 - 1))
def test_start_sets_fill_boxes_of_any_aspect_evenly(n, aspect, tall, seed):
    size = (1.0, aspect) if tall else (aspect, 1.0)
    domain = Domain.rect(*size)
    # narrower than the spacing: refused by poisson_disk
    assume(min(size) >= 2.0 * hexagonal_radius(n, domain.area))
    pts = start_points(n, domain, seed=seed, device=False)
    assert pts.shape == (n, 2)
    assert np.all(pts >= 0) and np.all(pts <= size)
    d = cKDTree(pts).query(pts, k=2)[0][:, 1].min()
    assert d >= 0.35 * 2.0 * hexagonal_radius(n, domain.area)   # darts, not clumps at seams
    # the points spread over the whole length: no empty tenth
    along = pts[:, 1 if tall else 0] / max(size)
    assert len(np.unique(np.minimum((along * 10).astype(int), 9))) == 10


def test_the_same_seed_gives_the_same_long_box():
    a = start_points(2000, Domain.rect(1.0, 40.0), seed=3, device=False)
    b = start_points(2000, Domain.rect(1.0, 40.0), seed=3, device=False)
    np.testing.assert_array_equal(a, b)


def test_a_box_narrower_than_the_spacing_is_refused():
    with pytest.raises(ValueError, match="narrower than the spacing"):
        poisson_disk(1000, box="1e9x1e-9", backend="exact")


def test_a_set_that_memory_cannot_hold_is_refused_before_the_work():
    with pytest.raises(MemoryLimit, match="points need about"):
        poisson_disk(min_distance=1e-7, backend="exact")


def test_a_radius_search_that_memory_cannot_hold_is_refused_before_the_first_trial():
    from diskpack_cl import max_points_for_radius

    with pytest.raises(MemoryLimit, match=r"points need about [0-9.e+]+ GiB.*\(a larger radius\)"):
        max_points_for_radius(1e-7, backend="exact")


def test_poisson_radius_names_the_size_and_the_flag(tmp_path, capsys):
    from diskpack_cl import cli

    out = tmp_path / "p.npz"
    assert cli.main(["poisson", "--radius", "1e-6", "-o", str(out)]) == 1
    assert re.search(r"points need about [0-9.e+]+ GiB.*\(a larger --radius\)",
                     capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.parametrize("asked", [dict(n=10**10), dict(min_distance=1e-4)])
def test_a_3d_set_that_memory_cannot_hold_is_refused_before_the_work(asked):
    with pytest.raises(MemoryLimit, match="points need about"):
        poisson_disk(**asked, dim=3, backend="exact")
