"""The device base: what every stage that runs OpenCL programs holds, in one place.

A stage (:class:`~diskpack_cl.device.raster.PowerRaster`, :class:`~diskpack_cl.device.cells.CellMIC`,
:class:`~diskpack_cl.device.cells3.CellMIC3`, :class:`~diskpack_cl.device.blur.DeviceBlur`, the
dart rounds' grid) is a small class on :class:`DeviceStage`: the context, one
queue, the device's verdict (:mod:`diskpack_cl.device.checks`), programs
built with the switches the checks chose and refused where they failed,
waits that let Ctrl-C through, and kernel profiling.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import pyopencl as cl

from .context import describe, get_context, wait_for
from .programs import build_program
from .._nesting import Outermost
from .._timing import Stopwatch
from .checks import UntrustedProgram, verdict_of

__all__ = ["DeviceStage", "buffers_handed_on", "has_fp64", "tile_lanes"]

# The buffers handed on inside buffers_handed_on blocks (None outside any), by context.
_handed = {"spare": None}
_handing = Outermost(lambda: _handed.update(spare={}), lambda: _handed.update(spare=None))


@contextmanager
def buffers_handed_on():
    """Inside the block a stage's buffers that it hands on (:meth:`DeviceStage.hand_on`) go
    to the next stage on the same context that needs a buffer of at least half their size
    (:meth:`DeviceStage.buffer`), instead of back to the system.

    A device buffer's pages are the process's on a CPU device: a fresh one pays a page
    fault for each page its kernels first touch (at a million Poisson points the dart
    grids' 134 MB and the MIC outputs' 116 MB, some 30 000 faults each).  Inside a run that
    makes the one and then the other, the second takes the first's pages.  Buffers no
    stage took are dropped when the outermost block ends.

    Examples
    --------
    >>> stage = DeviceStage()
    >>> with buffers_handed_on():
    ...     first = stage.buffer("a", 1000)
    ...     stage.hand_on()
    ...     DeviceStage().buffer("b", 800) is first
    True
    """
    with _handing.block():
        yield


def _claim(ctx, nbytes):
    """The smallest buffer handed on for `ctx` that holds `nbytes` and is at most twice
    as large (so that no stage keeps much more than it asked for), taken; else None."""
    with _handing.lock:
        spare = (_handed["spare"] or {}).get(ctx, [])
        fits = [buf for buf in spare if nbytes <= buf.size <= 2 * nbytes]
        if not fits:
            return None
        buf = min(fits, key=lambda b: b.size)
        spare.remove(buf)
        return buf


def has_fp64(ctx):
    """True when the context's device supports double precision (``cl_khr_fp64``).

    Examples
    --------
    >>> from diskpack_cl import get_context
    >>> has_fp64(get_context()) in (True, False)
    True
    """
    return "cl_khr_fp64" in ctx.devices[0].extensions


def tile_lanes(verdict):
    """Vector lanes of the CPU tile layout: 16 where the device's checks trusted 512-bit
    vectors through builtins (``verdict.wide``), else 8.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> tile_lanes(SimpleNamespace(wide=True)), tile_lanes(SimpleNamespace(wide=False))
    (16, 8)
    """
    return 16 if verdict.wide else 8


class DeviceStage:
    """Context, queue, trusted programs and waits of one stage on one OpenCL device.

    Parameters
    ----------
    device : str or pyopencl.Context, optional
        See :func:`diskpack_cl.get_context`.
    profile : bool
        Profile the kernels with OpenCL events: :meth:`wait` adds each
        kernel's device seconds to `timings` (``kernel_<name>``, ``kernel``).
    timings : Stopwatch, optional
        Where the stage's seconds go (default: a new one).
    fp64 : bool
        The stage needs float64: a device without ``cl_khr_fp64`` raises.

    Raises
    ------
    NoOpenCLError
        No device.
    RuntimeError
        `fp64` and the device has none.

    Examples
    --------
    >>> stage = DeviceStage()
    >>> sorted(stage.program("raster_mic", {"PERIODIC": 1}))
    ['cell_argmax', 'cell_max']
    """

    def __init__(self, device=None, *, profile=False, timings=None, fp64=False):
        self.ctx = get_context(device)
        self.device_name = describe(self.ctx)
        if fp64 and not has_fp64(self.ctx):
            raise RuntimeError(f"{self.device_name} has no float64 support (cl_khr_fp64)")
        self.verdict = verdict_of(self.ctx)
        props = cl.command_queue_properties.PROFILING_ENABLE if profile else 0
        self.queue = cl.CommandQueue(self.ctx, properties=props)
        self.profile = profile
        self.timings = Stopwatch() if timings is None else timings
        #: Vector lanes of the CPU tile layout (:func:`tile_lanes`).
        self.lanes = tile_lanes(self.verdict)
        self._kept = {}
        self._lent = {}   # lend's buffers, with their host arrays

    @property
    def device(self):
        """The ``pyopencl.Device``."""
        return self.ctx.devices[0]

    @property
    def is_cpu(self):
        """Whether the device is a CPU (the stages pick their layouts by it)."""
        return bool(self.device.type & cl.device_type.CPU)

    def program(self, stem, defines=None):
        """The kernels of ``kernels/<stem>.cl`` built with `defines` and the checks' switches.

        Raises
        ------
        UntrustedProgram
            The program failed its known-answer check on this device.
        """
        why = self.verdict.refused(stem)
        if why is not None:
            raise UntrustedProgram(f"{stem} failed its check on {self.device_name}: {why}")
        return build_program(self.ctx, stem, {**(defines or {}), **self.verdict.defines(stem)})

    def trusts(self, stem):
        """Whether program `stem` passed its check on this device."""
        return self.verdict.refused(stem) is None

    def buffer(self, name, nbytes):
        """The stage's device buffer `name` of at least `nbytes` (kept from call to call,
        made anew only when it must grow)."""
        buf = self._kept.get(name)
        if buf is None or buf.size < max(nbytes, 8):
            buf = (_claim(self.ctx, max(nbytes, 8))
                   or cl.Buffer(self.ctx, cl.mem_flags.READ_WRITE, max(nbytes, 8)))
            self._kept[name] = buf
        return buf

    def regions(self, name, sizes):
        """Sub-buffers of `sizes` bytes side by side in one buffer `name` (:meth:`buffer`),
        each at a multiple of the device's base alignment: arrays that one stage keeps,
        handed on as one (:meth:`hand_on`) to a stage that needs one large buffer."""
        align = self.device.mem_base_addr_align // 8
        ends = np.cumsum([-(-max(size, 1) // align) * align for size in sizes])
        buf = self.buffer(name, int(ends[-1]))
        return [buf.get_sub_region(int(end - step), int(size))
                for end, step, size in zip(ends, np.diff(ends, prepend=0), sizes)]

    def hand_on(self):
        """Give up the stage's buffers (:meth:`buffer`), once its queue is done: inside a
        :func:`buffers_handed_on` block to the next stage that needs one, else to the
        system.  The stage must not run again."""
        self.queue.finish()
        kept, self._kept = list(self._kept.values()), {}
        with _handing.lock:
            if _handed["spare"] is not None:
                _handed["spare"].setdefault(self.ctx, []).extend(kept)

    def upload(self, name, host, wait=True):
        """:meth:`buffer` `name` holding the host array `host` (``wait=False``: the copy
        is queued, and `host` must live until the queue has read it)."""
        buf = self.buffer(name, host.nbytes)
        if host.nbytes:
            cl.enqueue_copy(self.queue, buf, host, is_blocking=wait)
        return buf

    def lend(self, name, host):
        """A read-only buffer `name` of the host array `host` (C-contiguous), which must stay
        unchanged until the kernels queued after this call are done.

        On a CPU device the array itself (``USE_HOST_PTR``: no copy, and no wait for the
        device's threads to make one, which a loaded machine stretches to milliseconds),
        kept with its buffer until :meth:`release_lent`, or until `name` is lent again (after
        the queue is done with it); elsewhere :meth:`upload`."""
        if not self.is_cpu or not host.nbytes:
            return self.upload(name, host)
        if name in self._lent:
            self.queue.finish()   # idle but after a pass left unread: its kernels end first
        buf = cl.Buffer(self.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=host)
        self._lent[name] = buf
        return buf

    def release_lent(self):
        """Drop the lent arrays (:meth:`lend`): for a caller whose kernels that read them are
        done, so that a step's arrays are not held beside the next step's work."""
        self._lent.clear()

    def zeros(self, name, nbytes):
        """:meth:`buffer` `name` with its first `nbytes` set to zero on the device (queued: no
        host array to make, zero and copy)."""
        buf = self.buffer(name, nbytes)
        if nbytes:
            cl.enqueue_fill_buffer(self.queue, buf, np.zeros(1, np.int32), 0, nbytes)
        return buf

    def wait(self, event, name):
        """Wait for kernel `name` (signals get through); with `profile`, add its device time."""
        wait_for(event)
        if self.profile:
            self.timings.kernel(name, (event.profile.end - event.profile.start) * 1e-9)
