"""Benchmark rows as JSON lines with their context, and the medians the docs' tables show.

The benchmarks behind ``docs/guide/performance.md`` append one JSON object
per measurement to their ``--json FILE`` with :func:`append`, which adds the
context of the measurement (:func:`context`: date, git commit, load
average, OpenCL device, cores).  Each benchmark's ``summary(rows)`` turns
the rows back into the ``(header, rows)`` of a table with :func:`medians`,
and ``docs/_ext/diskpack_docs.py`` builds the page's tables from the rows
stored in ``docs/perf/`` at build time, with :func:`provenance` under each.
"""

from __future__ import annotations

import compileall
import datetime
import functools
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@functools.cache
def device_name():
    """The default OpenCL device's name, asked in a child process.

    A child, because creating an OpenCL context in a benchmark's parent
    before it forks workers (bench_peers, bench_batch) is unsafe with PoCL.
    """
    code = "from diskpack_cl.device.context import get_context; print(get_context().devices[0].name)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    return done.stdout.strip() or "no OpenCL device"


@functools.cache
def commit():
    """The checkout's short commit, ``-dirty`` when tracked files other than the stored rows differ from it."""
    def git(*args):
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True).stdout.strip()

    dirty = git("status", "--porcelain", "-uno", "--", ".", ":!docs/perf")
    return (git("rev-parse", "--short", "HEAD") or "unknown") + ("-dirty" if dirty else "")


def installed_bytecode():
    """Compile the package's bytecode, as ``pip install .`` leaves it, before a whole process is timed.

    A checkout run under ``PYTHONDONTWRITEBYTECODE`` (some sandboxes and CI images set it) would
    compile every module of the package in each timed process: 0.06-0.1 s of a
    ``diskpack poisson -n 1000000`` that the README's install never pays.
    """
    if not compileall.compile_dir(str(ROOT / "diskpack_cl"), quiet=1):
        raise RuntimeError("could not compile the package's bytecode")


def context():
    """What a row needs to be read later: when, which code, how busy the machine was, which device."""
    return {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "commit": commit(), "load": round(os.getloadavg()[0], 2), "cores": os.cpu_count(),
            "device": device_name()}


def append(path, row):
    """Append ``row`` and its :func:`context` as one JSON line to ``path`` (nothing when ``path`` is None).

    A key of ``row`` that the context also has is an error: it would hide the context (a stage named
    ``device``, say); prefix stage names with ``stage_``.
    """
    if path is None:
        return
    ctx = context()
    if set(row) & set(ctx):
        raise ValueError(f"row keys {sorted(set(row) & set(ctx))} would hide the context")
    with open(path, "a") as fh:
        # numpy scalars and arrays become numbers and lists
        fh.write(json.dumps({**ctx, **row}, default=lambda v: v.tolist()) + "\n")


def read(path):
    """The rows of a ``.jsonl`` file, in order."""
    return [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]


def medians(rows, keys, values):
    """One dict per distinct ``keys`` tuple (first-seen order): the keys, the median of each of ``values``.

    A value missing from every row of a group is None; ``repeats`` counts the group's rows.
    """
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    out = []
    for key, group in groups.items():
        row = dict(zip(keys, key), repeats=len(group))
        for v in values:
            have = [r[v] for r in group if r.get(v) is not None]
            row[v] = statistics.median(have) if have else None
        out.append(row)
    return out


def num(x, unit=""):
    """A measured number as the tables print it: three significant digits, none lost above 100."""
    if x is None:
        return ""
    return (f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}") + unit


def count(n):
    """An integer with thin groups of three digits (``1 000 000``)."""
    return "" if n is None else f"{int(n):,}".replace(",", " ")


def _span(low, high, fmt=str):
    """``low to high``, or one value when they are the same."""
    return fmt(low) if fmt(low) == fmt(high) else f"{fmt(low)} to {fmt(high)}"


def provenance(rows):
    """A sentence on where ``rows`` come from: dates, commits, load averages and devices."""
    first, last = (d[:16].split("T") for d in (min(r["date"] for r in rows), max(r["date"] for r in rows)))
    when = f"on {first[0]}, {_span(first[1], last[1])}" if first[0] == last[0] else \
        f"from {' '.join(first)} to {' '.join(last)}"
    loads = [r["load"] for r in rows]
    commits = ", ".join(sorted({r["commit"] for r in rows}))
    return (f"{count(len(rows))} stored row{'s' if len(rows) > 1 else ''}, measured {when} UTC at commit "
            f"{commits} on {', '.join(sorted({r['device'] for r in rows}))} ({rows[0]['cores']} cores), "
            f"load average {_span(min(loads), max(loads), lambda x: f'{x:.1f}')}.")
