"""The one timing collector: seconds per named stage, summed over calls.

An engine owns one :class:`Stopwatch` and hands it to the processing
objects it drives (:class:`~diskpack_cl.device.cells.CellMIC`,
:class:`~diskpack_cl.device.raster.PowerRaster`), so that every stage and every
profiled kernel lands in one place. A caller that wants one step's share
takes a :meth:`Stopwatch.mark` before the step and :meth:`Stopwatch.since`
after it; the totals are :attr:`Stopwatch.seconds`.
"""

from __future__ import annotations

import time
from contextlib import contextmanager


class Stopwatch:
    """Seconds per named stage; ``with watch("raster"): ...`` adds to ``watch.seconds["raster"]``.

    Examples
    --------
    >>> watch = Stopwatch(["raster", "exact"])
    >>> with watch("raster"):
    ...     pass
    >>> sorted(watch.seconds), watch.seconds["exact"]
    (['exact', 'raster'], 0.0)
    >>> mark = watch.mark()
    >>> watch.kernel("labels", 0.5)
    >>> watch.since(mark)
    {'kernel': 0.5, 'kernel_labels': 0.5}
    """

    def __init__(self, names=()):
        self.seconds = {name: 0.0 for name in names}

    @contextmanager
    def __call__(self, name):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)

    def add(self, name, seconds):
        """Add `seconds` to stage `name`."""
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds

    def kernel(self, name, seconds):
        """Add the device `seconds` of kernel `name` to ``kernel_<name>`` and to ``kernel``."""
        self.add("kernel", seconds)
        self.add(f"kernel_{name}", seconds)

    @contextmanager
    def discarded(self):
        """Drop whatever is added inside (a warm-up run is no caller's work)."""
        keep = self.mark()
        try:
            yield
        finally:
            self.seconds = keep

    def mark(self):
        """The totals now, for :meth:`since`."""
        return dict(self.seconds)

    def since(self, mark):
        """Seconds per stage added after `mark`; only the stages that ran."""
        return {name: secs - mark.get(name, 0.0) for name, secs in self.seconds.items()
                if secs != mark.get(name, 0.0)}
