"""The docs' generated tables list every option, and their sources still load.

``docs/_ext/diskpack_docs.py`` builds the CLI reference from the parser, the
option tables from the option dataclasses and the results tables from the
benchmark rows in ``docs/perf/``; these tests catch a table that drops an option
or a benchmark file the summary can no longer read, without a Sphinx build.
"""

import dataclasses
import importlib.util
from pathlib import Path

import pytest

from diskpack_cl import RelaxOptions, StippleOptions, ToneOptions, WriteOptions
from diskpack_cl.pens import ColorOptions
from diskpack_cl.options import describe

ROOT = Path(__file__).resolve().parents[1]


def _ext():
    spec = importlib.util.spec_from_file_location("diskpack_docs", ROOT / "docs" / "_ext" / "diskpack_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("cls", [StippleOptions, ToneOptions, WriteOptions, RelaxOptions, ColorOptions])
def test_option_table_lists_every_field(cls):
    rows = _ext().option_rows(cls)
    assert [r[0].strip("`") for r in rows] == list(describe(cls))
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for name, flag, default, _, _, meaning in rows:
        f = fields[name.strip("`")]
        assert meaning == f.metadata["help"]
        if f.default is not None and not isinstance(f.default, (tuple, list)):
            assert default in (str(f.default), repr(f.default)), (name, default, f.default)
        if f.metadata["cli"]:
            assert flag == "`--" + f.name.replace("_", "-") + "`"


@pytest.mark.parametrize("command", ["devices", "poisson", "relax", "stipple", "export", "analyze"])
def test_cli_table_lists_every_option(command):
    ext = _ext()
    parser = ext.subparser(command)
    rows = ext.cli_rows(parser)
    shown = {s.strip() for r in rows for s in r[0].strip("`").split(",")}
    want = {s for a in parser._actions for s in (a.option_strings or [a.dest])} - {"-h", "--help"}
    assert shown == want
    assert all(r[3] for r in rows), "an option without help text"


def test_results_tables_build_from_the_stored_rows():
    ext = _ext()
    header, rows = ext.TABLES["stipple-tally"]()
    assert header[:3] == ["configuration", "n", "images"] and len(rows) == 6
    assert {r[0] for r in rows} == {"before", "default"}
    header, rows = ext.TABLES["color-summary"]()
    assert len(rows) == 8 and rows[0][0] == "astronaut CMYK, 5000"


def _guide_commands():
    """``diskpack`` commands of the guide's bash blocks, less those with placeholders (``IMAGE``, ``...``)."""
    import re
    import shlex

    out = []
    for page in sorted((ROOT / "docs" / "guide").glob("*.md")):
        for block in re.findall(r"^```bash\n(.*?)^```", page.read_text(encoding="utf-8"), flags=re.S | re.M):
            for line in block.splitlines():
                line = line.split(" #")[0].strip()
                if not line.startswith("diskpack ") or "..." in line or "[" in line:
                    continue
                argv = shlex.split(line)[1:]
                if any(re.fullmatch(r"[A-Z][A-Z0-9_]*", a) for a in argv):
                    continue
                out.append((page.name, argv))
    return out


def test_guide_commands_parse():
    from diskpack_cl.cli import build_parser

    commands = _guide_commands()
    assert len(commands) >= 25
    parser = build_parser()
    for page, argv in commands:
        try:
            parser.parse_args(argv)
        except SystemExit as exc:  # pragma: no cover - shown on failure
            pytest.fail(f"{page}: diskpack {' '.join(argv)} does not parse (status {exc.code})")


#: A column each performance table must have (the one that names what it measures).
PERF_COLUMNS = {"relax": "cells (opencl default)", "peers-2d": "low", "peers-3d": "rho", "paper": "the paper",
                "qmc": "share farther than radius diskpack / scipy",
                "million": "total / Delaunay", "cli-poisson": "process / Delaunay",
                "cli-poisson-stages": "the rest of the process", "stipple": "default mix s/iter (MIC / labels and centroids)",
                "stipple-end-to-end": "seconds to the certified result", "stipple-large": "peak resident memory",
                "stipple-tiled": "seam NN 1st percentile tiled / untiled",
                "batch": "images per minute", "batch-memory": "peak resident memory"}


@pytest.mark.parametrize("name", sorted(PERF_COLUMNS))
def test_performance_tables_build_from_their_rows(name):
    ext = _ext()
    header, rows = ext.TABLES[name]()
    assert PERF_COLUMNS[name] in header
    assert rows and all(len(r) == len(header) for r in rows)
    assert all(any(str(c).strip() for c in r[1:]) for r in rows), "a row without numbers"
    stored = ext.perf_rows(name)
    assert all({"date", "commit", "load", "device"} <= set(r) for r in stored)
    assert "load average" in ext._benchmark("perf_rows").provenance(stored)


def test_every_stored_table_is_registered():
    ext = _ext()
    assert set(PERF_COLUMNS) == set(ext.PERF_TABLES)
    assert {p.name for p in ext.ROWS.glob("*.jsonl")} == {ext.rows_file(name) for name in ext.TABLES}


def test_docs_keeps_no_rows_at_its_root():
    # rows the build reads live in docs/perf/, the others in benchmarks/data/
    assert not [p.name for p in (ROOT / "docs").glob("*.json*")]


def test_tables_name_no_issue():
    # the tables are read by users of the guides: their rows say what they measure, not which ticket
    import re

    ext = _ext()
    cells = [str(c) for name in ext.TABLES for row in ext.TABLES[name]()[1] for c in row]
    assert not [c for c in cells if re.search(r"\bissue\s*\d", c, flags=re.I)]
    guides = sorted((Path(__file__).parents[1] / "docs" / "guide").glob("*.md"))
    assert not [f"{g.name}: {line}" for g in guides for line in g.read_text().splitlines()
                if re.search(r"\bissue\s*\d|_issue\d", line, flags=re.I)]


def test_summary_takes_the_median_of_the_repeats():
    # first row, mean and median differ for every measured value
    bench = _ext()._benchmark("bench_relax")
    rows = [{"n": 1000, "engine": engine, "iteration": i, "seconds": scale * s, "stage_buckets": 0.1 * s,
             "stage_device": 0.2 * s, "stage_refine": 0.3 * s, "max_dx": 1e-16}
            for engine, scale in (("cells", 1.0), ("exact", 10.0), ("raster", 20.0))
            for i, s in enumerate((9, 1, 2))]
    rows += [{"n": 1000, "engine": "call", "iteration": i, "seconds": s, "iterations": 5}
             for i, s in enumerate((7, 3, 4))]   # whole calls: no stages, no centre difference
    header, table = bench.summary(rows)
    (row,) = table
    cells = dict(zip(header, row))
    assert cells["n"] == "1 000"
    assert cells["cells (opencl default)"] == "2" and cells["exact (scipy)"] == "20"
    assert cells["raster route"] == "40" and cells["plain scipy"] == ""
    assert cells["cells / exact"] == "0.1"
    assert cells["cells stages: buckets / device / host check"] == "0.2 / 0.4 / 0.6"
    assert cells["relax_poisson call, per iteration"] == "4"


def test_peers_summary_shows_a_stopped_peer():
    bench = _ext()._benchmark("bench_peers")
    rows = [{"dim": 2, "asked": 1000, "domain": "box", "sampler": "bridson", "n": n, "seconds": s, "rho": 0.66,
             "low": 0.1, "peak": 1.5} for n, s in ((1017, 3.0), (1010, 0.1), (1020, 0.2))]
    rows.append({"dim": 2, "asked": 10**6, "domain": "box", "sampler": "scipy", "stopped_after": 60.0})
    header, table = bench.summary(rows, dim=2)
    assert [r[3:5] for r in table] == [["1 017", "0.2"], ["", "> 60 (stopped)"]]
    assert bench.summary(rows, dim=3)[1] == []
