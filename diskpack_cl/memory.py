"""Memory estimates of a stippling run, checked before the work.

:func:`check_stipple_memory` refuses a raster (``supersample``) or a PNG
preview (``png_scale``) that the machine's available memory or the OpenCL
device cannot hold, naming the option to lower and the largest value that
fits (:class:`MemoryLimit`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import mmap
import os
import threading
from contextlib import contextmanager

from ._nesting import Outermost
from .options import NamedOptionError

__all__ = ["HOST_BYTES_PER_CELL", "DEVICE_BYTES_PER_CELL", "HOST_BYTES_PER_PNG_PIXEL",
           "HOST_BYTES_PER_POINT", "MemoryLimit", "available_memory", "check_png_memory",
           "check_poisson_memory", "check_stipple_memory", "drop_pages", "freed_memory_kept",
           "give_back", "PageReserve", "share_main_arena"]

# Peak bytes per unit of a stippling run (default schedule; PNG writer)
HOST_BYTES_PER_CELL = 64       # one raster cell: maps, density, centroid sums
DEVICE_BYTES_PER_CELL = 12     # labels, distances, neighbours (4 bytes each)
HOST_BYTES_PER_PNG_PIXEL = 32  # ink coverage, gray values, the encoded image


class MemoryLimit(NamedOptionError):
    """A size that memory cannot hold; the message names the option to lower.

    Examples
    --------
    >>> exc = MemoryLimit("lower {}", "supersample")
    >>> str(exc), isinstance(exc, ValueError)
    ('lower supersample', True)
    """


def available_memory():
    """Bytes of memory the machine has available now (MemAvailable), or None.

    Examples
    --------
    >>> free = available_memory()
    >>> free is None or free > 0
    True
    """
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


# glibc's mallopt parameters, and the thresholds its dynamic ones reach on
# 64-bit systems (DEFAULT_MMAP_THRESHOLD_MAX and twice that)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_ARENA_MAX = -1, -3, -8
_MADV_DONTNEED = 4   # Linux
_MMAP_AFTER, _TRIM_AFTER = 32 << 20, 64 << 20
_KEEP = 2**31 - 1   # mallopt takes an int
_kept = {"libc": None, "advice": None}


def _glibc():
    """The C library when it is glibc (it has mallopt and malloc_trim), else None."""
    if _kept["libc"] is None:
        _kept["libc"] = _load_glibc() or False
    return _kept["libc"] or None


def _load_glibc():
    """glibc by its name (no ``ldconfig`` run: 17 ms), else the C library ctypes finds, where
    it is glibc (it has mallopt and malloc_trim); else None."""
    for name in ("libc.so.6", None):
        try:
            libc = ctypes.CDLL(name or ctypes.util.find_library("c") or "libc.so.6")
        except OSError:
            continue
        if hasattr(libc, "malloc_trim") and hasattr(libc, "mallopt"):
            return libc
    return None


def share_main_arena():
    """Have the threads started from now on allocate from glibc's main arena.

    glibc gives a new thread an arena of heaps of its own, and hands a heap
    back to the system as soon as all of it is free, whatever
    :func:`freed_memory_kept` asks: the arrays that the worker threads of a
    stippling's steps make and drop would pay all their page faults again at
    every step.  In the main arena they take the pages the block keeps.
    glibc fixes its limit of arenas when it first needs one more, so the
    setting holds for the rest of the process (the command line sets it
    before the OpenCL driver starts its threads; :func:`freed_memory_kept`
    sets it too).  With another C library it does nothing.

    Examples
    --------
    >>> share_main_arena()
    """
    libc = _glibc()
    if libc is not None:
        libc.mallopt(_M_ARENA_MAX, ctypes.c_int(1))


def _set_thresholds(libc, mmap_bytes, trim_bytes):
    libc.mallopt(_M_MMAP_THRESHOLD, ctypes.c_int(mmap_bytes))
    libc.mallopt(_M_TRIM_THRESHOLD, ctypes.c_int(trim_bytes))


def _huge_page_advice(on):
    """Turn numpy's advice to back its large arrays with transparent huge pages on or
    off; returns the previous setting, or None where numpy has no such switch or the
    user chose with numpy's ``NUMPY_MADVISE_HUGEPAGE`` (then nothing changes)."""
    if on is None or "NUMPY_MADVISE_HUGEPAGE" in os.environ:
        return None
    try:
        from numpy._core.multiarray import _set_madvise_hugepage
    except ImportError:
        try:
            from numpy.core.multiarray import _set_madvise_hugepage   # numpy 1.x
        except ImportError:
            return None
    return bool(_set_madvise_hugepage(bool(on)))


