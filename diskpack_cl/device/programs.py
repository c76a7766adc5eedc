"""Locate the ``.cl`` sources and build each program once per context."""

from __future__ import annotations

import hashlib
import importlib.resources
import os
import time
import warnings
from pathlib import Path

import pyopencl as cl

from .cache import cache_dir

__all__ = ["kernel_dir", "build_program", "inline_math", "prune", "BuildError", "KEEP_BYTES", "KEEP_DAYS"]

_PROGRAMS: dict = {}

#: Kept binaries not used for this many days are removed when a new one is kept (each
#: release of the kernels, driver or device keys new ones, and the old ones would stay).
KEEP_DAYS = 30

#: Of the rest, the newest are kept up to this many bytes in all.
KEEP_BYTES = 256 << 20

#: A part file older than this (seconds) was left by a process killed while writing it.
_PART_AGE = 3600


class BuildError(RuntimeError):
    """A build that the driver reported done but that holds no kernels (a broken entry of
    PoCL's kernel cache does this)."""


def kernel_dir() -> Path:
    """Folder holding the OpenCL sources: the package data ``diskpack_cl/device/kernels``."""
    p = Path(str(importlib.resources.files("diskpack_cl.device") / "kernels"))
    if not (p / "common.h").is_file():
        raise FileNotFoundError(f"OpenCL kernel sources not found in {p}")
    return p


def _kernels(prg):
    """The kernels of the built program `prg`, by name."""
    return {k.function_name: k for k in prg.all_kernels()}


def _binary_path(ctx, src, opts):
    """Where the binary of `src` built with `opts` for the device of `ctx` is kept: a hash
    of the source, the kernel folder's headers, the options and the device and driver."""
    dev = ctx.devices[0]
    key = hashlib.sha256("\0".join([src, *opts, dev.name, dev.platform.version,
                                     dev.driver_version, dev.version]).encode())
    for header in sorted(kernel_dir().glob("*.h")):
        key.update(header.read_bytes())
    return cache_dir() / "programs" / f"{key.hexdigest()}.bin"


def _from_binary(ctx, path, opts):
    """The kernels of the binary at `path` built with `opts`; none where it is missing or
    its build fails (then the source is built)."""
    try:
        binary = path.read_bytes()
    except OSError:
        return {}
    try:
        kernels = _kernels(_quietly_built(cl.Program(ctx, ctx.devices[:1], [binary]), opts))
    except cl.Error:
        return {}
    _mark_used(path)
    return kernels


def _mark_used(path):
    """Date the binary at `path` as used now (its time decides how long it is kept)."""
    try:
        os.utime(path)
    except OSError:
        pass   # a read-only cache: its binaries are kept as they are


def _quietly_built(prg, opts):
    """`prg` built with `opts`, its driver's build log unshown: pyopencl warns of any log
    that is not empty (a driver's notes, or the log of a worker interrupted mid-build, which
    then broke a Ctrl-C's one line), and none says anything a user can act on; a build that
    fails still raises."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cl.CompilerWarning)
        return prg.build(options=opts)


def _store(prg, path):
    """Keep the binary of the built program `prg` at `path` (written whole, then renamed,
    so that a process reading it meanwhile never sees part of it; a folder that cannot be
    written keeps none)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        part = path.with_suffix(f".{os.getpid()}.part")
        part.write_bytes(prg.get_info(cl.program_info.BINARIES)[0])
        os.replace(part, path)
    except OSError:
        return   # the program was built: the next process builds it again
    prune(path.parent)


def prune(folder, now=None):
    """Remove from the binary folder `folder` what no process is likely to read again.

    Binaries unused for :data:`KEEP_DAYS` days go, then the oldest used until those left
    hold at most :data:`KEEP_BYTES`; part files older than an hour (a process killed while
    writing) go too.  Runs where a new binary is kept, so a cache that only serves pays
    nothing; a file another process removes first is skipped.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "old.bin").write_bytes(b"x")
    >>> os.utime(folder / "old.bin", (0, 0))   # last used in 1970
    >>> prune(folder)
    >>> list(folder.iterdir())
    []
    """
    now = time.time() if now is None else now
    files = []
    for path in folder.iterdir():
        try:
            st = path.stat()
        except OSError:
            continue
        if path.suffix == ".part":
            if now - st.st_mtime > _PART_AGE:
                _remove(path)
        elif path.suffix == ".bin":
            files.append((st.st_mtime, st.st_size, path))
    kept = 0
    for mtime, size, path in sorted(files, reverse=True):
        kept += size
        if now - mtime > KEEP_DAYS * 86400 or kept > KEEP_BYTES:
            _remove(path)


def _remove(path):
    try:
        path.unlink()
    except OSError:
        pass   # gone already, or a folder this user cannot change


def _built(ctx, src, opts):
    """The kernels of `src` built with `opts`: from the binary kept at the last build where
    there is one, else built by the driver (and the binary kept).  PoCL caches source
    builds itself, but a hit there still parses the program: 25-60 ms a program against
    2-10 ms from a binary, with three programs in a ``diskpack poisson`` process."""
    path = _binary_path(ctx, src, opts)
    kernels = _from_binary(ctx, path, opts)
    if not kernels:
        prg = _quietly_built(cl.Program(ctx, src), opts)
        kernels = _kernels(prg)
        if kernels:
            _store(prg, path)
    return kernels


def inline_math(ctx) -> int:
    """1 where the kernels should use clang's builtins for their scalar math: PoCL's
    CPU device, whose own builtins stay calls (``kernels/common.h``); else 0."""
    dev = ctx.devices[0]
    return int("Portable Computing Language" in dev.platform.name and bool(dev.type & cl.device_type.CPU))


def build_program(ctx, stem: str, defines: dict | None = None):
    """Build ``diskpack_cl/device/kernels/<stem>.cl`` with ``-D`` defines; return a kernel dict.

    ``INLINE_MATH`` is defined too, as :func:`inline_math` says, unless `defines` sets it.

    Built programs and their kernel objects are memoized by
    (context, stem, defines), so each combination compiles once per process.
    """
    defines = dict(sorted({"INLINE_MATH": inline_math(ctx), **(defines or {})}.items()))
    key = (ctx.int_ptr, stem, tuple(defines.items()))
    if key not in _PROGRAMS:
        src = (kernel_dir() / f"{stem}.cl").read_text()
        opts = ["-I", str(kernel_dir())] + [f"-D{k}={v}" for k, v in defines.items()]
        kernels = _built(ctx, src, opts)
        if not kernels:
            raise BuildError(f"{stem}.cl built without kernels on {ctx.devices[0].name.strip()} "
                             "(a broken kernel-cache entry?)")
        _PROGRAMS[key] = kernels
    return _PROGRAMS[key]
