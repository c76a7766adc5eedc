"""Sphinx directives that build reference tables from the code itself.

``diskpack-options CLASS``
    One row per field of an option dataclass (:func:`diskpack_cl.options.describe`):
    name, command-line flag, default, range or choices, unit, help.
``diskpack-cli SUBCOMMAND``
    One row per argument of a subcommand of :func:`diskpack_cl.cli.build_parser`:
    flags, argument, default, help.
``diskpack-table NAME``
    A results table computed at build time from a benchmark's ``.jsonl`` file
    in ``docs/perf/`` (:data:`ROWS`) by the benchmark's own summary code (see
    :data:`TABLES`); the performance tables (:data:`PERF_TABLES`) are followed
    by the date, commit, load and device their rows carry.

The tables are docutils nodes made here (plain text in every cell), so they
read the same from reStructuredText and from MyST Markdown, and no help text
can break the markup.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import importlib
import importlib.util
import io
import json
import sys
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive

ROOT = Path(__file__).resolve().parents[2]


def table_node(header, rows, widths=None):
    """A docutils table with a header row; every cell is plain text (inline code where wrapped in backticks)."""
    widths = widths or [1] * len(header)
    table = nodes.table(classes=["diskpack-table"])
    group = nodes.tgroup(cols=len(header))
    table += group
    for w in widths:
        group += nodes.colspec(colwidth=w)

    def row(cells):
        r = nodes.row()
        for cell in cells:
            entry = nodes.entry()
            text = "" if cell is None else str(cell)
            if len(text) > 1 and text.startswith("`") and text.endswith("`"):
                entry += nodes.paragraph("", "", nodes.literal(text=text[1:-1]))
            else:
                entry += nodes.paragraph(text=text)
            r += entry
        return r

    head = nodes.thead()
    head += row(header)
    body = nodes.tbody()
    for cells in rows:
        body += row(cells)
    group += head
    group += body
    return table


def _object(dotted):
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def _shown(value):
    """A default as the reader types it (None: decided later, by the schedule or the image)."""
    if value is None:
        return "None (see meaning)"
    if isinstance(value, (tuple, list)) and value and isinstance(value[0], tuple):
        return "(a list of phases)"
    return repr(value) if isinstance(value, str) else str(value)


def option_rows(cls):
    """``(name, flag, default, range, unit, help)`` per documented field of the dataclass ``cls``."""
    from diskpack_cl.options import describe, flag_name

    fields = {f.name: f for f in dataclasses.fields(cls)}
    rows = []
    for name, d in describe(cls).items():
        meta = fields[name].metadata
        flag = (meta.get("flag") or flag_name(name)) if meta.get("cli") else "(library only)"
        allowed = d["range"] or (" | ".join(map(str, d["choices"])) if d["choices"] else "")
        rows.append((f"`{name}`", f"`{flag}`" if meta.get("cli") else flag,
                     _shown(d["default"]), allowed, d["unit"] or "", d["help"]))
    return rows


class OptionsDirective(Directive):
    """``.. diskpack-options:: diskpack_cl.StippleOptions``: the fields of an option dataclass."""

    required_arguments = 1

    def run(self):
        rows = option_rows(_object(self.arguments[0]))
        return [table_node(("field", "flag", "default", "range", "unit", "meaning"), rows,
                           widths=(14, 14, 10, 10, 5, 47))]


def subparser(name):
    """The ``argparse`` parser of the subcommand ``name`` of ``diskpack``."""
    from diskpack_cl.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def cli_rows(parser):
    """``(flags, argument, default, help)`` per argument of ``parser``, in ``--help`` order."""
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction) or action.help == argparse.SUPPRESS:
            continue
        flags = ", ".join(action.option_strings) or action.dest
        if action.choices is not None:
            arg = " | ".join(map(str, action.choices))
        elif action.nargs == 0:
            arg = ""
        else:
            arg = action.metavar or (action.dest.upper() if action.option_strings else "")
        default = action.default
        shown = "" if default in (None, False, argparse.SUPPRESS) or action.nargs == 0 else str(default)
        helptext = formatter._expand_help(action) if action.help else ""
        rows.append((f"`{flags}`", arg, shown, " ".join(helptext.split())))
    return rows


class CliDirective(Directive):
    """``.. diskpack-cli:: stipple``: the usage line and every argument of a subcommand."""

    required_arguments = 1

    def run(self):
        parser = subparser(self.arguments[0])
        usage = " ".join(parser.format_usage().split())
        out = [nodes.literal_block(usage, usage, language="text")]
        if parser.description:
            out.append(nodes.paragraph(text=" ".join(parser.description.split())))
        out.append(table_node(("option", "argument", "default", "meaning"), cli_rows(parser),
                              widths=(20, 14, 10, 56)))
        return out


def _benchmark(name):
    """Import ``benchmarks/NAME.py`` (not a package) as a module."""
    if str(ROOT / "benchmarks") not in sys.path:   # where the benchmarks find perf_rows, as when run
        sys.path.insert(0, str(ROOT / "benchmarks"))
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _markdown_rows(text):
    """Header and rows of the first Markdown table in ``text`` (``\\|`` is a literal bar)."""
    lines = [line for line in text.splitlines() if line.startswith("|")]
    split = [[c.strip().replace("\\|", "|") for c in line.replace("\\|", "\0").split("|")[1:-1]]
             for line in lines]
    split = [[c.replace("\0", "|") for c in cells] for cells in split]
    return split[0], split[2:]


#: Where the stored rows that the docs build reads live (one folder: performance and quality alike).
ROWS = ROOT / "docs" / "perf"

#: The quality tables: name -> their rows in :data:`ROWS`.
RESULT_ROWS = {"stipple-tally": "stipple_quality.jsonl", "color-quality": "color_quality.jsonl",
               "color-summary": "color_quality.jsonl"}


def _stipple_tally():
    q = _benchmark("stipple_quality")
    summary = q.summarize(q.read_rows([ROWS / RESULT_ROWS["stipple-tally"]]))
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        q.print_tally(summary, ["before", "default"])
    return _markdown_rows(buf.getvalue())


def _color_table():
    return _markdown_rows(_benchmark("color_quality").table(ROWS / RESULT_ROWS["color-quality"]))


def _pen_range(row):
    vals = [v for v in row["p01"] if v is not None]
    return f"{min(vals):.2f}-{max(vals):.2f}"


def _color_summary():
    """Per image, pens and n: Delta E and P01 of the naive overlay, its overprint and the multi-class packing."""
    groups = {}
    for line in (ROWS / RESULT_ROWS["color-summary"]).read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            groups.setdefault((r["image"], r["palette"], r["n"]), {})[r["method"]] = r
    rows = []
    for (image, palette, n), m in groups.items():
        naive, over, multi = m["naive"], m.get("naive-overprint"), m["multi-class"]
        pens = "CMYK" if palette == "cmyk" else "/".join(p.split("=")[0] for p in palette.split(","))
        over_e = "-" if over is None else f"{over['delta_e']:.1f}"
        rows.append((f"{image} {pens}, {n}",
                     f"{naive['delta_e']:.1f} / {over_e} / {multi['delta_e']:.1f}",
                     f"{naive['p01_joint']:.2f} / {multi['p01_joint']:.2f} (mono {multi['mono_p01']:.2f})",
                     f"{_pen_range(naive)} / {_pen_range(multi)}"))
    header = ("image, n", "Delta E: naive / overprint / multi-class",
              "P01 of all dots: naive / multi-class", "P01 per pen (min-max): naive / multi-class")
    return header, rows


#: The performance tables: name -> (benchmark, its rows in ``docs/perf/``, its summary function, arguments).
PERF_TABLES = {
    "relax": ("bench_relax", "relax.jsonl", "summary", {}),
    "peers-2d": ("bench_peers", "peers.jsonl", "summary", {"dim": 2}),
    "peers-3d": ("bench_peers", "peers_3d.jsonl", "summary", {"dim": 3}),
    "qmc": ("bench_qmc", "qmc.jsonl", "summary", {}),
    "paper": ("bench_paper", "paper.jsonl", "summary", {}),
    "million": ("bench_million", "million.jsonl", "summary", {}),
    "cli-poisson": ("bench_cli_poisson", "cli_poisson.jsonl", "summary", {}),
    "cli-poisson-stages": ("bench_cli_poisson", "cli_poisson.jsonl", "stages", {}),
    "stipple": ("bench_stipple", "stipple.jsonl", "summary", {}),
    "stipple-end-to-end": ("bench_stipple", "stipple.jsonl", "summary_end_to_end", {}),
    "stipple-large": ("stipple_large", "stipple_large.jsonl", "summary", {}),
    "stipple-tiled": ("stipple_tiled", "stipple_tiled.jsonl", "summary", {}),
    "batch": ("bench_batch", "batch.jsonl", "summary", {}),
    "batch-memory": ("bench_batch", "batch.jsonl", "summary_memory", {}),
}


def rows_file(name):
    """The name of the file in :data:`ROWS` that the table ``name`` is made from."""
    return PERF_TABLES[name][1] if name in PERF_TABLES else RESULT_ROWS[name]


def perf_rows(name):
    """The stored rows of the performance table ``name``."""
    return _benchmark("perf_rows").read(ROWS / PERF_TABLES[name][1])


def perf_table(name):
    """``(header, rows)`` of the performance table ``name``, by its benchmark's summary of the stored rows."""
    bench, _, function, kwargs = PERF_TABLES[name]
    return getattr(_benchmark(bench), function)(perf_rows(name), **kwargs)


