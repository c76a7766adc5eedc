"""The automatic palette (``--colors auto:N``): black (white on black paper) and
N - 1 pens of the image's own hues, chosen to fit its colours; and what the
palette routes say of an image without hue (:func:`grey_note`).
"""

from __future__ import annotations

from itertools import product

import numpy as np

from .colorspace import (hex_color, linear_negative, linear_to_srgb, srgb_to_lab, srgb_to_linear,
                         unmix)
from .image import load_rgb
from .pens import AUTO_MAX_PENS

__all__ = ["NO_HUE", "has_hue", "grey_note", "auto_palette"]


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
    """Whether any pixel of the colour `image` (:func:`~diskpack_cl.image.load_rgb`) has a hue
    besides grey.

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
    mix = 1.0 - unmix(target_lin, pens_lin) @ (1.0 - pens_lin)
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
    (:func:`~diskpack_cl.colorspace.linear_negative`) of those chosen for the
    image's negative: light pens on black mix as their negatives do on white.

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A colour image (:func:`~diskpack_cl.image.load_rgb`).
    n : int
        Pens, black included: 2 to :data:`~diskpack_cl.pens.AUTO_MAX_PENS`.
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
