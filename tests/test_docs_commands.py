"""Every fenced ``bash`` and ``python`` block of the README and the guides runs as written.

Each page runs in a folder of its own, block after block (a later block reads
what an earlier one wrote), with the virtual environment's ``bin`` first on
``PATH`` as ``source .venv/bin/activate`` puts it, and ``.venv`` there the
environment these tests run in. A block passes when it exits 0 and the files
it names as outputs (``-o``, vpype's ``write``, the Python writers) exist.
A page makes the inputs it names (``photo.jpg`` and the like) in a block of
its own, so a reader can follow it too.

A block is left out only where the HTML comment just above its fence says so,
with the reason, and the test reports it as a skip:

- ``<!-- docs-test: skip (REASON) -->``: too long for the suite or a server
  that runs until stopped; the reason says how long or what runs it instead.
- ``<!-- docs-test: ci (REASON) -->``: an install into a fresh virtual
  environment; ``.ci/run`` runs each such line (checked here).
"""

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]
FENCE = re.compile(r"^```(bash|python)\n(.*?)^```", re.S | re.M)
MARK = re.compile(r"<!--\s*docs-test:\s*(skip|ci)\s*\((.+)\)\s*-->\s*\Z")
#: The longest a block may run (a block past it has drifted far from the docs' budget).
BLOCK_TIMEOUT_S = 600


@dataclass(frozen=True)
class Block:
    """One fenced block of a page."""

    page: Path
    line: int
    lang: str
    code: str
    mark: str | None = None
    reason: str | None = None

    @property
    def name(self):
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def page_blocks(page):
    """The ``bash`` and ``python`` blocks of ``page``, each with the mark above its fence."""
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        above = text[:m.start()].rstrip().rsplit("\n", 1)[-1]
        mark = MARK.search(above)
        out.append(Block(page, text.count("\n", 0, m.start()) + 1, m.group(1), m.group(2),
                         *(mark.groups() if mark else (None, None))))
    return out


BLOCKS = [b for page in PAGES for b in page_blocks(page)]


def _outputs(block):
    """The files a block says it writes: ``-o`` paths, vpype's ``write`` target and the
    first argument of the Python writers (templates as glob patterns)."""
    if block.lang == "python":
        names = re.findall(r"write_\w+\(\s*[\"']([^\"']+)[\"']", block.code)
        names += [n for m in re.findall(r"\[([^\]]*)\]", block.code)
                  for n in re.findall(r"[\"']([^\"']*\{\w[^\"']*)[\"']", m)]
    else:
        names = []
        for line in block.code.splitlines():
            line = line.split(" #")[0].strip()
            if line.startswith("#"):
                continue
            names += re.findall(r"(?:^|\s)(?:-o|--output)\s+(\S+)", line)
            if re.search(r"\bvpype\b.*\bwrite\b", line):
                names.append(line.split()[-1])
    return [re.sub(r"\{[^}]*\}", "*", n) for n in names]


@pytest.fixture(scope="session")
def page_folders(tmp_path_factory):
    """A folder per page, with ``.venv`` the test's environment, and the blocks run there."""
    folders = {}

    def folder(page):
        if page not in folders:
            path = tmp_path_factory.mktemp(page.stem)
            (path / ".venv").symlink_to(sys.prefix, target_is_directory=True)
            folders[page] = {"path": path, "ran": set()}
        return folders[page]

    return folder


def _env(folder):
    """The environment after ``source .venv/bin/activate`` in ``folder``."""
    env = dict(os.environ, VIRTUAL_ENV=str(folder / ".venv"))
    env["PATH"] = os.pathsep.join([str(folder / ".venv" / "bin"), env.get("PATH", "")])
    env.pop("PYTHONHOME", None)
    return env


def _run(block, folder):
    """Run one block in ``folder``; fail with its output unless it exits 0 and writes its outputs."""
    if block.lang == "python":
        script = folder / f"doc_block_{block.line}.py"
        script.write_text(block.code, encoding="utf-8")
        argv = ["python", script.name]
    else:
        argv = ["bash", "-e", "-o", "pipefail", "-c", block.code]
    done = subprocess.run(argv, cwd=folder, env=_env(folder), capture_output=True, text=True,
                          timeout=BLOCK_TIMEOUT_S)
    assert done.returncode == 0, (f"{block.name} exits {done.returncode}:\n{block.code}\n"
                                  f"--- stdout\n{done.stdout[-3000:]}\n--- stderr\n{done.stderr[-3000:]}")
    missing = [o for o in _outputs(block) if not list(folder.glob(o))]
    assert not missing, f"{block.name}: says it writes {missing}, which are not there"


@pytest.mark.parametrize("block", BLOCKS, ids=lambda b: b.name)
def test_doc_block_runs(block, ctx, page_folders):
    if block.mark is not None:
        pytest.skip(f"docs-test: {block.mark} ({block.reason})")
    state = page_folders(block.page)
    for earlier in page_blocks(block.page):   # what this block reads, as a reader has it
        if earlier.line < block.line and earlier.mark is None and earlier.line not in state["ran"]:
            _run(earlier, state["path"])
            state["ran"].add(earlier.line)
    _run(block, state["path"])
    state["ran"].add(block.line)


def test_ci_blocks_run_in_ci():
    """A block marked ``ci`` is an install; ``.ci/run`` runs each of its commands."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    marked = [b for b in BLOCKS if b.mark == "ci"]
    assert marked
    for block in marked:
        for line in block.code.splitlines():
            line = line.split(" #")[0].strip()
            if line and not line.startswith("#"):
                assert _ci_runs(line, ci), f"{block.name}: .ci/run does not run {line!r}"


def _ci_runs(line, ci):
    """Whether ``.ci/run`` runs ``line``: verbatim with ``python3`` as ``"$PYTHON"``, or
    read from the README by the ``grep -Fx`` of a ``readme_line`` call."""
    verbatim = line.replace("python3 ", '"$PYTHON" ')
    return verbatim in ci or any(line == want for want in re.findall(r"readme_line '([^']+)'", ci))


def test_marks_are_on_fences():
    """A mark that is not just above a fence would skip nothing (or the wrong block)."""
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        marks = len(re.findall(r"^<!--\s*docs-test:", text, flags=re.M))
        assert marks == sum(b.mark is not None for b in page_blocks(page)), page.name
