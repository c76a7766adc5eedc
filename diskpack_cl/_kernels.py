"""Locate the ``.cl`` sources and build each program once per context."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

__all__ = ["kernel_dir", "build_program"]

_PROGRAMS: dict = {}


def kernel_dir() -> Path:
    """Folder holding the OpenCL sources: the package data ``diskpack_cl/kernels``."""
    p = Path(str(importlib.resources.files("diskpack_cl") / "kernels"))
    if not (p / "common.h").is_file():
        raise FileNotFoundError(f"OpenCL kernel sources not found in {p}")
    return p


def build_program(ctx, stem: str, defines: dict | None = None):
    """Build ``diskpack_cl/kernels/<stem>.cl`` with ``-D`` defines; return a kernel dict.

    ``INLINE_MATH`` is defined too: 1 on PoCL (see ``kernels/common.h``), else 0.

    Built programs and their kernel objects are memoized by
    (context, stem, defines), so each combination compiles once per process.
    """
    import pyopencl as cl

    # PoCL's builtins stay calls unless the kernels use clang's (kernels/common.h)
    pocl = "Portable Computing Language" in ctx.devices[0].platform.name
    defines = dict(sorted({"INLINE_MATH": int(pocl), **(defines or {})}.items()))
    key = (ctx.int_ptr, stem, tuple(defines.items()))
    if key not in _PROGRAMS:
        src = (kernel_dir() / f"{stem}.cl").read_text()
        opts = ["-I", str(kernel_dir())] + [f"-D{k}={v}" for k, v in defines.items()]
        prg = cl.Program(ctx, src).build(options=opts)
        _PROGRAMS[key] = {k.function_name: k for k in prg.all_kernels()}
    return _PROGRAMS[key]
