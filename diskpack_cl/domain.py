"""The plane region points live in: the unit torus or a rectangle in pixel units."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Domain"]


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

    def wrap(self, points):
        """Wrap points into [0,W) x [0,H) (periodic domains only); a new array.

        Only the coordinates outside ``[0, size)`` (and -0.0) go through
        ``np.mod``: a relaxed set has few, and a million-point ``np.mod``
        costs about 20 ms a call.  Coordinates inside are unchanged by
        ``np.mod`` anyway, so the result is the same bit for bit.  A set
        that lies inside already (as most sets wrapped again do) costs a
        copy and two reductions, a fifth of the search for the outside ones.
        """
        q = np.array(points, dtype=np.float64)
        q += 0.0   # -0.0 becomes 0.0, as np.mod makes it; every other value stays
        flat = q.ravel()
        if q.ndim == 2 and q.shape[1] == 2 and len(flat) and flat.min() >= 0.0 \
                and flat.max() < min(self.width, self.height):   # NaN fails both
            return q
        size = np.broadcast_to(self.size, q.shape)
        out = np.nonzero(np.signbit(q) | ~(q < size))   # ~(<): NaN too, as np.mod has it
        if len(out[0]):
            s = size[out]
            v = np.mod(q[out], s)
            v[v >= s] = 0.0  # mod of -tiny can round to exactly `size`
            q[out] = v
        return q

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
