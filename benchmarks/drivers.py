"""README command (a)'s stippling on each OpenCL driver the ICD loader can be shown alone.

For each driver (pip's PoCL, from pyopencl's ``.libs/pocl.icd``, and every
``/etc/OpenCL/vendors/*.icd``): the stippling of README command (a) once with
no cached device verdict (the known-answer checks run first) and ``--runs``
times warm, in alternation; prints the wall seconds, the median warm time,
its ratio to the first driver's, and the summary's engine and device.
With ``--cold`` the first run also starts with an empty PoCL kernel cache
(``POCL_CACHE_DIR``), as a new user's does: every build is paid there.

    .venv/bin/python benchmarks/drivers.py --runs 3 [--cold]
"""

from __future__ import annotations

import argparse
import glob
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pyopencl

COMMAND = ["stipple", "sample", "-n", "20000", "-o", "{out}/stipple.svg", "-o", "{out}/stipple.png"]


def drivers():
    """``[(name, icd path)]``: pip's PoCL first, then the system's ICDs."""
    pip = Path(pyopencl.__file__).parent / ".libs" / "pocl.icd"
    found = [("pip PoCL", str(pip))] if pip.exists() else []
    return found + [(f"system {Path(p).stem}", p) for p in sorted(glob.glob("/etc/OpenCL/vendors/*.icd"))]


def run(icd, cache, out, pocl_cache=None):
    """Wall seconds of one stippling with only `icd` visible, and its summary line;
    PoCL's kernel cache in `pocl_cache` where given."""
    env = dict(os.environ, OCL_ICD_VENDORS=icd, DISKPACK_CL_CACHE_DIR=cache)
    if pocl_cache is not None:
        env["POCL_CACHE_DIR"] = pocl_cache
    cmd = [str(Path(sys.executable).parent / "diskpack")] + [a.format(out=out) for a in COMMAND]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode:
        return seconds, f"FAILED ({proc.returncode}): {proc.stderr.strip().splitlines()[-1:]}"
    line = [ln for ln in proc.stderr.splitlines() if " dots on " in ln][-1]
    return seconds, line[line.find(" on OpenCL") if " on OpenCL" in line else 0:][:80]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cold", action="store_true", help="first runs with an empty PoCL kernel cache")
    args = ap.parse_args()
    found = drivers()
    with tempfile.TemporaryDirectory(prefix="diskpack-drivers-") as tmp:
        caches = {name: f"{tmp}/cache-{i}" for i, (name, _) in enumerate(found)}
        pocl = {name: f"{caches[name]}-pocl" if args.cold else None for name, _ in found}
        cold = {name: run(icd, caches[name], tmp, pocl[name]) for name, icd in found}
        warm = {name: [] for name, _ in found}
        for _ in range(args.runs):
            for name, icd in found:
                warm[name].append(run(icd, caches[name], tmp, pocl[name])[0])
    base = statistics.median(warm[found[0][0]])
    for name, _ in found:
        med = statistics.median(warm[name])
        print(f"{name:<22} first (checks) {cold[name][0]:6.1f} s  warm "
              f"{' '.join(f'{s:.2f}' for s in warm[name])} s  median {med:.2f} s "
              f"({med / base:.2f}x {found[0][0]})  {cold[name][1]}")


if __name__ == "__main__":
    main()
