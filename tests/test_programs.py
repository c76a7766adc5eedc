"""device.programs: built programs come from a binary cache that follows their sources."""

import os
import time

import numpy as np
import pyopencl as cl
import pytest

from diskpack_cl.device import programs


def _value(ctx, stem):
    """What kernel ``value`` of program `stem` writes (built anew, past the memo)."""
    programs._PROGRAMS.clear()
    kernel = programs.build_program(ctx, stem)["value"]
    q = cl.CommandQueue(ctx)
    out = np.zeros(1, dtype=np.int32)
    buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
    kernel(q, (1,), None, buf)
    cl.enqueue_copy(q, out, buf)
    return int(out[0])


@pytest.fixture
def kernels(tmp_path, monkeypatch):
    """A kernel folder and a program cache of their own: ``probe.cl`` writes ``VALUE`` of
    its header ``probe.h``."""
    folder = tmp_path / "kernels"
    folder.mkdir()
    (folder / "probe.cl").write_text('#include "probe.h"\n'
                                     "__kernel void value(__global int *out) { out[0] = VALUE; }\n")
    monkeypatch.setattr(programs, "kernel_dir", lambda: folder)
    monkeypatch.setenv("DISKPACK_CL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(programs, "_PROGRAMS", {})
    return folder


def test_a_cached_program_follows_its_header(ctx, kernels, tmp_path):
    """The second build comes from the cache, and a changed header is built again (a
    binary keyed by the source alone would still write the old value)."""
    (kernels / "probe.h").write_text("#define VALUE 1\n")
    assert _value(ctx, "probe") == 1
    assert any((tmp_path / "cache" / "programs").iterdir())
    assert _value(ctx, "probe") == 1
    (kernels / "probe.h").write_text("#define VALUE 2\n")
    assert _value(ctx, "probe") == 2


@pytest.mark.parametrize("damage", ["random", "no kernels"])
def test_a_broken_binary_is_built_again(ctx, kernels, tmp_path, damage):
    """A kept binary that does not build, or builds without kernels (one kept from a broken
    driver cache entry), is not used: the driver builds the source."""
    (kernels / "probe.h").write_text("#define VALUE 3\n")
    assert _value(ctx, "probe") == 3
    other = cl.Program(ctx, "int no_kernel(int x) { return x; }").build()
    for path in (tmp_path / "cache" / "programs").iterdir():
        path.write_bytes(np.random.default_rng(0).bytes(256) if damage == "random"
                         else other.get_info(cl.program_info.BINARIES)[0])
    assert _value(ctx, "probe") == 3


def test_a_cache_that_cannot_be_written_keeps_nothing_and_builds(ctx, kernels, tmp_path, monkeypatch):
    """Where the cache folder cannot be made (a file stands in its place), the program is
    built from its source and works; nothing is kept."""
    (kernels / "probe.h").write_text("#define VALUE 4\n")
    (tmp_path / "blocked").write_text("a file, not a folder")
    monkeypatch.setenv("DISKPACK_CL_CACHE_DIR", str(tmp_path / "blocked"))
    assert _value(ctx, "probe") == 4
    assert (tmp_path / "blocked").read_text() == "a file, not a folder"


def test_a_build_log_is_not_shown(ctx, kernels, recwarn):
    """A program whose build leaves a log (here a #warning) builds without pyopencl's
    CompilerWarning: a log says nothing a user can act on, and a worker's broke the one
    line of a Ctrl-C."""
    (kernels / "probe.h").write_text('#warning "a note in the build log"\n#define VALUE 5\n')
    assert _value(ctx, "probe") == 5
    assert not [w for w in recwarn if issubclass(w.category, cl.CompilerWarning)]


def _aged(folder, name, days, size=16, now=None):
    """A file `name` of `size` bytes in `folder`, last changed `days` days before `now`."""
    path = folder / name
    path.write_bytes(b"x" * size)
    stamp = (now or time.time()) - days * 86400
    os.utime(path, (stamp, stamp))
    return path


def test_keeping_a_binary_removes_the_unused_ones_and_dead_parts(ctx, kernels, tmp_path):
    """A new binary kept removes binaries unused for KEEP_DAYS and part files a killed
    process left; recent binaries, a part file being written and other files stay."""
    folder = tmp_path / "cache" / "programs"
    folder.mkdir(parents=True)
    old = _aged(folder, "old.bin", programs.KEEP_DAYS + 1)
    recent = _aged(folder, "recent.bin", programs.KEEP_DAYS - 1)
    dead = _aged(folder, "x.123.part", 1)
    writing = _aged(folder, "y.456.part", 0)
    other = _aged(folder, "notes.txt", 400)
    (kernels / "probe.h").write_text("#define VALUE 6\n")
    assert _value(ctx, "probe") == 6
    assert not old.exists() and not dead.exists()
    assert recent.exists() and writing.exists() and other.exists()
    assert len(list(folder.glob("*.bin"))) == 2


def test_the_newest_binaries_are_kept_up_to_the_byte_cap(tmp_path, monkeypatch):
    """Over KEEP_BYTES, the least recently used binaries go first."""
    monkeypatch.setattr(programs, "KEEP_BYTES", 100)
    now = time.time()
    paths = [_aged(tmp_path, f"{i}.bin", days=i, size=40, now=now) for i in range(5)]
    programs.prune(tmp_path, now=now)
    assert [p.exists() for p in paths] == [True, True, False, False, False]


def test_a_binary_read_is_marked_used(ctx, kernels, tmp_path):
    """A process that builds from a kept binary dates it as used, so that a binary in use
    every day is never pruned however old its file."""
    (kernels / "probe.h").write_text("#define VALUE 7\n")
    assert _value(ctx, "probe") == 7
    (path,) = (tmp_path / "cache" / "programs").glob("*.bin")
    stamp = time.time() - (programs.KEEP_DAYS + 5) * 86400
    os.utime(path, (stamp, stamp))
    assert _value(ctx, "probe") == 7
    programs.prune(path.parent)
    assert path.exists()
