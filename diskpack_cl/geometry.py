"""Exact float64 geometry: domains, certified maximal inscribed circles of power cells."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Domain"]


@dataclass(frozen=True)
class Domain:
    """The plane region the points live in.

    ``Domain.torus()`` is the unit torus [0,1)^2 (periodic); ``Domain.rect(W, H)``
    is the closed rectangle [0,W] x [0,H], used for images in pixel units.
    """

    width: float = 1.0
    height: float = 1.0
    periodic: bool = True

    @classmethod
    def torus(cls):
        return cls(1.0, 1.0, True)

    @classmethod
    def rect(cls, width, height):
        if not (width > 0 and height > 0):
            raise ValueError(f"domain size must be positive, got {width} x {height}")
        return cls(float(width), float(height), False)

    @property
    def area(self):
        return self.width * self.height

    def wrap(self, points):
        """Wrap points into [0,W) x [0,H) (periodic domains only)."""
        p = np.asarray(points, dtype=np.float64)
        size = np.array([self.width, self.height])
        q = np.mod(p, size)
        q[q >= size] = 0.0  # mod of -tiny can round to exactly `size`
        return q
