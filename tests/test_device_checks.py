"""Known-answer checks (diskpack_cl.device.checks): faults injected into the check itself.

Each fault is what a broken driver does: a program that returns wrong numbers,
one that crashes its process, one that never returns, and broken entries of
PoCL's kernel cache.  Each must be refused in the child, the parent (this
test process) stays alive, the fallback is taken, and the verdict is cached
and reused without running the checks again.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from diskpack_cl import NoOpenCLError
from diskpack_cl.device import checks as device_checks
from diskpack_cl.device import context as _device
from diskpack_cl.device.checks import DeviceWarning, verdict_of
from diskpack_cl.device.known_answers import check_device

pytest.importorskip("pyopencl")


@pytest.fixture
def fresh(monkeypatch, tmp_path, ctx):
    """A private verdict cache and no verdict or context remembered by this process."""
    monkeypatch.setenv("DISKPACK_CL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("DISKPACK_CL_CHECK_TIME_LIMIT_S", "60")
    monkeypatch.setattr(device_checks, "_MEMO", {})
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    return ctx


def _cached_files(tmp_path):
    return sorted((tmp_path / "cache" / "device-checks").glob("*.json"))


def _no_children(monkeypatch):
    """Make any further check process an error: a cached verdict must be enough."""
    def refuse(*args, **kwargs):
        raise AssertionError("the checks ran again where a verdict was cached")
    monkeypatch.setattr(device_checks.subprocess, "Popen", refuse)


def test_the_known_answers_pass_on_the_test_device(fresh, tmp_path):
    v = verdict_of(fresh)
    assert not v.cached and v.core_failure() is None
    assert all(e["ok"] for e in v.programs.values() if e["why"] != "the device has no float64")
    assert len(_cached_files(tmp_path)) == 1


def test_wrong_numbers_refuse_a_core_program_and_the_device(fresh, tmp_path, monkeypatch):
    monkeypatch.setenv("DISKPACK_CL_CHECK_FAULT", "cells=wrong")
    v = verdict_of(fresh)
    why = v.refused("cells")
    assert why is not None and "MIC radii" in why and "off by" in why
    assert v.refused("raster_labels") is None
    # the device is passed over with one line, and the engine falls back to the host
    with pytest.warns(DeviceWarning, match="passed over: cells"):
        with pytest.raises(NoOpenCLError, match="cells"):
            _device.get_context()
    from diskpack_cl.domain import Domain
    from diskpack_cl.engine import make_engine

    with pytest.warns(DeviceWarning):
        engine = make_engine(Domain.torus(), 100, "auto")
    assert engine.backend == "exact" and "cells" in engine.fallback
    # cached, and reused without a child (the fault is gone: the verdict still holds)
    monkeypatch.delenv("DISKPACK_CL_CHECK_FAULT")
    monkeypatch.setattr(device_checks, "_MEMO", {})
    _no_children(monkeypatch)
    again = verdict_of(fresh)
    assert again.cached and again.refused("cells") == why


def test_a_crash_refuses_that_program_only_and_its_stage_runs_on_the_host(fresh, monkeypatch):
    monkeypatch.setenv("DISKPACK_CL_CHECK_FAULT", "blur=crash")
    v = verdict_of(fresh)
    if v.programs["blur"]["why"] == "the device has no float64":
        pytest.skip("no float64: the blur never runs on this device")
    assert "crashed (SIGSEGV)" in v.refused("blur")
    # the programs after it were checked in a new child
    assert v.core_failure() is None and v.programs["cells3"]["ok"]
    from diskpack_cl.device.blur import DeviceBlur
    from diskpack_cl.device.checks import UntrustedProgram
    from diskpack_cl.stipple import stipple

    with pytest.raises(UntrustedProgram, match="blur failed its check"):
        DeviceBlur(fresh)
    g = np.linspace(0, 1, 48 * 32).reshape(32, 48)
    with pytest.warns(DeviceWarning, match="blurs on the host"):
        got = stipple(g, 60, seed=1, schedule=[("mix", 3, 0.5)], device=fresh)
    assert got.engine == "opencl" and len(got.points) == 60


def test_a_hang_is_killed_at_the_time_limit_and_refused(fresh, monkeypatch):
    monkeypatch.setenv("DISKPACK_CL_CHECK_FAULT", "parallel_darts=hang")
    monkeypatch.setenv("DISKPACK_CL_CHECK_TIME_LIMIT_S", "8")
    v = verdict_of(fresh)
    if v.programs["parallel_darts"]["why"] == "the device has no float64":
        pytest.skip("no float64: the dart rounds never run on this device")
    assert "no answer in 8 s (killed)" in v.refused("parallel_darts")
    assert v.programs["blur"]["ok"]   # checked after the hang, in a new child
    from diskpack_cl.parallel_darts import parallel_darts

    with pytest.warns(DeviceWarning, match="dart rounds on the host"):
        got = parallel_darts(3000, seed=4, device=fresh)
    np.testing.assert_array_equal(got, parallel_darts(3000, seed=4, device=False))


def test_the_checks_run_in_children_side_by_side(fresh, monkeypatch):
    """On two cores the programs are dealt to two children that run at once (each waits at
    a barrier only both pass together), and the verdict is that of one child for all."""
    import threading

    real = device_checks._children
    barrier, dealt = threading.Barrier(2, timeout=60), []

    def side_by_side(address, stems, wide, salt, limit=None):
        if limit is None and len(dealt) < 2:   # the two children of the first pass
            dealt.append(list(stems))
            barrier.wait()
        return real(address, stems, wide, salt, limit)

    monkeypatch.setattr(device_checks, "usable_cores", lambda: 2)
    monkeypatch.setattr(device_checks, "_children", side_by_side)
    both = device_checks._run_checks(fresh.devices[0])
    assert len(dealt) == 2 and not set(dealt[0]) & set(dealt[1])
    assert any({"raster_labels", "raster_sums"} <= set(group) for group in dealt)
    monkeypatch.setattr(device_checks, "usable_cores", lambda: 1)
    monkeypatch.setattr(device_checks, "_children", real)
    one = device_checks._run_checks(fresh.devices[0])
    assert list(both.programs) == list(one.programs) == list(device_checks.PROGRAMS)
    assert both.wide == one.wide
    assert {k: (e["ok"], e["why"]) for k, e in both.programs.items()} == {
        k: (e["ok"], e["why"]) for k, e in one.programs.items()}


@pytest.mark.parametrize("workers", [1, 2, 3, 4, 9])
def test_programs_built_together_are_checked_in_one_child(workers):
    """Each program once, the programs one stage builds together in one child (two
    children building one program would build it twice, at once, into one cache)."""
    stems = list(device_checks.PROGRAMS)
    groups = device_checks._dealt(stems, workers)
    assert sorted(s for g in groups for s in g) == sorted(stems)
    assert len(groups) == min(workers, len(device_checks.CHECK_COST))
    for family in device_checks.CHECK_COST:
        assert sum(bool(set(family) & set(g)) for g in groups) == 1, (family, groups)


def test_each_check_builds_only_programs_of_its_own_child(ctx, monkeypatch):
    """What a program's check builds lies in its entry of CHECK_COST (the nearest
    neighbours' engine builds the MIC program too): no two children build one program."""
    from diskpack_cl.device import stage as _stage
    from diskpack_cl.device.known_answers import CHECKS

    real, built = _stage.build_program, []

    def recorded(c, stem, defines=None):
        built.append(stem)
        return real(c, stem, defines)

    monkeypatch.setattr(_stage, "build_program", recorded)
    family = {s: set(group) for group in device_checks.CHECK_COST for s in group}
    fp64 = "cl_khr_fp64" in ctx.devices[0].extensions
    for stem in device_checks.PROGRAMS:
        if fp64 or stem not in device_checks.FP64_PROGRAMS:
            built.clear()
            assert CHECKS[stem](ctx, False) is None
            assert built and set(built) <= family[stem], (stem, built)


