"""Colour separation into pen layers, ink compositing and colour measures.

A colour stippling draws every dot with one of a set of pens. The dots of a
certified packing never overlap, so what the eye sees after blurring is an
*area mix* (a Neugebauer mix without overprints): with ``a_p`` the fraction
of the paper that pen ``p`` covers and ``c_p`` its colour in linear RGB, the
reflectance is ``(1 - sum a_p) * white + sum a_p c_p``, linear in the
coverages. Separation inverts this model per pixel:

* **any set of pens** (``--pens NAME=COLOR,...``): the coverages are the
  constrained least-squares solution of ``white + sum a_p (c_p - white) =
  t`` in linear RGB (``t`` the pixel) with ``a_p >= 0`` and ``sum a_p <=
  1``: the nearest point to ``t`` of the gamut, the convex hull of paper
  and pens. It is found exactly, for all colours at once, by projecting
  onto every face of at most four of those vertices (a point of a 3-D
  hull is a mix of at most four, Caratheodory) and keeping the nearest
  feasible one; where several mixes give the colour (four pens or more),
  the one with the least ink.
* **CMYK** (``--colors cmyk``): black generation first, then the coloured
  pens. Black covers ``K = g (1 - max(R, G, B))`` (linear RGB; ``g`` the
  black generation, 1 = full grey-component replacement): the largest black
  area that the rest of the paper can still lighten to the pixel's colour.
  Under-colour removal: cyan, magenta and yellow then separate the rest,
  ``t / (1 - K)``, in the remaining area ``1 - K`` (the model above with
  those three pens, which is exact: paper, C, M, Y are affinely
  independent). Pen colours are the ideal process inks (cyan ``#00ffff``,
  magenta ``#ff00ff``, yellow ``#ffff00``, black ``#000000``); give real
  pen colours with ``--pens``.
* **CMY** (``--colors cmy``): the three coloured pens by the model above;
  their darkest grey is 2/3 of white (in linear light).
* **Black paper** (``--invert``, ``invert=True``): light pens on black
  paper, ``(1 - sum a_p) * black + sum a_p c_p``. That is the negative, in
  linear light, of pens ``1 - c_p`` on white paper drawing the negative of
  the image (:func:`linear_negative`), so the separation above runs on the
  negatives. ``auto:N`` chooses white and N - 1 light pens (the negatives
  of those it chooses for the negative image); ``cmyk`` and ``cmy`` are
  made for white paper and refused (:func:`check_paper`).

The ``"overprint"`` model (``separate(..., model="overprint")``, CMYK and
CMY only) is the textbook separation for inks printed over each other, and
what layers stippled independently give on average (their dots overlap at
random, so reflectances multiply): ``K = g (1 - max(R, G, B))``, then
``C = 1 - R / (1 - K)`` and likewise M, Y (linear light; exact for the
ideal inks). The naive overlay of ``benchmarks/color_quality.py`` uses it.

``clean_black``/``clean_white``: pixels whose R, G and B (sRGB values in
[0, 1]) are all within the tolerance of black (white) are separated as pure
black (white, no ink), so near-black areas are drawn by one pen.

Measures (:func:`color_measures`): mean CIELAB Delta E (CIE 1976) between the
photograph and the rendered stippling, both blurred by about one dot
spacing; SSIM per separated layer (:func:`diskpack_cl.picture_measures.tone_ssim`);
spacing P01 per pen and of all dots (:func:`diskpack_cl.picture_measures.spacing`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations, product
import os
import re

import numpy as np

from .options import OptionConflict, check_fields, option
from .image import load_gray

__all__ = ["ColorOptions", "PALETTES", "Separation", "parse_pens", "parse_pen_dots", "separate", "load_rgb", "srgb_to_linear",
           "linear_to_srgb", "srgb_to_lab", "area_mix", "delta_e", "render_pens", "pen_tone_radii",
           "pen_ink_radii", "linear_negative", "check_paper",
           "pen_spacing", "color_measures", "palette_of", "auto_palette", "parse_auto",
           "NO_HUE", "has_hue", "grey_note"]

#: Named palettes: (name, sRGB hex) per pen, lightest first.
PALETTES = {
    "cmyk": (("yellow", "#ffff00"), ("cyan", "#00ffff"), ("magenta", "#ff00ff"), ("black", "#000000")),
    "cmy": (("yellow", "#ffff00"), ("cyan", "#00ffff"), ("magenta", "#ff00ff")),
}

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


def _color(text):
    from PIL import ImageColor  # not loaded at start-up

    try:
        return np.array(ImageColor.getrgb(text)[:3], dtype=np.float64) / 255.0
    except ValueError:
        raise ValueError(f"unknown colour {text!r}: give #rgb, #rrggbb or a CSS colour name") from None


def parse_pens(text):
    """``"black=#000,red=#c00"`` to ``(names, colors)``, colours sRGB in [0, 1].

    Examples
    --------
    >>> names, colors = parse_pens("black=#000,red=#c00")
    >>> names, colors.round(1).tolist()
    (('black', 'red'), [[0.0, 0.0, 0.0], [0.8, 0.0, 0.0]])
    """
    names, colors = [], []
    for item in str(text).split(","):
        name, sep, value = item.strip().partition("=")
        if not sep or not name.strip() or not value.strip():
            raise ValueError(f"bad pen {item.strip()!r}: give NAME=COLOR, e.g. red=#c00")
        names.append(name.strip())
        colors.append(_color(value.strip()))
    if len(set(names)) != len(names):
        raise ValueError(f"pen names must differ, got {', '.join(names)}")
    return tuple(names), np.array(colors)


def parse_pen_dots(text):
    """``"cyan=12000,black=8000"`` to ``{"cyan": 12000, "black": 8000}``: dots per pen.

    Raises
    ------
    ValueError
        An item that is not ``NAME=N``, a count that is not a non-negative
        integer, or a pen named twice.

    Examples
    --------
    >>> parse_pen_dots("cyan=12000, black=8000")
    {'cyan': 12000, 'black': 8000}
    """
    out = {}
    for item in str(text).split(","):
        name, sep, value = (part.strip() for part in item.partition("="))
        if not sep or not name or not value:
            raise ValueError(f"bad pen count {item.strip()!r}: give NAME=N, e.g. cyan=12000")
        try:
            count = int(value)
        except ValueError:
            raise ValueError(f"the dots of pen {name} must be an integer, got {value!r}") from None
        if count < 0:
            raise ValueError(f"the dots of pen {name} must be >= 0, got {count}")
        if name in out:
            raise ValueError(f"pen {name} is given twice")
        out[name] = count
    return out


#: The most pens ``auto:N`` chooses (a plotter's carousel holds about 8).
AUTO_MAX_PENS = 8


def parse_auto(text):
    """The number of pens N of an automatic palette ``"auto:N"``; None for other pens.

    Raises
    ------
    ValueError
        ``auto`` with an N that is not a whole number from 2 to :data:`AUTO_MAX_PENS`.

    Examples
    --------
    >>> parse_auto("auto:4"), parse_auto("cmyk"), parse_auto("auto=#f00")
    (4, None, None)
    >>> parse_auto("auto:1")
    Traceback (most recent call last):
    ...
    ValueError: auto:N takes N = 2 to 8 pens (black and N - 1 colours of the image), got 'auto:1'
    """
    if not isinstance(text, str) or not re.fullmatch(r"auto(:.*)?", text.strip(), re.IGNORECASE):
        return None
    value = text.strip().partition(":")[2].strip()
    if not re.fullmatch(r"[0-9]+", value) or not 2 <= int(value) <= AUTO_MAX_PENS:
        raise ValueError(f"auto:N takes N = 2 to {AUTO_MAX_PENS} pens (black and N - 1 colours of "
                         f"the image), got {text!r}")
    return int(value)


def check_colors(text):
    """Refuse a ``colors`` that is not a palette name or ``auto:N`` (one line).

    Examples
    --------
    >>> check_colors("auto:3")
    >>> check_colors("rgb")
    Traceback (most recent call last):
    ...
    ValueError: colors must be 'cmyk', 'cmy' or 'auto:N' (N = 2 to 8), got 'rgb'
    """
    if text not in PALETTES and parse_auto(text) is None:
        raise ValueError(f"colors must be {', '.join(map(repr, PALETTES))} or 'auto:N' "
                         f"(N = 2 to {AUTO_MAX_PENS}), got {text!r}")


def _linear_sample(rgb, side=48):
    """The image averaged in linear light over blocks of about 1/`side` of its long side:
    (m, 3) linear colours, what a blurred drawing is compared with."""
    H, W, _ = rgb.shape
    f = max(1, int(np.ceil(max(H, W) / side)))
    lin = srgb_to_linear(rgb[:H // f * f, :W // f * f])
    return lin.reshape(H // f, f, W // f, f, 3).mean(axis=(1, 3)).reshape(-1, 3)


def _full_colours(lin):
    """Each linear colour's hue at full strength: the grey part removed and the rest scaled
    to a largest channel of 1 (rows of grey colours are NaN)."""
    span = lin.max(axis=1) - lin.min(axis=1)
    return (lin - lin.min(axis=1, keepdims=True)) / np.where(span > 1e-3, span, np.nan)[:, None]


def _hue_weights(pixels):
    """``(full colours, weights)`` of sRGB `pixels` (n, 3): each one's hue at full strength
    and its chroma, 0 for a grey (it has no hue to give)."""
    lab = srgb_to_lab(pixels)
    full = _full_colours(srgb_to_linear(pixels))
    return full, np.where(np.isnan(full[:, 0]), 0.0, np.hypot(lab[:, 1], lab[:, 2]))


#: What every palette route says of an image without colour.
NO_HUE = "the image has no hue besides grey"


def has_hue(image):
    """Whether any pixel of the colour `image` (:func:`load_rgb`) has a hue besides grey.

    Examples
    --------
    >>> has_hue(np.full((2, 2, 3), 0.4)), has_hue(np.array([[[0.4, 0.4, 0.5]]]))
    (False, True)
    """
    return bool(_hue_weights(load_rgb(image).reshape(-1, 3))[1].any())


def grey_note(image, names, pen):
    """The note of a colour stippling of an `image` without hue (cmyk, cmy, pens: every dot
    goes to the pens that mix its grey), else None; `names` the pens, `pen` each dot's.

    Examples
    --------
    >>> grey_note(np.full((2, 2, 3), 0.4), ("cyan", "black"), np.array([1, 1, 1]))
    'the image has no hue besides grey: black draws all 3 dots (cyan none); one pen draws it alike (without --colors/--pens)'
    """
    if has_hue(image):
        return None
    counts = np.bincount(np.asarray(pen), minlength=len(names))
    drawn = [f"{name} {c}" for name, c in zip(names, counts) if c]
    unused = [name for name, c in zip(names, counts) if not c]
    what = (f"{drawn[0].rpartition(' ')[0]} draws all {len(pen)} dots" if len(drawn) == 1
            else "the dots are " + ", ".join(drawn))
    return (f"{NO_HUE}: {what}" + (f" ({', '.join(unused)} none)" if unused else "")
            + "; one pen draws it alike (without --colors/--pens)")


def _hue_candidates(rgb, k, seed, m=4000):
    """Up to `k` candidate pens (linear, (c, 3)): the image's hues at full strength, the
    sample's full colour nearest to each centre of a k-means in CIELAB of the full colours
    of `m` pixels drawn by their chroma (grey pixels have no hue to give)."""
    from scipy.cluster.vq import kmeans2  # not loaded at start-up

    pixels = rgb.reshape(-1, 3)
    full, weight = _hue_weights(pixels)
    if not weight.sum() > 0:
        return np.zeros((0, 3))
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(pixels), size=m, p=weight / weight.sum())
    hues = np.unique(np.round(linear_to_srgb(full[pick]) * 255), axis=0) / 255.0
    hue_lab = srgb_to_lab(hues)
    if len(hues) <= k:
        return srgb_to_linear(hues)
    centres, _ = kmeans2(srgb_to_lab(linear_to_srgb(full[pick])), k, seed=seed, minit="++")
    nearest = np.argmin(((hue_lab[None] - centres[:, None]) ** 2).sum(axis=2), axis=1)
    return srgb_to_linear(hues[np.unique(nearest)])


def _mix_error(target_lin, target_lab, pens_lin):
    """Mean CIE 1976 Delta E of the area-mix separation of `target_lin` with these pens."""
    mix = 1.0 - _unmix(target_lin, pens_lin) @ (1.0 - pens_lin)
    d = srgb_to_lab(linear_to_srgb(mix)) - target_lab
    return float(np.mean(np.sqrt(np.sum(d * d, axis=1))))


def auto_palette(image, n, *, seed=0, invert=False):
    """Black and ``n - 1`` pens of the image's own hues (``--colors auto:N``); with `invert`,
    white and ``n - 1`` light pens for black paper.

    The candidates are the image's hues at full strength (grey part removed,
    largest channel 1; :func:`_hue_candidates`): dark colours are then drawn
    by black and a little of a bright pen, so the coloured dots stay few
    where dots of several pens would otherwise crowd and overlap (measured
    in ``docs/color.md``: pens of the image's own dark colours drew dark
    photographs far too light). Black is always a pen; the others are
    chosen greedily, then improved by swaps, to minimise the mean CIE 1976
    Delta E of the area-mix separation of the image averaged over blocks of
    1/48 of its long side. Deterministic for a given `seed` (the pixel draw
    and the k-means). On black paper (`invert`) the pens are the negatives
    (:func:`linear_negative`) of those chosen for the image's negative: light
    pens on black mix as their negatives do on white.

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A colour image (:func:`load_rgb`).
    n : int
        Pens, black included: 2 to :data:`AUTO_MAX_PENS`.
    seed : int
        Seed of the pixel draw and the k-means.
    invert : bool
        Pens for black paper.

    Returns
    -------
    names : tuple of str
        ``"black"`` last, the others their own ``#rrggbb`` (lightest first);
        with `invert`, ``"white"`` last and the others darkest first.
    colors : (n, 3) float64
        sRGB in [0, 1].

    Raises
    ------
    ValueError
        `n` out of range, or fewer than ``n - 1`` hues in the image.

    Examples
    --------
    >>> img = np.zeros((8, 24, 3)); img[:, :8] = [1.0, 0.5, 0.0]; img[:, 8:16] = [0.0, 0.6, 1.0]
    >>> auto_palette(img, 3)[0]
    ('#ff8000', '#0099ff', 'black')
    >>> auto_palette(img, 3, invert=True)[0]
    ('#0099ff', '#ff8000', 'white')
    """
    if invert:
        names, colors = auto_palette(linear_negative(load_rgb(image)), n, seed=seed)
        colors = np.round(linear_negative(colors) * 255) / 255
        return tuple(hex_color(c) for c in colors[:-1]) + ("white",), colors
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 2 <= n <= AUTO_MAX_PENS:
        raise ValueError(f"auto:N takes N = 2 to {AUTO_MAX_PENS} pens, got {n!r}")
    rgb = load_rgb(image)
    cand = _hue_candidates(rgb, 2 * n + 2, seed)
    if len(cand) < n - 1:
        raise ValueError(f"the image has {len(cand)} hue(s) besides grey, auto:{n} needs {n - 1}: "
                         f"give auto:{len(cand) + 1} or fewer" if len(cand) else
                         f"{NO_HUE}: give the pens or draw it with one pen")
    lin = _linear_sample(rgb)
    lab = srgb_to_lab(linear_to_srgb(lin))
    chosen = [None] * (n - 1)
    for i in range(n - 1):   # greedy: each pen the one that helps most with those before it
        free = [c for c in range(len(cand)) if c not in chosen]
        chosen[i] = min(free, key=lambda c: _mix_error(
            lin, lab, np.vstack([np.zeros(3), cand[[*chosen[:i], c]]])))
    best, better = _mix_error(lin, lab, np.vstack([np.zeros(3), cand[chosen]])), True
    while better:   # swaps: a pen for a candidate not chosen while the error falls
        better = False
        for i, c in product(range(n - 1), range(len(cand))):
            if c not in chosen:
                trial = [*chosen[:i], c, *chosen[i + 1:]]
                err = _mix_error(lin, lab, np.vstack([np.zeros(3), cand[trial]]))
                if err < best - 1e-9:
                    best, chosen, better = err, trial, True
    colors = linear_to_srgb(cand[chosen])
    lum = cand[chosen] @ np.array([0.2126, 0.7152, 0.0722])
    colors = np.vstack([np.round(colors[np.argsort(-lum, kind="stable")] * 255) / 255, np.zeros(3)])
    return tuple(hex_color(c) for c in colors[:-1]) + ("black",), colors


def _pens_before_image(colors):
    """The pen names known before the image is read and the number of pens: all of them,
    except for ``auto:N`` (black only; N pens)."""
    n = parse_auto(colors)
    if n is not None:
        return ("black",), n
    names = _palette(colors)[0]
    return names, len(names)


def _palette(colors):
    """``(names, colors)`` of a palette name or a ``NAME=COLOR,...`` text."""
    if isinstance(colors, str) and colors.lower() in PALETTES:
        pens = PALETTES[colors.lower()]
        return tuple(p[0] for p in pens), np.array([_color(p[1]) for p in pens])
    if isinstance(colors, str):
        return parse_pens(colors)
    names, rgb = zip(*colors)
    return tuple(names), np.array([_color(c) if isinstance(c, str) else np.asarray(c, float) for c in rgb])


@dataclass(frozen=True)
class Separation:
    """Pen layers of a colour image.

    Attributes
    ----------
    layers : (P, H, W) float64
        Coverage of each pen in [0, 1], summing to at most 1 per pixel.
    names : tuple of str
    colors : (P, 3) float64
        Pen colours, sRGB in [0, 1].
    rgb : (H, W, 3) float64
        The image separated (sRGB in [0, 1], after the clean tolerances).
    invert : bool
        Light pens on black paper (the pens mix with black, not white).

    Examples
    --------
    >>> sep = separate(np.array([[[1.0, 0.0, 0.0], [1.0, 1.0, 1.0]]]), "cmy")
    >>> sep.names, sep.layers.shape, sep.layers[:, 0, 1].tolist()
    (('yellow', 'cyan', 'magenta'), (3, 1, 2), [0.0, 0.0, 0.0])
    """

    layers: np.ndarray
    names: tuple
    colors: np.ndarray
    rgb: np.ndarray
    invert: bool = False

    @property
    def darkness(self):
        """All pens' coverage per pixel: the density of all dots together."""
        return np.clip(self.layers.sum(axis=0), 0.0, 1.0)

    def render(self):
        """The area mix of the layers (sRGB, (H, W, 3)): what a perfect stippling shows."""
        return area_mix(self.layers, self.colors, invert=self.invert)


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


