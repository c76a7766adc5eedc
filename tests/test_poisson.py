"""poisson_disk: torus and box, count or distance, mask, polygon, density."""

import json

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.distance import pdist

from diskpack_cl.domain import Domain
from diskpack_cl.geometry import chebyshev_center_linprog
from diskpack_cl.measures import HEXAGONAL_CELL
from diskpack_cl.poisson import as_box, count_for_distance, poisson_disk, start_points
from diskpack_cl.relax import relax_poisson


def _brute_min_distance(pts, torus=False):
    """Smallest pairwise distance by the full pairwise table (minimum image on the unit torus)."""
    if not torus:
        return pdist(pts).min()
    d = pts[:, None, :] - pts[None, :, :]
    d -= np.round(d)
    r = np.hypot(d[..., 0], d[..., 1])
    return r[np.triu_indices(len(pts), 1)].min()



def test_a_torus_set_on_a_float64_device_loads_no_kd_tree(ctx):
    """A torus set from parallel darts, the per-cell kernel and local steps runs on grids
    alone: scipy.spatial (a fifth of a second to import, a tenth of ``diskpack poisson
    -n 1000000``) stays unloaded.  In a fresh interpreter, as the command line runs."""
    import subprocess
    import sys

    from diskpack_cl.device.stage import has_fp64

    if not has_fp64(ctx):
        pytest.skip("the exact route (no float64) uses scipy's trees")
    code = ("import sys; from diskpack_cl.poisson import poisson_disk; "
            "res = poisson_disk(20000, seed=1); "
            "print(res.stages['engine']['route'], res.stats['local_iterations'] > 0, "
            "'scipy.spatial' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["cells", "True", "False"], out.stdout + out.stderr


def test_as_box():
    assert as_box("3x0.5") == Domain.rect(3, 0.5)
    assert as_box((2, 1)) == Domain.rect(2, 1)
    assert as_box("torus") == Domain.torus()
    for bad in ("2x", "0x1", "axb", (1, 2, 3), "-1x1"):
        with pytest.raises(ValueError, match="box must be"):
            as_box(bad)


def test_count_for_distance_and_the_papers_fig7():
    # rho = (D / 2) / sqrt(area / (2 sqrt(3) n)) at the count: at most rho_max, the next exceeds
    n = count_for_distance(0.026, 1.0, 0.8)
    rho = lambda m: 0.013 / np.sqrt(1.0 / (HEXAGONAL_CELL * m))  # noqa: E731
    assert rho(n) <= 0.8 < rho(n + 1)
    # the paper's Fig. 7 caption: 1300 points at radius 0.013 is rho 0.87, not 0.80
    assert rho(1300) == pytest.approx(0.872, abs=1e-3)
    with pytest.raises(ValueError, match="min_distance must be positive"):
        count_for_distance(0.0, 1.0)
    with pytest.raises(ValueError, match="rho_max must be in"):
        count_for_distance(0.1, 1.0, 1.0)


@pytest.mark.parametrize("box", [None, "2x1", "1x3", "0.01x0.02"])
def test_min_distance_one_run(box, backend):
    dom = as_box(box)
    D = 0.05 * min(dom.width, dom.height) * (1 if box != "1x3" else 2)
    res = poisson_disk(min_distance=D, box=box, seed=3, backend=backend)
    assert res.reached and res.stop_reason == "eps"
    assert len(res.points) == count_for_distance(D, dom.area)
    assert _brute_min_distance(res.points, dom.periodic) >= D
    assert np.all(res.points >= 0) and np.all(res.points <= dom.size)


def test_count_in_a_box_reaches_eps(backend):
    res = poisson_disk(600, box=(3, 1), seed=np.random.default_rng(5), backend=backend)
    assert len(res.points) == 600 and res.reached
    rho = 0.5 * _brute_min_distance(res.points) / np.sqrt(3.0 / (HEXAGONAL_CELL * 600))
    assert rho == pytest.approx(res.rho, rel=1e-12) and rho >= 0.8


def _clipped_cell_center(X, i, dom):
    """linprog Chebyshev centre of point i's Voronoi cell clipped to the box (all bisectors)."""
    d = np.delete(X, i, axis=0) - X[i]
    L = np.hypot(d[:, 0], d[:, 1])
    normals = np.vstack([d / L[:, None], [[-1, 0], [1, 0], [0, -1], [0, 1]]])
    beta = np.concatenate([L / 2, [X[i, 0], dom.width - X[i, 0], X[i, 1], dom.height - X[i, 1]]])
    q, _ = chebyshev_center_linprog(normals, beta)
    return X[i] + q


def test_box_walls_are_exact(backend):
    dom = Domain.rect(2.0, 0.7)
    X = np.random.default_rng(2).random((40, 2)) * dom.size
    X[:4] = [[0, 0.3], [2.0, 0.1], [1.0, 0.0], [0.5, 0.7]]   # points on the walls
    res = relax_poisson(X, 0.99, domain=dom, max_iter=1, backend=backend)
    want = np.array([_clipped_cell_center(X, i, dom) for i in range(len(X))])
    assert np.abs(res.points - want).max() < 1e-7


def test_box_refuses_outside_and_coincident_points():
    dom = Domain.rect(1, 1)
    with pytest.raises(ValueError, match=r"1 point lies outside the domain \[0, 1\] x \[0, 1\] \(first: row 1\)"):
        relax_poisson([[0.5, 0.5], [1.5, 0.5]], domain=dom)
    with pytest.raises(ValueError, match="coincident points in the box"):
        relax_poisson([[0.5, 0.5], [0.5, 0.5], [0.1, 0.1]], domain=dom)


def _degenerate(kind, n, rng):
    if kind == "lattice":
        j, i = np.divmod(np.arange(n), int(np.ceil(np.sqrt(n))))
        return np.column_stack([i, j]) / np.sqrt(n) + 0.01
    if kind == "cluster":
        return 0.5 + 1e-3 * rng.random((n, 2))
    if kind == "walls":
        t = rng.random(n)
        side = rng.integers(0, 4, n)
        return np.column_stack([np.where(side == 0, 0, np.where(side == 1, 1, t)),
                                np.where(side == 2, 0, np.where(side == 3, 1, t))])
    return rng.random((n, 2))


@settings(max_examples=12)
@given(kind=st.sampled_from(["lattice", "cluster", "walls", "random"]), n=st.integers(3, 60),
       seed=st.integers(0, 2 ** 16))
def test_box_relaxation_hypothesis(kind, n, seed, backend):
    rng = np.random.default_rng(seed)
    X = np.unique(_degenerate(kind, n, rng), axis=0)
    assume(len(X) >= 2)
    dom = Domain.rect(1.0, 1.0)
    res = relax_poisson(X, 0.8, domain=dom, max_iter=4, backend=backend, verify=True)
    assert np.all(res.points >= -1e-12) and np.all(res.points <= 1 + 1e-12)
    # rho may drop in a box (a wall cuts a cell's disk), but stays positive
    assert res.rho[-1] > 0 and len(np.unique(res.points, axis=0)) == len(X)


def test_polygon_mask_against_matplotlib():
    from matplotlib.path import Path

    tri = np.array([[0.1, 0.1], [1.9, 0.2], [0.5, 0.95]])
    res = poisson_disk(800, box="2x1", polygon=tri, seed=0, backend="exact")
    assert Path(tri).contains_points(res.points).all()
    assert abs(len(res.points) - 800) < 60
    with pytest.raises(ValueError, match="polygon must be"):
        poisson_disk(10, box="2x1", polygon=[[0, 0], [1, 1]])


def test_image_mask_keeps_the_spacing():
    y, x = np.mgrid[0:50, 0:100]
    ring = ((x - 50) ** 2 + (y - 25) ** 2 < 20 ** 2).astype(float)
    res = poisson_disk(min_distance=0.03, box=(2, 1), mask=ring, seed=1, backend="exact")
    px = (res.points * (50, 50)).astype(int)
    assert ring[px[:, 1], px[:, 0]].all()
    assert _brute_min_distance(res.points) >= 0.03
    with pytest.raises(ValueError, match="no room"):
        poisson_disk(10, box=(2, 1), mask=np.zeros((4, 4)))
    with pytest.raises(ValueError, match="needs a box"):
        poisson_disk(10, mask=ring)


def test_density_gives_variable_spacing():
    res = poisson_disk(600, box="2x1", density=lambda x, y: 0.1 + x, seed=0, backend="exact")
    counts = np.histogram(res.points[:, 0], bins=2, range=(0, 2))[0]
    # integrals of 0.1 + x over [0, 1] and [1, 2]: 0.6 and 1.6
    assert counts[1] / counts[0] == pytest.approx(1.6 / 0.6, rel=0.15)
    with pytest.raises(ValueError, match="density sets the spacing"):
        poisson_disk(min_distance=0.1, density=np.ones((2, 2)))
    with pytest.raises(ValueError, match="non-negative"):
        poisson_disk(10, density=-np.ones((2, 2)))


def test_start_points_in_a_box_keep_the_darts_spacing():
    p = start_points(500, Domain.rect(4, 1), seed=0)
    inset = 0.74 * np.sqrt(4 / (HEXAGONAL_CELL * 500))   # where the walls push relaxed points
    assert p.shape == (500, 2) and np.all(p >= inset) and np.all(p <= np.array([4, 1]) - inset)
    assert _brute_min_distance(p) > 0.5 * np.sqrt(4 / (HEXAGONAL_CELL * 500))


def test_neither_count_nor_distance():
    with pytest.raises(ValueError, match="give exactly one of n or min_distance"):
        poisson_disk()


@pytest.mark.parametrize("dim, box, what", [(2, "2x1", dict(min_distance=0.05)),
                                            (2, "1x1", dict(n=300)),
                                            (3, "1x1x0.5", dict(min_distance=0.1))])
def test_walls_points_lets_the_points_reach_the_walls(dim, box, what):
    size = np.array([float(v) for v in box.split("x")])
    res = poisson_disk(box=box, walls="points", seed=3, dim=dim, **what)
    disks = poisson_disk(box=box, seed=3, dim=dim, **what)
    d_min = pdist(res.points).min()
    assert np.all((res.points > 0) & (res.points < size)) and d_min >= res.min_distance
    if "min_distance" in what:
        assert len(res.points) > len(disks.points) and d_min >= what["min_distance"]
    gap = np.minimum(res.points.min(axis=0), (size - res.points).min(axis=0))
    assert np.all(gap < 0.25 * d_min)           # a point near every wall
    old = np.minimum(disks.points.min(axis=0), (size - disks.points).min(axis=0))
    assert np.all(old > 0.4 * disks.min_distance)   # the band "disks" leaves


def test_walls_points_needs_a_plain_box():
    for kwargs, match in [(dict(walls="wall"), "walls must be 'disks' or 'points'"),
                          (dict(walls="points"), "needs a box"),
                          (dict(walls="points", box="1x1", polygon=[(0, 0), (1, 0), (0, 1)]),
                           "takes no mask")]:
        with pytest.raises(ValueError, match=match):
            poisson_disk(50, **kwargs)


def test_generator_seed_is_reproducible():
    a = poisson_disk(200, seed=np.random.default_rng(9), backend="exact").points
    b = poisson_disk(200, seed=np.random.default_rng(9), backend="exact").points
    assert np.array_equal(a, b)


# ------------------------------------------------------------------------ CLI

def _cli(args, capsys):
    from diskpack_cl import cli

    rc = cli.main(args)
    return rc, capsys.readouterr()


def test_cli_box_and_min_distance(tmp_path, capsys):
    import json

    from diskpack_cl.io import read_points

    out = tmp_path / "box.npz"
    rc, cap = _cli(["poisson", "--box", "2x1", "--min-distance", "0.05", "-o", str(out),
                    "--seed", "1", "--backend", "exact", "--json"], capsys)
    assert rc == 0, cap.err
    s = json.loads(cap.out)
    pts = read_points(out)
    assert s["n"] == len(pts) == count_for_distance(0.05, 2.0) and s["box"] == [2.0, 1.0]
    assert pdist(pts).min() >= 0.05 and np.all(pts <= (2, 1))


def test_cli_unreached_eps_exits_3(tmp_path, capsys):
    out = tmp_path / "p.npz"
    args = ["poisson", "-n", "200", "--eps", "0.95", "--max-iter", "3", "-o", str(out),
            "--seed", "1", "--backend", "exact"]
    rc, cap = _cli(args, capsys)
    assert rc == 3 and out.exists()
    assert "did not reach --eps 0.95 (stop: max_iter)" in cap.err
    rc, cap = _cli(args + ["--allow-unreached"], capsys)
    assert rc == 0


def test_cli_mask_image(tmp_path, capsys):
    from PIL import Image

    from diskpack_cl.io import read_points

    y, x = np.mgrid[0:40, 0:80]
    Image.fromarray(((x < 40) * 255).astype(np.uint8)).save(tmp_path / "m.png")
    out = tmp_path / "m.csv"
    rc, cap = _cli(["poisson", "--mask", str(tmp_path / "m.png"), "-n", "300", "-o", str(out),
                    "--seed", "2", "--backend", "exact"], capsys)
    assert rc == 0, cap.err
    pts = read_points(out)
    assert np.all(pts[:, 0] <= 0.5) and abs(len(pts) - 300) < 30   # box 1 x 0.5, left half


def test_a_mask_inside_the_walls_gets_n_points_on_average():
    """n over the mask's share of the box within the walls' margin, where the points lie:
    a disc clear of the walls got 3.4 % too many (1034 of 1000) with the whole box's share."""
    y, x = np.mgrid[0:64, 0:64]
    disc = (x - 31.5) ** 2 + (y - 31.5) ** 2 < 24 ** 2
    counts = [len(poisson_disk(1000, box="1x1", mask=disc, seed=s, backend="exact").points)
              for s in range(4)]
    assert abs(np.mean(counts) - 1000) < 10, counts


def test_cli_mask_says_what_n_means(tmp_path, capsys):
    from PIL import Image

    y, x = np.mgrid[0:40, 0:80]
    Image.fromarray(((x < 40) * 255).astype(np.uint8)).save(tmp_path / "m.png")
    rc, cap = _cli(["poisson", "--mask", str(tmp_path / "m.png"), "-n", "300", "--json",
                    "-o", str(tmp_path / "m.csv"), "--seed", "2", "--backend", "exact"], capsys)
    assert rc == 0, cap.err
    assert "points inside the mask (-n 300: about that many)" in cap.err
    assert json.loads(cap.out)["n_asked"] == 300


def test_cli_three_columns_need_columns(tmp_path, capsys):
    src = tmp_path / "p3.csv"
    pts = np.random.default_rng(0).random((50, 3))
    np.savetxt(src, pts, delimiter=",", header="x,y,z", comments="")
    out = tmp_path / "o.npz"
    rc, cap = _cli(["relax", str(src), "-o", str(out), "--backend", "exact", "-q"], capsys)
    assert rc == 1 and "has a z column" in cap.err and not out.exists()
    rc, cap = _cli(["relax", str(src), "-o", str(out), "--backend", "exact", "-q",
                    "--columns", "x,z", "--max-iter", "300"], capsys)
    assert rc == 0, cap.err


def test_cli_refuses_a_dart_radius_the_darts_cannot_reach(tmp_path, capsys):
    rc, cap = _cli(["poisson", "-n", "300", "--dart-radius", "0.95", "-o", str(tmp_path / "d.npz"),
                    "--seed", "1", "--backend", "exact"], capsys)
    assert rc == 2 and "--dart-radius: must be in (0, 0.78), got 0.95" in cap.err
    assert not (tmp_path / "d.npz").exists()


def test_stall_counts_only_real_progress():
    from diskpack_cl import relax

    # a lattice whose rho cannot grow: stalled after `patience` iterations
    n = 12
    j, i = np.mgrid[0:n, 0:n]
    lat = np.column_stack([(i + 0.5 * (j % 2)).ravel() / n, (j.ravel() + 0.5) / n])
    lat += 1e-9 * np.random.default_rng(0).random(lat.shape)
    res = relax.relax_poisson(lat, 0.99, patience=3, max_iter=100, backend="exact")
    assert res.stop_reason == "stalled" and res.iterations < 100   # was max_iter at 1e-12
    # a cluster 1e-6 wide grows geometrically from rho 1e-7: progress, not a stall
    x = 0.5 + 1e-6 * np.random.default_rng(1).random((60, 2))
    res = relax.relax_poisson(x, 0.8, patience=10, max_iter=300, backend="exact")
    assert res.stop_reason == "eps" and res.rho[0] < 1e-5


@settings(max_examples=8)
@given(st.integers(2_000, 30_000), st.sampled_from([None, "2x1", "1x5"]), st.integers(0, 2**32 - 1))
def test_a_set_whose_relaxation_takes_the_dart_grids_buffer_is_the_same(ctx, n, box, seed):
    """Inside poisson_disk the relaxation's MIC outputs take the dart grids' device
    buffer, handed on (``device.stage.buffers_handed_on``): the same points, bit for
    bit, as with every buffer made anew (no buffer claimed)."""
    from unittest import mock
    from diskpack_cl.device import stage

    claimed = []

    def claim(ctx, nbytes):
        buf = take(ctx, nbytes)
        claimed.append(buf is not None)
        return buf

    take = stage._claim
    with mock.patch.object(stage, "_claim", claim):
        got = poisson_disk(n, box=box, seed=seed, device=ctx)
    assume(any(claimed))   # a box's darts may leave no buffer the outputs fit
    with mock.patch.object(stage, "_claim", lambda ctx, nbytes: None):
        want = poisson_disk(n, box=box, seed=seed, device=ctx)
    assert got.points.tobytes() == want.points.tobytes()
    assert (got.rho, got.iterations) == (want.rho, want.iterations)


def test_a_buffer_handed_on_goes_to_a_stage_it_fits_inside_the_block_only(ctx):
    """A buffer handed on serves a later request of half its size up to its size, once,
    inside the block; outside one, or for a request it cannot hold or would hold twice
    over, a new buffer is made.  Regions lie side by side, each aligned."""
    from diskpack_cl.device.stage import DeviceStage, buffers_handed_on

    first, second = DeviceStage(ctx), DeviceStage(ctx)
    align = first.device.mem_base_addr_align // 8
    with buffers_handed_on():
        parts = first.regions("grids", (1000, 3, 5000))
        handed = first._kept["grids"]
        assert handed.size >= 6003 and all(p.offset % align == 0 for p in parts)
        assert [p.size for p in parts] == [1000, 3, 5000]
        assert all(a.offset + a.size <= b.offset for a, b in zip(parts, parts[1:]))
        first.hand_on()
        assert first._kept == {}
        assert second.buffer("small", handed.size // 2 - 8) is not handed
        assert second.buffer("large", handed.size + 8) is not handed
        assert second.buffer("fits", handed.size - 8) is handed
        assert DeviceStage(ctx).buffer("again", handed.size - 8) is not handed
    first.regions("grids", (8000,))
    kept = first._kept["grids"]
    first.hand_on()
    assert second.buffer("outside", kept.size) is not kept


def test_an_interrupted_start_leaves_no_reserve_thread_touching_pages(monkeypatch):
    """Ctrl-C in the darts: the thread that touches the relaxation's pages on idle cores
    stops with the run, and does not go on touching them (375 MB at 1.5M points)."""
    import threading

    import diskpack_cl.poisson as poisson
    from diskpack_cl import memory

    if memory._glibc() is None:
        pytest.skip("the reserve needs glibc")

    def interrupted(*args, **kwargs):
        assert any(t.name == "diskpack-reserve" for t in threading.enumerate())
        raise KeyboardInterrupt

    monkeypatch.setattr(poisson, "start_points", interrupted)
    with pytest.raises(KeyboardInterrupt):
        poisson_disk(1_500_000, seed=0, backend="exact")
    assert not any(t.name == "diskpack-reserve" for t in threading.enumerate())
