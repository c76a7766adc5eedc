"""Argument checks shared by the samplers and the stippling stage."""

from __future__ import annotations

import argparse

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


def check_point_count(n):
    """A count of points given as an option (``-n``): an integer of at least 2.

    Examples
    --------
    >>> check_point_count(1)
    Traceback (most recent call last):
    ...
    ValueError: need at least 2 points, got 1
    """
    if check_count(n) < 2:
        raise ValueError(f"need at least 2 points, got {n}")


def count_text(text, *words):
    """The command line's count of points: an integer of at least 2 (``20k`` and ``1.5M``
    too: a k, M or G suffix), or one of `words`.

    Raises ``argparse.ArgumentTypeError``, which argparse reports with the flag.

    Examples
    --------
    >>> count_text("12"), count_text("tone", "tone"), count_text("20k"), count_text("1.5M")
    (12, 'tone', 20000, 1500000)
    """
    if text in words:
        return text
    value = _count_text(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    if value < 2:
        raise argparse.ArgumentTypeError(f"need at least 2 points, got {value}")
    return value


def check_seed(seed):
    """A seed as an option: an integer seed must be at least 0 (a Generator passes).

    Examples
    --------
    >>> check_seed(-1)
    Traceback (most recent call last):
    ...
    ValueError: seed must be at least 0, got -1
    """
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed < 0:
        raise ValueError(f"seed must be at least 0, got {seed}")


def seed_text(text):
    """The command line's seed: an integer >= 0 (``argparse.ArgumentTypeError`` else).

    Examples
    --------
    >>> seed_text("7")
    7
    """
    value = _integer_text(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, got {text}")
    return value


def _count_text(text):
    """An integer, also with a k, M or G suffix (``20k``: 20000); exact: ``0.0005k`` is no
    count."""
    import decimal

    scale = {"k": 10**3, "m": 10**6, "g": 10**9}.get(text.strip()[-1:].lower())
    if scale is None:
        return _integer_text(text)
    try:
        value = decimal.Decimal(text.strip()[:-1]) * scale
    except decimal.InvalidOperation:
        value = decimal.Decimal("NaN")
    if not value.is_finite() or value != value.to_integral_value():
        raise argparse.ArgumentTypeError(f"not a count: {text!r} (e.g. 20000, 20k, 1.5M)")
    return int(value)


def _integer_text(text):
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def check_points(points, name="points"):
    """`points` as a float64 (n, 2) array, checked to be finite.

    Examples
    --------
    >>> check_points([[0.5, 0.25]]).dtype
    dtype('float64')
    >>> check_points([[0.5, float("nan")]])
    Traceback (most recent call last):
    ...
    ValueError: points must be finite
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite")
    return p


#: Widest spread of power weights the engines accept: the raster kernels
#: compute power distances in float32 (largest finite value about 3.4e38).
WEIGHT_SPREAD = 1e30


def check_sites(points, weights, domain, minimum=1):
    """Sites and weights as float64 copies, checked as every engine checks them.

    Parameters
    ----------
    points : (n, 2) array_like
        Sites; wrapped into the domain when it is a torus.
    weights : (n,) array_like or None
        Power weights (zeros when None).
    domain : Domain
    minimum : int
        Fewest sites accepted.

    Returns
    -------
    X : (n, 2) float64
    w : (n,) float64
        Not shifted.

    Raises
    ------
    ValueError
        A wrong shape, fewer than `minimum` sites, NaN or infinite
        coordinates or weights, or weights spread wider than
        :data:`WEIGHT_SPREAD`.  A kernel given such sites would leave grid
        cells without an owner, or never end its ring search.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> check_sites([[0.5, 0.5]], [np.nan], Domain.torus())
    Traceback (most recent call last):
    ...
    ValueError: weights must be n finite numbers
    """
    X = np.array(points, dtype=np.float64)
    n = len(X)
    if X.ndim != 2 or X.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {X.shape}")
    if n < minimum:
        raise ValueError(f"need at least {minimum} point(s), got {n}")
    if not np.all(np.isfinite(X)):
        raise ValueError("points contain NaN or infinite coordinates")
    if domain.periodic:
        X = domain.wrap(X, copy=False)
    if weights is None:   # zeros: nothing to check (a relaxation's step of a thousand sites)
        return X, np.zeros(n)
    w = np.array(weights, dtype=np.float64)
    if w.shape != (n,) or not np.all(np.isfinite(w)):
        raise ValueError("weights must be n finite numbers")
    if n and not np.ptp(w) < WEIGHT_SPREAD:
        raise ValueError(f"weights must span less than {WEIGHT_SPREAD:g}, got {np.ptp(w):g}")
    return X, w
