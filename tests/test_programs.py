"""device.programs: built programs come from a binary cache that follows their sources."""

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
