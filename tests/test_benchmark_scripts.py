"""Benchmark scripts that no other test runs, run at a small size: they still run."""

import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def _runs(script, *args):
    run = subprocess.run([sys.executable, script, *args], cwd=BENCH, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


def test_stipple_setup_runs_at_a_small_size(ctx):
    """benchmarks/stipple_setup.py ends and prints its ratio (it named a constant the
    stippling module no longer has)."""
    assert "setup / anchor:" in _runs("stipple_setup.py", "--size", "256", "--n", "2000", "--repeat", "1")


def test_host_step_runs_at_a_small_size(ctx):
    """benchmarks/host_step.py replays a step's host work and prints its parts (it called
    the MIC stage's packing without the warm start's bits)."""
    out = _runs("host_step.py", "--size", "256", "--n", "2000", "--steps", "2", "--repeats", "1")
    assert "(stipple + cells + raster)" in out
