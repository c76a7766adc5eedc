"""Device strings: how DISKPACK_DEVICE / PYOPENCL_CTX / device= pick a device (fake platforms)."""

import pyopencl as cl
import pytest

from diskpack_cl import NoOpenCLError
from types import SimpleNamespace

from diskpack_cl.device import checks as device_checks
from diskpack_cl.device import context as _device
from diskpack_cl.device.checks import DeviceWarning


class _Dev:
    def __init__(self, name, kind):
        self.name, self.type = name, kind


class _Plat:
    def __init__(self, name, vendor, devices):
        self.name, self.vendor, self._devices = name, vendor, devices
        self.version = f"OpenCL 3.0 {name} 1.0"

    def get_devices(self):
        return self._devices


CPU = _Dev("pthread-AMD EPYC", cl.device_type.CPU)
GPU0 = _Dev("NVIDIA H200", cl.device_type.GPU)
GPU1 = _Dev("NVIDIA A100", cl.device_type.GPU)
PLATFORMS = [_Plat("Portable Computing Language", "The pocl project", [CPU]),
             _Plat("NVIDIA CUDA", "NVIDIA Corporation", [GPU0, GPU1])]


@pytest.fixture
def fake(monkeypatch):
    monkeypatch.setattr(_device, "_platforms", lambda: PLATFORMS)


@pytest.mark.parametrize("spec, want", [
    ("", GPU0),                      # default: the first GPU
    ("0", CPU), ("1", GPU0), ("1:1", GPU1), ("0:0", CPU), ("1:", GPU0),
    ("portable:0", CPU),             # pyopencl's PYOPENCL_CTX form: platform substring, device index
    ("nvidia:1", GPU1), ("NVIDIA:a100", GPU1), ("cuda:h200", GPU0),
    ("pocl", CPU),                   # platform vendor
    ("cpu", CPU), ("gpu", GPU0), ("a100", GPU1), ("Portable", CPU),
])
def test_device_strings(fake, spec, want):
    assert _device._pick(spec)[0] is want


@pytest.mark.parametrize("spec", ["2", "0:1", "portable:1", "amd:0", "opencl-nowhere", "1:h100"])
def test_unknown_device_strings_name_the_devices(fake, spec):
    with pytest.raises(NoOpenCLError, match=rf"no OpenCL device matches '{spec}'; available: "
                                            r"0:0 pthread-AMD EPYC, 1:0 NVIDIA H200, 1:1 NVIDIA A100"):
        _device._pick(spec)


def test_no_platform_message_names_no_command_line_flag(monkeypatch):
    monkeypatch.setattr(cl, "get_platforms", lambda: [])
    with pytest.raises(NoOpenCLError, match="no OpenCL platform found") as err:
        _device._platforms()
    assert "--" not in str(err.value) and "exact backend" in str(err.value)


def test_pyopencl_ctx_environment_is_read(fake, monkeypatch):
    made = []
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    monkeypatch.setattr(_device, "_context", lambda d: (made.append([d]) or object(), None))
    monkeypatch.setattr(device_checks, "verdict_of", lambda ctx: SimpleNamespace(core_failure=lambda: None))
    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.setenv("PYOPENCL_CTX", "portable:0")
    ctx = _device.get_context()
    assert made == [[CPU]] and _device.get_context() is ctx
    monkeypatch.setenv("DISKPACK_DEVICE", "1:1")      # ours first
    _device.get_context()
    assert made[-1] == [GPU1]


# -- devices whose compiler refuses kernels or gives wrong answers --------------------


def test_a_device_that_fails_its_core_checks_is_passed_over(fake, monkeypatch):
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    monkeypatch.setattr(_device, "_context", lambda d: (SimpleNamespace(devices=[d]), None))
    monkeypatch.setattr(_device, "describe", lambda ctx: ctx.devices[0].name)

    def verdict(ctx):
        why = "raster_labels: error: unknown target CPU 'generic'" if ctx.devices[0] is GPU0 else None
        return SimpleNamespace(core_failure=lambda: why)
    monkeypatch.setattr(device_checks, "verdict_of", verdict)
    with pytest.warns(DeviceWarning, match="NVIDIA H200 passed over: raster_labels"):
        assert _device.get_context().devices[0] is GPU1              # the next GPU
    with pytest.raises(NoOpenCLError, match="NVIDIA H200 passed over: raster_labels: .*unknown target"):
        with pytest.warns(DeviceWarning):
            _device.get_context("1:0")                               # asked for by name: refused


