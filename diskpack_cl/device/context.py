"""OpenCL device choice: one cached context per device string.

Order of choice: the explicit ``device`` argument, then the environment
variable ``DISKPACK_DEVICE``, then ``PYOPENCL_CTX``, then the first GPU, then
the first CPU device (PoCL, installed from pip on Linux x86-64).  A device
that reports several kinds at once (the Oclgrind simulator says GPU, CPU and
accelerator) is named so (:func:`device_kind`), and a device of one kind
wins over it, for the default and for ``"gpu"`` and ``"cpu"``.

A device string is ``"P"`` or ``"P:D"`` (platform and device, each an index
or a case-insensitive name substring, as pyopencl reads ``PYOPENCL_CTX``:
``"0:1"``, ``"portable:0"``), or a case-insensitive substring of the device name,
platform name or platform vendor (``"pocl"``, ``"nvidia"``), or ``"cpu"``/``"gpu"``.
"""

from __future__ import annotations

import os
import warnings

__all__ = ["NoOpenCLError", "get_context", "context_unchecked", "list_devices", "list_platforms",
           "platform_origin", "library_origin", "icd_files", "describe", "wait_for", "device_kind",
           "kernel_group_limit", "group_size", "preferred_multiple", "padded",
           "requested_device", "check_requested_device"]

_CONTEXTS: dict = {}
_KINDS = ("GPU", "CPU", "ACCELERATOR")

_FIX = (
    "install an OpenCL driver: on Linux x86-64 `pip install pocl-binary-distribution` "
    "gives a CPU device; on CPUs newer than its LLVM, such as AMD Zen 5, "
    "`sudo apt install pocl-opencl-icd` gives one on Debian and Ubuntu, and a stippling "
    "about 13x faster than on the host; GPUs: your vendor's OpenCL runtime. "
    "Both algorithms also run without OpenCL on the exact backend"
)


class NoOpenCLError(RuntimeError):
    """No usable OpenCL platform or device was found.

    Examples
    --------
    Raised for a device that does not exist, and where OpenCL has no platform:

    >>> try:
    ...     get_context("no-such-device")
    ... except NoOpenCLError as exc:
    ...     print(type(exc).__name__, isinstance(exc, RuntimeError))
    NoOpenCLError True
    """


def _usable_pocl_cache():
    """PoCL refuses every context when ``POCL_CACHE_DIR`` is set empty: point it at a
    private folder of ours instead (before PoCL starts, which reads it once), with a note."""
    if os.environ.get("POCL_CACHE_DIR", None) == "":
        from .cache import cache_dir
        from .checks import DeviceWarning

        os.environ["POCL_CACHE_DIR"] = str(cache_dir() / "pocl")
        warnings.warn(DeviceWarning(f"POCL_CACHE_DIR was set empty, which PoCL cannot use: "
                                    f"kernels are cached in {os.environ['POCL_CACHE_DIR']}"))


def _platforms():
    _usable_pocl_cache()
    try:
        import pyopencl as cl  # not loaded at start-up
    except ImportError as exc:  # pragma: no cover - pyopencl is a dependency
        raise NoOpenCLError(f"pyopencl is not importable ({exc}); {_FIX}") from exc
    try:
        platforms = cl.get_platforms()
    except cl.Error as exc:
        raise NoOpenCLError(f"no OpenCL platform found ({exc}); {_FIX}") from exc
    if not platforms:
        raise NoOpenCLError(f"no OpenCL platform found; {_FIX}")
    return platforms


def _kinds(device):
    """The kinds among GPU, CPU and ACCELERATOR whose bits `device` reports."""
    import pyopencl as cl  # not loaded at start-up

    return [k for k in _KINDS if device.type & getattr(cl.device_type, k)]


