"""OpenCL device choice: one cached context per device string.

Order of choice: the explicit ``device`` argument, then the environment
variable ``DISKPACK_DEVICE``, then ``PYOPENCL_CTX``, then the first GPU, then
the first CPU device (PoCL, installed from pip on Linux x86-64).

A device string is ``"P"`` or ``"P:D"`` (platform and device, each an index
or a case-insensitive name substring, as pyopencl reads ``PYOPENCL_CTX``:
``"0:1"``, ``"portable:0"``), or a case-insensitive substring of the device name,
platform name or platform vendor (``"pocl"``, ``"nvidia"``), or ``"cpu"``/``"gpu"``.
"""

from __future__ import annotations

import os

__all__ = ["NoOpenCLError", "get_context", "list_devices", "describe", "wait_for"]

_CONTEXTS: dict = {}

_FIX = (
    "install an OpenCL driver: on Linux x86-64 `pip install pocl-binary-distribution` "
    "gives a CPU device; elsewhere install PoCL or your GPU vendor's OpenCL runtime. "
    "Both algorithms also run without OpenCL on the exact backend"
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


def _available(pairs):
    return ", ".join(f"{a}:{b} {d.name.strip()}" for a, b, _, d in pairs)


def _matches(part, index, *names):
    """A device-string part matches an index (digits) or a name substring (case-insensitive)."""
    part = part.strip()
    if part.isdigit():
        return int(part) == index
    return any(part.lower() in name.lower() for name in names)


def _pick(spec):
    """The device a device string names, or the default one (first GPU, else first device).

    ``"P:D"``: platform P (index or name substring) and its device D (index
    or name substring; empty: 0), as pyopencl reads ``PYOPENCL_CTX``
    (``"portable:0"``, ``"0:1"``).  Without a colon: ``"P"`` (index: that
    platform's first device), ``"gpu"``/``"cpu"``, or a substring of a
    device or platform name.
    """
    import pyopencl as cl

    pairs = []
    for ip, p in enumerate(_platforms()):
        try:
            pairs += [(ip, idev, p, d) for idev, d in enumerate(p.get_devices())]
        except cl.Error:
            continue
    if not pairs:
        raise NoOpenCLError(f"OpenCL platforms exist but have no devices; {_FIX}")
    if not spec:
        return next((q[3] for q in pairs if q[3].type & cl.device_type.GPU), pairs[0][3])
    plat, colon, dev = spec.partition(":")
    kinds = {"gpu": cl.device_type.GPU, "cpu": cl.device_type.CPU}
    for ip, idev, p, d in pairs:
        if colon:
            hit = _matches(plat, ip, p.name, p.vendor) and _matches(dev or "0", idev, d.name)
        elif spec.strip().isdigit():
            hit = int(spec) == ip and idev == 0
        else:
            s = spec.strip().lower()
            hit = (s in kinds and d.type & kinds[s]) or _matches(s, -1, d.name, p.name, p.vendor)
        if hit:
            return d
    raise NoOpenCLError(f"no OpenCL device matches {spec!r}; available: {_available(pairs)}")


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


def wait_for(event):
    """Wait for an OpenCL event so that Ctrl-C and SIGTERM still get through.

    ``event.wait()`` blocks inside the OpenCL library, and Python runs signal
    handlers only between bytecodes, so a long kernel would hold off Ctrl-C
    until it ends.  Here a helper thread waits on the event, and the calling
    thread waits on that thread in slices of 0.1 s, handling signals in
    between: the ``KeyboardInterrupt`` (or the CLI's SIGTERM exception)
    arrives while the device is still busy.  Callers keep each enqueue
    bounded (see :class:`diskpack_cl.raster.PowerRaster`), so that what is
    already queued ends soon after; the helper is not a daemon thread, so an
    interrupted process exits once that enqueue is done (a daemon thread
    stopped inside the OpenCL library at exit would abort the process).

    Raises
    ------
    pyopencl.Error
        What ``event.wait()`` raised in the helper thread.
    """
    import threading

    done = threading.Event()
    failed = []

    def wait():
        try:
            event.wait()
        except BaseException as exc:  # handed to the caller below
            failed.append(exc)
        finally:
            done.set()

    threading.Thread(target=wait, name="diskpack-opencl-wait").start()
    while not done.wait(0.1):
        pass
    if failed:
        raise failed[0]


def describe(ctx):
    """One line naming the context's device and platform.

    Examples
    --------
    >>> text = describe(get_context())        # e.g. 'pthread-AMD EPYC (Portable Computing Language)'
    >>> text.endswith(")") and " (" in text
    True
    """
    d = ctx.devices[0]
    return f"{d.name.strip()} ({d.platform.name.strip()})"
