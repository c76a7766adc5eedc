"""Process-wide switches that nested or concurrent blocks share."""

from __future__ import annotations

import threading
from contextlib import contextmanager


class Outermost:
    """A switch turned on when the first of its blocks begins and off when the last ends.

    Blocks may nest and may run in several threads at once: `enter` runs once
    before the first, `leave` once after the last, both under :attr:`lock`
    (which the switch's users may also take to read the state it guards).

    Examples
    --------
    >>> seen = []
    >>> switch = Outermost(lambda: seen.append("on"), lambda: seen.append("off"))
    >>> with switch.block():
    ...     with switch.block():
    ...         pass
    >>> seen
    ['on', 'off']
    """

    def __init__(self, enter, leave):
        self.lock = threading.Lock()
        self._enter, self._leave = enter, leave
        self._depth = 0

    @property
    def on(self):
        """True inside a block (of any thread)."""
        return self._depth > 0

    @contextmanager
    def block(self):
        """A block inside which the switch is on."""
        with self.lock:
            if self._depth == 0:
                self._enter()
            self._depth += 1
        try:
            yield
        finally:
            with self.lock:
                self._depth -= 1
                if self._depth == 0:
                    self._leave()
