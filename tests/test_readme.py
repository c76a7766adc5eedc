"""The README's option tables state the defaults the command-line parser has."""

import inspect
import re
from pathlib import Path

import pytest

from diskpack_cl.cli import build_parser
from diskpack_cl.export import write_svg
from diskpack_cl.relax import relax_poisson
from diskpack_cl.schedule import GAMMA_DEFAULT

README = Path(__file__).resolve().parents[1] / "README.md"


def _table_after(text, marker):
    """Rows ``(options cell, meaning cell)`` of the first table after `marker`."""
    lines = text[text.index(marker):].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| option"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows.append((cells[0], cells[1]))
    return rows


def _subparser(name):
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return sub.choices[name]


def _stated_defaults(first, meaning):
    """``{option: default}`` a row states: a number or a backticked choice.

    A ``(default X)`` right after a backticked ``--option`` is that option's;
    one with no option named before it in the cell is the row's own (first)
    option's; others (a default of another mode) are not read.
    """
    out = {}
    for m in re.finditer(r"`([\w-]+)` \(default\)|\(default:? (-?[0-9][0-9.e+-]*)[;:,)\s]", meaning):
        before = meaning[:m.start()]
        if m.group(1):
            out[first] = m.group(1)
        elif re.search(r"`(--[\w-]+)`\s*$", before):       # "`--dart-radius` (default 0.74)"
            out[re.search(r"`(--[\w-]+)`\s*$", before).group(1)] = float(m.group(2))
        elif "`--" not in before:                             # the row's own option
            out[first] = float(m.group(2))
    return out


#: Where an option the parser leaves as None gets its default.
LIBRARY = {"poisson": [relax_poisson], "relax": [relax_poisson],
           "stipple": [{"gamma": GAMMA_DEFAULT}, write_svg]}


def _effective_default(command, action):
    if action.default is not None:
        return action.default
    for func in LIBRARY[command]:
        if isinstance(func, dict):      # a default the options resolve (None: 3.0)
            if action.dest in func:
                return func[action.dest]
            continue
        p = inspect.signature(func).parameters.get(action.dest)
        if p is not None and p.default is not inspect.Parameter.empty:
            return p.default
    return None


def _rows(marker, command):
    sub = _subparser(command)
    options = {s: a for a in sub._actions for s in a.option_strings}
    for cell, meaning in _table_after(README.read_text(encoding="utf-8"), marker):
        first = next(iter(re.findall(r"`(--[\w-]+)", cell)), None)
        for opt, stated in _stated_defaults(first, meaning).items():
            if opt in options:
                yield opt, stated, _effective_default(command, options[opt])


@pytest.mark.parametrize("marker, command", [
    ("Options of `poisson` and `relax`:", "poisson"),
    ("Options of `poisson` and `relax`:", "relax"),
    ("### `diskpack stipple`", "stipple"),
])
def test_readme_defaults_are_the_parser_defaults(marker, command):
    checked = 0
    for opt, stated, default in _rows(marker, command):
        if default is None and isinstance(stated, str):
            continue      # a choice the command resolves itself (``--dots``: tone unless --dot-mm)
        checked += 1
        assert default is not None, f"README states a default {stated!r} for {command} {opt}; there is none"
        want = float(default) if isinstance(stated, float) else str(default)
        assert stated == want, (command, opt, stated, default)
    assert checked >= 3
