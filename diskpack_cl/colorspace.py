"""Colour science: sRGB and linear light (IEC 61966-2-1), CIELAB and Delta E,
and the area mix of pens side by side on paper (:func:`area_mix`) with its
inverse (:func:`unmix`), which :mod:`diskpack_cl.separation` and the automatic
palette (:mod:`diskpack_cl.palette`) solve.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

__all__ = ["srgb_to_linear", "linear_to_srgb", "linear_negative", "srgb_to_lab", "delta_e",
           "hex_color", "area_mix", "unmix"]


# distances (linear RGB) and inks closer than this are ties in the unmixing
_TIE = 1e-9


def srgb_to_linear(v):
    """sRGB values in [0, 1] to linear light (IEC 61966-2-1).

    Examples
    --------
    >>> srgb_to_linear(np.array([0.0, 0.5, 1.0])).round(4).tolist()
    [0.0, 0.214, 1.0]
    """
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    """Linear light in [0, 1] to sRGB values (the inverse of :func:`srgb_to_linear`).

    Examples
    --------
    >>> float(linear_to_srgb(srgb_to_linear(0.3)).round(12))
    0.3
    """
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


_RGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])


_WHITE_D65 = _RGB_TO_XYZ.sum(axis=1)


def linear_negative(rgb):
    """The negative of sRGB colours in [0, 1] in linear light: ``1 - c`` in linear light, as sRGB.

    Area mixing is linear in linear light, so pens of colours ``c_p`` on
    paper ``P`` give the negative of what pens ``linear_negative(c_p)`` give
    on paper ``linear_negative(P)``: light pens on black paper are dark pens
    on white paper drawing the negative.

    Examples
    --------
    >>> linear_negative(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])).round(6).tolist()
    [[0.0, 1.0, 1.0], [1.0, 1.0, 1.0]]
    """
    return linear_to_srgb(1.0 - srgb_to_linear(rgb))


def srgb_to_lab(rgb):
    """sRGB values (..., 3) in [0, 1] to CIELAB (D65 white).

    Examples
    --------
    >>> srgb_to_lab(np.array([1.0, 1.0, 1.0])).round(6).tolist()
    [100.0, 0.0, 0.0]
    """
    xyz = srgb_to_linear(rgb) @ _RGB_TO_XYZ.T / _WHITE_D65
    e = 216 / 24389
    f = np.where(xyz > e, np.cbrt(xyz), (24389 / 27 * xyz + 16) / 116)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], axis=-1)


def delta_e(rgb_a, rgb_b):
    """Mean CIE 1976 Delta E*ab between two sRGB images (..., 3) in [0, 1].

    Examples
    --------
    >>> delta_e(np.zeros((2, 2, 3)), np.ones((2, 2, 3)))
    100.0
    """
    d = srgb_to_lab(rgb_a) - srgb_to_lab(rgb_b)
    return float(np.mean(np.sqrt(np.sum(d * d, axis=-1))))


def hex_color(rgb):
    """``#rrggbb`` of an sRGB colour in [0, 1].

    Examples
    --------
    >>> hex_color([1.0, 0.8, 0.0])
    '#ffcc00'
    """
    return "#" + "".join(f"{int(round(255 * float(v))):02x}" for v in rgb)


def area_mix(coverage, colors, *, invert=False):
    """sRGB image of pens side by side: ``(1 - sum a_p) paper + sum a_p c_p`` in linear light,
    the paper white, or black with `invert`.

    Examples
    --------
    >>> area_mix(np.full((1, 1, 1), 0.5), np.array([[0.0, 0.0, 0.0]])).round(4).tolist()
    [[[0.7354, 0.7354, 0.7354]]]
    >>> area_mix(np.full((1, 1, 1), 0.5), np.array([[1.0, 1.0, 1.0]]), invert=True).round(4).tolist()
    [[[0.7354, 0.7354, 0.7354]]]
    """
    a = np.asarray(coverage, dtype=np.float64)
    if invert:   # the negative of the negative pens on white
        return linear_negative(area_mix(a, linear_negative(colors)))
    absorb = 1.0 - srgb_to_linear(colors)               # (P, 3)
    lin = 1.0 - np.tensordot(a, absorb, axes=([0], [0]))
    return linear_to_srgb(lin)


def _face(vertices, targets):
    """Nearest points of the simplex `vertices` (s, 3) to `targets` (m, 3), restricted to
    its affine hull: ``(barycentric (m, s), distance (m,))``, NaN where degenerate."""
    v0, B = vertices[0], vertices[1:] - vertices[0]
    m = len(targets)
    if len(B) == 0:
        return np.ones((m, 1)), np.linalg.norm(targets - v0, axis=1)
    G = B @ B.T
    if np.linalg.matrix_rank(G) < len(B):
        return np.full((m, len(vertices)), np.nan), np.full(m, np.inf)
    mu = np.linalg.solve(G, B @ (targets - v0).T).T                     # (m, s - 1)
    bary = np.column_stack([1.0 - mu.sum(axis=1), mu])
    return bary, np.linalg.norm(targets - v0 - mu @ B, axis=1)


def unmix(targets, pens):
    """Coverages (m, P) of pens (P, 3) mixing the linear colours `targets` (m, 3) side by
    side on white paper: the nearest mix in the convex hull of paper and pens, the one
    with the least ink where several are as near (see :mod:`diskpack_cl.separation`).

    Examples
    --------
    Mid grey in linear light is half black, and half of each of two
    complementary pens:

    >>> unmix(np.array([[0.5, 0.5, 0.5]]), np.array([[0.0, 0.0, 0.0]])).round(6).tolist()
    [[0.5]]
    >>> red_and_cyan = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    >>> unmix(np.array([[0.5, 0.5, 0.5]]), red_and_cyan).round(6).tolist()
    [[0.5, 0.5]]
    """
    V = np.vstack([np.ones(3), pens])                                   # paper, then the pens
    out = np.zeros((len(targets), len(pens)))
    rest = np.arange(len(targets))
    if len(V) == 4:   # paper and 3 pens: a colour in their tetrahedron is its one mix
        bary, _ = _face(V, targets)
        inside = np.all(bary >= -1e-12, axis=1)
        out[inside], rest = bary[inside, 1:], rest[~inside]
    best, ink = np.full(len(rest), np.inf), np.full(len(rest), np.inf)
    for s in range(1, min(4, len(V)) + 1):                              # faces of <= 4 vertices
        for face in combinations(range(len(V)), s):
            bary, dist = _face(V[list(face)], targets[rest])
            ok = np.all(bary >= -1e-12, axis=1)
            used = bary[:, [i for i, f in enumerate(face) if f > 0]].sum(axis=1)
            better = ok & ((dist < best - _TIE) | ((dist < best + _TIE) & (used < ink - _TIE)))
            best[better], ink[better] = np.minimum(dist[better], best[better]), used[better]
            out[rest[better]] = 0.0
            for i, f in enumerate(face):
                if f > 0:
                    out[rest[better], f - 1] = bary[better, i]
    return np.clip(out, 0.0, 1.0)
