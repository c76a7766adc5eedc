"""The README: short, a picture first, live links, and code blocks that run.

Its option tables moved to the docs, where they are generated from the
parser and the option dataclasses (``docs/_ext/diskpack_docs.py``, checked in
``tests/test_docs.py``). Its code blocks run as written in
``tests/test_docs_commands.py``; here every ``diskpack`` command, inline ones
too, is parsed by the real parser, and command (a), whose install
``.ci/run`` runs, runs without the install on the bundled sample.
"""

import re
import shlex
from pathlib import Path

import pytest

from diskpack_cl.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def _blocks(lang):
    """The bodies of the README's fenced code blocks in ``lang``."""
    text = README.read_text(encoding="utf-8")
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


def _commands(block):
    """Shell commands of a block: one per line, split at ``&&``, comments dropped."""
    out = []
    for line in block.splitlines():
        line = line.split(" #")[0].strip()
        if line and not line.startswith("#"):
            out += [shlex.split(part) for part in line.split("&&")]
    return out


def _diskpack_commands():
    """Arguments of every ``diskpack`` (or ``.venv/bin/diskpack``) command in the README's bash
    blocks and inline code (those that elide arguments with ``...`` left out)."""
    blocks = [argv[1:] for block in _blocks("bash") for argv in _commands(block)
              if argv and Path(argv[0]).name == "diskpack"]
    inline = re.findall(r"`diskpack ([^`]+)`", README.read_text(encoding="utf-8"))
    return blocks + [shlex.split(c) for c in inline if "..." not in c]


def test_readme_is_short_with_a_picture_first():
    text = README.read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) < 10_000, "the README is over 10 KB: move detail into docs/"
    first = next(line for line in text.splitlines()[1:] if line.strip())
    m = re.fullmatch(r"!\[[^\]]+\]\(([^)]+)\)", first)
    assert m, f"the README's first line after the title is not a picture: {first!r}"
    assert (ROOT / m.group(1)).is_file(), m.group(1)


def test_readme_links_point_at_files():
    targets = re.findall(r"\]\((?!https?://)([^)#]+)", README.read_text(encoding="utf-8"))
    assert len(targets) >= 10
    missing = [t for t in targets if not (ROOT / t).exists()]
    assert not missing, f"README links to missing files: {missing}"


def test_readme_keeps_the_ci_test_command():
    """Command (b) is what ``.ci/run`` runs; the docs command is what it builds with."""
    (a, b), = [re.findall(r"^python3 -m venv .*$", blk, flags=re.M) for blk in _blocks("bash")[:1]]
    assert b == 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/python -m pytest -q'
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert '.venv/bin/pip install -e ".[test]"' in ci and "-m pytest -q" in ci
    docs = next(c for blk in _blocks("bash") for c in _commands(blk) if "sphinx" in c)
    assert docs[-5:] == ["-W", "-b", "html", "docs", "docs/_build/html"]
    assert "-m sphinx -W -b html docs" in ci, ".ci/run does not build the docs with -W"


def test_readme_diskpack_commands_parse():
    commands = _diskpack_commands()
    assert len(commands) >= 4
    parser = build_parser()
    for argv in commands:
        try:
            parser.parse_args(argv)
        except SystemExit as exc:  # pragma: no cover - shown on failure
            pytest.fail(f"README command does not parse (status {exc.code}): diskpack {shlex.join(argv)}")


def test_readme_setup_command_a_runs(ctx, tmp_path, monkeypatch):
    """Command (a) without the install: the stippling and the point set it promises."""
    monkeypatch.chdir(tmp_path)
    first = _blocks("bash")[0].splitlines()
    line = next(x for x in first if x.startswith("python3") and "pytest" not in x)
    runs = [argv[1:] for argv in _commands(line) if Path(argv[0]).name == "diskpack"]
    assert [r[0] for r in runs] == ["stipple", "poisson"]
    (tmp_path / "out").mkdir()
    for argv in runs:
        assert main([*argv, "--quiet"]) == 0, argv
    for name in ("out/stipple.svg", "out/stipple.png", "out/points.npz"):
        assert (tmp_path / name).stat().st_size > 0, name
