"""The plane region points live in: the unit torus or a rectangle in pixel units."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .options import check_fields, option

__all__ = ["Domain", "DomainOptions", "box_sizes"]


def box_sizes(box, form):
    """The sizes a box names (``"2x1"``, ``(2, 1)``), as many as `form` (``"WxH"``) has, each > 0.

    Examples
    --------
    >>> box_sizes("2x1x0.5", "WxHxD")
    [2.0, 1.0, 0.5]
    """
    parts = box.lower().split("x") if isinstance(box, str) else list(np.ravel(box))
    try:
        size = [float(v) for v in parts]
    except (TypeError, ValueError):
        raise ValueError(f"box must be 'torus' or {form}, got {box!r}") from None
    if len(size) != len(form.split("x")) or not all(np.isfinite(v) and v > 0 for v in size):
        raise ValueError(f"box must be {form}: positive finite sizes, got {box!r}")
    return size


@dataclass(frozen=True)
class Domain:
    """The plane region the points live in.

    ``Domain.torus()`` is the unit torus [0,1)^2 (periodic); ``Domain.rect(W, H)``
    is the closed rectangle [0,W] x [0,H], used for images in pixel units.

    Examples
    --------
    >>> Domain.rect(4, 2).area
    8.0
    >>> Domain.torus().wrap([[1.25, -0.5]]).tolist()
    [[0.25, 0.5]]
    """

    width: float = 1.0
    height: float = 1.0
    periodic: bool = True

    @classmethod
    def torus(cls):
        """The unit torus [0,1)^2."""
        return cls(1.0, 1.0, True)

    @classmethod
    def rect(cls, width, height):
        """The closed rectangle [0, width] x [0, height]; sizes must be positive."""
        if not (width > 0 and height > 0):
            raise ValueError(f"domain size must be positive, got {width} x {height}")
        return cls(float(width), float(height), False)

    @property
    def size(self):
        """``(width, height)`` as a float64 array."""
        return np.array([self.width, self.height])

    @property
    def area(self):
        return self.width * self.height

    def wrap(self, points, *, copy=True):
        """Wrap points into [0,W) x [0,H) (periodic domains only); a new array, or
        without `copy`, the float64 array `points` itself, wrapped in place.

        Only the coordinates outside ``[0, size)`` (and -0.0) go through
        ``np.mod``: a relaxed set has few.  Coordinates inside are unchanged
        by ``np.mod`` anyway, so the result is the same bit for bit.  A set
        that lies inside already (as most sets wrapped again do) costs two
        reductions (and the copy); the search for the outside ones goes
        along :meth:`_axes`.
        """
        q = np.array(points, dtype=np.float64) if copy else points
        q += 0.0   # -0.0 becomes 0.0, as np.mod makes it; every other value stays
        if self.holds(q):
            return q
        for col, s in self._axes(q):
            out = np.flatnonzero(~((col >= 0.0) & (col < s)))   # NaN too, as np.mod has it
            if len(out):
                v = np.mod(col[out], s)
                v[v >= s] = 0.0  # mod of -tiny can round to exactly `size`
                col[out] = v
        return q

    def holds(self, points):
        """Whether every coordinate of the float64 array `points` lies in ``[0, min(W, H))``
        (two reductions, no copy; NaN fails): points a wrap leaves as they are (but -0.0).

        Examples
        --------
        >>> Domain.torus().holds(np.array([[0.5, 0.0], [0.25, 0.75]]))
        True
        >>> Domain.torus().holds(np.array([[0.5, 1.0]]))
        False
        """
        flat = np.ravel(points)
        return bool(len(flat) and flat.min() >= 0.0 and flat.max() < min(self.width, self.height))

    def shortest(self, offsets):
        """The offsets `offsets` (``(..., 2)`` float64) made shortest over the periods, in
        place (a rectangle's stay as they are); returns them.

        Examples
        --------
        >>> Domain.torus().shortest(np.array([[0.75, -0.5], [0.25, 1.5]])).tolist()
        [[-0.25, -0.5], [0.25, -0.5]]
        """
        if self.periodic:
            for col, s in self._axes(offsets):
                col -= np.round(col / s) * s
        return offsets

    def _axes(self, a):
        """``(values, period)`` pairs of the ``(..., 2)`` array `a` (views): one of all its
        values where the periods are equal and `a` is contiguous (a square: one pass), else
        one a column (an ``(n, 2)`` broadcast of the size would run numpy's inner loop two
        values at a time)."""
        if self.width == self.height and a.flags.c_contiguous:
            return [(a.reshape(-1), self.width)]
        return zip(a.reshape(-1, 2).T, (self.width, self.height))

    def images(self, points, margin):
        """The points and their periodic images within `margin` of the domain.

        Parameters
        ----------
        points : (n, 2) ndarray
            Points inside the domain.
        margin : float or (2,) array_like
            How far outside the domain images are kept (per axis if two).

        Returns
        -------
        pos : (m, 2) ndarray
            Positions; the first n rows are the points themselves.
        site : (m,) ndarray of int
            The point each row is an image of.

        Examples
        --------
        >>> pos, site = Domain.torus().images(np.array([[0.05, 0.5]]), 0.1)
        >>> pos.tolist(), site.tolist()
        ([[0.05, 0.5], [1.05, 0.5]], [0, 0])
        """
        n = len(points)
        pos, site = [points], [np.arange(n)]
        if not self.periodic:
            return points, site[0]
        size = self.size
        reach = int(np.ceil(np.max(margin / size)))
        for sx in range(-reach, reach + 1):
            for sy in range(-reach, reach + 1):
                if sx == 0 and sy == 0:
                    continue
                q = points + size * (sx, sy)
                keep = np.all((q >= -margin) & (q <= size + margin), axis=1)
                pos.append(q[keep])
                site.append(np.nonzero(keep)[0])
        return np.concatenate(pos), np.concatenate(site)


@dataclass(frozen=True)
class DomainOptions:
    """Where the points lie: the unit torus or a box (``relax``, ``poisson``, ``analyze``).

    The box stays as given (``"2x1"`` or sizes); each job reads it as its
    dimension needs (:func:`box_sizes`).

    Examples
    --------
    >>> DomainOptions(box="2x1").box
    '2x1'
    """

    box: object = option(None, "the box [0,W] x [0,H] (3D: WxHxD) whose walls bound the points "
                         "instead of the unit torus, e.g. 2x1 (analyze: no wrap, a Hann-windowed "
                         "periodogram; default there: the box a point .npz records)",
                         metavar="WxH", cli_type=str)

    def __post_init__(self):
        check_fields(self)
