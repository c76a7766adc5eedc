"""Benchmark scripts that no other test runs, run at a small size: they still run."""

import os
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


def test_cli_poisson_benchmark_runs_at_a_small_size(ctx, tmp_path):
    """benchmarks/bench_cli_poisson.py reads each process's stages from the summary the
    command prints with --json: its rows hold them and its stages table builds."""
    import json

    rows = tmp_path / "rows.jsonl"
    out = _runs("bench_cli_poisson.py", "--n", "3000", "--repeat", "1", "--json", str(rows))
    assert "same points as poisson_disk(n, seed=1): True" in out
    run = [json.loads(line) for line in rows.read_text().splitlines()][0]
    parts = [run[k] for k in ("start", "global", "local", "rest")]
    assert all(p >= 0 for p in parts) and abs(sum(parts) - run["cli"]) < 1e-9
    # the process's own usage, not the benchmark's or the warm-up's: some, and less than
    # its wall time on every core (the check of the points runs after the rounds)
    assert 0 < run["system"] <= run["cpu"] <= (os.cpu_count() or 1) * run["cli"]
    assert run["faults"] > 0


def test_tiled_benchmark_runs_at_a_small_size(ctx):
    """benchmarks/stipple_tiled.py runs its tiled command in a folder of its own (made and
    removed around the runs) and prints the result's certificate."""
    out = _runs("stipple_tiled.py", "--size", "384", "--n", "3000", "--no-untiled")
    assert "valid True" in out
