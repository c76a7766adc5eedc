"""Shared fixtures: an OpenCL context on the PoCL (or any) device.

Tests that need OpenCL ask for ``ctx``. Without any OpenCL platform they are
skipped with the driver error as the reason; with ``DISKPACK_CL_REQUIRE_OPENCL=1``
(set by ``.ci/run``) they fail instead.
"""

import os

import pytest

try:  # no per-example deadline: a 2-core CI machine has noisy timings
    from hypothesis import settings

    settings.register_profile("diskpack", deadline=None)
    settings.load_profile("diskpack")
except ImportError:  # pragma: no cover - hypothesis is in the test extra
    pass


def _require_opencl():
    return os.environ.get("DISKPACK_CL_REQUIRE_OPENCL", "") == "1"


def pytest_report_header(config):
    from diskpack_cl._device import NoOpenCLError, list_devices

    try:
        rows = list_devices()
    except NoOpenCLError as exc:
        return [f"OpenCL: none ({exc})"]
    return ["OpenCL devices:"] + [f"  {i}  {p} | {d} [{t}]" for i, p, d, t in rows]


@pytest.fixture(scope="session")
def ctx():
    """A ``pyopencl.Context`` from :func:`diskpack_cl._device.get_context`."""
    from diskpack_cl._device import NoOpenCLError, get_context

    try:
        return get_context()
    except NoOpenCLError as exc:
        if _require_opencl():
            pytest.fail(f"DISKPACK_CL_REQUIRE_OPENCL=1 but no OpenCL device: {exc}")
        pytest.skip(f"no OpenCL device: {exc}")
