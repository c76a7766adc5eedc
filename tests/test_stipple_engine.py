"""Stippling engines: exact host labels and centroids against brute force and the OpenCL raster."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from diskpack_cl import NoOpenCLError
import reference as ref
from diskpack_cl.domain import Domain
from diskpack_cl.labels import cell_centroids, grid_power_labels
from diskpack_cl.stipple import stipple
from diskpack_cl.engine import ExactEngine, make_engine


def _sites(seed, dom, n=40, heavy=0.5):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 2)) * (dom.width, dom.height)
    spacing = np.sqrt(dom.area / n)
    return pts, (heavy * spacing * rng.random(n)) ** 2


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), periodic=st.booleans(), voronoi=st.booleans())
def test_host_labels_are_the_brute_force_owners(seed, periodic, voronoi):
    dom = Domain.torus() if periodic else Domain.rect(30.0, 20.0)
    pts, w = _sites(seed, dom)
    w = None if voronoi else w
    lab = grid_power_labels(pts, w, dom, (24, 36))
    want, gap = ref.power_labels_ref(pts, w, dom, (24, 36))
    scale = max(dom.width, dom.height)
    sure = gap > 1e-9 * scale ** 2       # not a tie in float64
    assert np.array_equal(lab[sure], want[sure])


def test_host_centroids_are_the_brute_force_centroids():
    dom = Domain.torus()
    pts, w = _sites(3, dom)
    dens = np.random.default_rng(4).random((24, 36))
    c, mass = cell_centroids(grid_power_labels(pts, w, dom, (24, 36)), pts, dens, dom)
    c_ref, m_ref = ref.lloyd_centroids_ref(pts, w, dom, (24, 36), dens)
    np.testing.assert_allclose(mass, m_ref, rtol=1e-12)
    d = c - c_ref
    d -= np.round(d)
    assert np.nanmax(np.abs(d)) <= 1e-12
    with pytest.raises(ValueError, match=r"density must have the raster shape \(24, 36\)"):
        cell_centroids(np.zeros((24, 36), int), pts, np.ones((3, 3)), dom)


def test_exact_and_opencl_engines_agree(ctx):
    """Same MICs; same labels except where float32 power distances tie; so same centroids there."""
    dom, shape = Domain.rect(48.0, 32.0), (64, 96)
    pts, w = _sites(7, dom, n=120)
    dens = np.random.default_rng(8).random(shape) + 0.1
    cl = make_engine(dom, None, "opencl", device=ctx, grid=shape)
    ex = ExactEngine(dom, shape)
    a, b = cl.mic(pts, w), ex.mic(pts, w)
    np.testing.assert_array_equal(a.empty, b.empty)
    np.testing.assert_allclose(a.radii, b.radii, rtol=0, atol=1e-9)
    lab_cl = cl.raster.compute(pts, w, distance=False).labels
    lab_ex = grid_power_labels(pts, w, dom, shape)
    _, gap = ref.power_labels_ref(pts, w, dom, shape)
    differ = lab_cl != lab_ex
    assert np.all(gap[differ] < 1e-4 * 48.0 ** 2)          # float32 ties only
    ca, ma = cl.centroids(pts, w, dens)
    cb, mb = ex.centroids(pts, w, dens)
    touched = np.unique(np.concatenate([lab_cl[differ], lab_ex[differ]]))
    same = np.setdiff1d(np.arange(len(pts)), touched)
    same = same[mb[same] > 0]
    # the OpenCL engine reduces on the device in fixed point (2^-24 a run)
    np.testing.assert_allclose(ca[same], cb[same], rtol=0, atol=1e-5)
    np.testing.assert_allclose(ma[same], mb[same], rtol=1e-7)


def test_opencl_engine_reuses_the_labels_of_its_mic(ctx, monkeypatch):
    dom, shape = Domain.rect(16.0, 16.0), (32, 32)
    pts, w = _sites(1, dom, n=20)
    eng = make_engine(dom, None, "opencl", device=ctx, grid=shape, route="raster")   # MICs from the raster's labels
    eng.mic(pts, w)
    calls = []
    real = eng.raster.compute
    monkeypatch.setattr(eng.raster, "compute", lambda *a, **k: calls.append(1) or real(*a, **k))
    eng.centroids(pts, w, None)
    assert calls == []                          # the power cells of the mic step
    eng.centroids(pts, np.zeros(len(pts)), None)
    assert calls == [1]                         # Voronoi cells: labelled again


def test_stipple_exact_backend_runs_without_opencl(monkeypatch):
    from diskpack_cl.device import context as _device
    def boom():
        raise NoOpenCLError("no OpenCL platform found (test)")

    monkeypatch.setattr(_device, "_platforms", boom)
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    g = np.tile(np.linspace(0.0, 1.0, 40), (30, 1))
    res = stipple(g, 80, seed=1, schedule=[("mix", 3, 0.5), ("lloyd", 1), ("pack", 2)])
    assert res.engine == "exact" and res.certificate.valid
    assert [h["kind"] for h in res.history] == ["mix"] * 3 + ["lloyd"] + ["pack"] * 2
    again = stipple(g, 80, seed=1, schedule=[("mix", 3, 0.5), ("lloyd", 1), ("pack", 2)], backend="exact")
    np.testing.assert_array_equal(again.points, res.points)
    with pytest.raises(NoOpenCLError, match="no OpenCL platform found"):
        stipple(g, 80, backend="opencl")
    with pytest.raises(NoOpenCLError):
        make_engine(Domain.rect(40, 30), None, "auto", device="0:0", grid=(30, 40))


def test_make_engine_checks_the_backend():
    eng = make_engine(Domain.rect(8, 8), None, "exact", grid=(8, 8))
    assert eng.name == "exact" and eng.fallback is None
    with pytest.raises(ValueError, match=r"backend must be one of \('opencl', 'exact', 'auto'\), got 'gpu'"):
        make_engine(Domain.rect(8, 8), None, "gpu", grid=(8, 8))


def test_profiled_stippling_reports_kernel_time_and_the_same_result(ctx):
    """profile=True adds the device seconds of every step's kernels (MIC
    kernel, labels, centroid sums) and changes nothing else."""
    g = np.tile(np.linspace(0.1, 0.9, 64), (48, 1))
    kw = dict(schedule=[("mix", 2, 0.5), ("lloyd", 1), ("pack", 1)], device=ctx)
    plain = stipple(g, 300, **kw)
    prof = stipple(g, 300, profile=True, **kw)
    np.testing.assert_array_equal(plain.points, prof.points)
    assert all("kernel_s" not in h for h in plain.history) and "kernel" not in plain.timings
    for h in prof.history:
        assert 0.0 < h["kernel_s"] <= h["seconds"]
        per = {k: v for k, v in h.items() if k.startswith("kernel_") and k != "kernel_s"}
        assert per and sum(per.values()) == pytest.approx(h["kernel_s"])
        assert ("kernel_cell_mic_s" in per) == (h["kind"] != "lloyd")
    assert prof.timings["kernel"] == pytest.approx(sum(h["kernel_s"] for h in prof.history))
    names = {k for k in prof.timings if k.startswith("kernel_")}
    # MICs, and labels with centroid sums: one kernel on a CPU (power_sums_tile), else two
    assert "kernel_cell_mic" in names and len(names) >= 2
    for name in names:
        assert prof.timings[name] == pytest.approx(sum(h.get(f"{name}_s", 0.0) for h in prof.history))


@pytest.mark.parametrize("route", ["exact", "cells", "raster"])
@pytest.mark.parametrize("method", ["mic", "centroids"])
@pytest.mark.parametrize("pts, w, match", [
    (None, [0.1, np.nan, 0.2, 0.1, 0.3], "weights must be n finite numbers"),
    (np.full((5, 2), np.nan), np.zeros(5), "points contain NaN or infinite coordinates"),
    (np.zeros((0, 2)), np.zeros(0), r"need at least \d point\(s\), got 0"),
])
def test_stipple_engines_refuse_sites_they_cannot_bound(ctx, route, method, pts, w, match):
    dom = Domain.rect(8.0, 8.0)
    if route == "exact":
        eng = ExactEngine(dom, (8, 8))
    else:
        eng = make_engine(dom, None, "opencl", device=ctx, grid=(8, 8), route=route)
    if pts is None:
        pts = np.random.default_rng(0).random((5, 2)) * 8.0
    args = (pts, np.asarray(w)) + ((np.ones((8, 8)),) if method == "centroids" else ())
    with pytest.raises(ValueError, match=match):
        getattr(eng, method)(*args)


def test_centroids_begun_before_the_mics_change_no_step(ctx, monkeypatch):
    """``pack_step`` begins the centroids' pass before the MICs (on the ``cells`` route
    it runs beside the MIC kernel): every step of a run is the same, bit for bit, as
    with the centroids asked for after the MICs (the base engine's ``start_centroids``)."""
    from diskpack_cl import engine

    g = np.clip(np.add.outer(np.linspace(0.1, 0.9, 40), np.linspace(0.0, 0.5, 56)), 0, 1)
    g[10:20, 20:30] = 0.0   # a black square: off_support, reseat_dead and ink factors at work
    args = dict(schedule=[("mix", 5, 0.7), ("pack", 2), ("mix", 1, 0.5)], device=ctx,
                backend="opencl", support=8.0, capacity=0.1, seed=3)
    begun = stipple(g, 300, **args)
    if make_engine(Domain.rect(56, 40), 300, "opencl", device=ctx).name != "cells":
        pytest.skip("the raster route labels the grid in its MIC step: nothing is begun early")
    monkeypatch.setattr(engine.OpenCLEngine, "start_centroids", engine._Engine.start_centroids)
    after = stipple(g, 300, **args)
    np.testing.assert_array_equal(begun.points, after.points)
    def measures(entry):   # what a step found, not its seconds
        return {k: v for k, v in entry.items() if not (k.endswith("_s") or k == "seconds")}
    assert [measures(h) for h in begun.history] == [measures(h) for h in after.history]


@settings(max_examples=10)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 300), weighted=st.booleans())
def test_begun_centroids_ignore_the_callers_changes_meanwhile(ctx, seed, n, weighted):
    """On the ``cells`` route a helper thread prepares the centroids' pass: it works on
    copies, so the caller's arrays changed after ``start_centroids`` returns (here before
    the helper even starts) change nothing; the answer is the raster's, bit for bit."""
    import threading

    dom = Domain.rect(40.0, 30.0)
    eng = make_engine(dom, n, "opencl", device=ctx, grid=(48, 64))
    if eng.name != "cells":
        pytest.skip("the raster route begins nothing early")
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 2)) * (40.0, 30.0)
    w = (0.5 * np.sqrt(dom.area / n) * rng.random(n)) ** 2 if weighted else None
    dens = rng.random((48, 64)).astype(np.float32)
    want = eng.raster.centroids(pts, w, dens)
    eng.start_centroids(pts, w, dens)()   # the helper made
    hold = threading.Event()
    eng._helper.submit(hold.wait)          # busy until the caller's arrays have changed
    done = eng.start_centroids(pts, w, dens)
    pts[:] = 1.0
    if w is not None:
        w[:] = 0.0
    hold.set()
    for got, ref_ in zip(done(), want):
        np.testing.assert_array_equal(got, ref_)