def _keep_freed():
    _kept["advice"] = _huge_page_advice(False)
    libc = _glibc()
    if libc is not None:
        _set_thresholds(libc, _KEEP, _KEEP)
        share_main_arena()


def _give_freed_back():
    _huge_page_advice(_kept["advice"])
    libc = _glibc()
    if libc is not None:
        _set_thresholds(libc, _MMAP_AFTER, _TRIM_AFTER)
        libc.malloc_trim(ctypes.c_size_t(0))


# The outermost freed_memory_kept block, of any thread, sets and resets the switches.
_keeping = Outermost(_keep_freed, _give_freed_back)


@contextmanager
def freed_memory_kept():
    """Keep the memory freed inside the block in the process, for its next arrays.

    A stippling run makes and drops many arrays of the whole picture or of
    all dots.  glibc hands every freed block above its mmap threshold back
    to the system at once, and the next array pays a page fault for each of
    its pages again; on virtual machines that return freed pages to the host
    (free page reporting) such a fresh page costs many times more than one
    the process kept.  Inside the block, freed memory stays in the heap;
    leaving it (the outermost block, when nested or in several threads)
    gives the free memory back (``malloc_trim``) and sets glibc's mmap and
    trim thresholds to the values its dynamic thresholds reach (32 and
    64 MiB).  With another C library it does nothing of this.

    Inside the block numpy does not ask for transparent huge pages for its
    large arrays (on Linux it does by default): a run writes each whole-picture
    array once and reads it in passes, and a fresh huge page can cost the
    kernel a compaction or, on a virtual machine, the host's faults for all of
    it.  Setting numpy's ``NUMPY_MADVISE_HUGEPAGE`` keeps the user's choice.

    Examples
    --------
    >>> import numpy as np
    >>> with freed_memory_kept():
    ...     a = np.ones(1 << 20); del a
    ...     b = np.ones(1 << 20)   # the same pages again
    >>> float(b.sum())
    1048576.0
    """
    with _keeping.block():
        yield


def give_back():
    """Hand the heap's free memory back to the system now, inside :func:`freed_memory_kept` too.

    For memory that the rest of a run will not ask for again: a stippling
    gives back its float gray image once its fields are made, so that the
    steps' peak is the fields', not the fields' and the picture's.  With
    another C library it does nothing.

    Examples
    --------
    >>> import numpy as np
    >>> with freed_memory_kept():
    ...     a = np.ones(1 << 20); del a
    ...     give_back()
    """
    libc = _glibc()
    if libc is not None:
        libc.malloc_trim(ctypes.c_size_t(0))


