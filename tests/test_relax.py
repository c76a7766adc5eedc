"""Algorithm 1 (relax_poisson): monotone rho, backends agree, input checks, stop reasons."""

import numpy as np
import pytest

from diskpack_cl.device import context as _device
import reference as ref
from diskpack_cl.domain import Domain
from diskpack_cl.relax import relax_poisson


def _dart(n, seed, r=None):
    """Naive dart throwing on the torus: accept a candidate farther than 2r from all."""
    rng = np.random.default_rng(seed)
    r = 0.6 * np.sqrt(1 / (2 * np.sqrt(3) * n)) if r is None else r
    pts = np.zeros((0, 2))
    while len(pts) < n:
        c = rng.random(2)
        d = pts - c
        d -= np.round(d)
        if len(pts) == 0 or np.hypot(d[:, 0], d[:, 1]).min() >= 2 * r:
            pts = np.vstack([pts, c])
    return pts


def _hex_lattice():
    """A lattice on the torus whose Voronoi cells are centrally symmetric
    with a unique Chebyshev centre (the site): nothing can move."""
    nx, ny = 12, 14          # ny > 2 nx / sqrt(3): the 4 diagonal neighbours are closest
    j, i = np.mgrid[0:ny, 0:nx]
    return np.stack([((i + 0.5 * (j % 2)) / nx).ravel(), (j / ny).ravel()], 1)


@pytest.mark.parametrize("start", ["random", "dart"])
def test_rho_never_decreases(start, backend):
    n = 300
    pts = np.random.default_rng(1).random((n, 2)) if start == "random" else _dart(n, 2)
    seen = []
    res = relax_poisson(pts, eps=0.85, max_iter=25, backend=backend,
                        callback=lambda it, rho: seen.append((it, rho)))
    assert [it for it, _ in seen] == list(range(1, res.iterations + 1))
    assert np.allclose([r for _, r in seen], res.rho[1:], rtol=0, atol=0)
    assert np.all(np.diff(res.rho) >= -1e-12), np.diff(res.rho).min()
    assert res.rho[0] == pytest.approx(ref.min_distance_ref(pts, Domain.torus()) / 2
                                       / np.sqrt(1 / (2 * np.sqrt(3) * n)), abs=1e-12)
    assert res.rho[-1] == pytest.approx(
        ref.min_distance_ref(res.points, Domain.torus()) / 2 / np.sqrt(1 / (2 * np.sqrt(3) * n)), abs=1e-12)


@pytest.mark.parametrize("eps, max_iter, reason", [(0.8, 1000, "eps"), (0.9, 3, "max_iter")])
def test_the_last_iterate_gets_its_nearest_neighbours_alone(ctx, monkeypatch, eps, max_iter, reason):
    """The iterate that probably ends the run (its rho's last two gains once more reach
    eps, or it is the last allowed) gets its nearest neighbours alone, not its MICs: one
    MIC call an iteration (the start's included, the last's left out), one
    nearest-neighbour call, and the iterates and rho of a run that solves every MIC."""
    import diskpack_cl.relax as relax
    from diskpack_cl.device.cells import CellMIC
    from diskpack_cl.sampling import dart_throwing

    X = dart_throwing(1024, seed=1)
    calls = {"mic": 0, "nearest": 0}
    mic, nearest = relax._mic, CellMIC.nearest
    monkeypatch.setattr(relax, "_mic", lambda *a, **k: calls.__setitem__("mic", calls["mic"] + 1)
                        or mic(*a, **k))
    monkeypatch.setattr(CellMIC, "nearest", lambda self, pts: calls.__setitem__(
        "nearest", calls["nearest"] + 1) or nearest(self, pts))
    res = relax_poisson(X, eps, max_iter=max_iter, backend="opencl", device=ctx)
    assert res.stop_reason == reason and calls == {"mic": res.iterations, "nearest": 1}
    monkeypatch.setattr(relax, "_last_soon", lambda *args: False)
    want = relax_poisson(X, eps, max_iter=max_iter, backend="opencl", device=ctx)
    np.testing.assert_array_equal(res.points, want.points)
    np.testing.assert_array_equal(res.rho, want.rho)
    assert calls == {"mic": 2 * res.iterations + 1, "nearest": 1}


def test_backends_give_the_same_iterates(ctx):
    pts = np.random.default_rng(3).random((200, 2))
    a = relax_poisson(pts, eps=0.99, max_iter=4, backend="exact")
    b = relax_poisson(pts, eps=0.99, max_iter=4, backend="opencl")
    assert a.backend == "exact" and b.backend == "opencl"
    d = a.points - b.points
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-9
    assert np.allclose(a.rho, b.rho, atol=1e-9, rtol=0)


def test_reaches_eps_from_random_start(backend):
    pts = np.random.default_rng(0).random((256, 2))
    res = relax_poisson(pts, eps=0.8, backend=backend)
    assert res.stop_reason == "eps"
    assert res.rho[-1] >= 0.8
    assert res.rho[-2] < 0.8
    assert len(res.rho) == res.iterations + 1
    assert np.all((res.points >= 0) & (res.points < 1))


