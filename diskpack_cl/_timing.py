"""One timing helper: seconds per named stage, summed over calls."""

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
