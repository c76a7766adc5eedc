"""The stippling start: exactly ``n`` points by Floyd-Steinberg error diffusion.

Pixel units: origin at the top-left pixel corner, x right, y down; gray in
[0, 1] with 1 = white, darkness ``1 - gray``.
"""

from __future__ import annotations

import numpy as np

from ._checks import check_count

__all__ = ["error_diffusion"]

#: Points whose pixels :func:`_pixels_in_blocks` draws at a time.
PICK_CHUNK = 1 << 16


def _wave(t, H, W):
    """Rows ``r0..r1`` of anti-diagonal wavefront `t` (the pixels ``(r, t - 2 r)``) and
    the slice that picks them from the flat row-major image (a row further is ``W - 2``
    further: a strided view, not an index array).

    Examples
    --------
    >>> r0, r1, sl = _wave(4, 3, 5)
    >>> (r0, r1), np.arange(15)[sl].tolist()   # pixels (0, 4), (1, 2), (2, 0)
    ((0, 2), [4, 7, 10])
    """
    r0 = max(0, -((W - 1 - t) // 2))  # ceil((t - W + 1) / 2)
    r1 = min(H - 1, t // 2)
    i0 = t + r0 * (W - 2)
    if r1 == r0:   # (every wavefront of an image under 3 columns: its step would be 0 or less)
        return r0, r1, slice(i0, i0 + 1)
    return r0, r1, slice(i0, i0 + (r1 - r0) * (W - 2) + 1, W - 2)


def _fs_wavefront(v):
    """Multi-level Floyd-Steinberg error diffusion of ``v >= 0``.

    Each pixel emits ``q = max(round(v + error), 0)`` points (so a pixel can
    hold several when ``v > 1``), and its residual goes to the four usual
    neighbours with weights 7/16, 3/16, 5/16, 1/16; error pushed across the
    border is lost. Exactly the raster-order result, computed along
    anti-diagonal wavefronts: pixel (r, c) only depends on pixels with a
    smaller ``c + 2 r``, so each wavefront is one vectorized numpy step
    (W + 2H steps instead of W * H Python iterations). A pixel takes its
    neighbours' errors in the order of their wavefronts: up-left, up, left,
    then up-right.

    The error owed to the next three wavefronts is kept in a ring of four
    rows indexed by image row, so each step reads and writes contiguous
    slices (and the image strided ones), not index arrays.

    Returns ``(counts, residual)``, both (H, W); residual is ``v + error - q``.
    """
    H, W = v.shape
    flat = np.ascontiguousarray(v, dtype=np.float64).reshape(-1)
    counts, resid = np.empty(H * W, np.int64), np.empty(H * W)
    T = W + 2 * H - 2
    # ring[t % 4][r]: pixel (r, t - 2 r) of wavefront t; row H and the rows off the
    # image take the error lost at the border, and are never read
    ring = np.zeros((4, H + 1))
    for t in range(3):
        _load_wave(ring, flat, t, T, (H, W))
    w7, w3, w5, w1 = 7 / 16, 3 / 16, 5 / 16, 1 / 16
    for t in range(T):
        _load_wave(ring, flat, t + 3, T, (H, W))   # its slot held wavefront t - 1
        r0, r1, sl = _wave(t, H, W)
        x = ring[t % 4, r0:r1 + 1]
        qq = np.floor(x + 0.5)
        np.maximum(qq, 0.0, out=qq)
        e = x - qq
        resid[sl] = e
        counts[sl] = qq
        ring[(t + 1) % 4, r0:r1 + 1] += e * w7
        ring[(t + 1) % 4, r0 + 1:r1 + 2] += e * w3
        ring[(t + 2) % 4, r0 + 1:r1 + 2] += e * w5
        ring[(t + 3) % 4, r0 + 1:r1 + 2] += e * w1
    return counts.reshape(H, W), resid.reshape(H, W)


def _load_wave(ring, flat, t, T, shape):
    """Put wavefront `t`'s values of the image in its slot of the ring, before any error."""
    slot = ring[t % 4]
    slot[:] = 0.0
    if t < T:
        r0, r1, sl = _wave(t, *shape)
        slot[r0:r1 + 1] = flat[sl]


def least_k(values, k):
    """Indices of the `k` least `values`, least first, ties to the lower index (the
    first `k` of a stable argsort, without sorting all of them).

    Examples
    --------
    >>> least_k(np.array([3.0, 1.0, 2.0, 1.0]), 3).tolist()
    [1, 3, 2]
    """
    if k < values.size:
        # every value up to the k-th least, in index order: a stable sort of these few
        values_k = np.partition(values, k - 1)[k - 1]
        few = np.flatnonzero(values <= values_k)
        return few[np.argsort(values[few], kind="stable")[:k]]
    return np.argsort(values, kind="stable")


def _fix_count(counts, resid, n):
    """Add or remove points where the residual says they are most owed or least."""
    counts = counts.ravel().copy()
    resid = resid.ravel()
    diff = n - int(counts.sum())
    if diff > 0:
        # most owed first; ties go to the lower pixel index
        order = least_k(-resid, diff)
        while diff > 0:
            take = order[: min(diff, order.size)]
            counts[take] += 1
            diff -= take.size
    while diff < 0:
        have = np.flatnonzero(counts > 0)
        take = have[least_k(resid[have], min(-diff, have.size))]
        counts[take] -= 1
        diff += take.size
    return counts


def _block_sums(blocks, dark, rows=8):
    """``(Hc, Wc)`` sums of the ``(Hc, b, Wc, b)`` blocks of a density, each over its
    ``b * b`` pixels in row-major order, made `rows` block rows at a time (a copy of
    the whole density with each block's pixels contiguous would be another image; a
    few rows' copy stays in the cache).
    With `dark`, the blocks hold gray and the density is its darkness ``1 - gray``,
    made a band at a time too.

    Examples
    --------
    >>> _block_sums(np.arange(16.0).reshape(2, 2, 2, 2), False).tolist()
    [[10.0, 18.0], [42.0, 50.0]]
    >>> _block_sums(np.full((1, 2, 1, 2), 0.25), True).tolist()
    [[3.0]]
    """
    Hc, b, Wc, _ = blocks.shape
    out = np.empty((Hc, Wc))
    for r0 in range(0, Hc, rows):
        part = blocks[r0:r0 + rows].transpose(0, 2, 1, 3).reshape(-1, b * b)
        if dark:
            part = 1.0 - part
        out[r0:r0 + rows] = part.sum(axis=1).reshape(-1, Wc)
    return out


def _pixels_in_blocks(blk, blocks, dark, shape, rng):
    """(row, col) of a pixel for each point of block ``blk``, drawn by the block's density.

    ``blocks`` is the ``(Hc, b, Wc, b)`` view of the density padded to whole
    blocks (with `dark`, of the gray whose darkness is the density).  A
    block without density (a point added by the residual fix) or a draw past
    the image picks a pixel of its block uniformly.
    """
    H, W = shape
    n = len(blk)
    b = blocks.shape[1]
    Wc = -(-W // b)
    u = rng.random(n)
    tot, sub = np.empty(n), np.empty(n, np.int64)
    for c0 in range(0, n, PICK_CHUNK):   # in chunks: a few MiB of temporaries, not n * b * b
        sl = slice(c0, c0 + PICK_CHUNK)
        cum = blocks[blk[sl] // Wc, :, blk[sl] % Wc, :].reshape(-1, b * b)   # a copy: index arrays
        if dark:
            np.subtract(1.0, cum, out=cum)
        np.cumsum(cum, axis=1, out=cum)
        tot[sl] = cum[:, -1]
        sub[sl] = np.count_nonzero(cum <= (u[sl] * tot[sl])[:, None], axis=1)
    bad = (tot <= 0) | (sub >= b * b)
    sub[bad] = rng.integers(0, b * b, size=int(bad.sum()))
    brow, bcol = np.divmod(blk, Wc)
    srow, scol = np.divmod(sub, b)
    return np.minimum(brow * b + srow, H - 1), np.minimum(bcol * b + scol, W - 1)


def error_diffusion(gray, n, *, seed=None, density=None):
    """Exactly ``n`` points distributed like the darkness of ``gray``.

    Floyd-Steinberg error diffusion of ``s * density`` (density defaults to
    the darkness ``1 - gray``), with the scale ``s`` chosen so that the total
    is ``n``. When there are fewer than a quarter as many points as pixels the
    diffusion runs on ``b x b`` pixel blocks (about 4 points' worth of
    density per block at most, on average 1/4 point), and each point then
    picks a pixel of its block with probability proportional to the density. Pixels whose diffused value exceeds 1.5 emit several points, so
    any ``n`` works, including more points than pixels. The few points gained
    or lost at the borders (error diffused out of the image) are added where
    the final residual is largest, or removed where it is smallest,
    deterministically. Each point is placed uniformly at random inside its
    pixel with ``seed``.

    Parameters
    ----------
    gray : (H, W) array_like
        Gray image in [0, 1], 1 = white.
    n : int
        Number of points, >= 1.
    seed : int or numpy.random.Generator, optional
        Jitter inside the pixel. The same seed gives the same points.
    density : (H, W) array_like, optional
        Non-negative density to diffuse instead of the darkness.

    Returns
    -------
    points : (n, 2) float64
        Pixel units, x right, y down, in row-major pixel order.

    Raises
    ------
    ValueError
        ``n < 1``, or the density is zero everywhere (a white image).

    Examples
    --------
    >>> import numpy as np
    >>> g = np.tile(np.linspace(0, 1, 32), (16, 1))
    >>> error_diffusion(g, 100, seed=1).shape
    (100, 2)
    """
    n = check_count(n)
    # the darkness is read from the gray a band or a block at a time: no second image
    d, dark = (_checked_gray(gray), True) if density is None else (_density(gray, density), False)
    H, W = d.shape
    # Few points for many pixels: diffuse on b x b blocks (about 4 points per
    # block... at most), so that the error does not wander across half the
    # image before the first point is emitted; a point then picks a pixel of
    # its block with probability proportional to the density.
    b = max(1, int(np.sqrt(H * W / (4.0 * n))))
    Hc, Wc = -(-H // b), -(-W // b)
    if (Hc * b, Wc * b) == (H, W):
        dp = d
    else:
        dp = np.full((Hc * b, Wc * b), 1.0 if dark else 0.0)   # no density past the image
        dp[:H, :W] = d
    blocks = dp.reshape(Hc, b, Wc, b)
    coarse = _block_sums(blocks, dark)
    scale = n / coarse.sum()
    counts, resid = _fs_wavefront(coarse * scale)
    m = int(counts.sum())
    if abs(m - n) > max(8, 0.002 * n):
        # one secant correction of the scale for the mass lost at the border
        scale *= n / max(m, 1)
        counts, resid = _fs_wavefront(coarse * scale)
    counts = _fix_count(counts, resid, n)
    blk = np.repeat(np.arange(Hc * Wc), counts)
    rng = np.random.default_rng(seed)
    row, col = _pixels_in_blocks(blk, blocks, dark, (H, W), rng) if b > 1 else np.divmod(blk, W)
    return _jittered(row, col, rng.random((n, 2)))


def _checked_gray(gray):
    """`gray` as float64 (no copy where it is one), checked: 2-D, finite, at most 1, not all white."""
    g = _plane(gray)
    lo, hi = g.min(), g.max()   # NaN wins both
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi > 1.0:
        raise ValueError("gray must be finite and at most 1 (darkness non-negative)")
    if not lo < 1.0:
        raise ValueError("nothing to stipple: the image is white (zero darkness everywhere)")
    return g


def _density(gray, density):
    """The checked `density` of :func:`error_diffusion`, a copy of its own."""
    g = _plane(gray)
    d = np.array(density, dtype=np.float64)
    if d.shape != g.shape:
        raise ValueError(f"density shape {d.shape} differs from the image shape {g.shape}")
    if not np.all(np.isfinite(d)) or d.min() < 0:
        raise ValueError("density must be finite and non-negative")
    if not d.sum() > 0:
        raise ValueError("nothing to stipple: the image is white (zero darkness everywhere)")
    return d


def _plane(gray):
    g = np.asarray(gray, dtype=np.float64)
    if g.ndim != 2 or g.size == 0:
        raise ValueError(f"gray must be a non-empty 2-D array, got shape {g.shape}")
    return g


def _jittered(row, col, jitter):
    """Points at pixels ``(row, col)`` plus `jitter`, inside their pixels' open upper bounds."""
    pts = np.empty((len(row), 2))
    pts[:, 0] = col + jitter[:, 0]
    pts[:, 1] = row + jitter[:, 1]
    # keep the open upper bound of the pixel (and the image)
    np.minimum(pts[:, 0], np.nextafter(col + 1.0, 0), out=pts[:, 0])
    np.minimum(pts[:, 1], np.nextafter(row + 1.0, 0), out=pts[:, 1])
    return pts
