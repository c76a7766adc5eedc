"""OpenCL device choice: one cached context per device string.

Order of choice: the explicit ``device`` argument, then the environment
variable ``DISKPACK_DEVICE``, then ``PYOPENCL_CTX``, then the first GPU, then
the first CPU device (PoCL, installed from pip on Linux x86-64).

A device string is ``"P"`` or ``"P:D"`` (platform and device indices, as in
``PYOPENCL_CTX``), or a case-insensitive substring of the device or platform
name (``"pocl"``, ``"nvidia"``, ``"cpu"``, ``"gpu"``).
"""

from __future__ import annotations

import os

__all__ = ["NoOpenCLError", "get_context", "list_devices", "describe"]

_CONTEXTS: dict = {}

_FIX = (
    "install an OpenCL driver: on Linux x86-64 `pip install pocl-binary-distribution` "
    "gives a CPU device; elsewhere install PoCL or your GPU vendor's OpenCL runtime. "
    "`--backend exact` works without OpenCL"
)


class NoOpenCLError(RuntimeError):
    """No usable OpenCL platform or device was found."""


def _platforms():
    try:
        import pyopencl as cl
    except ImportError as exc:  # pragma: no cover - pyopencl is a dependency
        raise NoOpenCLError(f"pyopencl is not importable ({exc}); {_FIX}") from exc
    try:
        platforms = cl.get_platforms()
    except cl.Error as exc:
        raise NoOpenCLError(f"no OpenCL platform found ({exc}); {_FIX}") from exc
    if not platforms:
        raise NoOpenCLError(f"no OpenCL platform found; {_FIX}")
    return platforms


def list_devices():
    """Return ``[(index_string, platform_name, device_name, type_name), ...]``.

    Raises
    ------
    NoOpenCLError
        When there is no OpenCL platform.
    """
    import pyopencl as cl

    rows = []
    for ip, p in enumerate(_platforms()):
        try:
            devices = p.get_devices()
        except cl.Error:
            continue
        for idev, d in enumerate(devices):
            rows.append((f"{ip}:{idev}", p.name.strip(), d.name.strip(),
                         cl.device_type.to_string(d.type)))
    return rows


def _pick(spec):
    import pyopencl as cl

    platforms = _platforms()
    pairs = []
    for ip, p in enumerate(platforms):
        try:
            pairs += [(ip, idev, p, d) for idev, d in enumerate(p.get_devices())]
        except cl.Error:
            continue
    if not pairs:
        raise NoOpenCLError(f"OpenCL platforms exist but have no devices; {_FIX}")
    if spec:
        parts = spec.split(":")
        if all(s.strip().isdigit() for s in parts if s.strip()) and parts[0].strip():
            ip = int(parts[0])
            idev = int(parts[1]) if len(parts) > 1 and parts[1].strip() else 0
            for q in pairs:
                if q[0] == ip and q[1] == idev:
                    return q[3]
            raise NoOpenCLError(
                f"no OpenCL device {spec!r}; available: "
                + ", ".join(f"{a}:{b} {d.name.strip()}" for a, b, _, d in pairs))
        s = spec.lower()
        kinds = {"gpu": cl.device_type.GPU, "cpu": cl.device_type.CPU}
        for q in pairs:
            d = q[3]
            if (s in kinds and d.type & kinds[s]) or s in d.name.lower() or s in q[2].name.lower():
                return d
        raise NoOpenCLError(
            f"no OpenCL device matches {spec!r}; available: "
            + ", ".join(f"{a}:{b} {d.name.strip()}" for a, b, _, d in pairs))
    for q in pairs:
        if q[3].type & cl.device_type.GPU:
            return q[3]
    return pairs[0][3]


def get_context(device=None):
    """Return a cached ``pyopencl.Context`` for the chosen device.

    Parameters
    ----------
    device : str or pyopencl.Context, optional
        Device string (see module docstring) or a ready context.

    Examples
    --------
    >>> ctx = get_context()
    >>> ctx is get_context()          # one context per device string
    True
    """
    import pyopencl as cl

    if isinstance(device, cl.Context):
        return device
    spec = device or os.environ.get("DISKPACK_DEVICE") or os.environ.get("PYOPENCL_CTX") or ""
    if spec not in _CONTEXTS:
        _CONTEXTS[spec] = cl.Context([_pick(spec)])
    return _CONTEXTS[spec]


def describe(ctx):
    """One line naming the context's device and platform."""
    d = ctx.devices[0]
    return f"{d.name.strip()} ({d.platform.name.strip()})"