def test_no_device_with_a_context_is_no_opencl(fake, monkeypatch):
    monkeypatch.setattr(_device, "_CONTEXTS", {})
    monkeypatch.setattr(_device, "_context", lambda d: (None, f"{d.name}: no OpenCL context"))
    with pytest.raises(NoOpenCLError, match="H200: no OpenCL context; NVIDIA A100: no OpenCL context; "
                                            "pthread-AMD EPYC: no OpenCL context; install"):
        _device.get_context("")


def test_a_real_device_gives_a_context(ctx):
    made, why = _device._context(ctx.devices[0])
    assert why is None and made.devices[0] == ctx.devices[0]


# -- devices that report several kinds ------------------------------------

BOTH = cl.device_type.GPU | cl.device_type.CPU | cl.device_type.ACCELERATOR | cl.device_type.DEFAULT
OCLGRIND = _Dev("Oclgrind Simulator", BOTH)
SIM = _Plat("Oclgrind", "University of Bristol", [OCLGRIND])


@pytest.mark.parametrize("platforms, spec, want", [
    ([SIM] + PLATFORMS, "", GPU0),          # default: a GPU of one kind wins over the simulator
    ([SIM] + PLATFORMS, "gpu", GPU0),
    ([SIM] + PLATFORMS, "cpu", CPU),
    ([SIM, PLATFORMS[0]], "", CPU),         # no GPU: the CPU, not the device that says GPU too
    ([SIM, PLATFORMS[0]], "gpu", OCLGRIND),  # the only device that has the GPU bit
    ([SIM], "", OCLGRIND),
    ([SIM] + PLATFORMS, "oclgrind", OCLGRIND),
    ([SIM] + PLATFORMS, "0", OCLGRIND),     # an explicit index always wins
])
def test_devices_of_several_kinds(monkeypatch, platforms, spec, want):
    monkeypatch.setattr(_device, "_platforms", lambda: platforms)
    assert _device._pick(spec)[0] is want


@pytest.mark.parametrize("dev, kind", [
    (CPU, "CPU"), (GPU0, "GPU"), (OCLGRIND, "GPU | CPU | ACCELERATOR"),
    (_Dev("pocl", cl.device_type.CPU | cl.device_type.DEFAULT), "CPU"),
])
def test_device_kind_names_every_kind_and_nothing_else(dev, kind):
    assert _device.device_kind(dev) == kind


def test_devices_command_names_kinds(monkeypatch, capsys):
    import diskpack_cl
    from diskpack_cl import cli

    monkeypatch.setattr(_device, "_platforms", lambda: [SIM] + PLATFORMS)
    monkeypatch.setattr(diskpack_cl, "get_context", lambda device=None: SimpleNamespace(
        devices=[SimpleNamespace(platform=PLATFORMS[1])]))
    monkeypatch.setattr(diskpack_cl, "describe", lambda ctx: "NVIDIA H200 (NVIDIA CUDA)")
    assert cli.main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "Oclgrind Simulator  [GPU | CPU | ACCELERATOR]" in out
    assert "pthread-AMD EPYC  [CPU]" in out and "ALL" not in out
    # each platform's version, and no origin for a platform that is no driver's object
    assert "    2  NVIDIA CUDA  |  OpenCL 3.0 NVIDIA CUDA 1.0\n         from unknown" in out
    assert out.endswith("using: NVIDIA H200 (NVIDIA CUDA), OpenCL 3.0 NVIDIA CUDA 1.0\n")


