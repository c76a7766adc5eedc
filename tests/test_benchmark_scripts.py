"""Benchmark scripts that no other test runs, run at a small size: they still run."""

import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def test_stipple_setup_runs_at_a_small_size(ctx):
    """benchmarks/stipple_setup.py ends and prints its ratio (it named a constant the
    stippling module no longer has)."""
    run = subprocess.run([sys.executable, "stipple_setup.py", "--size", "256", "--n", "2000",
                          "--repeat", "1"], cwd=BENCH, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "setup / anchor:" in run.stdout