def test_a_damaged_verdict_file_is_checked_again(fresh, tmp_path, monkeypatch):
    verdict_of(fresh)
    (path,) = _cached_files(tmp_path)
    path.write_text('{"format": 1, "programs": {"cells": ')
    monkeypatch.setattr(device_checks, "_MEMO", {})
    v = verdict_of(fresh)
    assert not v.cached and json.loads(path.read_text())["programs"].keys() == v.programs.keys()


def test_checks_off_trusts_without_a_child(monkeypatch, ctx):
    monkeypatch.setenv("DISKPACK_CL_DEVICE_CHECKS", "0")
    monkeypatch.setattr(device_checks, "_MEMO", {})
    _no_children(monkeypatch)
    assert verdict_of(ctx).core_failure() is None


_SCRIPT = """
import json, warnings
warnings.simplefilter("always")
from diskpack_cl.device.known_answers import check_device
v = check_device()
print(json.dumps({"notes": v.notes, "failed": {k: e["why"] for k, e in v.programs.items()
                  if not e["ok"] and e["why"] != "the device has no float64"}}))
"""


def _check_in_process(env):
    proc = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def _is_pocl(ctx):
    return "Portable Computing Language" in ctx.devices[0].platform.name


@pytest.mark.parametrize("damage", ["random", "empty"])
def test_a_broken_kernel_cache_entry_is_rebuilt_fresh(ctx, tmp_path, damage):
    if not _is_pocl(ctx):
        pytest.skip("PoCL's kernel cache")
    env = dict(os.environ, POCL_CACHE_DIR=str(tmp_path / "pocl"), DISKPACK_CL_CACHE_DIR=str(tmp_path / "a"),
               DISKPACK_CL_CHECK_TIME_LIMIT_S="120")
    first, _ = _check_in_process(env)
    assert first["failed"] == {}
    rng = np.random.default_rng(0)
    broken = 0
    for p in (tmp_path / "pocl").rglob("*"):
        if p.is_file() and p.stat().st_size > 0:
            p.write_bytes(rng.bytes(256) if damage == "random" else b"")
            broken += 1
    assert broken
    env["DISKPACK_CL_CACHE_DIR"] = str(tmp_path / "b")   # no verdict yet: the checks run
    second, _ = _check_in_process(env)
    assert second["failed"] == {}
    assert any("fresh kernel-cache entry" in n for n in second["notes"]), second


