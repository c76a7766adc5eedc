"""Argument checks shared by the samplers and the stippling stage."""

from __future__ import annotations

import numpy as np


def check_count(n, minimum=1, name="n"):
    """`n` as an int, checked to be an integer (not a bool or a float) >= `minimum`.

    Examples
    --------
    >>> check_count(np.int64(5))
    5
    >>> check_count(3.0)
    Traceback (most recent call last):
    ...
    ValueError: n must be an integer, got 3.0
    """
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {n!r}")
    if n < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {n}")
    return int(n)