def device_kind(device):
    """The kind of an OpenCL device: ``"GPU"``, ``"CPU"``, ``"ACCELERATOR"``, ...

    Only those bits count (``DEFAULT`` and ``ALL`` say nothing of the
    device; pyopencl's ``to_string`` prints PoCL's CPU as "ALL | CPU").  A
    device that reports several kinds is named by all of them, joined by
    ``" | "`` (Oclgrind: ``"GPU | CPU | ACCELERATOR"``); one with none, by
    pyopencl's name of its bits.
    """
    import pyopencl as cl  # not loaded at start-up

    kinds = _kinds(device)
    return " | ".join(kinds) if kinds else cl.device_type.to_string(device.type)


def list_devices():
    """Return ``[(index_string, platform_name, device_name, kind), ...]``.

    ``kind`` is :func:`device_kind`'s name.

    Raises
    ------
    NoOpenCLError
        When there is no OpenCL platform.

    Examples
    --------
    Empty where OpenCL has no platform; otherwise one row per device:

    >>> try:
    ...     rows = list_devices()
    ... except NoOpenCLError:
    ...     rows = []
    >>> all(len(row) == 4 and row[3] for row in rows)
    True
    """
    import pyopencl as cl  # not loaded at start-up

    rows = []
    for ip, p in enumerate(_platforms()):
        try:
            devices = p.get_devices()
        except cl.Error:
            continue
        for idev, d in enumerate(devices):
            rows.append((f"{ip}:{idev}", p.name.strip(), d.name.strip(), device_kind(d)))
    return rows


def list_platforms():
    """Return ``[(index, name, version, origin), ...]``: each OpenCL platform, its version
    string and where its driver comes from (:func:`platform_origin`); NoOpenCLError
    where there is none, as :func:`list_devices`.

    Examples
    --------
    >>> from contextlib import suppress
    >>> with suppress(NoOpenCLError):
    ...     assert all(version.startswith("OpenCL") for _, _, version, _ in list_platforms())
    """
    return [(str(i), p.name.strip(), p.version.strip(), platform_origin(p))
            for i, p in enumerate(_platforms())]


def platform_origin(platform):
    """Where the driver of an OpenCL `platform` comes from: ``"pip: LIBRARY"`` (a library
    inside this Python's environment, as pip's PoCL), ``"system: ICD -> LIBRARY"`` (a
    library an ICD file of the system's loader names), or ``"LIBRARY"`` / ``"unknown"``.

    The library is the shared object the platform's object lives in (its address, or that
    of its ICD dispatch table, in ``/proc/self/maps``; Linux only).

    Examples
    --------
    >>> platform_origin(object())   # no driver's platform
    'unknown'
    """
    import ctypes  # not loaded at start-up

    # a vendor's platform object is in its library, or else (on the heap) starts with a
    # pointer to its ICD dispatch table, which is; read only where memory is readable
    address = int(getattr(platform, "int_ptr", 0) or 0)
    perms, library = _mapping(address)
    if library is None and "r" in perms:
        library = _mapping(ctypes.c_void_p.from_address(address).value or 0)[1]
    return library_origin(library) if library else "unknown"


def _mapping(address):
    """``(permissions, file or None)`` of the memory at `address` in this process:
    ``("", None)`` where nothing is mapped there or /proc cannot tell."""
    try:
        with open("/proc/self/maps", encoding="utf-8") as fh:
            for line in fh:
                fields = line.split(maxsplit=5)
                lo, _, hi = fields[0].partition("-")
                if int(lo, 16) <= address < int(hi, 16):
                    path = fields[5].strip() if len(fields) == 6 else ""
                    return fields[1], path if path.startswith("/") else None
    except OSError:
        pass
    return "", None


def icd_files():
    """The ICD files the OpenCL loader reads: those of ``OCL_ICD_VENDORS`` (a file or a
    folder) and of ``/etc/OpenCL/vendors``.

    Examples
    --------
    >>> all(str(path).endswith(".icd") for path in icd_files())
    True
    """
    from pathlib import Path  # not loaded at start-up

    found = []
    for where in (os.environ.get("OCL_ICD_VENDORS"), "/etc/OpenCL/vendors"):
        path = Path(where) if where else None
        if path is not None and path.is_dir():
            found += sorted(path.glob("*.icd"))
        elif path is not None and path.suffix == ".icd" and path.is_file():
            found.append(path)
    return found


