#!/usr/bin/env bash
# One prepared run for the day a machine with a GPU is lent: which device,
# the kernel tests on it, the relaxation and stippling benchmarks; all
# figures go to one JSON file.
#
# Usage: benchmarks/gpu_check.sh [OUT.json]          (default: gpu_check.json)
#   PYTHON=...            interpreter with diskpack_cl[test] (default .venv/bin/python)
#   DISKPACK_DEVICE=...   device string (default "gpu": a GPU of one kind wins)
#   QUICK=1               small sizes only (a dry run of the script, minutes on a CPU)
#
# Sizes: relaxation 1024 to 1M points (the cells and raster routes, 3
# iterations each), stippling 50k to 1M dots (disk-packing, mix and Lloyd
# iterations on a 4096 x 4096 upscale of the sample).  A step that fails
# is recorded in the JSON with its exit status; the others still run.
set -uo pipefail
cd "$(dirname "$0")/.."

PYTHON="${PYTHON:-.venv/bin/python}"
OUT="${1:-gpu_check.json}"
export DISKPACK_DEVICE="${DISKPACK_DEVICE:-gpu}"
if [ "${QUICK:-0}" = 1 ]; then
    RELAX_SIZES=1024; STIPPLE_N=2000; STIPPLE_SIZE=512
else
    RELAX_SIZES=1024,20000,100000,1000000; STIPPLE_N="50000 250000 1000000"; STIPPLE_SIZE=4096
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

step() {   # step NAME COMMAND...: run, time, keep its output and exit status
    local name=$1; shift
    local t0=$SECONDS
    echo "== $name" >&2
    "$@" > "$work/$name.out" 2> "$work/$name.err"
    echo "$? $((SECONDS - t0))" > "$work/$name.status"
    tail -n 3 "$work/$name.out" >&2
}

step devices "$PYTHON" -c "import sys; from diskpack_cl.cli import main; sys.exit(main(['devices', '--check']))"
# the lent machine's CPU may be of another family than the developers': the driver every
# README user gets (pip's PoCL) alone, its known-answer checks, README (a)'s stippling and
# the kernel tests on it
PIP_ICD="$("$PYTHON" -c 'import pathlib, pyopencl; print(pathlib.Path(pyopencl.__file__).parent / ".libs" / "pocl.icd")')"
lscpu | grep -E "Model name|CPU family|^Model:" > "$work/cpu.txt"
step pip_driver env OCL_ICD_VENDORS="$PIP_ICD" DISKPACK_DEVICE=cpu DISKPACK_CL_CACHE_DIR="$work/verdicts" \
    "$PYTHON" -c "import sys; from diskpack_cl.cli import main; sys.exit(main(['devices', '--check']))"
step pip_readme_a env OCL_ICD_VENDORS="$PIP_ICD" DISKPACK_DEVICE=cpu DISKPACK_CL_CACHE_DIR="$work/verdicts" \
    "$PYTHON" benchmarks/drivers.py --runs 2
step pip_kernel_tests env OCL_ICD_VENDORS="$PIP_ICD" DISKPACK_DEVICE=cpu DISKPACK_CL_REQUIRE_OPENCL=1 \
    "$PYTHON" -m pytest -q -p no:cacheprovider tests/test_device_checks.py tests/test_raster.py tests/test_blur.py
step kernel_tests env DISKPACK_CL_REQUIRE_OPENCL=1 "$PYTHON" -m pytest -q -p no:cacheprovider \
    --junitxml="$work/tests.xml" tests/test_device.py tests/test_raster.py tests/test_cells.py \
    tests/test_engine.py tests/test_stipple_engine.py
step relax "$PYTHON" - "$RELAX_SIZES" "$work/relax.json" <<'PY'
"""Seconds per relaxation iteration, cells and raster routes (benchmarks/bench_relax.py's timing)."""
import json, sys
sys.path.insert(0, "benchmarks")
from bench_relax import run_engine
from diskpack_cl.sampling import dart_throwing

rows = []
for n in (int(s) for s in sys.argv[1].split(",")):
    pts = dart_throwing(n, seed=1)
    for route in ("cells", "raster"):
        sec, stages, _, rho = run_engine(pts, route, 3, True)
        rows.append({"n": n, "route": route, "s_per_iter": sec, "rho": float(rho), "stages": stages})
        print(rows[-1], flush=True)
json.dump(rows, open(sys.argv[2], "w"))
PY
step stipple "$PYTHON" benchmarks/bench_stipple.py --n $STIPPLE_N --sizes $STIPPLE_SIZE --iters 3 \
    --profile --device "$DISKPACK_DEVICE" --json "$work/stipple.json"

"$PYTHON" - "$work" "$OUT" <<'PY'
"""Gather the steps' figures into one JSON."""
import json, pathlib, sys
import xml.etree.ElementTree as ET

work, out = pathlib.Path(sys.argv[1]), sys.argv[2]
report = {"device_string": __import__("os").environ["DISKPACK_DEVICE"]}
for status in sorted(work.glob("*.status")):
    rc, secs = map(int, status.read_text().split())
    name = status.stem
    entry = {"rc": rc, "seconds": secs}
    if rc:
        entry["stderr_tail"] = (work / f"{name}.err").read_text()[-2000:]
    report[name] = entry
report["devices"]["lines"] = (work / "devices.out").read_text().splitlines()
report["cpu"] = (work / "cpu.txt").read_text().splitlines()
for name in ("pip_driver", "pip_readme_a", "pip_kernel_tests"):
    report[name]["lines"] = (work / f"{name}.out").read_text().splitlines()[-14:]
if (work / "tests.xml").exists():
    suite = ET.parse(work / "tests.xml").getroot().find("testsuite")
    report["kernel_tests"].update({k: int(suite.get(k, 0)) for k in ("tests", "failures", "errors", "skipped")})
for name in ("relax", "stipple"):
    if (work / f"{name}.json").exists():
        report[name]["rows"] = json.loads((work / f"{name}.json").read_text())
pathlib.Path(out).write_text(json.dumps(report, indent=1))
print(f"wrote {out}")
PY
