"""Where each stage ran: the summaries' ``stages``, the summary line and its fallback notes."""

import json
import warnings

import numpy as np
import pytest

from diskpack_cl import cli, describe, stipple, stipple_colors
from diskpack_cl.device.blur import DeviceBlur
from diskpack_cl.device.checks import DeviceWarning, UntrustedProgram
from diskpack_cl.device.stage import has_fp64
from diskpack_cl.poisson import poisson_disk, poisson_summary
from diskpack_cl.poisson3 import relax_poisson3
from diskpack_cl.relax import RelaxResult, relax_poisson, relax_summary
from diskpack_cl.jobs.tiles import TileOptions, stipple_tiled

GRAY = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
SHORT = [("mix", 3, 0.5)]
HOST = {"backend": "exact", "device": "cpu (scipy)"}
EXACT_ENGINE = {**HOST, "route": "exact"}
#: The fix that the exact engine's fallback names (diskpack_cl.device.context's advice).
FIX = "pip install pocl-binary-distribution"


@pytest.fixture
def no_opencl(monkeypatch):
    """No OpenCL platform, and no context cached from earlier tests."""
    import pyopencl

    import diskpack_cl.device.context as dev

    monkeypatch.setattr(pyopencl, "get_platforms", lambda: [])
    monkeypatch.setattr(dev, "_CONTEXTS", {})


@pytest.fixture
def untrusted_blur(ctx, monkeypatch):
    """The blur program refused on the device, as a failed device check refuses it."""
    if not has_fp64(ctx):
        pytest.skip("the device has no float64: the blur runs on the host anyway")

    def refused(self, device=None):
        raise UntrustedProgram("blur failed its check on X: wrong")

    monkeypatch.setattr(DeviceBlur, "__init__", refused)


def _main(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out), err


def _notes(err):
    return [line for line in err.splitlines() if line.startswith("diskpack: note: ")]


# ----------------------------------------------------------------- stippling

def test_the_exact_backend_says_exact_and_no_fallback():
    stages = stipple(GRAY, 60, schedule=SHORT, backend="exact").summary()["stages"]
    assert stages == {"engine": EXACT_ENGINE, "blur": HOST}


def test_an_opencl_run_names_the_device_of_each_stage(ctx):
    stages = stipple(GRAY, 60, schedule=SHORT, device=ctx).summary()["stages"]
    where = describe(ctx)
    assert stages["engine"]["backend"] == "opencl" and stages["engine"]["device"] == where
    assert stages["engine"]["route"] in ("cells", "raster")
    assert "fallback" not in stages["engine"]
    assert stages["blur"] == ({"backend": "opencl", "device": where} if has_fp64(ctx)
                              else {**HOST, "fallback": f"{where} has no float64 (cl_khr_fp64)"})


def test_without_opencl_the_summary_says_the_exact_engine_and_why(no_opencl):
    stages = stipple(GRAY, 60, schedule=SHORT).summary()["stages"]
    engine = stages["engine"]
    assert {k: engine[k] for k in EXACT_ENGINE} == EXACT_ENGINE
    assert engine["fallback"].startswith("no OpenCL device (no OpenCL platform found")
    assert FIX in engine["fallback"]
    assert stages["blur"] == HOST   # no device to blur on: the engine's note says why


def test_a_blur_that_falls_back_is_recorded_on_the_host(untrusted_blur, ctx):
    with pytest.warns(DeviceWarning, match="blur failed its check"):
        stages = stipple(GRAY, 60, schedule=SHORT, device=ctx).summary()["stages"]
    assert stages["blur"] == {**HOST, "fallback": "blur failed its check on X: wrong"}
    assert stages["engine"]["backend"] == "opencl"


def test_a_large_picture_s_bands_record_their_blur(untrusted_blur, ctx):
    tall = np.tile(np.linspace(0.0, 1.0, 24), (1100, 1))   # more than 1024 rows: in bands
    with pytest.warns(DeviceWarning):
        stages = stipple(tall, 200, schedule=SHORT, device=ctx).summary()["stages"]
    assert stages["blur"]["fallback"] == "blur failed its check on X: wrong"