def library_origin(library, *, prefix=None, icds=None):
    """Where the driver `library` (a path) comes from: ``"pip: LIBRARY"`` inside the
    environment `prefix` (default ``sys.prefix``), else ``"system: ICD -> LIBRARY"``
    with the ICD file of `icds` (default :func:`icd_files`) that names it, else the path.

    Examples
    --------
    >>> library_origin("/venv/lib/site-packages/pyopencl/.libs/libpocl.so", prefix="/venv")
    'pip: /venv/lib/site-packages/pyopencl/.libs/libpocl.so'
    >>> library_origin("/opt/x/libx.so", prefix="/venv", icds=[])
    '/opt/x/libx.so'
    """
    import sys  # not loaded at start-up
    from pathlib import Path  # not loaded at start-up

    prefix = os.path.realpath(sys.prefix if prefix is None else prefix)
    real = os.path.realpath(library)
    if os.path.commonpath([prefix, real]) == prefix:
        return f"pip: {library}"
    for icd in icd_files() if icds is None else icds:
        try:
            named = Path(icd).read_text(encoding="utf-8").strip()
        except OSError:
            continue
        if named and (os.path.realpath(named) == real if os.path.isabs(named)
                      else os.path.basename(real).startswith(named)
                      or os.path.basename(library) == named):
            return f"system: {icd} -> {library}"
    return library


def _available(pairs):
    return ", ".join(f"{a}:{b} {d.name.strip()}" for a, b, _, d in pairs)


def _matches(part, index, *names):
    """A device-string part matches an index (digits) or a name substring (case-insensitive)."""
    part = part.strip()
    if part.isdigit():
        return int(part) == index
    return any(part.lower() in name.lower() for name in names)


def _of_kind(pairs, kind, mixed=True):
    """The first device of `kind` alone; else (with `mixed`) the first that reports it among others."""
    found = [d for *_, d in pairs if _kinds(d) == [kind]]
    if mixed:
        found += [d for *_, d in pairs if kind in _kinds(d)]
    return found[0] if found else None


def _preferred(pairs):
    """Every device, the default first: GPUs, then CPUs, of one kind each; then the rest."""
    order = [d for *_, d in pairs if _kinds(d) == ["GPU"]] + [d for *_, d in pairs if _kinds(d) == ["CPU"]]
    return order + [d for *_, d in pairs if d not in order]


def _context(device):
    """``(context, None)`` on `device`, or ``(None, why)`` where the driver refuses one."""
    import pyopencl as cl  # not loaded at start-up

    try:
        return cl.Context([device]), None
    except cl.Error as exc:
        return None, f"{device.name.strip()}: no OpenCL context ({exc})"


def _pick(spec):
    """The devices a device string names, or every device, the default first (:func:`_preferred`).

    ``"P:D"``: platform P (index or name substring) and its device D (index
    or name substring; empty: 0), as pyopencl reads ``PYOPENCL_CTX``
    (``"portable:0"``, ``"0:1"``).  Without a colon: ``"P"`` (index: that
    platform's first device), ``"gpu"``/``"cpu"`` (a device of that kind
    alone wins over one that reports several kinds), or a substring of a
    device or platform name.
    """
    import pyopencl as cl  # not loaded at start-up

    pairs = []
    for ip, p in enumerate(_platforms()):
        try:
            pairs += [(ip, idev, p, d) for idev, d in enumerate(p.get_devices())]
        except cl.Error:
            continue
    if not pairs:
        raise NoOpenCLError(f"OpenCL platforms exist but have no devices; {_FIX}")
    if not spec:
        return _preferred(pairs)
    plat, colon, dev = spec.partition(":")
    kind = spec.strip().upper()
    if not colon and kind in ("GPU", "CPU") and (found := _of_kind(pairs, kind)) is not None:
        return [found]
    for ip, idev, p, d in pairs:
        if colon:
            hit = _matches(plat, ip, p.name, p.vendor) and _matches(dev or "0", idev, d.name)
        elif spec.strip().isdigit():
            hit = int(spec) == ip and idev == 0
        else:
            hit = _matches(spec, -1, d.name, p.name, p.vendor)
        if hit:
            return [d]
    raise NoOpenCLError(f"no OpenCL device matches {spec!r}; available: {_available(pairs)}")


