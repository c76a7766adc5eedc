"""Locate the ``.cl`` sources and build each program once per context."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

import pyopencl as cl

__all__ = ["kernel_dir", "build_program", "inline_math", "BuildError"]

_PROGRAMS: dict = {}


class BuildError(RuntimeError):
    """A build that the driver reported done but that holds no kernels (a broken entry of
    PoCL's kernel cache does this)."""


def kernel_dir() -> Path:
    """Folder holding the OpenCL sources: the package data ``diskpack_cl/device/kernels``."""
    p = Path(str(importlib.resources.files("diskpack_cl.device") / "kernels"))
    if not (p / "common.h").is_file():
        raise FileNotFoundError(f"OpenCL kernel sources not found in {p}")
    return p


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
        prg = cl.Program(ctx, src).build(options=opts)
        kernels = {k.function_name: k for k in prg.all_kernels()}
        if not kernels:
            raise BuildError(f"{stem}.cl built without kernels on {ctx.devices[0].name.strip()} "
                             "(a broken kernel-cache entry?)")
        _PROGRAMS[key] = kernels
    return _PROGRAMS[key]
