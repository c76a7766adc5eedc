"""Every kernel on the Oclgrind simulator: memory, data races, API use (the Oclgrind pass).

Each scenario of ``tests/oclgrind_scenarios.py`` runs in a child process on
Oclgrind with its memory check (always on), data-race check (uniform
writes included: several work items writing one value count too) and API check;
any report fails the test, except the simulator's known false positives
below, matched by their exact text.  The child's arrays must equal those of
the same scenario on the test's own device (integers exactly, floats to
1e-9 relative: Oclgrind and PoCL may contract multiply-adds differently).
Three runs take the simulator as trusted with 512-bit vectors
(``DISKPACK_TEST_WIDE=1``): the wide builds and the 16-lane tiles are
checked there even where the test's own driver is not trusted with them
(pip's PoCL on AMD Zen 4), against its 16-lane answers where it is, else
against its 8-lane ones.

These tests run only when asked: ``DISKPACK_CL_OCLGRIND=1`` (set by the
Oclgrind pass of ``.ci/run``; Debian's ``oclgrind`` package must be
installed).  Elsewhere they skip, so the README's test command needs no
simulator.  Locally::

    apt-get install oclgrind
    DISKPACK_CL_OCLGRIND=1 .venv/bin/python -m pytest -q tests/test_oclgrind.py

Known false positives
---------------------
``clGetDeviceInfo`` / ``CL_INVALID_VALUE`` / ``'param_name'`` (API check):
before a build through its source cache, pyopencl asks whether the device
is an NVIDIA GPU (``pyopencl.characterize.nv_compute_capability`` reads
``CL_DEVICE_COMPUTE_CAPABILITY_MAJOR_NV``, a property of an NVIDIA
extension that Oclgrind does not have) and catches the error itself.
Minimal reproduction, with ``OCLGRIND_CHECK_API=1``::

    from pyopencl.characterize import nv_compute_capability
    nv_compute_capability(oclgrind_device)     # one report; returns None

It reports once per program build, and never with ``PYOPENCL_NO_CACHE=1``.
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import oclgrind_scenarios

ICD = Path("/usr/lib/oclgrind/liboclgrind-rt-icd.so")

#: Reports of the simulator that are not errors of ours (see the module docstring).
FALSE_POSITIVES = (
    "Oclgrind - OpenCL runtime error detected\n"
    "\tFunction: clGetDeviceInfo\n"
    "\tError:    CL_INVALID_VALUE\n"
    "\tFor argument 'param_name'",
)

#: Scenarios and the extra simulator settings they run with: one with a work-group
#: limit of 16, so that the small-group launches are checked too.
RUNS = [(name, {}) for name in oclgrind_scenarios.SCENARIOS] + [
    ("raster_rect", {"OCLGRIND_MAX_WGSIZE": "16"}),
    ("cells_torus", {"OCLGRIND_MAX_WGSIZE": "8"}),
    ("cells3_torus", {"OCLGRIND_MAX_WGSIZE": "8"}),
    # the wide builds and 16-lane tiles, whether or not this machine's driver is trusted with them
    ("raster_rect", {"DISKPACK_TEST_WIDE": "1"}),
    ("raster_torus", {"DISKPACK_TEST_WIDE": "1"}),
    ("blur", {"DISKPACK_TEST_WIDE": "1"}),
]


@pytest.fixture(scope="module")
def icd_dir(tmp_path_factory):
    """A vendors folder that registers Oclgrind with the OpenCL ICD loader."""
    if os.environ.get("DISKPACK_CL_OCLGRIND", "") != "1":
        pytest.skip("the Oclgrind pass: DISKPACK_CL_OCLGRIND=1 (see this module's docstring)")
    if not ICD.is_file():
        pytest.fail(f"DISKPACK_CL_OCLGRIND=1 but {ICD} is missing: apt-get install oclgrind")
    folder = tmp_path_factory.mktemp("icd")
    (folder / "oclgrind.icd").write_text(f"{ICD}\n")
    return folder


def reports(text):
    """The simulator's reports in `text` (blank-line separated), known false positives removed."""
    blocks = [b.strip("\n") for b in text.split("\n\n")]
    found = [b for b in blocks if b.strip() and ("Oclgrind" in b or "\tKernel: " in b
                                                  or b.lstrip().startswith(("Invalid", "Data race",
                                                                            "Uninitialized")))]
    return [b for b in found if b not in FALSE_POSITIVES]