def get_context(device=None):
    """Return a cached ``pyopencl.Context`` for the chosen device, once it is trusted.

    A device is taken once its core programs gave the host's answers (:mod:`diskpack_cl.device.checks`: run
    once per driver, device and kernel sources, in child processes, and
    cached); a device that fails them is passed over, with one line saying
    why, for the next one the device string allows.

    Parameters
    ----------
    device : str or pyopencl.Context, optional
        Device string (see module docstring) or a ready context (taken as it is).

    Raises
    ------
    NoOpenCLError
        No device, or none that builds kernels and gives the known answers.

    Examples
    --------
    >>> ctx = get_context()
    >>> ctx is get_context()          # one context per device string
    True
    """
    import pyopencl as cl  # not loaded at start-up

    from .checks import DeviceWarning, verdict_of  # not loaded at start-up

    if isinstance(device, cl.Context):
        return device
    spec = requested_device(device)
    if spec not in _CONTEXTS:
        refused = []
        for ctx, why in _contexts(spec):
            failure = None if ctx is None else verdict_of(ctx).core_failure()
            if ctx is not None and failure is None:
                _CONTEXTS[spec] = ctx
                break
            if why is None:
                why = f"{describe(ctx)} passed over: {failure}"
                warnings.warn(DeviceWarning(why), stacklevel=2)
            refused.append(why)
        else:
            raise NoOpenCLError(f"{'; '.join(refused)}; {_FIX}")
    return _CONTEXTS[spec]


def context_unchecked(device=None):
    """The context :func:`get_context` would try first, before its known-answer checks
    (``diskpack devices --check`` checks it)."""
    import pyopencl as cl  # not loaded at start-up

    if isinstance(device, cl.Context):
        return device
    refused = []
    for ctx, why in _contexts(requested_device(device)):
        if ctx is not None:
            return ctx
        refused.append(why)
    raise NoOpenCLError(f"{'; '.join(refused)}; {_FIX}")


def requested_device(device=None):
    """The device string a run asks for: `device`, else ``DISKPACK_DEVICE``, else
    ``PYOPENCL_CTX``; ``""`` where none is asked for (the best available).

    Examples
    --------
    >>> requested_device("pocl")
    'pocl'
    """
    return device or os.environ.get("DISKPACK_DEVICE") or os.environ.get("PYOPENCL_CTX") or ""


def check_requested_device(device=None):
    """Refuse, before the work, a device asked for (:func:`requested_device`) that does not
    exist or fails its checks; nothing asked for, or a list for several workers
    (``"0:0,0:1"``, each checked where it runs), passes.

    Raises
    ------
    NoOpenCLError
        With the message of :func:`get_context`, whichever way the device was asked for.

    Examples
    --------
    >>> check_requested_device("no-such-device")
    Traceback (most recent call last):
    ...
    diskpack_cl.device.context.NoOpenCLError: no OpenCL ...

    (``no OpenCL device matches 'no-such-device'; available: ...``, or where no
    platform is installed ``no OpenCL platform found; ...``.)
    """
    spec = requested_device(device)
    if spec and "," not in spec:
        try:
            get_context(spec)
        except NoOpenCLError as exc:
            if device:
                raise
            asked = "DISKPACK_DEVICE" if os.environ.get("DISKPACK_DEVICE") else "PYOPENCL_CTX"
            raise NoOpenCLError(f"{asked}={spec}: {exc}") from None


def _contexts(spec):
    """``(context, None)`` or ``(None, why)`` for each device `spec` names, the default first."""
    for d in _pick(spec):
        yield _context(d)