def drop_pages(a):
    """Hand the whole pages of C-contiguous array `a`'s memory back to the system now.

    Their contents become zeros (``madvise(MADV_DONTNEED)``): for the rows of
    an array that its owner, the run that made it, will not read again, so
    that the run's peak memory falls as it goes.  Elsewhere than Linux with
    glibc it does nothing.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.ones((4, 4096))
    >>> drop_pages(a[:2])
    >>> float(a[2:].sum())
    8192.0
    """
    libc = _glibc()
    if libc is None or not a.flags.c_contiguous:
        return
    page = mmap.PAGESIZE
    addr = a.ctypes.data
    start, end = -(-addr // page) * page, (addr + a.nbytes) // page * page
    if end > start:
        libc.madvise(ctypes.c_void_p(start), ctypes.c_size_t(end - start), _MADV_DONTNEED)


class PageReserve:
    """`nbytes` of memory whose pages another thread touches now, handed back on :meth:`release`.

    Inside :func:`freed_memory_kept` the arrays made after the release take
    these pages: the first touch of each page (a page fault, far dearer on
    virtual machines that hand freed pages back to their host) is paid on an
    idle core while the caller goes on with work of one core (reading the
    picture, the error diffusion). The pages are touched a chunk at a time,
    and :meth:`release` touches those the thread has not reached beside it
    rather than waiting for it. Outside such a block, or with another C
    library, it reserves nothing.

    With `idle`, the thread takes only the time no other thread wants
    (``SCHED_IDLE`` where the system has it) and holds no lock of Python's
    while it touches: for a caller whose work keeps the cores busy at times
    and leaves them idle at others (a device's kernels, the host's work
    between them), such as the darts of a Poisson set.

    Examples
    --------
    >>> with freed_memory_kept():
    ...     reserve = PageReserve(1 << 20)   # ... work of one core ...
    ...     reserve.release()                # ... then the arrays that reuse its pages
    """

    #: Bytes touched at a time (a whole number of pages): the thread and the caller take
    #: chunks in turn.
    CHUNK = 8 << 20

    def __init__(self, nbytes, *, idle=False):
        self._block = self._thread = None
        self._next, self._lock, self._idle = 0, threading.Lock(), idle
        if nbytes > 0 and _keeping.on and _glibc() is not None:
            import numpy as np   # (this module is read at start-up without numpy)

            self._block = np.empty(int(nbytes), np.uint8)
            self._thread = threading.Thread(target=self._run, name="diskpack-reserve", daemon=True)
            self._thread.start()

    def _run(self):
        """The thread's work: :meth:`_touch`, at the system's idle priority if `idle`."""
        if self._idle:
            _idle_priority()
        self._touch()

    def _touch(self):
        """Touch the pages of the chunks not yet taken, until none is left."""
        while (at := self._take()) is not None:
            if self._idle:   # a C call: Python's lock is let go during the faults
                ctypes.memset(self._block.ctypes.data + at, 0, min(self.CHUNK, len(self._block) - at))
            else:
                self._block[at:at + self.CHUNK:mmap.PAGESIZE] = 0   # numpy lets the other threads run

    def _take(self):
        """The start of the next chunk to touch, or None."""
        with self._lock:
            at = self._next
            if at >= len(self._block):
                return None
            self._next = at + self.CHUNK
            return at

    def release(self):
        """Touch the pages the thread has not reached, beside it; then give the memory to the heap."""
        if self._thread is not None:
            self._touch()
            self._thread.join()
        self._block = self._thread = None

    def cancel(self):
        """Stop the thread after its chunk and give the memory to the heap, its pages touched
        or not: for a run that ends early (an error, Ctrl-C), which needs none of them."""
        if self._thread is not None:
            with self._lock:
                self._next = len(self._block)
            self._thread.join()
        self._block = self._thread = None


def _idle_priority():
    """Run the calling thread only when no other thread wants a core (Linux's
    ``SCHED_IDLE``); elsewhere, or where it is refused, nothing changes."""
    try:
        os.sched_setscheduler(threading.get_native_id(), os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        pass


def _gib(b):
    return f"{b / 2**30:.3g} GiB"


def _raster_limits(free, device):
    """``(bytes per raster cell, bytes available, what)`` of the machine and the device."""
    from .device.context import NoOpenCLError, get_context  # not loaded at start-up

    limits = []
    if free is not None:
        limits.append((HOST_BYTES_PER_CELL, free, "memory available on this machine"))
    try:
        dev = get_context(device).devices[0]
    except NoOpenCLError:
        dev = None
    if dev is not None:
        limits += [(4, dev.max_mem_alloc_size, "the OpenCL device's largest buffer"),
                   (DEVICE_BYTES_PER_CELL, dev.global_mem_size, "the OpenCL device's memory")]
    return limits


def check_stipple_memory(width, height, n, *, supersample=None, png_scale=None, device=None,
                         outputs=(), free=None, ink=None, png_area=None):
    """Refuse, before the work, a raster or a PNG preview that memory cannot hold.

    The raster (``supersample``, default automatic: see
    :func:`~diskpack_cl.schedule.auto_supersample`, which reads the image's
    `ink` where it is given) is checked against the machine's available
    memory (`free`, default :func:`available_memory`) and the OpenCL
    device's largest buffer and global memory; a PNG among `outputs`
    (``png_scale`` PNG pixels per image pixel, over `png_area`: the width and
    height in image pixels of what it shows, default the image's: a
    whole-page preview shows more) against the machine's memory.

    Raises
    ------
    MemoryLimit
        Naming the option to lower and the largest value that fits.

    Examples
    --------
    With ``free`` given (bytes), the check does not read the machine:

    >>> check_stipple_memory(512, 512, 20000, free=8 * 2**30)
    >>> check_stipple_memory(512, 512, 20000, free=10**6)
    Traceback (most recent call last):
    ...
    diskpack_cl.memory.MemoryLimit: supersample 2 makes a 1024x1024 raster ...
    """
    from .schedule import auto_supersample  # not loaded at start-up

    free = available_memory() if free is None else free
    s = supersample or auto_supersample(n, width, height, ink)
    cells = (s * width) * (s * height)
    for per_cell, have, what in _raster_limits(free, device):
        if cells * per_cell > have:
            fit = math.isqrt(int(have // (per_cell * width * height)))
            lower = (f"lower {{}} (at most {fit} here)" if fit >= 1 else
                     "the image is too large even at {} 1: downscale it")
            raise MemoryLimit(f"supersample {s} makes a {s * width}x{s * height} raster "
                              f"needing {_gib(cells * per_cell)}, more than {what} "
                              f"({_gib(have)}): {lower}", "supersample")
    if png_scale is not None:
        check_png_memory(*(png_area or (width, height)), png_scale, outputs, free=free)


def check_png_memory(width, height, png_scale, outputs, *, free=None):
    """Refuse, before the work, a PNG among `outputs` that memory cannot hold.

    Parameters
    ----------
    width, height : float
        What the PNG shows, in image pixels (the picture, or a whole page).
    png_scale : float
        PNG pixels per image pixel.
    outputs : iterable of str
        The run's output paths; only a ``.png`` among them is checked.
    free : int, optional
        Bytes available (default :func:`available_memory`).

    Raises
    ------
    MemoryLimit
        Naming ``png_scale``, the PNG's size and the largest scale that fits.

    Examples
    --------
    >>> check_png_memory(512, 512, 2.0, ["out.png"], free=8 * 2**30)
    >>> check_png_memory(512, 512, 1e6, ["out.png"], free=8 * 2**30)
    Traceback (most recent call last):
    ...
    diskpack_cl.memory.MemoryLimit: png_scale 1e+06 makes a 512000000x512000000 PNG needing 7.81e+09 GiB, more than the memory available (8 GiB): lower png_scale (at most 32 here)
    """
    free = available_memory() if free is None else free
    if free is None or not any(str(o).lower().endswith(".png") for o in outputs):
        return
    pw, ph = _png_size(width, height, png_scale)
    if pw * ph * HOST_BYTES_PER_PNG_PIXEL > free:
        fit = math.floor(math.sqrt(free / HOST_BYTES_PER_PNG_PIXEL / (width * height)) * 10) / 10
        while fit > 0 and math.prod(_png_size(width, height, fit)) * HOST_BYTES_PER_PNG_PIXEL > free:
            fit = round(fit - 0.1, 1)   # the PNG's sides are rounded up to whole pixels
        raise MemoryLimit(f"{{}} {png_scale:g} makes a {pw}x{ph} PNG needing "
                          f"{_gib(pw * ph * HOST_BYTES_PER_PNG_PIXEL)}, more than the memory "
                          f"available ({_gib(free)}): lower {{}} (at most {fit:g} here)",
                          "png_scale", "png_scale")


def _png_size(width, height, png_scale):
    """The PNG's pixels, as the writers round them."""
    return max(1, round(width * png_scale)), max(1, round(height * png_scale))


#: Peak host bytes per point of a 2D Poisson disk set (start set, relaxation, KD-tree
#: measure, writing), with room: 400 000 points peaked at 324 MB resident
HOST_BYTES_PER_POINT = 1000


def check_poisson_memory(n, *, free=None, names=("n", "min_distance")):
    """Refuse, before the work, a Poisson disk set of `n` points that memory cannot hold.

    Parameters
    ----------
    n : int
    free : int, optional
        Bytes available (default :func:`available_memory`).
    names : tuple of str, optional
        The options that ask for the count: the count and the distance, or the
        distance alone (a count it chooses itself).

    Raises
    ------
    MemoryLimit
        Naming the count (``n``, or a ``min_distance`` that asks for it) and the most
        points that fit.

    Examples
    --------
    >>> check_poisson_memory(10**6, free=8 * 2**30)
    >>> check_poisson_memory(10**9, free=8 * 2**30)
    Traceback (most recent call last):
    ...
    diskpack_cl.memory.MemoryLimit: 1000000000 points need about 931 GiB, more than the memory available (8 GiB): ask for at most 8589934 points (a smaller n or a larger min_distance)
    >>> check_poisson_memory(10**9, free=8 * 2**30, names=("radius",))
    Traceback (most recent call last):
    ...
    diskpack_cl.memory.MemoryLimit: 1000000000 points need about 931 GiB, more than the memory available (8 GiB): ask for at most 8589934 points (a larger radius)
    """
    free = available_memory() if free is None else free
    if free is not None and n * HOST_BYTES_PER_POINT > free:
        change = "a smaller {} or a larger {}" if len(names) == 2 else "a larger {}"
        raise MemoryLimit(f"{n} points need about {_gib(n * HOST_BYTES_PER_POINT)}, more than "
                          f"the memory available ({_gib(free)}): ask for at most "
                          f"{free // HOST_BYTES_PER_POINT} points ({change})", *names)
