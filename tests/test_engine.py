"""Engines (cells, raster, exact) give the same certified MICs and iterates."""

import numpy as np
import pytest

from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.relax import relax_poisson
from diskpack_cl.sampling import dart_throwing


@pytest.mark.parametrize("start", ["dart", "random"])
def test_cells_engine_gives_the_exact_iterates(ctx, start):
    """The float64 kernel route against scipy alone, with every iteration
    verified against exact_mic and a KD-tree inside relax_poisson."""
    rng = np.random.default_rng(11)
    pts = dart_throwing(700, seed=rng) if start == "dart" else rng.random((700, 2))
    a = relax_poisson(pts, eps=0.99, max_iter=8, backend="exact")
    b = relax_poisson(pts, eps=0.99, max_iter=8, backend="opencl", device=ctx, route="cells", verify=True)
    assert b.stats["engine"] == "cells"
    d = a.points - b.points
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-9
    assert np.abs(a.rho - b.rho).max() <= 1e-12
    assert np.all(np.diff(b.rho) >= -1e-15)


def test_raster_route_for_devices_without_fp64(ctx):
    """Forcing the float32 raster route on PoCL: the same iterates as the
    float64 per-cell route."""
    pts = dart_throwing(500, seed=12)
    a = relax_poisson(pts, eps=0.99, max_iter=5, backend="opencl", device=ctx, route="raster")
    b = relax_poisson(pts, eps=0.99, max_iter=5, backend="opencl", device=ctx, route="cells")
    assert a.stats["engine"] == "raster" and b.stats["engine"] == "cells"
    d = a.points - b.points
    d -= np.round(d)
    assert np.abs(d).max() <= 1e-9


@pytest.mark.parametrize("name", ["cells", "raster", "exact"])
def test_engines_agree_on_power_cells_in_a_rectangle(ctx, name):
    rng = np.random.default_rng(13)
    dom = Domain.rect(120.0, 80.0)
    pts = rng.random((3000, 2)) * (120.0, 80.0)
    w = (rng.random(3000) * 1.5) ** 2 * 10.0 ** rng.uniform(-3, 0, 3000)
    backend = "exact" if name == "exact" else "opencl"
    eng = make_engine(dom, len(pts), backend, device=ctx, route="auto" if name == "exact" else name)
    assert eng.name == name
    step = eng.mic(pts, w)
    ref = make_engine(dom, len(pts), "exact").mic(pts, w)
    assert np.array_equal(step.empty, ref.empty) and step.empty.any()
    assert np.abs(step.radii - ref.radii).max() <= 1e-9
    live = ~ref.empty
    assert np.abs(step.centers[live] - ref.centers[live]).max() <= 1e-9


def _radii_off(monkeypatch, engine_class):
    """Make every answer of ``diskpack_cl.engine.<engine_class>`` off by 1e-6 of its radii."""
    from diskpack_cl import engine as engine_mod

    cls = getattr(engine_mod, engine_class)
    real = cls._mic

    def off(self, points, weights, exact, certify, warm):
        m = real(self, points, weights, exact, certify, warm)
        m.radii = m.radii * (1 + 1e-6)
        return m

    monkeypatch.setattr(cls, "_mic", off)


def test_verify_catches_a_wrong_engine(ctx, monkeypatch):
    """verify=True is a real check: an engine whose radii are off fails."""
    _radii_off(monkeypatch, "OpenCLEngine")
    pts = dart_throwing(300, seed=14)
    with pytest.raises(RuntimeError, match="differ from exact_mic"):
        relax_poisson(pts, eps=0.99, max_iter=3, backend="opencl", device=ctx, verify=True)


def test_bad_route():
    with pytest.raises(ValueError, match="route must be one of"):
        make_engine(Domain.torus(), 10, "opencl", route="gpu")


def test_stipple_engine_routes_agree(ctx):
    """The stippling engine's float64 per-cell route and its raster route (for
    devices without float64), forced on PoCL, give the same power-cell MICs."""
    rng = np.random.default_rng(15)
    dom, shape = Domain.rect(90.0, 60.0), (120, 180)
    pts = rng.random((900, 2)) * (90.0, 60.0)
    w = (0.8 * rng.random(900)) ** 2
    cells = make_engine(dom, None, "opencl", device=ctx, grid=shape, route="cells")
    raster = make_engine(dom, None, "opencl", device=ctx, grid=shape, route="raster")
    assert cells.cells is not None and raster.cells is None
    a, b = cells.mic(pts, w), raster.mic(pts, w)
    assert np.array_equal(a.empty, b.empty)
    assert np.abs(a.radii - b.radii).max() <= 1e-9
    live = ~a.empty
    assert np.abs(a.centers[live] - b.centers[live]).max() <= 1e-9


def test_stipple_verify_runs_every_step_against_exact_mic(ctx):
    from diskpack_cl import stipple

    gray = np.linspace(0.05, 0.95, 48 * 64).reshape(48, 64)
    res = stipple(gray, 300, device=ctx, verify=True, schedule=[("mix", 3, 0.5), ("pack", 2)])
    assert res.certificate.valid and len(res.history) == 5


def test_stipple_verify_catches_a_wrong_engine(ctx, monkeypatch):
    from diskpack_cl import stipple

    _radii_off(monkeypatch, "OpenCLEngine")
    gray = np.linspace(0.05, 0.95, 48 * 64).reshape(48, 64)
    with pytest.raises(RuntimeError, match="differ from exact_mic"):
        stipple(gray, 300, device=ctx, verify=True, schedule=[("pack", 2)])