def _unmix(targets, pens):
    """Coverages (m, P) of pens (P, 3) mixing the linear colours `targets` (m, 3) side by
    side on white paper: the nearest mix in the convex hull of paper and pens, the one
    with the least ink where several are as near (see the module docstring)."""
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


def _black_first(lin, names, black_generation):
    """CMYK's black coverage ``K`` (n,), what is left of each colour, ``t / (1 - K)``
    (n, 3), and the indices of the other pens."""
    k = black_generation * (1.0 - lin.max(axis=1))
    room = 1.0 - k
    t = np.divide(lin, room[:, None], out=np.ones_like(lin), where=room[:, None] > 1e-9)
    return k, np.clip(t, 0.0, 1.0), [p for p in range(len(names)) if names[p] != "black"]


def _separate_unique(rgb, names, colors, black_generation, model):
    """Coverages (m, P) of the distinct sRGB colours rgb (m, 3); with a
    `black_generation` (CMYK), the pen ``"black"`` first, then the others.
    ``model="overprint"``: the textbook formulas of the ideal inks (C = 1 - R)."""
    lin = srgb_to_linear(rgb)
    pens = srgb_to_linear(colors)
    out = np.zeros((len(lin), len(names)))
    k, t, others = (0.0, lin, list(range(len(names)))) if black_generation is None else \
        _black_first(lin, names, black_generation)
    if model == "area":
        out[:, others] = _unmix(t, pens[others]) * np.reshape(1.0 - k, (-1, 1))
    else:   # the channel each ideal ink absorbs: C absorbs R, M G, Y B
        out[:, others] = 1.0 - t[:, [int(np.argmin(pens[p])) for p in others]]
    if black_generation is not None:
        out[:, names.index("black")] = k
    out[out < 1e-9] = 0.0   # the solver's rounding: no ink
    return np.clip(out, 0.0, 1.0)