def test_an_empty_pocl_cache_dir_gets_a_private_one(ctx, tmp_path):
    if not _is_pocl(ctx):
        pytest.skip("PoCL's kernel cache")
    env = dict(os.environ, POCL_CACHE_DIR="", DISKPACK_CL_CACHE_DIR=str(tmp_path / "a"))
    got, err = _check_in_process(env)
    assert got["failed"] == {}
    assert "POCL_CACHE_DIR was set empty" in err
    assert (tmp_path / "a" / "pocl").is_dir()


def test_devices_check_prints_the_table(fresh, capsys):
    from diskpack_cl.cli import main

    assert main(["devices", "--check"]) == 0
    out = capsys.readouterr().out
    for stem in device_checks.PROGRAMS:
        assert stem in out
    assert "using:" in out and "through builtins" in out


def test_check_device_names_the_device(fresh):
    v = check_device()
    assert v.device == _device.describe(fresh)
    assert check_device() is v   # remembered by this process


def test_a_run_without_a_trusted_device_says_so_and_names_the_fix(ctx, tmp_path):
    """No silent 20x: where the only device fails a core program (as pip's PoCL builds no
    kernel on AMD Zen 5), the stippling runs on the host and its summary says why and
    what gives a fast device."""
    env = dict(os.environ, DISKPACK_CL_CACHE_DIR=str(tmp_path / "cache"),
               DISKPACK_CL_CHECK_FAULT="raster_labels=wrong")
    out = tmp_path / "s.npz"
    proc = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", "stipple", "sample", "-n", "300",
                           "-o", str(out)], env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert out.exists()
    text = proc.stderr
    assert "on the host" in text and "raster_labels" in text and "pocl-opencl-icd" in text