def test_stipple_cli_verify(ctx, tmp_path):
    from diskpack_cl import cli

    out = tmp_path / "s.npz"
    assert cli.main(["stipple", "sample", "-n", "300", "--schedule", "pack", "--verify",
                     "-o", str(out), "--quiet"]) == 0
    assert out.exists()


def _engine(name, dom, ctx):
    if name == "exact":
        return make_engine(dom, 5, "exact")
    return make_engine(dom, 5, "opencl", device=ctx, route=name)


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("name", ["cells", "raster", "exact"])
@pytest.mark.parametrize("pts, w, match", [
    (None, [0.1, np.nan, 0.2, 0.1, 0.3], "weights must be n finite numbers"),
    (np.full((5, 2), np.inf), None, "points contain NaN or infinite coordinates"),
    (np.zeros((0, 2)), None, r"need at least \d point\(s\), got 0"),
    (None, [0.0, -1e31, 0.0, 0.0, 0.0], "weights must span less than 1e"),
])
def test_every_engine_refuses_sites_it_cannot_bound(ctx, name, periodic, pts, w, match):
    """The engine classes are what new features call: each checks its sites
    (the raster route segfaulted on the NaN weight before, and never ended on
    a torus)."""
    dom = Domain.torus() if periodic else Domain.rect(8.0, 8.0)
    if pts is None:
        pts = np.random.default_rng(0).random((5, 2)) * (dom.width, dom.height)
    with pytest.raises(ValueError, match=match):
        _engine(name, dom, ctx).mic(pts, w)


# -- one protocol, one result type, one factory, one collector ---------------

def _protocol_engines(ctx, dom, grid):
    """Every engine the one factory makes, by route."""
    engines = {"exact": make_engine(dom, 60, "exact", grid=grid)}
    for route in ("cells", "raster"):
        engines[route] = make_engine(dom, 60, "opencl", device=ctx, grid=grid, route=route)
    return engines


def test_every_engine_answers_the_one_protocol_with_the_one_result_type(ctx):
    """Relaxation and stippling call the same engines: each answers ``mic`` with a
    geometry.MIC and ``centroids`` with (centroids, mass), and says which
    backend it is; a result type or factory of its own would fail here."""
    from diskpack_cl.geometry import MIC

    dom, grid = Domain.rect(30.0, 20.0), (40, 60)
    rng = np.random.default_rng(21)
    pts, w = rng.random((60, 2)) * (30.0, 20.0), (0.6 * rng.random(60)) ** 2
    dens = rng.random(grid) + 0.1
    ref = None
    for route, eng in _protocol_engines(ctx, dom, grid).items():
        assert eng.name == route and eng.backend == ("exact" if route == "exact" else "opencl")
        m = eng.mic(pts, w)
        assert type(m) is MIC and (m.nn is not None) == eng.gives_nn == (route == "cells")
        ref = ref or m
        assert np.array_equal(m.empty, ref.empty) and np.abs(m.radii - ref.radii).max() <= 1e-9
        c, mass = eng.centroids(pts, w, dens)
        assert c.shape == (60, 2) and mass.shape == (60,) and mass.sum() > 0


@pytest.mark.parametrize("route", ["exact", "cells", "raster"])
def test_the_collector_holds_every_stage_once(ctx, route):
    """The engine's one Stopwatch: a step's share (since a mark) plus the rest is
    the total, each kernel's seconds add up to ``kernel``, and the warm-up runs
    of the constructors are not counted."""
    dom, grid = Domain.rect(30.0, 20.0), (40, 60)
    if route == "exact":
        eng = make_engine(dom, 60, "exact", grid=grid)
    else:
        eng = make_engine(dom, 60, "opencl", device=ctx, grid=grid, route=route, profile=True)
    assert eng.timings.seconds == {}                     # nothing before the first call
    rng = np.random.default_rng(22)
    pts, w = rng.random((60, 2)) * (30.0, 20.0), (0.6 * rng.random(60)) ** 2
    eng.mic(pts, w)
    first = eng.timings.mark()
    eng.centroids(pts, np.zeros(60), np.ones(grid))
    step = eng.timings.since(first)
    assert "centroids" in step and not {"exact", "buckets"} & set(step)   # only what ran
    total = eng.timings.seconds
    for name, secs in step.items():
        assert total[name] == pytest.approx(first.get(name, 0.0) + secs)
    want = {"exact": {"exact"}, "cells": {"buckets", "device", "refine", "fallback"},
            "raster": {"raster_labels", "mic_estimate", "exact"}}[route]
    assert want <= set(first)
    if route != "exact":
        kernels = {k: v for k, v in total.items() if k.startswith("kernel_")}
        assert kernels and total["kernel"] == pytest.approx(sum(kernels.values()))


def test_verify_is_the_factory_s_switch_on_every_engine(ctx, monkeypatch):
    """``verify=True`` checks the answers of whatever engine the factory chose;
    without it a wrong answer passes (so the check is the switch's)."""
    _radii_off(monkeypatch, "ExactEngine")
    pts = np.random.default_rng(23).random((50, 2))
    make_engine(Domain.torus(), 50, "exact").mic(pts)
    with pytest.raises(RuntimeError, match="differ from exact_mic"):
        make_engine(Domain.torus(), 50, "exact", verify=True).mic(pts)
