"""Install commands in messages, help and docs: the form that works from a checkout.

The package is not on the package index, so ``pip install "diskpack_cl[vpype]"``
fails; every message names :func:`diskpack_cl.extras.install_command`'s form,
with an extra that pyproject.toml declares.
"""

import re
import tomllib
from pathlib import Path

import pytest

from diskpack_cl.extras import install_command

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*ROOT.joinpath("diskpack_cl").rglob("*.py"), ROOT / "README.md",
                  *ROOT.joinpath("docs", "guide").glob("*.md"), *ROOT.joinpath("examples").glob("*.py")])


def _extras():
    with open(ROOT / "pyproject.toml", "rb") as f:
        return set(tomllib.load(f)["project"]["optional-dependencies"])


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_install_from_the_package_index(path):
    """The package's own name with an extra, as pip would look it up on the index (also where
    a message splits ``pip install`` and the name over two string literals)."""
    found = re.findall(r"diskpack_cl\[\w+\]", path.read_text(encoding="utf-8"))
    assert not found, f"{path.relative_to(ROOT)}: {found}: the package is not on the index; " \
                      f"use {install_command('EXTRA')}"


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_named_extras_exist(path):
    text = path.read_text(encoding="utf-8")
    named = set(re.findall(r"install_command\(\"(\w+)\"\)", text))
    named |= set(re.findall(r"pip install (?:-e )?\"\.\[(\w+)\]\"", text))
    assert named <= _extras(), f"{path.relative_to(ROOT)}: no such extra: {named - _extras()}"