def test_reports_keep_errors_and_drop_only_the_known_false_positives():
    log = ("\n" + FALSE_POSITIVES[0] + "\n\n"
           "Invalid write of size 4 at global memory address 0x1000000000010\n"
           "\tKernel: k\n\n" + FALSE_POSITIVES[0].replace("param_name", "device") + "\n")
    got = reports(log)
    assert len(got) == 2 and got[0].startswith("Invalid write") and "'device'" in got[1]


_REPRODUCTION = """
import pyopencl as cl
from pyopencl.characterize import nv_compute_capability
dev = [p for p in cl.get_platforms() if p.name == "Oclgrind"][0].get_devices()[0]
assert nv_compute_capability(dev) is None
"""


def test_the_false_positive_is_what_its_reproduction_reports(icd_dir):
    env = dict(os.environ, OCL_ICD_VENDORS=str(icd_dir), OCLGRIND_CHECK_API="1")
    proc = subprocess.run([sys.executable, "-c", _REPRODUCTION], env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.strip("\n") == FALSE_POSITIVES[0] and reports(proc.stderr) == []


def _run_on_oclgrind(name, settings, icd_dir, tmp_path):
    log, out = tmp_path / "oclgrind.log", tmp_path / "out.npz"
    # the simulator's answers are checked here, scenario by scenario: no known-answer checks
    env = dict(os.environ, OCL_ICD_VENDORS=str(icd_dir), DISKPACK_DEVICE="oclgrind",
               DISKPACK_CL_DEVICE_CHECKS="0",
               OCLGRIND_CHECK_API="1", OCLGRIND_DATA_RACES="1", OCLGRIND_UNIFORM_WRITES="1",
               OCLGRIND_LOG=str(log), **settings)
    script = Path(oclgrind_scenarios.__file__)
    proc = subprocess.run([sys.executable, str(script), name, str(out)], env=env,
                          capture_output=True, text=True, timeout=600)
    text = proc.stderr + (log.read_text() if log.exists() else "")
    assert proc.returncode == 0, text[-4000:]
    return dict(np.load(out)), reports(text)


@pytest.mark.parametrize("name, settings", RUNS, ids=[n + "".join(f"-{k.split('_')[-1].lower()}{v}"
                                                               for k, v in s.items()) for n, s in RUNS])
def test_scenario_is_clean_on_oclgrind_and_matches(ctx, icd_dir, tmp_path, name, settings,
                                                  monkeypatch):
    got, found = _run_on_oclgrind(name, settings, icd_dir, tmp_path)
    assert "Oclgrind" in str(got.pop("device"))
    assert not found, "\n\n".join(found[:5])
    # the reference in Oclgrind's tile lanes: tiles of another shape round the fused
    # sums per tile elsewhere (the scenarios name the lanes where they test both)
    from diskpack_cl.device import stage as device_stage
    monkeypatch.setattr(device_stage, "tile_lanes", lambda verdict: 8)
    want = oclgrind_scenarios.SCENARIOS[name](ctx)
    # 16-lane tiles where both devices are trusted with them (only one side's where the
    # other is not: Oclgrind's memory checks above still ran on its own)
    assert all(k.startswith("tile16") for k in set(want) ^ set(got)), sorted(set(want) ^ set(got))
    if settings.get("DISKPACK_TEST_WIDE") == "1" and name.startswith("raster"):
        assert any(k.startswith("tile16") for k in got), sorted(got)
    for key, b in got.items():
        # a 16-lane answer the test's device does not give: its 8-lane one, whose tiles of
        # another shape round the fused sums otherwise (a few parts in 1e9)
        a = want.get(key, want.get(key.replace("tile16", "tile"), None))
        if a is None:
            continue
        if a.dtype.kind == "f":
            np.testing.assert_allclose(b, a, rtol=1e-9 if key in want else 1e-7, atol=0, err_msg=key)
        else:
            np.testing.assert_array_equal(b, a, err_msg=key)
