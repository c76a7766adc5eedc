"""Colour separation into pen layers.

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
  the image (:func:`~diskpack_cl.colorspace.linear_negative`), so the
  separation above runs on the negatives. ``auto:N`` chooses white and N - 1 light pens (the negatives
  of those it chooses for the negative image); ``cmyk`` and ``cmy`` are
  made for white paper and refused (:func:`~diskpack_cl.pens.check_paper`).

The ``"overprint"`` model (``separate(..., model="overprint")``, CMYK and
CMY only) is the textbook separation for inks printed over each other, and
what layers stippled independently give on average (their dots overlap at
random, so reflectances multiply): ``K = g (1 - max(R, G, B))``, then
``C = 1 - R / (1 - K)`` and likewise M, Y (linear light; exact for the
ideal inks). The naive overlay of ``benchmarks/color_quality.py`` uses it.

``clean_black``/``clean_white``: pixels whose R, G and B (sRGB values in
[0, 1]) are all within the tolerance of black (white) are separated as pure
black (white, no ink), so near-black areas are drawn by one pen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .colorspace import area_mix, linear_negative, srgb_to_linear, unmix
from .image import load_rgb
from .palette import auto_palette
from .pens import PALETTES, check_paper, palette_pens, parse_auto

__all__ = ["Separation", "separate"]


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
        out[:, others] = unmix(t, pens[others]) * np.reshape(1.0 - k, (-1, 1))
    else:   # the channel each ideal ink absorbs: C absorbs R, M G, Y B
        out[:, others] = 1.0 - t[:, [int(np.argmin(pens[p])) for p in others]]
    if black_generation is not None:
        out[:, names.index("black")] = k
    out[out < 1e-9] = 0.0   # the solver's rounding: no ink
    return np.clip(out, 0.0, 1.0)


def separate(image, colors="cmyk", *, black_generation=1.0, clean_black=0.0, clean_white=0.0,
             model="area", invert=False):
    """Separate a colour image into pen layers (see the module docstring).

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A colour image (:func:`~diskpack_cl.image.load_rgb`).
    colors : str or sequence of (name, colour)
        ``"cmyk"``, ``"cmy"``, ``"auto:N"`` (black and N - 1 pens of the
        image's hues, :func:`~diskpack_cl.palette.auto_palette`), a ``"NAME=COLOR,..."`` text or
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
        (:func:`~diskpack_cl.colorspace.linear_negative`: the negative pens separating the negative
        image on white); ``auto:N`` chooses white and N - 1 light pens
        (:func:`~diskpack_cl.palette.auto_palette`); ``cmyk`` and ``cmy`` are refused
        (:func:`~diskpack_cl.pens.check_paper`).

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
    names, pens = (None, None) if auto is not None else palette_pens(colors)
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