def test_library_origin_names_pip_or_the_system_s_icd_file(tmp_path):
    """A driver inside the environment is pip's; outside, the ICD file that names it
    (by its file name, or its path through a link) is the system's."""
    venv, lib = tmp_path / "venv", tmp_path / "usr" / "lib"
    (venv / "site").mkdir(parents=True)
    lib.mkdir(parents=True)
    (lib / "libpocl.so.2.10.0").touch()
    (lib / "libpocl.so.2").symlink_to(lib / "libpocl.so.2.10.0")
    by_name, by_path, other = (tmp_path / f"{k}.icd" for k in ("pocl", "linked", "other"))
    by_name.write_text("libpocl.so.2.10.0\n")
    by_path.write_text(f"{lib / 'libpocl.so.2'}\n")
    other.write_text("libnvidia-opencl.so.1\n")
    pip = venv / "site" / "libpocl-21062cec.so"
    assert _device.library_origin(str(pip), prefix=venv, icds=[by_name]) == f"pip: {pip}"
    system = str(lib / "libpocl.so.2.10.0")
    for icd in (by_name, by_path):
        assert _device.library_origin(system, prefix=venv, icds=[other, icd]) == \
            f"system: {icd} -> {system}"
    assert _device.library_origin(system, prefix=venv, icds=[other]) == system


def test_every_real_platform_has_its_version_and_origin(ctx):
    import os

    for _, _, version, origin in _device.list_platforms():
        assert version.startswith("OpenCL ")
        kind, _, where = origin.partition(": ")
        assert kind in ("pip", "system"), origin
        assert os.path.isfile(where.rpartition(" -> ")[2]), origin


def test_hypothesis_is_derandomized_in_ci():
    """With CI=true the suite runs hypothesis's fixed-seed profile without a database."""
    import os
    import subprocess
    import sys

    code = ("import conftest, hypothesis; s = hypothesis.settings.default; "
            "print(s.derandomize, s.database)")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "CI": "true"}
    env.pop("HYPOTHESIS_PROFILE", None)
    out = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == ["True", "None"]


@pytest.mark.parametrize("variable", ["DISKPACK_DEVICE", "PYOPENCL_CTX"])
def test_a_device_asked_for_in_the_environment_that_does_not_exist_is_an_error(
        ctx, tmp_path, capsys, monkeypatch, variable):   # ctx: the devices it lists exist
    from diskpack_cl import cli

    monkeypatch.delenv("DISKPACK_DEVICE", raising=False)
    monkeypatch.setenv(variable, "no-such-device")
    out = tmp_path / "x.svg"
    assert cli.main(["stipple", "sample", "-n", "200", "-o", str(out)]) == 1
    assert (f"diskpack: error: {variable}=no-such-device: no OpenCL device matches "
            f"'no-such-device'; available: ") in capsys.readouterr().err
    assert not out.exists()


def test_a_device_given_as_an_argument_is_named_as_given(ctx, tmp_path, capsys, monkeypatch):
    from diskpack_cl import cli

    monkeypatch.setenv("PYOPENCL_CTX", "0")
    out = tmp_path / "x.svg"
    assert cli.main(["stipple", "sample", "-n", "200", "--device", "no-such-device",
                     "-o", str(out)]) == 1
    assert ("diskpack: error: no OpenCL device matches 'no-such-device'"
            in capsys.readouterr().err)


def test_lent_arrays_are_read_as_uploads_and_kept_until_lent_again(ctx):
    """DeviceStage.lend: the kernels read the host array's values (on a CPU the array
    itself, kept by the stage while the device may read it: until its name is lent again);
    DeviceStage.zeros: a buffer of zeros, whatever it held."""
    import gc
    import weakref

    import numpy as np

    from diskpack_cl.device.stage import DeviceStage

    stage = DeviceStage(ctx)
    a = np.arange(1000, dtype=np.float32)
    ref = weakref.ref(a)
    buf = stage.lend("x", a)
    out = np.empty_like(a)
    cl.enqueue_copy(stage.queue, out, buf)
    assert np.array_equal(out, np.arange(1000))
    del a, buf
    gc.collect()
    assert (ref() is not None) == stage.is_cpu   # an upload keeps no host array
    stage.lend("x", np.zeros(3, np.float32))
    gc.collect()
    assert ref() is None
    b = np.ones(5, np.float32)
    ref = weakref.ref(b)
    stage.lend("y", b)
    del b
    stage.release_lent()   # the caller's kernels are done
    gc.collect()
    assert ref() is None
    z = stage.upload("z", np.full(16, 7, np.int32))
    assert stage.zeros("z", 32) is z
    back = np.empty(16, np.int32)
    cl.enqueue_copy(stage.queue, back, z)
    assert back.tolist() == [0] * 8 + [7] * 8