def test_colour_and_tiled_summaries_hold_the_stages():
    img = np.dstack([GRAY, np.full(GRAY.shape, 0.3), np.full(GRAY.shape, 0.8)])
    colour = stipple_colors(img, 80, "cmy", backend="exact", schedule=SHORT).summary()["stages"]
    assert colour == {"engine": EXACT_ENGINE, "blur": HOST, "pens": EXACT_ENGINE}
    g = np.tile(np.linspace(0.0, 1.0, 96), (64, 1))
    tiled = stipple_tiled(g, 400, tiling=TileOptions(tiles="1x2", halo=2, seam_band=1),
                          schedule=SHORT, backend="exact")
    assert tiled.summary()["stages"] == {"engine": EXACT_ENGINE, "blur": HOST}
    assert all(part["stages"] == {"engine": EXACT_ENGINE, "blur": HOST} for part in tiled.history)


# ------------------------------------------------------------- command line

def test_stipple_line_and_json_name_the_engine_and_device(ctx, tmp_path, capsys):
    s, err = _main(["stipple", "sample", "-n", "500", "-o", str(tmp_path / "s.npz"), "--json"],
                   capsys)
    where = describe(ctx)
    assert s["stages"]["engine"]["backend"] == "opencl" and s["stages"]["engine"]["device"] == where
    name = where.rpartition(" (")[0]
    assert f" s in all on OpenCL ({name}); wrote " in err
    assert _notes(err) == ([] if has_fp64(ctx) else
                           [f"diskpack: note: blur ran on the host: {where} has no float64 "
                            f"(cl_khr_fp64)"])


def test_stipple_without_opencl_says_the_exact_engine_and_the_fix(no_opencl, tmp_path, capsys):
    s, err = _main(["stipple", "sample", "-n", "100", "--schedule", "pack", "--json",
                    "-o", str(tmp_path / "s.npz")], capsys)
    assert s["stages"]["engine"]["backend"] == "exact" and FIX in s["stages"]["engine"]["fallback"]
    assert " s in all on the host (exact engine); wrote " in err
    (note,) = _notes(err)
    assert note.startswith("diskpack: note: engine ran on the host: no OpenCL device (") and FIX in note


def test_stipple_notes_a_blur_on_the_host(untrusted_blur, tmp_path, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeviceWarning)
        s, err = _main(["stipple", "sample", "-n", "100", "--schedule", "pack", "--json",
                        "-o", str(tmp_path / "s.npz")], capsys)
    assert s["stages"]["blur"]["fallback"] == "blur failed its check on X: wrong"
    assert _notes(err) == ["diskpack: note: blur ran on the host: blur failed its check "
                           "on X: wrong"]


def test_poisson_line_and_json_say_where_and_why(no_opencl, tmp_path, capsys):
    s, err = _main(["poisson", "-n", "64", "--max-iter", "2", "--allow-unreached", "--json",
                    "-o", str(tmp_path / "p.npz")], capsys)
    assert s["backend"] == "exact" and s["stages"]["engine"]["backend"] == "exact"
    assert FIX in s["stages"]["engine"]["fallback"]
    assert "s on the host (exact engine), stop: " in err
    (note,) = _notes(err)
    assert note.startswith("diskpack: note: engine ran on the host: no OpenCL device (")


# ------------------------------------------------------- relaxation, poisson

def test_relax_and_poisson_summaries_hold_the_stages():
    res = relax_poisson(np.random.default_rng(0).random((64, 2)), 0.7, backend="exact")
    assert relax_summary(res, 0.7)["stages"] == {"engine": EXACT_ENGINE}
    assert poisson_summary(poisson_disk(64, seed=0, backend="exact"))["stages"] == \
        {"engine": EXACT_ENGINE}


def test_relax_on_opencl_names_its_device(ctx):
    res = relax_poisson(np.random.default_rng(0).random((64, 2)), 0.7, device=ctx)
    engine = relax_summary(res, 0.7)["stages"]["engine"]
    assert engine["backend"] == "opencl" and engine["device"] == describe(ctx)


def test_the_per_cell_kernel_s_fallback_count_is_no_reason():
    res = RelaxResult(np.zeros((2, 2)), np.ones(1), 0, "eps", 0.0, {}, "opencl", "gpu",
                      {"engine": "cells", "fallback": 3})
    assert res.stages == {"engine": {"backend": "opencl", "device": "gpu", "route": "cells"}}


def test_3d_relaxation_without_opencl_says_why(no_opencl):
    res = relax_poisson3(np.random.default_rng(0).random((40, 3)), 0.6, max_iter=3)
    engine = res.stages["engine"]
    assert (engine["backend"], engine["device"]) == ("exact", "cpu (scipy)")
    assert engine["fallback"].startswith("no OpenCL device (") and FIX in engine["fallback"]