#: The tables ``diskpack-table`` builds: name -> () -> (header, rows).
TABLES = {"stipple-tally": _stipple_tally, "color-quality": _color_table,
          "color-summary": _color_summary, **{name: functools.partial(perf_table, name) for name in PERF_TABLES}}


class BenchmarkTableDirective(Directive):
    """``.. diskpack-table:: stipple-tally``: a results table summarized from the stored benchmark rows."""

    required_arguments = 1

    def run(self):
        name = self.arguments[0]
        out = [table_node(*TABLES[name]())]
        env = self.state.document.settings.env
        env.note_dependency(str(ROWS / rows_file(name)))   # changed rows rebuild the page
        if name in PERF_TABLES:
            # and so does changed summary code
            for path in (ROOT / "benchmarks" / f"{PERF_TABLES[name][0]}.py",
                         ROOT / "benchmarks" / "perf_rows.py"):
                env.note_dependency(str(path))
            note = _benchmark("perf_rows").provenance(perf_rows(name))
            out.append(nodes.paragraph("", "", nodes.emphasis(text=note)))
        return out


def setup(app):
    app.add_directive("diskpack-options", OptionsDirective)
    app.add_directive("diskpack-cli", CliDirective)
    app.add_directive("diskpack-table", BenchmarkTableDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
