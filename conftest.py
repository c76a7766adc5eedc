"""Test fixtures and hooks for tests/ and the doctests: an OpenCL context on the PoCL (or any) device.

Every test that needs OpenCL asks for ``ctx``. Without any OpenCL platform
those tests are skipped with the driver error as the reason; with
``DISKPACK_CL_REQUIRE_OPENCL=1`` (set by ``.ci/run``) they fail instead.
Doctests that need a device are named in :data:`OPENCL_DOCTESTS` and treated
the same way.

Hypothesis runs the ``ci`` profile (derandomized, no example database)
when ``CI`` is true (``.ci/run`` sets it), else ``diskpack``; ``HYPOTHESIS_PROFILE``
chooses one explicitly.

``DISKPACK_CL_HIDE_OPENCL=1`` patches pyopencl's platform list empty for the
whole run, so that one machine can check that the suite passes (and skips
cleanly) where no OpenCL exists; ``.ci/run`` runs the suite once that way.
"""

import os

import pytest

try:
    from hypothesis import HealthCheck, settings

    # The one home of what every property test shares; a test states only a budget
    # (max_examples) that differs from this one. No per-example deadline and no
    # too_slow check: a 2-core CI machine has noisy timings, and a device test's
    # example takes a kernel launch. Function-scoped fixtures (tmp_path, backend)
    # are shared by a test's examples on purpose: each example overwrites its files.
    settings.register_profile(
        "diskpack", max_examples=100, deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    # CI: the same examples on every run (derandomized, a fixed seed) and no
    # example database, so that a run depends on the commit alone
    settings.register_profile("ci", parent=settings.get_profile("diskpack"),
                              derandomize=True, database=None, print_blob=True)
    settings.load_profile(os.environ.get(
        "HYPOTHESIS_PROFILE",
        "ci" if os.environ.get("CI", "").lower() in ("1", "true", "yes") else "diskpack"))
except ImportError:  # pragma: no cover - hypothesis is in the test extra
    pass

#: Doctests that run OpenCL kernels (they cannot ask for the ``ctx`` fixture);
#: a class's entry also covers the doctests of its methods.
OPENCL_DOCTESTS = {
    "diskpack_cl.device.context.get_context",
    "diskpack_cl.device.context.describe",
    "diskpack_cl.device.context.group_size",
    "diskpack_cl.device.blur.DeviceBlur",
    "diskpack_cl.device.raster.PowerRaster",
    "diskpack_cl.device.raster.RasterResult",
    "diskpack_cl.device.stage.has_fp64",
    "diskpack_cl.device.stage.buffers_handed_on",
    "diskpack_cl.device.stage.DeviceStage",
    "diskpack_cl.device.checks",
    "diskpack_cl.device.known_answers",
    "diskpack_cl.engine.OpenCLEngine",
    "diskpack_cl.device.cells.CellMIC",
    "diskpack_cl.device.cells3.CellMIC3",
}


def _require_opencl():
    return os.environ.get("DISKPACK_CL_REQUIRE_OPENCL", "") == "1"


def _hide_opencl():
    return os.environ.get("DISKPACK_CL_HIDE_OPENCL", "") == "1"


def pytest_configure(config):
    if _hide_opencl():
        import pyopencl

        real = pyopencl.get_platforms
        pyopencl.get_platforms = lambda: []
        config.add_cleanup(lambda: setattr(pyopencl, "get_platforms", real))


def pytest_report_header(config):
    from diskpack_cl import NoOpenCLError, list_devices

    try:
        rows = list_devices()
    except NoOpenCLError as exc:
        return [f"OpenCL: none ({exc})"]
    return ["OpenCL devices:"] + [f"  {i}  {p} | {d} [{t}]" for i, p, d, t in rows]


def _context_or_skip():
    import warnings

    from diskpack_cl import NoOpenCLError, get_context
    from diskpack_cl.device.checks import DeviceWarning

    try:
        # a device passed over for the next one (pip's PoCL on AMD Zen 5 beside the
        # distribution's) says so once, here; the suite runs on the one taken
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeviceWarning)
            return get_context()
    except NoOpenCLError as exc:
        if _require_opencl():
            pytest.fail(f"DISKPACK_CL_REQUIRE_OPENCL=1 but no OpenCL device: {exc}")
        pytest.skip(f"no OpenCL device: {exc}")


@pytest.fixture(scope="session")
def ctx():
    """A ``pyopencl.Context`` from :func:`diskpack_cl.get_context`."""
    return _context_or_skip()


@pytest.fixture(params=["exact", "opencl"])
def backend(request):
    """Each engine in turn; the ``opencl`` one takes the ``ctx`` fixture (skips without a device)."""
    if request.param == "opencl":
        request.getfixturevalue("ctx")
    return request.param


def _runs_opencl(name):
    """Whether the doctest `name` is one of :data:`OPENCL_DOCTESTS` or a method of one."""
    return any(name == d or name.startswith(d + ".") for d in OPENCL_DOCTESTS)


def pytest_runtest_setup(item):
    if getattr(item, "dtest", None) is not None and _runs_opencl(item.dtest.name):
        _context_or_skip()