#: Threads that wait on events for :func:`wait_for`, and the process that made them.
_WAITERS = [None, None]


def _waiters():
    """The waiting threads' pool (ThreadPoolExecutor), made anew in a forked child (the
    parent's threads are not there, and its pool would count them as idle)."""
    from concurrent.futures import ThreadPoolExecutor  # not loaded at start-up

    if _WAITERS[1] != os.getpid():
        _WAITERS[:] = [ThreadPoolExecutor(4, thread_name_prefix="diskpack-opencl-wait"), os.getpid()]
    return _WAITERS[0]


def wait_for(event):
    """Wait for an OpenCL event so that Ctrl-C and SIGTERM still get through.

    ``event.wait()`` blocks inside the OpenCL library, and Python runs signal
    handlers only between bytecodes, so a long kernel would hold off Ctrl-C
    until it ends.  Here a helper thread waits on the event, and the calling
    thread waits on that thread in slices of 0.1 s, handling signals in
    between: the ``KeyboardInterrupt`` (or the CLI's SIGTERM exception)
    arrives while the device is still busy.  Callers keep each enqueue
    bounded (see :class:`diskpack_cl.device.raster.PowerRaster`), so that what is
    already queued ends soon after; the helpers are not daemon threads, so an
    interrupted process exits once that enqueue is done (a daemon thread
    stopped inside the OpenCL library at exit would abort the process).
    The helpers are a pool kept from wait to wait (a thread started per wait
    cost about 60 us more: a tenth of a small relaxation's step), and an
    event already complete needs none.

    Raises
    ------
    pyopencl.Error
        What ``event.wait()`` raised in the helper thread.
    """
    from concurrent.futures import TimeoutError as Later  # not loaded at start-up

    import pyopencl as cl  # not loaded at start-up

    if event.command_execution_status == cl.command_execution_status.COMPLETE:
        return   # already done (a pass that ran beside another, a later band): no helper
    waited = _waiters().submit(event.wait)
    while True:
        try:
            return waited.result(0.1)   # raises what event.wait() raised
        except Later:
            pass


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


def kernel_group_limit(kernel, device):
    """The largest work-group `kernel` may run in on `device`.

    The smaller of the kernel's ``CL_KERNEL_WORK_GROUP_SIZE`` (what its
    registers and local memory allow) and the device's maximum.  Tests
    replace this function to force a small GPU's limits on any device.
    """
    import pyopencl as cl  # not loaded at start-up

    info = cl.kernel_work_group_info.WORK_GROUP_SIZE
    return min(kernel.get_work_group_info(info, device), device.max_work_group_size)


def group_size(kernel, device, want):
    """Work-group size for a 1-D launch of `kernel`: at most `want` and the limit.

    Rounded down to a multiple of the kernel's preferred work-group size
    multiple (a GPU's warp or wavefront) where the limit leaves one.

    Examples
    --------
    >>> ctx = get_context()
    >>> from diskpack_cl.device.programs import build_program
    >>> k = build_program(ctx, "raster_mic", {"PERIODIC": 1})["cell_max"]
    >>> g = group_size(k, ctx.devices[0], 256)
    >>> 1 <= g <= 256
    True
    """
    limit = max(1, min(int(want), kernel_group_limit(kernel, device)))
    multiple = preferred_multiple(kernel, device)
    return limit // multiple * multiple if limit >= multiple else limit


def preferred_multiple(kernel, device):
    """The kernel's preferred work-group size multiple on `device` (a GPU's warp)."""
    import pyopencl as cl  # not loaded at start-up

    info = cl.kernel_work_group_info.PREFERRED_WORK_GROUP_SIZE_MULTIPLE
    return kernel.get_work_group_info(info, device)


def padded(size, group):
    """`size` rounded up to a multiple of `group` (a launch's global size).

    Examples
    --------
    >>> padded(100, 32), padded(64, 32)
    (128, 64)
    """
    return -(-int(size) // group) * group
