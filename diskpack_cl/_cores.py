"""Work of one array shared by the machine's cores: consecutive runs of it, a thread each.

numpy releases Python's lock inside a loop over a large array, so that the
threads' runs go on together.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor


def usable_cores():
    """Cores this process may run on (its CPU set where the system has one).

    Examples
    --------
    >>> usable_cores() >= 1
    True
    """
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def on_cores(run, length, work, part):
    """Call ``run(rows)`` for consecutive slices `rows` covering ``range(length)``, together.

    As many slices as cores, but each at least `part` of the `work` (the
    work of all `length` rows: their items, say), and no empty one; one
    slice runs here, on no thread.

    Examples
    --------
    >>> seen = []
    >>> on_cores(seen.append, 10, 10, 100)
    >>> seen
    [slice(0, 10, None)]
    """
    runs = max(1, min(os.cpu_count() or 1, length, work // max(int(part), 1)))
    ends = [length * k // runs for k in range(runs + 1)]
    parts = [slice(ends[k], ends[k + 1]) for k in range(runs)]
    if runs == 1:
        run(parts[0])
    else:
        with ThreadPoolExecutor(runs) as pool:
            list(pool.map(run, parts))