@pytest.mark.parametrize("points, match", [
    ([[0.1, 0.2], [np.nan, 0.5], [0.3, 0.3]], "NaN or infinite"),
    ([[0.1, 0.2], [np.inf, 0.5], [0.3, 0.3]], "NaN or infinite"),
    ([[0.1, 0.2]], "has 1 point, need at least 2"),
    (np.zeros((0, 2)), "has 0 points, need at least 2"),
    ([[0.1, 0.2], [0.1, 0.2], [0.3, 0.3]], "coincident"),
    ([[0.25, 0.5], [1.25, 0.5], [0.3, 0.3]], "coincident"),    # same point on the torus
    (np.zeros((4, 3)), r"shape \(n, 2\)"),
    (np.zeros(6), r"shape \(n, 2\)"),
    ([["a", "b"], ["c", "d"]], "must be numeric"),
])
def test_bad_points(points, match):
    with pytest.raises(ValueError, match=match):
        relax_poisson(points, backend="exact")


def test_the_callers_points_are_left_as_they_were():
    # a float64 array is what the check takes as it is; the torus wraps a copy
    pts = np.random.default_rng(3).random((64, 2)) + [1.0, -1.0]
    before = pts.copy()
    relax_poisson(pts, eps=0.7, backend="exact")
    assert np.array_equal(pts, before)


@pytest.mark.parametrize("eps", [0.0, 1.0, 1.5, -0.1, np.nan])
def test_bad_eps(eps):
    pts = np.random.default_rng(0).random((10, 2))
    with pytest.raises(ValueError, match="eps must be in"):
        relax_poisson(pts, eps=eps, backend="exact")


def test_bad_backend():
    pts = np.random.default_rng(0).random((10, 2))
    with pytest.raises(ValueError, match="backend must be one of"):
        relax_poisson(pts, backend="cuda")


def test_points_outside_are_wrapped_and_input_not_mutated():
    rng = np.random.default_rng(4)
    pts = rng.random((64, 2))
    shifted = pts + rng.integers(-3, 4, pts.shape)
    keep = shifted.copy()
    a = relax_poisson(pts, eps=0.99, max_iter=3, backend="exact")
    b = relax_poisson(shifted, eps=0.99, max_iter=3, backend="exact")
    assert np.array_equal(shifted, keep)
    assert not np.may_share_memory(b.points, shifted)
    assert np.all((b.points >= 0) & (b.points < 1))
    d = a.points - b.points
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-12
    assert np.allclose(a.rho, b.rho, atol=1e-12)


def test_same_input_same_output(backend):
    pts = np.random.default_rng(5).random((150, 2))
    a = relax_poisson(pts, eps=0.99, max_iter=5, backend=backend)
    b = relax_poisson(pts, eps=0.99, max_iter=5, backend=backend)
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.rho, b.rho)


def test_stop_reasons():
    pts = np.random.default_rng(6).random((128, 2))
    res = relax_poisson(pts, eps=0.99, max_iter=3, backend="exact")
    assert res.stop_reason == "max_iter" and res.iterations == 3 and len(res.rho) == 4
    res = relax_poisson(pts, eps=0.99, max_iter=0, backend="exact")
    assert res.stop_reason == "max_iter" and res.iterations == 0
    np.testing.assert_array_equal(res.points, pts)
    res = relax_poisson(pts, eps=0.5, max_iter=200, backend="exact")
    assert res.stop_reason == "eps"
    # already good enough: no iteration at all
    lat = _hex_lattice()
    res = relax_poisson(lat, eps=0.9, backend="exact")
    assert res.stop_reason == "eps" and res.iterations == 0


def test_stalled_on_a_lattice(backend):
    lat = _hex_lattice()
    rho0 = ref.min_distance_ref(lat, Domain.torus()) / 2 / np.sqrt(1 / (2 * np.sqrt(3) * len(lat)))
    assert 0.99 < rho0 < 0.999
    res = relax_poisson(lat, eps=0.999, max_iter=50, patience=2, backend=backend)
    assert res.stop_reason == "stalled"
    assert res.iterations == 2
    assert np.allclose(res.rho, rho0, atol=1e-12)
    d = res.points - lat
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-12


def test_opencl_with_unknown_device_raises(monkeypatch, ctx):
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    pts = np.random.default_rng(0).random((10, 2))
    with pytest.raises(_device.NoOpenCLError, match="no OpenCL device matches"):
        relax_poisson(pts, backend="opencl", device="no-such-device-xyz")


def test_auto_falls_back_to_exact_without_opencl(monkeypatch):
    def boom():
        raise _device.NoOpenCLError("no OpenCL platform found (test)")

    monkeypatch.setattr(_device, "_platforms", boom)
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    pts = np.random.default_rng(0).random((32, 2))
    res = relax_poisson(pts, eps=0.99, max_iter=2, backend="auto")
    assert res.backend == "exact"
    with pytest.raises(_device.NoOpenCLError):
        relax_poisson(pts, eps=0.99, max_iter=2, backend="opencl")
