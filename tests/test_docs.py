"""The docs' generated tables list every option, and their sources still load.

``docs/_ext/diskpack_docs.py`` builds the CLI reference from the parser, the
option tables from the option dataclasses and the results tables from the
benchmark rows in ``docs/``; these tests catch a table that drops an option
or a benchmark file the summary can no longer read, without a Sphinx build.
"""

import dataclasses
import importlib.util
from pathlib import Path

import pytest

from diskpack_cl import RelaxOptions, StippleOptions, ToneOptions, WriteOptions
from diskpack_cl.color import ColorOptions
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
