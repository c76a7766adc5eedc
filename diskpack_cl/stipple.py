"""Image stippling by unequal disk packing on power diagrams (paper Algorithm 2).

Coordinates are pixel units: origin at the top-left pixel corner, x to the
right, y down, so pixel (row r, col c) covers [c, c+1) x [r, r+1). Gray values
are floats in [0, 1] with 1 = white; darkness is ``1 - gray``.

The loop (:func:`stipple`):

1. Start: :func:`error_diffusion` of the darkness gives exactly ``n`` points.
2. Disk-packing iteration: base radius ``r_i = max(I_i, floor) ** (gamma/2)``
   with ``I_i`` the gray value of the pixel containing point ``i``; weights
   ``w_i = (k r_i)^2``; bounded power diagram of the points in the image
   rectangle on a grid of ``supersample`` cells per pixel side (OpenCL raster),
   maximal inscribed circle (MIC) of each power cell (raster estimate refined
   to the exact float64 Chebyshev centre with the rectangle's edges among the
   constraints), points moved to the MIC centres, ``k = min_i R_i / r_i``.
3. Lloyd iteration: density-weighted centroids (density = darkness) of the
   Voronoi cells on the same raster (Secord 2002).
3'. Mix iteration (the default schedule): a disk-packing step whose move is
   blended with the density-weighted centroid of the *same power cell*:
   ``x <- m + blend * (c - m)``, ``m`` the MIC centre, ``c`` the centroid.
   ``blend = 0`` is a disk-packing step.
4. Final: radii re-sampled at the final positions and ``k`` set to the
   largest value for which all disks ``k r_i`` lie inside the image and are
   pairwise disjoint; the result is certified by
   :func:`diskpack_cl.geometry.certify_disks`.

Radius mappings (:func:`radius_field`): ``"gray"`` is the paper's
``max(I, floor) ** (gamma/2)``; the ``floor`` on the gray value keeps black
regions workable (with ``floor = 0`` a black pixel would give a zero radius and
the power cell of a zero-weight point among heavy neighbours is often empty),
and the largest/smallest radius ratio is ``floor ** (-gamma/2)``.
``"density"`` (the default schedule's) is ``r ~ max(D, floor) ** -0.5`` with
``D`` the darkness blurred by ``radius_sigma`` pixels: a packing has local
point density ~ ``1 / r^2`` ~ ``D``, the density Lloyd's centroids aim at, so
packing and centroid moves no longer pull the tone curve apart (with gray
radii and gamma 3 a packing's density goes like ``I^-3``, not ``1 - I``).

The default schedule and why (measured in ``docs/stipple_quality.md``): 35
mix iterations with blend 0.5 then 12 with blend 0.4, density radii (floor
0.01, ``radius_sigma`` 3, the blur of the tone and spacing measures), centroid
density blurred by 0.5 px, and ``k`` from the 15% quantile of ``R_i / r_i``
instead of the minimum. On the three test photographs at n = 20000 it beats
50 Lloyd iterations in tone SSIM and in spacing P01, with a lower mean
|psi6|. Options that come with a named schedule are in
:data:`SCHEDULE_OPTIONS`; explicit keyword arguments override them.

Empty power cells (possible with unequal weights) keep their point where it
is; they are counted in the history (``"empty"``), never produce NaN and
never lose a point.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "StippleResult",
    "stipple",
    "error_diffusion",
    "base_radii",
    "radius_field",
    "largest_valid_k",
    "make_schedule",
    "SCHEDULES",
    "SCHEDULE_OPTIONS",
]

#: Named schedules: lists of (kind, iterations) or ("mix", iterations, blend),
#: kind "pack", "lloyd" or "mix".
SCHEDULES = {
    # The paper's loop (section 5, Fig. 5): 40 disk-packing, 10 Lloyd, 40, 10, 20.
    "paper": [("pack", 40), ("lloyd", 10), ("pack", 40), ("lloyd", 10), ("pack", 20)],
    # Secord-style weighted Voronoi stippling, the baseline.
    "lloyd": [("lloyd", 50)],
    # Disk packing only (shows the paper's small holes, Fig. 5b).
    "pack": [("pack", 60)],
}
# Disk packing blended with Lloyd (see :func:`stipple`, ``"mix"`` phases):
# 35 steps of MIC + 0.5 (centroid - MIC), then 12 of MIC + 0.4 (centroid - MIC),
# with the density-consistent radii. Measured in docs/stipple_quality.md.
SCHEDULES["default"] = [("mix", 35, 0.5), ("mix", 12, 0.4)]

#: Option defaults that come with a named schedule; explicit keyword arguments
#: of :func:`stipple` override them. ``method="lloyd"`` uses ``"lloyd"``'s, and
#: a schedule built from ``beta``/``lloyd``/``rounds`` uses ``"paper"``'s.
SCHEDULE_OPTIONS = {
    "paper": {"radii": "gray", "floor": 0.1, "blend": 0.0, "radius_sigma": 0.0,
              "density_sigma": 0.0, "k_quantile": 0.0},
    "lloyd": {"radii": "gray", "floor": 0.1, "blend": 0.0, "radius_sigma": 0.0,
              "density_sigma": 0.0, "k_quantile": 0.0},
    "pack": {"radii": "gray", "floor": 0.1, "blend": 0.0, "radius_sigma": 0.0,
             "density_sigma": 0.0, "k_quantile": 0.0},
    "default": {"radii": "density", "floor": 0.01, "blend": 0.5, "radius_sigma": 3.0,
                "density_sigma": 0.5, "k_quantile": 0.15},
}


@dataclass
class StippleResult:
    """Result of :func:`stipple`.

    Attributes
    ----------
    points : (n, 2) float64
        Stipple centres in pixel units (x right, y down).
    radii : (n,) float64
        Certified radii ``k * r_i``: the disks lie inside the image and are
        pairwise disjoint (exact float64 check).
    k : float
        The final scale factor.
    base_radii : (n,) float64
        ``r_i = max(I_i, floor) ** (gamma / 2)`` at the final positions.
    certificate : object
        The :func:`diskpack_cl.geometry.certify_disks` certificate.
    history : list of dict
        One entry per iteration: ``kind`` ("pack" or "lloyd"), ``iteration``,
        ``k``, ``empty`` (empty power cells), ``moved`` (mean displacement, px),
        ``seconds`` and per-stage seconds.
    width, height : int
        Image size in pixels.
    timings : dict
        Total seconds per stage.
    params : dict
        The parameters used (for reports and ``--json``).
    """

    points: np.ndarray
    radii: np.ndarray
    k: float
    base_radii: np.ndarray
    certificate: object
    history: list
    width: int
    height: int
    timings: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    @property
    def n(self):
        return len(self.points)

    def summary(self):
        """A JSON-ready dict: sizes, k, certificate fields, timings."""
        cert = self.certificate
        if hasattr(cert, "as_dict"):
            cdict = cert.as_dict()
        else:
            cdict = {"valid": bool(getattr(cert, "valid", False))}
        return {
            "n": int(self.n),
            "width": int(self.width),
            "height": int(self.height),
            "k": float(self.k),
            "min_radius": float(self.radii.min()),
            "max_radius": float(self.radii.max()),
            "iterations": len(self.history),
            "empty_cells_total": int(sum(h.get("empty", 0) for h in self.history)),
            "certificate": cdict,
            "timings": {k: float(v) for k, v in self.timings.items()},
            "params": self.params,
        }


# --------------------------------------------------------------------------
# Start: error diffusion
# --------------------------------------------------------------------------


def _fs_wavefront(v):
    """Multi-level Floyd-Steinberg error diffusion of ``v >= 0``.

    Each pixel emits ``q = max(round(v + error), 0)`` points (so a pixel can
    hold several when ``v > 1``), and its residual goes to the four usual
    neighbours with weights 7/16, 3/16, 5/16, 1/16; error pushed across the
    border is lost. Exactly the raster-order result, computed along
    anti-diagonal wavefronts: pixel (r, c) only depends on pixels with a
    smaller ``c + 2 r``, so each wavefront is one vectorized numpy step
    (W + 2H steps instead of W * H Python iterations).

    Returns ``(counts, residual)``, both (H, W); residual is ``v + error - q``.
    """
    H, W = v.shape
    Wp = W + 2  # one pad column each side absorbs the error lost at the border
    buf = np.zeros((H + 1) * Wp)
    buf.reshape(H + 1, Wp)[:H, 1 : W + 1] = v
    q = np.zeros((H + 1) * Wp)
    rows = np.arange(H)
    w7, w3, w5, w1 = 7 / 16, 3 / 16, 5 / 16, 1 / 16
    for t in range(W + 2 * H - 2):
        r0 = max(0, -((W - 1 - t) // 2))  # ceil((t - W + 1) / 2)
        r1 = min(H - 1, t // 2)
        r = rows[r0 : r1 + 1]
        idx = r * Wp + (t - 2 * r + 1)
        x = buf[idx]
        qq = np.floor(x + 0.5)
        np.maximum(qq, 0.0, out=qq)
        e = x - qq
        buf[idx] = e
        q[idx] = qq
        buf[idx + 1] += e * w7
        buf[idx + (Wp - 1)] += e * w3
        buf[idx + Wp] += e * w5
        buf[idx + (Wp + 1)] += e * w1
    counts = q.reshape(H + 1, Wp)[:H, 1 : W + 1].astype(np.int64)
    resid = buf.reshape(H + 1, Wp)[:H, 1 : W + 1].copy()
    return counts, resid


def _fix_count(counts, resid, n):
    """Add or remove points where the residual says they are most owed or least."""
    counts = counts.ravel().copy()
    resid = resid.ravel()
    diff = n - int(counts.sum())
    if diff > 0:
        # most owed first; stable sort: ties go to the lower pixel index
        order = np.argsort(-resid, kind="stable")
        while diff > 0:
            take = order[: min(diff, order.size)]
            counts[take] += 1
            diff -= take.size
    while diff < 0:
        have = np.flatnonzero(counts > 0)
        order = have[np.argsort(resid[have], kind="stable")]
        take = order[: min(-diff, order.size)]
        counts[take] -= 1
        diff += take.size
    return counts


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
    g = np.asarray(gray, dtype=np.float64)
    if g.ndim != 2 or g.size == 0:
        raise ValueError(f"gray must be a non-empty 2-D array, got shape {g.shape}")
    n = _check_n(n)
    d = 1.0 - g if density is None else np.asarray(density, dtype=np.float64)
    if d.shape != g.shape:
        raise ValueError(f"density shape {d.shape} differs from the image shape {g.shape}")
    if not np.all(np.isfinite(d)) or d.min() < 0:
        raise ValueError("density must be finite and non-negative")
    d = np.maximum(d, 0.0)
    total = d.sum()
    if not total > 0:
        raise ValueError("nothing to stipple: the image is white (zero darkness everywhere)")
    H, W = d.shape
    # Few points for many pixels: diffuse on b x b blocks (about 4 points per
    # block... at most), so that the error does not wander across half the
    # image before the first point is emitted; a point then picks a pixel of
    # its block with probability proportional to the density.
    b = max(1, int(np.sqrt(H * W / (4.0 * n))))
    Hc, Wc = -(-H // b), -(-W // b)
    dp = np.zeros((Hc * b, Wc * b))
    dp[:H, :W] = d
    blocks = dp.reshape(Hc, b, Wc, b).transpose(0, 2, 1, 3).reshape(Hc * Wc, b * b)
    coarse = blocks.sum(axis=1).reshape(Hc, Wc)
    scale = n / total
    counts, resid = _fs_wavefront(coarse * scale)
    m = int(counts.sum())
    if abs(m - n) > max(8, 0.002 * n):
        # one secant correction of the scale for the mass lost at the border
        scale *= n / max(m, 1)
        counts, resid = _fs_wavefront(coarse * scale)
    counts = _fix_count(counts, resid, n)
    blk = np.repeat(np.arange(Hc * Wc), counts)
    rng = np.random.default_rng(seed)
    if b > 1:
        cum = np.cumsum(blocks[blk], axis=1)
        tot = cum[:, -1]
        u = rng.random(n) * tot
        sub = np.count_nonzero(cum <= u[:, None], axis=1)
        # a block without density (residual fix) or past the image: uniform
        bad = (tot <= 0) | (sub >= b * b)
        sub[bad] = rng.integers(0, b * b, size=int(bad.sum()))
        brow, bcol = np.divmod(blk, Wc)
        srow, scol = np.divmod(sub, b)
        row = np.minimum(brow * b + srow, H - 1)
        col = np.minimum(bcol * b + scol, W - 1)
    else:
        row, col = np.divmod(blk, W)
    jitter = rng.random((n, 2))
    pts = np.empty((n, 2))
    pts[:, 0] = col + jitter[:, 0]
    pts[:, 1] = row + jitter[:, 1]
    # keep the open upper bound of the pixel (and the image)
    np.minimum(pts[:, 0], np.nextafter(col + 1.0, 0), out=pts[:, 0])
    np.minimum(pts[:, 1], np.nextafter(row + 1.0, 0), out=pts[:, 1])
    return pts


# --------------------------------------------------------------------------
# Radii, k
# --------------------------------------------------------------------------


def _check_n(n):
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        if isinstance(n, float) and n.is_integer():
            n = int(n)
        else:
            raise ValueError(f"n must be an integer >= 1, got {n!r}")
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    return n


def _pixel_of(points, W, H):
    col = np.clip(np.floor(points[:, 0]).astype(np.int64), 0, W - 1)
    row = np.clip(np.floor(points[:, 1]).astype(np.int64), 0, H - 1)
    return row, col


def base_radii(gray, points, *, gamma=3.0, floor=0.1):
    """``r_i = max(I_i, floor) ** (gamma / 2)``, ``I_i`` the gray of the pixel holding point i.

    The paper's mapping (w_i = k^2 I_i^gamma) with a floor so that black
    regions keep a positive radius.
    """
    g = np.asarray(gray, dtype=np.float64)
    H, W = g.shape
    row, col = _pixel_of(np.asarray(points, dtype=np.float64), W, H)
    return np.maximum(g[row, col], floor) ** (0.5 * gamma)


def radius_field(gray, *, radii="gray", gamma=3.0, floor=0.1, sigma=2.0):
    """Base radius per pixel: ``r_i`` of a point is the value at its pixel.

    Parameters
    ----------
    gray : (H, W) array_like
        Gray image in [0, 1], 1 = white.
    radii : {"gray", "density"}
        ``"gray"``: the paper's ``max(I, floor) ** (gamma / 2)``.
        ``"density"``: ``sqrt(floor / max(D, floor))`` with ``D`` the darkness
        ``1 - I`` blurred with a Gaussian of ``sigma`` pixels; a packing of
        disks with these radii has local point density ~ ``1 / r^2`` ~ ``D``,
        the density Lloyd's centroids (and the tone measure) aim at, so
        packing and Lloyd moves agree on the tone curve. ``gamma`` is unused.
    gamma : float
        Contrast exponent of the ``"gray"`` mapping.
    floor : float
        ``"gray"``: floor on the gray value; ``"density"``: floor on the
        blurred darkness (largest/smallest radius ratio ``floor ** -0.5``).
    sigma : float
        Blur of the darkness for ``"density"`` (pixels; 0 = none).

    Returns
    -------
    (H, W) float64, largest value 1 or less.

    Examples
    --------
    >>> g = np.tile(np.linspace(0, 1, 16), (4, 1))
    >>> f = radius_field(g, radii="density", floor=0.01, sigma=0)
    >>> bool(f[0, 0] < f[0, 8] < f[0, 15])
    True
    """
    g = np.asarray(gray, dtype=np.float64)
    if radii == "gray":
        return np.maximum(g, floor) ** (0.5 * gamma)
    if radii == "density":
        d = 1.0 - g
        if sigma and sigma > 0:
            from scipy import ndimage

            d = ndimage.gaussian_filter(d, float(sigma), mode="reflect")
        return np.sqrt(floor / np.maximum(d, floor))
    raise ValueError(f"radii must be 'gray' or 'density', got {radii!r}")


def _field_at(field, points):
    H, W = field.shape
    row, col = _pixel_of(np.asarray(points, dtype=np.float64), W, H)
    return field[row, col]


def _radius_classes(r):
    """Indices of points grouped by radius octave."""
    lr = np.floor(np.log2(r / r.min())).astype(np.int64)
    return [np.flatnonzero(lr == c) for c in np.unique(lr)]


def largest_valid_k(points, r, width, height):
    """Largest ``k`` with all disks ``(points_i, k r_i)`` inside the rectangle and disjoint.

    Exact in float64 over all binding candidates: the edge constraints
    ``k r_i <= min(x_i, W - x_i, y_i, H - y_i)`` and every pair with
    ``d_ij <= k_u (r_i + r_j)``, where ``k_u`` is an upper bound from the
    nearest neighbours; pairs are found with cKDTrees per radius octave, so
    the search stays local even when the radii vary by orders of magnitude.

    Returns
    -------
    k : float
        ``min(min_i edge_i / r_i, min_ij d_ij / (r_i + r_j))``; 0 when two
        points coincide or a point lies on the border.
    """
    from scipy.spatial import cKDTree

    p = np.asarray(points, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    edge = np.minimum.reduce([p[:, 0], width - p[:, 0], p[:, 1], height - p[:, 1]])
    k = float(np.min(edge / r))
    if len(p) < 2:
        return max(k, 0.0)
    tree = cKDTree(p)
    d, j = tree.query(p, k=2)
    k = min(k, float(np.min(d[:, 1] / (r + r[j[:, 1]]))))
    if k <= 0:
        return 0.0
    classes = _radius_classes(r)
    trees = [cKDTree(p[c]) for c in classes]
    rmax = [r[c].max() for c in classes]
    for a in range(len(classes)):
        for b in range(a, len(classes)):
            reach = k * (rmax[a] + rmax[b]) * (1 + 1e-9)
            sdm = trees[a].sparse_distance_matrix(trees[b], reach, output_type="ndarray")
            if sdm.size == 0:
                continue
            i = classes[a][sdm["i"]]
            jj = classes[b][sdm["j"]]
            keep = i != jj
            if not np.any(keep):
                continue
            i, jj = i[keep], jj[keep]
            dij = np.hypot(p[i, 0] - p[jj, 0], p[i, 1] - p[jj, 1])
            k = min(k, float(np.min(dij / (r[i] + r[jj]))))
    return max(k, 0.0)


def _certified(points, r, width, height, domain):
    """k and radii certified by certify_disks, shrinking k by ulps if rounding bites."""
    from diskpack_cl.geometry import certify_disks

    k = largest_valid_k(points, r, width, height)
    if not k > 0:
        raise ValueError("two stipples coincide or lie on the image border: no valid radius")
    shrink = 1.0 - 4 * np.finfo(float).eps
    for _ in range(8):
        k *= shrink
        radii = k * r
        cert = certify_disks(points, radii, domain)
        if cert.valid:
            return k, radii, cert
        shrink = shrink * shrink * shrink * (1 - 1e-12)
    return k, radii, cert


# --------------------------------------------------------------------------
# Schedules
# --------------------------------------------------------------------------


def make_schedule(schedule="default", *, beta=None, lloyd=None, rounds=None, method="diskpack"):
    """The list of phases to run: ``(kind, iterations)`` or ``("mix", iterations, blend)``.

    ``schedule`` is a name in :data:`SCHEDULES` or a list of
    ``("pack" | "lloyd" | "mix", iterations)`` and ``("mix", iterations,
    blend)`` (a ``"mix"`` phase without its own blend uses :func:`stipple`'s
    ``blend``); phases with 0 iterations are dropped. When any of ``beta`` (disk-packing
    iterations per round), ``lloyd`` (Lloyd iterations between rounds) or
    ``rounds`` is given, the schedule is built from them the paper's way:
    ``rounds`` packing phases of ``beta`` iterations separated by ``lloyd``
    Lloyd iterations, the last packing phase half as long (the paper: 40, 10,
    40, 10, 20 is beta 40, lloyd 10, rounds 3). Missing ones come from the
    paper (40, 10, 3). ``method="lloyd"`` gives ``[("lloyd", total)]`` with
    the same total number of iterations (50 by default).

    Examples
    --------
    >>> make_schedule("default")
    [('mix', 35, 0.5), ('mix', 12, 0.4)]
    >>> make_schedule([("mix", 3, 0.2), ("lloyd", 0), ("pack", 2)])
    [('mix', 3, 0.2), ('pack', 2)]
    """
    if method not in ("diskpack", "lloyd"):
        raise ValueError(f"method must be 'diskpack' or 'lloyd', got {method!r}")
    if method == "diskpack" and (beta is not None or lloyd is not None or rounds is not None):
        beta = 40 if beta is None else int(beta)
        lloyd_n = 10 if lloyd is None else int(lloyd)
        rounds = 3 if rounds is None else int(rounds)
        if beta < 0 or lloyd_n < 0 or rounds < 1:
            raise ValueError("beta and lloyd must be >= 0 and rounds >= 1")
        phases = []
        for i in range(rounds):
            last = i == rounds - 1
            phases.append(("pack", (beta + 1) // 2 if last and rounds > 1 else beta))
            if not last:
                phases.append(("lloyd", lloyd_n))
    elif isinstance(schedule, str):
        if schedule not in SCHEDULES:
            raise ValueError(f"unknown schedule {schedule!r}; choose from {sorted(SCHEDULES)}")
        phases = list(SCHEDULES[schedule])
    else:
        phases = []
        for ph in schedule:
            kind, it = str(ph[0]), int(ph[1])
            if kind not in ("pack", "lloyd", "mix") or it < 0:
                raise ValueError(
                    f"bad schedule phase ({kind!r}, {it}): kind must be 'pack', 'mix' or 'lloyd'")
            if len(ph) == 3 and kind == "mix":
                a = float(ph[2])
                if not 0.0 <= a <= 1.0:
                    raise ValueError(f"blend must be in [0, 1], got {a}")
                phases.append((kind, it, a))
            elif len(ph) == 2:
                phases.append((kind, it))
            else:
                raise ValueError(f"bad schedule phase {tuple(ph)!r}: (kind, iterations) or ('mix', iterations, blend)")
    if method == "lloyd":
        # the baseline: Lloyd only; `lloyd` sets its length, else 50
        phases = [("lloyd", 50 if lloyd is None else int(lloyd))]
    return [tuple(p) for p in phases if p[1] > 0]


# --------------------------------------------------------------------------
# The loop
# --------------------------------------------------------------------------


def _auto_supersample(n, W, H):
    # about 16 grid cells per average cell; more where the image is dark is
    # left to the user (--supersample)
    return int(min(8, max(1, np.ceil(np.sqrt(16.0 * n / (W * H))))))


def _upsample(a, s):
    if s == 1:
        return np.ascontiguousarray(a)
    return np.repeat(np.repeat(a, s, axis=0), s, axis=1)


def stipple(
    image,
    n,
    *,
    gamma=3.0,
    floor=None,
    schedule="default",
    beta=None,
    lloyd=None,
    rounds=None,
    supersample=None,
    seed=0,
    device=None,
    method="diskpack",
    invert=False,
    refine_every=1,
    start=None,
    k0=1e-6,
    callback=None,
    radii=None,
    radius_sigma=None,
    blend=None,
    blend_cell="power",
    k_quantile=None,
    density_sigma=None,
):
    """Stipple an image with ``n`` dots by unequal disk packing (paper Algorithm 2).

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A file path, a Pillow image, or a gray/RGB(A) array (see
        :func:`diskpack_cl.image.to_gray`; float arrays are gray in [0, 1],
        1 = white).
    n : int
        Number of stipples.
    gamma : float, optional
        Contrast exponent of the paper: base radius ``r_i = I_i^(gamma/2)``.
    floor : float, optional
        Gray-value floor in the radius mapping, ``max(I_i, floor)``, so that
        black regions keep a positive radius (default 0.1: radius ratio
        ``0.1^(-1.5)`` ~ 32 between white and black).
    schedule : str or list of phases, optional
        ``"default"`` (35 mix at blend 0.5, 12 mix at blend 0.4, with the
        options in ``SCHEDULE_OPTIONS["default"]``), ``"paper"`` (40 pack, 10
        Lloyd, 40, 10, 20 pack; gray radii), ``"pack"``, ``"lloyd"`` or an
        explicit list of ``(kind, iterations)`` with kind ``"pack"``,
        ``"lloyd"`` or ``"mix"``, or ``("mix", iterations, blend)``; see
        :func:`make_schedule`. A named schedule brings its option defaults
        (:data:`SCHEDULE_OPTIONS`); an explicit list, or ``beta``/``lloyd``/
        ``rounds``, uses the paper's.
    beta, lloyd, rounds : int, optional
        Build the schedule from disk-packing iterations per round, Lloyd
        iterations between rounds, and the number of rounds.
    supersample : int, optional
        Grid cells per image pixel side (default: about 16 cells per average
        power cell, at most 8).
    seed : int, optional
        Seed of the error-diffusion jitter. The same seed gives the same result.
    device : str or pyopencl.Context, optional
        OpenCL device (see :mod:`diskpack_cl._device`).
    method : {"diskpack", "lloyd"}
        ``"lloyd"`` is weighted Voronoi stippling (Secord 2002) on the same
        raster engine, from the same start.
    invert : bool, optional
        Stipple the light parts (for light-on-dark output).
    refine_every : int, optional
        Refine the raster MIC estimate exactly every this many disk-packing
        iterations (1 = always; 0 = never). The final output is always exact
        and certified.
    start : (n, 2) array_like, optional
        Start points instead of error diffusion (must lie inside the image).
    k0 : float, optional
        Initial scale factor (the paper: 1e-6, so that no disks overlap).
    callback : callable, optional
        Called with each history entry (a dict) after every iteration.
    radii : {"gray", "density"}, optional
        Radius mapping, see :func:`radius_field` (schedule default: ``"gray"``
        for the paper's, ``"density"`` for ``"default"``).
    radius_sigma : float, optional
        Blur (pixels) of the darkness in the ``"density"`` mapping
        (``"default"``: 3).
    blend : float in [0, 1], optional
        Move of a ``"mix"`` phase without its own blend:
        ``x <- m + blend * (c - m)`` (``m`` MIC centre, ``c`` centroid);
        ``"default"``: 0.5.
    blend_cell : {"power", "voronoi"}, optional
        Cells whose centroids a mix step blends towards: the power cells of
        the same raster (default, no extra work) or the Voronoi cells (one
        more labelling per step; measured worse).
    k_quantile : float in [0, 1), optional
        ``k`` after a disk-packing or mix step is this quantile of
        ``R_i / r_i`` (0: the minimum, the paper's rule; ``"default"``: 0.15).
        Only the weights of the next iteration see it; the returned radii
        always use the largest valid ``k``.
    density_sigma : float, optional
        Blur (pixels) of the darkness used as the centroid density of Lloyd
        and mix steps (paper: 0; ``"default"``: 0.5).

    Returns
    -------
    StippleResult

    Raises
    ------
    ValueError
        n < 1, n too large for the grid, gamma <= 0, a white image, bad
        schedule, bad start, an option out of its range.
    """
    from diskpack_cl.geometry import Domain, exact_mic
    from diskpack_cl.image import to_gray
    from diskpack_cl.raster import PowerRaster

    t_start = time.perf_counter()
    gray = to_gray(image, invert=invert)
    H, W = gray.shape
    n = _check_n(n)
    if not (np.isfinite(gamma) and gamma > 0):
        raise ValueError(f"gamma must be > 0, got {gamma}")
    darkness = 1.0 - gray
    if not darkness.max() > 1e-9:
        raise ValueError("nothing to stipple: the image is white")
    s = _auto_supersample(n, W, H) if supersample is None else int(supersample)
    if s < 1:
        raise ValueError(f"supersample must be >= 1, got {supersample}")
    ny, nx = s * H, s * W
    if 4 * n > nx * ny:
        raise ValueError(
            f"n = {n} is too large for a {W}x{H} image at supersample {s}: at most "
            f"{nx * ny // 4} points (4 grid cells per point); raise supersample"
        )
    phases = make_schedule(schedule, beta=beta, lloyd=lloyd, rounds=rounds, method=method)
    opts = dict(SCHEDULE_OPTIONS["paper"])
    if method == "lloyd":
        opts = dict(SCHEDULE_OPTIONS["lloyd"])
    elif beta is None and lloyd is None and rounds is None and isinstance(schedule, str):
        opts.update(SCHEDULE_OPTIONS.get(schedule, {}))
    radii = opts["radii"] if radii is None else radii
    blend = float(opts["blend"] if blend is None else blend)
    floor = float(opts["floor"] if floor is None else floor)
    radius_sigma = float(opts["radius_sigma"] if radius_sigma is None else radius_sigma)
    density_sigma = float(opts["density_sigma"] if density_sigma is None else density_sigma)
    k_quantile = float(opts["k_quantile"] if k_quantile is None else k_quantile)
    if not (np.isfinite(floor) and 0 < floor <= 1):
        raise ValueError(f"floor must be in (0, 1], got {floor}")
    if not (np.isfinite(radius_sigma) and radius_sigma >= 0):
        raise ValueError(f"radius_sigma must be >= 0, got {radius_sigma}")
    if not (np.isfinite(density_sigma) and density_sigma >= 0):
        raise ValueError(f"density_sigma must be >= 0, got {density_sigma}")
    if radii not in ("gray", "density"):
        raise ValueError(f"radii must be 'gray' or 'density', got {radii!r}")
    if not 0.0 <= blend <= 1.0:
        raise ValueError(f"blend must be in [0, 1], got {blend}")
    if blend_cell not in ("power", "voronoi"):
        raise ValueError(f"blend_cell must be 'power' or 'voronoi', got {blend_cell!r}")
    if not 0.0 <= k_quantile < 1.0:
        raise ValueError(f"k_quantile must be in [0, 1), got {k_quantile}")
    rfield = radius_field(gray, radii=radii, gamma=gamma, floor=floor, sigma=radius_sigma)
    params = {
        "n": n, "gamma": float(gamma), "floor": float(floor), "supersample": s,
        "seed": seed, "method": method, "invert": bool(invert),
        "schedule": [list(p) for p in phases], "refine_every": int(refine_every),
        "radii": radii, "radius_sigma": float(radius_sigma), "blend": blend,
        "blend_cell": blend_cell, "k_quantile": float(k_quantile),
        "density_sigma": float(density_sigma),
    }

    dom = Domain.rect(W, H)
    timings = {"load": time.perf_counter() - t_start}
    t0 = time.perf_counter()
    if start is None:
        x = error_diffusion(gray, n, seed=seed)
    else:
        x = np.array(start, dtype=np.float64)
        if x.shape != (n, 2) or not np.all(np.isfinite(x)):
            raise ValueError(f"start must be a finite ({n}, 2) array")
        if np.any(x < 0) or np.any(x[:, 0] > W) or np.any(x[:, 1] > H):
            raise ValueError("start points must lie inside the image")
    timings["start"] = time.perf_counter() - t0

    pr = PowerRaster(dom, shape=(ny, nx), device=device)
    dark_c = darkness
    if density_sigma > 0:
        from scipy import ndimage

        dark_c = ndimage.gaussian_filter(darkness, float(density_sigma), mode="reflect")
    dens = _upsample(np.maximum(dark_c, 1e-6), s)
    if not (np.isfinite(k0) and k0 > 0):
        raise ValueError(f"k0 must be > 0, got {k0}")
    k = float(k0)
    history = []
    stage = {"raster": 0.0, "exact": 0.0, "centroids": 0.0}
    it_total = 0
    pack_count = 0
    zeros = np.zeros(n)
    for phase in phases:
        kind, iters = phase[0], phase[1]
        alpha = float(phase[2]) if len(phase) == 3 else blend
        for _ in range(iters):
            ti = time.perf_counter()
            entry = {"kind": kind, "iteration": it_total}
            if kind in ("pack", "mix"):
                r = _field_at(rfield, x)
                w = (k * r) ** 2
                t1 = time.perf_counter()
                est = pr.compute(x, w)
                t2 = time.perf_counter()
                entry["raster_s"] = t2 - t1
                stage["raster"] += t2 - t1
                refine = refine_every and (pack_count % refine_every == 0)
                if refine:
                    mic = exact_mic(x, w, dom, estimate=(est.centers, est.radii))
                    centers, R = np.asarray(mic.centers), np.asarray(mic.radii)
                    empty = np.asarray(mic.empty, bool) | ~np.isfinite(R)
                    t3 = time.perf_counter()
                    entry["exact_s"] = t3 - t2
                    stage["exact"] += t3 - t2
                else:
                    centers, R = np.asarray(est.centers), np.asarray(est.radii)
                    empty = ~(R > 0)
                ok = ~empty & np.all(np.isfinite(centers), axis=1)
                newx = x.copy()
                newx[ok] = centers[ok]
                if kind == "mix" and alpha > 0:
                    t3 = time.perf_counter()
                    if blend_cell == "voronoi":
                        pr.compute(x, zeros, distance=False)
                    cen, mass = pr.centroids(dens)
                    cen = np.asarray(cen)
                    okc = ok & (np.asarray(mass) > 0) & np.all(np.isfinite(cen), axis=1)
                    newx[okc] += alpha * (cen[okc] - newx[okc])
                    t4 = time.perf_counter()
                    entry["centroids_s"] = t4 - t3
                    stage["centroids"] += t4 - t3
                entry["moved"] = float(np.mean(np.hypot(*(newx - x).T)))
                x = newx
                if np.any(ok):
                    ratio = R[ok] / r[ok]
                    k = float(np.quantile(ratio, k_quantile)) if k_quantile > 0 else float(np.min(ratio))
                entry["empty"] = int(np.count_nonzero(~ok))
                pack_count += 1
            else:
                t1 = time.perf_counter()
                pr.compute(x, zeros, distance=False)  # labels only: centroids need no distance
                t2 = time.perf_counter()
                cen, mass = pr.centroids(dens)
                t3 = time.perf_counter()
                entry["raster_s"] = t2 - t1
                entry["centroids_s"] = t3 - t2
                stage["raster"] += t2 - t1
                stage["centroids"] += t3 - t2
                cen = np.asarray(cen)
                ok = (np.asarray(mass) > 0) & np.all(np.isfinite(cen), axis=1)
                newx = x.copy()
                newx[ok] = cen[ok]
                entry["moved"] = float(np.mean(np.hypot(*(newx - x).T)))
                x = newx
                entry["empty"] = int(np.count_nonzero(~ok))
                # k for the next packing phase: largest valid for the new positions
                r = _field_at(rfield, x)
                k = max(largest_valid_k(x, r, W, H), 1e-6)
            entry["k"] = float(k)
            entry["seconds"] = time.perf_counter() - ti
            history.append(entry)
            it_total += 1
            if callback is not None:
                callback(entry)

    t0 = time.perf_counter()
    r = _field_at(rfield, x)
    k, radii, cert = _certified(x, r, W, H, dom)
    timings["certify"] = time.perf_counter() - t0
    timings.update(stage)
    timings["total"] = time.perf_counter() - t_start
    return StippleResult(
        points=x, radii=radii, k=float(k), base_radii=r, certificate=cert,
        history=history, width=W, height=H, timings=timings, params=params,
    )
