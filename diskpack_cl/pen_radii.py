"""Dot radius per pen: the radius at which a pen's dots hold its layer's ink,
overlapping ink added (:func:`pen_tone_radii`) or counted once
(:func:`pen_ink_radii`, the radii that :func:`diskpack_cl.stipple_colors` sets).
"""

from __future__ import annotations

import numpy as np

__all__ = ["pen_tone_radii", "pen_ink_radii"]


def pen_tone_radii(layers, counts):
    """Dot radius per pen at which its dots hold its layer's ink (1 where a pen has no dots).

    Examples
    --------
    Half coverage on 10 x 10 pixels is 50 pixels of ink: 50 dots of radius
    ``1 / sqrt(pi)`` hold it; a pen without dots gets 1.

    >>> pen_tone_radii(np.full((2, 10, 10), 0.5), [50, 0]).round(4).tolist()
    [0.5642, 1.0]
    """
    from .picture_measures import tone_radius  # not loaded at start-up

    return np.array([tone_radius(int(c), a) if c > 0 else 1.0 for a, c in zip(layers, counts)])


def _probes(x, R, k, rng):
    """`k` points in the disk of radius `R` around each of `x`, stratified by area
    (ring ``i`` of ``k`` equal areas, a random radius in it and a golden-angle turn):
    (len(x) * k, 2)."""
    ring = (np.arange(k) + rng.random((len(x), 1))) / k
    turn = 2.399963229728653 * np.arange(k) + 2 * np.pi * rng.random((len(x), 1))
    d = R * np.sqrt(ring)
    return (x[:, None, :] + np.stack([d * np.cos(turn), d * np.sin(turn)], axis=-1)).reshape(-1, 2)


def _ink_radius(x, ink, r0, shape, grow, probes, rng):
    """The radius at which dots `x` cover `ink` px² of the image, overlaps counted once."""
    from scipy.spatial import cKDTree  # not loaded at start-up

    H, W = shape
    m = len(x)
    R, k = grow * r0, max(16, min(64, probes // m))
    some = x if m * k <= probes else x[rng.choice(m, probes // k, replace=False)]
    y = _probes(some, R, k, rng)
    tree = cKDTree(x)
    # each probe stands for pi R^2 / k of the disk it was drawn in (times the dots per
    # dot probed), shared by every disk of radius R that holds it: the weights add
    # up to the area of the disks' union
    share = tree.query_ball_point(y, R, return_length=True)
    inside = (y[:, 0] >= 0) & (y[:, 0] <= W) & (y[:, 1] >= 0) & (y[:, 1] <= H)
    weight = np.where(inside, np.pi * R * R / k * m / len(some) / np.maximum(share, 1), 0.0)
    d = tree.query(y)[0]
    order = np.argsort(d)
    covered = np.cumsum(weight[order])
    at = np.searchsorted(covered, ink)
    return float(d[order][at]) if at < len(d) else R


def pen_ink_radii(points, pen, layers, *, grow=1.25, probes=100_000, seed=0):
    """Dot radius per pen at which its dots hold its layer's ink on the image, where they
    overlap counted once.

    :func:`pen_tone_radii` adds the ink of overlapping dots; on paper (and in
    :func:`~diskpack_cl.color_measures.render_pens`) a pen over its own ink adds nothing, so where a
    layer's coverage nears 1 its dots must be larger. The area that a pen's
    dots of radius r cover inside the image is measured on points drawn in
    the disks of radius `grow` times the tone radius around them (16 to 64
    around each dot, or around some of them, at most `probes` in all; each
    weighted by the disks that hold it, so that the weights add up to the
    union's area), and r is the
    smallest at which it holds the layer's ink; at most `grow` times the tone
    radius (beyond, the dots would cover the pen's light areas). 1 for a pen
    without dots.

    Examples
    --------
    Dots 2 px apart on 20 x 20 px of coverage 0.9: at the tone radius 1.070
    neighbours overlap and those on the edge lose ink off the image; at 1.116
    they cover 0.9 of it.

    >>> x, y = np.meshgrid(np.arange(1.0, 20, 2), np.arange(1.0, 20, 2))
    >>> pts, layer = np.column_stack([x.ravel(), y.ravel()]), np.full((1, 20, 20), 0.9)
    >>> pen_tone_radii(layer, [100]).round(3).tolist()
    [1.07]
    >>> pen_ink_radii(pts, np.zeros(100, int), layer).round(3).tolist()
    [1.116]
    """
    p, pen, layers = np.asarray(points, float), np.asarray(pen), np.asarray(layers, float)
    counts = np.bincount(pen, minlength=len(layers))
    radii = pen_tone_radii(layers, counts)
    rng = np.random.default_rng(seed)
    for q, (layer, m) in enumerate(zip(layers, counts)):
        if m > 0:
            radii[q] = _ink_radius(p[pen == q], float(layer.sum()), radii[q], layer.shape, grow,
                                   probes, rng)
    return radii