def palette_of(names, colors):
    """What :func:`separate` takes for pens read back from a file: ``"cmyk"`` or ``"cmy"``
    where they are that palette (so that CMYK separates black first), else the pairs.

    Examples
    --------
    >>> palette_of(("yellow", "cyan", "magenta"), [[1, 1, 0], [0, 1, 1], [1, 0, 1]])
    'cmy'
    >>> palette_of(("ink",), [[0.0, 0.0, 0.0]])
    [('ink', (0.0, 0.0, 0.0))]
    """
    colors = np.asarray(colors, dtype=np.float64)
    for key in PALETTES:
        names_p, colors_p = _palette(key)
        if tuple(names) == names_p and colors.shape == colors_p.shape and np.allclose(colors, colors_p):
            return key
    return [(name, tuple(float(v) for v in c)) for name, c in zip(names, colors)]


def check_paper(colors, invert):
    """Refuse a named palette made for white paper (``cmyk``, ``cmy``) on black paper (one line).

    Examples
    --------
    >>> check_paper("auto:3", True)
    >>> check_paper("cmyk", True)
    Traceback (most recent call last):
    ...
    ValueError: cmyk is for white paper: on black paper give auto:N (white and N - 1 of the image's hues) or light pens, e.g. white=#fff,red=#f00,green=#0f0,blue=#00f
    """
    if invert and isinstance(colors, str) and colors.strip().lower() in PALETTES:
        raise ValueError(f"{colors.strip()} is for white paper: on black paper give auto:N "
                         f"(white and N - 1 of the image's hues) or light pens, e.g. "
                         f"white=#fff,red=#f00,green=#0f0,blue=#00f")


