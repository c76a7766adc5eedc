"""freed_memory_kept: memory freed inside the block stays in the process, and is given back after it."""

import sys

import numpy as np
import pytest

from diskpack_cl import memory

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux") or memory._glibc() is None,
                                reason="glibc's mallopt and /proc/self/status")

MIB = 2**20


def _rss():
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmRSS:"))


def _touch_and_free(nbytes):
    a = np.ones(nbytes // 8)   # every page written
    del a


def test_freed_memory_stays_inside_the_block_and_goes_back_after():
    before = _rss()
    with memory.freed_memory_kept():
        with memory.freed_memory_kept():   # nested: only the outermost block gives memory back
            _touch_and_free(256 * MIB)
        inside = _rss()
        _touch_and_free(256 * MIB)         # the same pages again: no growth
        again = _rss()
    after = _rss()
    assert inside - before > 200 * MIB
    assert again - inside < 32 * MIB
    assert after - before < 64 * MIB


def test_outside_the_block_freed_memory_goes_back():
    before = _rss()
    _touch_and_free(256 * MIB)
    assert _rss() - before < 64 * MIB


def test_a_page_reserve_is_touched_and_its_pages_reused():
    with memory.freed_memory_kept():
        before = _rss()
        reserve = memory.PageReserve(256 * MIB)
        reserve.release()
        touched = _rss()
        a = np.ones(256 * MIB // 8)   # the reserve's pages
        reused = _rss()
        del a
    assert touched - before > 200 * MIB
    assert reused - touched < 32 * MIB


class _IdleThread:
    """A thread that never runs its target (a core too busy to touch a page)."""

    def __init__(self, target, **kw):
        pass

    def start(self):
        pass

    def join(self):
        pass


def test_a_page_reserve_release_touches_the_pages_its_thread_did_not(monkeypatch):
    monkeypatch.setattr(memory.threading, "Thread", _IdleThread)
    with memory.freed_memory_kept():
        before = _rss()
        reserve = memory.PageReserve(256 * MIB + 12345)   # not a whole number of chunks
        untouched = _rss()
        reserve.release()
        touched = _rss()
    assert untouched - before < 32 * MIB
    assert touched - before > 250 * MIB


@pytest.mark.parametrize("idle", [False, True])
def test_a_page_reserve_is_touched_by_its_thread_and_its_pages_reused(idle):
    """The thread touches the pages (at the idle priority too, with Python's lock let go)
    before the release: a reserve on an idle core, not on the caller's."""
    import time

    with memory.freed_memory_kept():
        before = _rss()
        reserve = memory.PageReserve(128 * MIB, idle=idle)
        deadline = time.monotonic() + 60
        while _rss() - before < 120 * MIB and time.monotonic() < deadline:
            time.sleep(0.01)   # the caller's work: none of it touches a page
        touched = _rss()
        reserve.release()
        a = np.ones(128 * MIB // 8)   # the reserve's pages
        reused = _rss()
        del a
    assert touched - before > 120 * MIB
    assert reused - touched < 16 * MIB


@pytest.mark.parametrize("idle", [False, True])
def test_an_idle_reserve_thread_runs_at_the_idle_priority(monkeypatch, idle):
    import os
    import threading

    if not hasattr(os, "SCHED_IDLE"):
        pytest.skip("no SCHED_IDLE here")
    seen = []
    set_idle = memory._idle_priority

    def recorded():
        set_idle()
        seen.append((threading.current_thread().name, os.sched_getscheduler(threading.get_native_id())))

    monkeypatch.setattr(memory, "_idle_priority", recorded)
    with memory.freed_memory_kept():
        memory.PageReserve(16 * MIB, idle=idle).release()
    assert seen == ([("diskpack-reserve", os.SCHED_IDLE)] if idle else [])
    assert os.sched_getscheduler(0) != os.SCHED_IDLE   # the caller's own is left alone


def test_a_cancelled_page_reserve_touches_nothing_more(monkeypatch):
    """A run that ends early (Ctrl-C in the darts) gives the reserve back untouched, where a
    release would touch every page its thread had not."""
    monkeypatch.setattr(memory.threading, "Thread", _IdleThread)
    with memory.freed_memory_kept():
        before = _rss()
        reserve = memory.PageReserve(256 * MIB, idle=True)
        reserve.cancel()
        after = _rss()
    assert after - before < 32 * MIB


def test_a_page_reserve_outside_the_block_reserves_nothing():
    before = _rss()
    reserve = memory.PageReserve(256 * MIB)
    reserve.release()
    assert _rss() - before < 32 * MIB


_THREAD_CHURN = """
import threading
import numpy as np
from diskpack_cl import memory

def faults():
    with open("/proc/self/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[7])

def churn():
    a = np.ones(100 << 17)   # 100 MiB, every page written
    del a

with memory.freed_memory_kept():
    counts = []
    for _ in range(3):
        before = faults()
        t = threading.Thread(target=churn)
        t.start()
        t.join()
        counts.append(faults() - before)
print(*counts)
"""


def test_arrays_of_new_threads_reuse_the_kept_pages():
    """Inside the block each new thread's array takes the pages the last one freed (glibc
    would give each thread an arena of its own and unmap its freed heaps: a stippling's
    worker threads paid their page faults again every step). In a fresh process: glibc
    fixes its arena limit once."""
    import subprocess

    out = subprocess.run([sys.executable, "-c", _THREAD_CHURN], capture_output=True, text=True,
                         check=True).stdout
    first, *again = map(int, out.split())
    assert first > 20_000   # 100 MiB of fresh pages
    assert max(again) < first // 10


class _Mallopt:
    """A C library that records the thresholds set through mallopt."""

    def __init__(self):
        self.set = {}

    def mallopt(self, param, value):
        self.set[param] = value.value

    def malloc_trim(self, pad):
        pass


def test_leaving_the_block_restores_each_threshold(monkeypatch):
    """glibc's mmap threshold 32 MiB and trim threshold 64 MiB, not the other way round; the
    one arena stays (glibc fixes its arena limit once)."""
    libc = _Mallopt()
    monkeypatch.setitem(memory._kept, "libc", libc)
    with memory.freed_memory_kept():
        assert libc.set == {memory._M_MMAP_THRESHOLD: memory._KEEP,
                            memory._M_TRIM_THRESHOLD: memory._KEEP, memory._M_ARENA_MAX: 1}
    # M_MMAP_THRESHOLD, M_TRIM_THRESHOLD, M_ARENA_MAX
    assert libc.set == {-3: 32 * MIB, -1: 64 * MIB, -8: 1}


def _numpy_switch():
    """numpy's switch of its huge-page advice (numpy 2: ``numpy._core``; 1.x: ``numpy.core``)."""
    module = "numpy._core.multiarray" if int(np.__version__.split(".")[0]) >= 2 else "numpy.core.multiarray"
    return pytest.importorskip(module)._set_madvise_hugepage


def _numpy_huge_page_advice():
    previous = _numpy_switch()(True)
    _numpy_switch()(previous)
    return bool(previous)


@pytest.mark.parametrize("outside", [True, False])
def test_numpy_asks_for_no_huge_pages_inside_the_block_and_as_before_after(outside, monkeypatch):
    monkeypatch.delenv("NUMPY_MADVISE_HUGEPAGE", raising=False)
    before = _numpy_switch()(outside)
    try:
        with memory.freed_memory_kept():
            with memory.freed_memory_kept():
                assert _numpy_huge_page_advice() is False
            assert _numpy_huge_page_advice() is False   # the inner block restores nothing
        assert _numpy_huge_page_advice() is outside
    finally:
        _numpy_switch()(before)


def test_the_users_numpy_huge_page_choice_is_kept(monkeypatch):
    monkeypatch.setenv("NUMPY_MADVISE_HUGEPAGE", "1")
    before = _numpy_switch()(True)
    try:
        with memory.freed_memory_kept():
            assert _numpy_huge_page_advice() is True
    finally:
        _numpy_switch()(before)