def separate(image, colors="cmyk", *, black_generation=1.0, clean_black=0.0, clean_white=0.0,
             model="area", invert=False):
    """Separate a colour image into pen layers (see the module docstring).

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A colour image (:func:`load_rgb`).
    colors : str or sequence of (name, colour)
        ``"cmyk"``, ``"cmy"``, ``"auto:N"`` (black and N - 1 pens of the
        image's hues, :func:`auto_palette`), a ``"NAME=COLOR,..."`` text or
        pairs.
    black_generation : float in [0, 1]
        CMYK only: black covers ``g (1 - max(R, G, B))`` (linear).
    clean_black, clean_white : float in [0, 1)
        Tolerances (sRGB) under which a pixel is separated as pure black or white.
    model : {"area", "overprint"}
        Ink model: ``"area"`` (dots side by side, the packing's) or
        ``"overprint"`` (CMYK and CMY only: layers printed over each
        other, as independent layers give on average; see the module docstring).
    invert : bool
        Light pens on black paper: the pens' mix with black
        (:func:`linear_negative`: the negative pens separating the negative
        image on white); ``auto:N`` chooses white and N - 1 light pens
        (:func:`auto_palette`); ``cmyk`` and ``cmy`` are refused
        (:func:`check_paper`).

    Returns
    -------
    Separation

    Examples
    --------
    >>> img = np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]]])
    >>> sep = separate(img, "cmyk")
    >>> sep.names, sep.layers[:, 0, :].round(3).T.tolist()
    (('yellow', 'cyan', 'magenta', 'black'), [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])

    On black paper, black is no ink, white all white pen, cyan all cyan pen:

    >>> separate(img, "white=#fff,cyan=#0ff", invert=True).layers[:, 0, :].round(6).tolist()
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    check_paper(colors, invert)
    auto = parse_auto(colors)
    names, pens = (None, None) if auto is not None else _palette(colors)
    if model not in ("area", "overprint"):
        raise ValueError(f"model must be 'area' or 'overprint', got {model!r}")
    palette = colors.lower() if isinstance(colors, str) and colors.lower() in PALETTES else None
    if model == "overprint" and palette is None:
        raise ValueError("model='overprint' is the textbook separation of 'cmyk' and 'cmy'; "
                         "other pens use model='area'")
    for name, v in (("black_generation", black_generation), ("clean_black", clean_black),
                    ("clean_white", clean_white)):
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"{name} must be in [0, 1], got {v}")
    rgb = load_rgb(image)
    rgb = np.where((rgb.max(axis=2) <= clean_black)[..., None], 0.0, rgb)
    rgb = np.where((rgb.min(axis=2) >= 1.0 - clean_white)[..., None], 1.0, rgb)
    if auto is not None:
        names, pens = auto_palette(rgb, auto, invert=invert)
    q = np.round(rgb * 255).astype(np.int64)
    keys, inverse = np.unique((q[..., 0] << 16) | (q[..., 1] << 8) | q[..., 2], return_inverse=True)
    uniq = np.stack([keys >> 16, (keys >> 8) & 255, keys & 255], axis=1) / 255.0
    gcr = black_generation if palette == "cmyk" else None
    if invert:   # light pens on black: the negative pens on white, drawing the negative
        cov = _separate_unique(linear_negative(uniq), names, linear_negative(pens), gcr, model)
    else:
        cov = _separate_unique(uniq, names, pens, gcr, model)
    layers = np.moveaxis(cov[inverse.reshape(rgb.shape[:2])], 2, 0)
    return Separation(np.ascontiguousarray(layers), names, pens, rgb, bool(invert))


def load_rgb(image):
    """Anything image-like to float64 sRGB (H, W, 3) in [0, 1] (a new array).

    Paths and Pillow images are read with their EXIF orientation, transparency
    composited on white; gray images give three equal channels. Arrays:
    ``(H, W)`` or ``(H, W, 3|4)``, integers scaled by their bit depth (uint8
    by 255, uint16 by 65535), floats in [0, 1].

    Examples
    --------
    >>> load_rgb(np.array([[[255, 0, 0, 0]]], dtype=np.uint8)).tolist()
    [[[1.0, 1.0, 1.0]]]
    """
    from PIL import Image, ImageOps  # not loaded at start-up

    if isinstance(image, (str, os.PathLike)):
        load_gray(image)   # the same checks and messages as for gray input
        with Image.open(image) as im:
            image = ImageOps.exif_transpose(im).convert("RGBA")
    elif isinstance(image, Image.Image):
        image = ImageOps.exif_transpose(image).convert("RGBA")
    a = np.asarray(image)
    if np.issubdtype(a.dtype, np.integer):
        f = a.astype(np.float64) / (255.0 if a.max(initial=0) <= 255 else 65535.0)
    else:
        f = np.asarray(a, dtype=np.float64)
    if f.ndim == 2:
        f = np.repeat(f[..., None], 3, axis=2)
    if f.ndim != 3 or f.shape[2] not in (3, 4) or not np.all(np.isfinite(f)) \
            or f.min(initial=0) < 0 or f.max(initial=0) > 1:
        raise ValueError(f"a colour image must be (H, W) or (H, W, 3|4) with values in [0, 1], "
                         f"got shape {a.shape}")
    if f.shape[2] == 4:
        f = f[..., :3] * f[..., 3:] + (1.0 - f[..., 3:])
    return np.ascontiguousarray(f)


#: Dots per pen in proportion to their layer's ink to this power unless given
#: (:func:`diskpack_cl.multipen.pen_counts`); measured in docs/color.md.
PEN_SHARE_EXPONENT = 0.7

#: Pens with fewer dots get no SSIM or P01 in :func:`color_measures` (a percentile of a
#: handful of distances says nothing).
MIN_DOTS = 50


def render_pens(points, pen, radii, colors, shape, *, scale=3, invert=False):
    """Linear-light RGB (H, W, 3) of dots drawn with their pens' inks, overprinting where they overlap.

    Each pen's dots (radius ``radii[p]`` px) are drawn at `scale` times the
    image resolution (:func:`diskpack_cl.picture_measures.render_dots`), coverage
    clipped at 1; inks multiply, ``prod_p (1 - a_p (1 - c_p))``, so pens
    side by side mix by area and overlapping dots overprint; the result is
    averaged back to the image's pixels. With `invert`, light pens on black
    paper: the negative of the negative pens on white,
    ``1 - prod_p (1 - a_p c_p)`` (side by side, the area mix over black).

    Examples
    --------
    >>> img = render_pens([[2.0, 2.0]], [0], [1.0], np.array([[0.0, 0.0, 0.0]]), (4, 4))
    >>> round(float(img[..., 0].mean()), 3)   # 1 - pi / 16
    0.804
    >>> img = render_pens([[2.0, 2.0]], [0], [1.0], np.array([[1.0, 1.0, 1.0]]), (4, 4), invert=True)
    >>> round(float(img[..., 0].mean()), 3)   # pi / 16
    0.196
    """
    from .picture_measures import render_dots  # not loaded at start-up

    if invert:
        return 1.0 - render_pens(points, pen, radii, linear_negative(colors), shape, scale=scale)
    p = np.asarray(points, dtype=np.float64)
    pen = np.asarray(pen)
    H, W = shape
    absorb = 1.0 - srgb_to_linear(colors)
    lin = np.ones((H * scale, W * scale, 3))
    for q in range(len(colors)):
        mine = pen == q
        if np.any(mine):
            a = np.minimum(render_dots(p[mine] * scale, radii[q] * scale, lin.shape[:2]), 1.0)
            lin *= 1.0 - a[..., None] * absorb[q]
    return lin.reshape(H, scale, W, scale, 3).mean(axis=(1, 3))


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
    :func:`render_pens`) a pen over its own ink adds nothing, so where a
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


def _own_density(points, shape):
    """The density of `points` themselves on the pixel grid, blurred over two of their
    spacings and scaled to a maximum of 1 (the reference of :func:`pen_spacing`
    without layers)."""
    from scipy import ndimage  # not loaded at start-up

    H, W = shape
    hist = np.histogram2d(points[:, 1], points[:, 0], bins=(H, W), range=((0, H), (0, W)))[0]
    blurred = ndimage.gaussian_filter(hist, 2.0 * np.sqrt(W * H / len(points)), mode="constant")
    return blurred / blurred.max()


def pen_spacing(points, pen, shape, *, layers=None, pens=None, sigma=3.0):
    """Spacing P01 of each pen's dots and of all dots together.

    Each set's nearest-neighbour distances are read against the spacing its
    density asks for (:func:`diskpack_cl.picture_measures.spacing`, 1st percentile):
    with `layers`, a pen's layer and, for all dots, all layers' coverage
    (what the dots were placed to follow); without, the density of the dots
    themselves (histogram blurred over two of their spacings), which needs
    no image but forgives dots that drift from their tone.

    Parameters
    ----------
    points, pen
        As :func:`color_measures`: all dots (pixel units) and the pen of each.
    shape : (int, int)
        Image height and width in pixels.
    layers : (P, H, W) array_like, optional
        The separated layers (coverage in [0, 1]).
    pens : int, optional
        Number of pens (default: the layers', else the largest pen + 1).
    sigma : float
        Blur in pixels of the expected density.

    Returns
    -------
    dict
        ``p01``: per pen (None for a pen of fewer than :data:`MIN_DOTS`
        dots); ``p01_joint``: of all dots.

    Examples
    --------
    >>> x, y = np.meshgrid(np.arange(2.0, 64, 4), np.arange(2.0, 64, 4))
    >>> pts = np.column_stack([x.ravel(), y.ravel()])
    >>> out = pen_spacing(pts, np.arange(256) % 2, (64, 64))
    >>> out["p01"][0] > 0.5, round(out["p01_joint"], 2) > 0.5
    (True, True)
    """
    from .picture_measures import spacing  # not loaded at start-up

    p, pen = np.asarray(points, float), np.asarray(pen)
    P = pens or (int(pen.max()) + 1 if layers is None else len(layers))
    mine = [pen == q for q in range(P)]
    if layers is None:
        dens = [_own_density(p[m], shape) if np.count_nonzero(m) else None for m in mine]
        total = _own_density(p, shape)
    else:
        dens = list(np.asarray(layers, float))
        total = np.sum(dens, axis=0)
        total = total / max(float(total.max()), 1.0)   # over 1 where overprinting layers add up
    return {"p01": [spacing(p[m], d, sigma=sigma).p01 if np.count_nonzero(m) >= MIN_DOTS else None
                    for m, d in zip(mine, dens)],
            "p01_joint": spacing(p, total, sigma=sigma).p01}


def color_measures(points, pen, layers, colors, rgb, *, sigma=None, tone_sigma=3.0, invert=False):
    """Colour fidelity and spacing of a colour stippling.

    Parameters
    ----------
    points : (n, 2) array_like
        All dots, pixel units.
    pen : (n,) array_like of int
        Pen per dot.
    layers : (P, H, W) array_like
        The separated layers the pens draw (coverage in [0, 1]).
    colors : (P, 3) array_like
        Pen colours, sRGB in [0, 1].
    rgb : (H, W, 3) array_like
        The photograph, sRGB in [0, 1].
    sigma : float, optional
        Blur in pixels for Delta E; default one dot spacing ``sqrt(W H / n)``.
    tone_sigma : float
        Blur in pixels for the SSIM and the spacing.
    invert : bool
        Light pens on black paper (:func:`render_pens`).

    Returns
    -------
    dict
        ``delta_e``: mean CIE 1976 Delta E*ab between the photograph and the
        drawing (:func:`render_pens`, each pen's dots at the radius holding
        its layer's ink, :func:`pen_ink_radii`), both blurred by `sigma` in
        linear light;
        ``ssim``: per pen, :func:`diskpack_cl.picture_measures.tone_ssim` of its
        dots against its layer; ``p01`` and ``p01_joint``: :func:`pen_spacing`
        against the layers (SSIM and P01 None for a pen of fewer than
        :data:`MIN_DOTS` dots).

    Examples
    --------
    >>> from diskpack_cl import stipple_colors
    >>> img = np.dstack([np.tile(np.linspace(0, 1, 32), (24, 1)), np.full((24, 32), 0.3), np.full((24, 32), 0.8)])
    >>> res = stipple_colors(img, 80, "cmyk", backend="exact", schedule=[("mix", 3, 0.5)])
    >>> m = color_measures(res.points, res.pen, res.layers, res.colors, img)
    >>> sorted(m), len(m["p01"]) == len(res.names)
    (['delta_e', 'p01', 'p01_joint', 'sigma', 'ssim'], True)
    """
    from scipy import ndimage  # not loaded at start-up

    from .picture_measures import tone_ssim  # not loaded at start-up

    p, pen, layers = np.asarray(points, float), np.asarray(pen), np.asarray(layers, float)
    P, H, W = layers.shape
    counts = np.bincount(pen, minlength=P)
    sigma = float(np.sqrt(W * H / len(p))) if sigma is None else float(sigma)
    drawn = render_pens(p, pen, pen_ink_radii(p, pen, layers), colors, (H, W), invert=invert)

    def blur(lin):
        return linear_to_srgb(ndimage.gaussian_filter(lin, (sigma, sigma, 0), mode="reflect"))

    mine = [pen == q for q in range(P)]
    return {
        "delta_e": delta_e(blur(drawn), blur(srgb_to_linear(rgb))),
        "ssim": [tone_ssim(p[m], a, sigma=tone_sigma) if c >= MIN_DOTS else None
                 for m, a, c in zip(mine, layers, counts)],
        **pen_spacing(p, pen, (H, W), layers=layers, sigma=tone_sigma),
        "sigma": sigma,
    }


_COLOUR = "colour (several pens, one certified packing of all dots)"


@dataclass(frozen=True)
class ColorOptions:
    """The separation options of :func:`diskpack_cl.stipple_colors` (``diskpack stipple
    --colors/--pens``); neither ``colors`` nor ``pens``: one pen.

    Examples
    --------
    >>> ColorOptions(colors="cmy").separation()["colors"]
    'cmy'
    >>> ColorOptions().separation() is None
    True
    """

    colors: str = option(None, "separate the image into pen layers: cmyk (black generation "
                         "K = G (1 - max(R, G, B)) in linear light, the other inks separate "
                         "the rest side by side), cmy, or auto:N (N = 2 to 8 pens: black and "
                         "N - 1 of the image's hues at full strength, chosen to fit its colours; "
                         "each pen named by its #rrggbb in the summary and the SVG layers); "
                         "one SVG layer per pen", check=check_colors, metavar="cmyk|cmy|auto:N",
                         group=_COLOUR)
    pens: str = option(None, "any set of pens, e.g. black=#000,red=#c00,blue=#06c: the nearest "
                       "mix of paper and pens side by side (linear RGB)", metavar="NAME=COLOR,...",
                       group=_COLOUR)
    black_generation: float = option(1.0, "cmyk: share of the grey component drawn in black "
                                     "(default 1)", lo=0, hi=1, metavar="G", group=_COLOUR)
    clean_black: float = option(0.0, "pixels with R, G, B all within T of black are pure black "
                                "(default 0)", lo=0, hi=1, metavar="T", group=_COLOUR)
    clean_white: float = option(0.0, "pixels with R, G, B all within T of white get no ink "
                                "(default 0)", lo=0, hi=1, metavar="T", group=_COLOUR)
    pen_share_exponent: float = option(
        PEN_SHARE_EXPONENT, "dots per pen in proportion to its layer's ink to the power A: below 1 "
        "the pens with little ink get more, smaller dots; every pen's dots hold its ink "
        f"(default {PEN_SHARE_EXPONENT:g})", lo=0, hi=1, metavar="A", group=_COLOUR)
    pen_dots: str = option(None, "dots of some or all pens, e.g. cyan=12000,black=8000: the pens "
                           "named get that many, the others share the rest by their ink to "
                           "the power of the pen share exponent (default: all pens share them so)",
                           metavar="NAME=N,...", check=parse_pen_dots, group=_COLOUR)

    def __post_init__(self):
        check_fields(self)
        if self.colors is not None and self.pens is not None:
            raise OptionConflict(f"{{}} {self.colors} and {{}} both name the pens; give one",
                                 "colors", "pens")
        if self.pen_dots is not None and self.colors is None and self.pens is None:
            raise OptionConflict("{} needs the pens: give {} or {}", "pen_dots", "colors", "pens")
        if self.pen_dots is not None:
            names = _pens_before_image(self.pens or self.colors)[0]
            unknown = [name for name in parse_pen_dots(self.pen_dots) if name not in names]
            if unknown:
                text = f"{', '.join(unknown)}, not one of the pens ({', '.join(names)}" + \
                    (", the only pen of auto:N known before the image)" if
                     parse_auto(self.colors) else ")")
                raise OptionConflict("{} names " + text.replace("{", "{{").replace("}", "}}"),
                                     "pen_dots")

    def check_pen_dots(self, n):
        """Refuse dots per pen that cannot add up to `n` dots in all (more than n, or every
        pen named and another sum), before any work.

        Examples
        --------
        >>> ColorOptions(colors="cmy", pen_dots="cyan=10,yellow=5,magenta=5").check_pen_dots(20)
        >>> ColorOptions(colors="cmy", pen_dots="cyan=30").check_pen_dots(20)
        Traceback (most recent call last):
        ...
        diskpack_cl.options.OptionConflict: pen_dots gives 30 dots, more than the 20 in all
        """
        if self.pen_dots is None:
            return
        dots = parse_pen_dots(self.pen_dots)
        given, every = sum(dots.values()), len(dots) == _pens_before_image(self.pens or self.colors)[1]
        if given > n or (every and given != n):
            raise OptionConflict(f"{{}} gives {given} dots, {'more than' if given > n else 'not'} "
                                 f"the {n} in all" + ("; leave a pen out to give it the rest"
                                                      if every and given < n else ""), "pen_dots")

    def separation(self):
        """The arguments of :func:`diskpack_cl.stipple_colors` (pens, separation and dots per
        pen), or None (one pen)."""
        if self.colors is None and self.pens is None:
            return None
        counts = None if self.pen_dots is None else parse_pen_dots(self.pen_dots)
        return dict(colors=self.pens or self.colors, black_generation=self.black_generation,
                    clean_black=self.clean_black, clean_white=self.clean_white, counts=counts,
                    pen_share_exponent=self.pen_share_exponent)
