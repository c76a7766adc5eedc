"""Drawn dots that touch: their share, and radii that never touch (``--no-overlap``).

The packing's disks never overlap (they are certified disjoint), but the
drawn dots need not be those disks: the tone dots all have the one size
whose ink is the image's, and a pen inks at least half its width around
the path. Where dots are dense, neighbours' ink touches, and on paper a pen
going over wet ink makes blots. ``no_overlap`` caps each drawn dot at
its packing disk (:func:`cap_radii`), so that no two touch, and
:func:`ink_figures` says how many touch and what the cap costs in ink.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["touching", "cap_radii", "check_apart", "ink_figures", "median_spacing"]

# the SVG's coordinates have 4 decimals (mm): a capped dot keeps this far inside its disk
_ROUNDING_MM = 2e-4


def touching(centres, ink):
    """Which dots' ink disk touches or overlaps another's.

    Parameters
    ----------
    centres : (n, 2) array
    ink : (n,) array
        Radius of each dot's ink (what the pen covers), in the units of `centres`.

    Returns
    -------
    (n,) bool array

    Examples
    --------
    >>> touching(np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]]), np.full(3, 0.5)).tolist()
    [True, True, False]
    """
    c = np.asarray(centres, np.float64).reshape(-1, 2)
    ink = np.asarray(ink, np.float64)
    out = np.zeros(len(c), bool)
    if len(c) < 2:
        return out
    pairs = cKDTree(c).query_pairs(2.0 * float(ink.max()), output_type="ndarray")
    gap = np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1) - ink[pairs].sum(axis=1)
    out[pairs[gap <= 0].ravel()] = True
    return out


def median_spacing(centres):
    """The median distance from a dot's centre to its nearest neighbour's (nan for fewer than 2).

    Examples
    --------
    >>> float(median_spacing(np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]])))
    1.0
    """
    c = np.asarray(centres, np.float64).reshape(-1, 2)
    if len(c) < 2:
        return float("nan")
    return float(np.median(cKDTree(c).query(c, k=2)[0][:, 1]))


def cap_radii(radii, packing):
    """Drawn radii at most the packing radii (a hair less: the SVG rounds its coordinates).

    Examples
    --------
    >>> cap_radii(np.array([0.6, 0.3]), np.array([0.5, 0.5])).round(4).tolist()
    [0.4998, 0.3]
    """
    packing = np.asarray(packing, np.float64)
    return np.minimum(radii, np.maximum(packing - _ROUNDING_MM, 0.5 * packing))


def check_apart(centres, radii, packing, *, pen=None, unit="mm"):
    """Refuse drawn dots that touch where ``no_overlap`` promised they do not.

    What is checked is what is drawn: each dot's ink reaches its drawn
    radius (already capped, :func:`cap_radii`), and at least half the pen;
    dots whose inks touch exactly count as touching.

    Parameters
    ----------
    centres : (n, 2) array
    radii : (n,) array
        Drawn radii after the cap, in `unit`.
    packing : (n,) array
        The radii they were capped at, in `unit`.
    pen : float, optional
        Pen width, in `unit`.

    Raises
    ------
    ValueError
        Two dots touch: the message says why (a pen wider than the packing
        disks, or disks that overlap: not a packing) and what to change.

    Examples
    --------
    >>> c = np.array([[0.0, 0.0], [1.0, 0.0]])
    >>> check_apart(c, np.full(2, 0.4), np.full(2, 0.5), pen=0.5)
    >>> check_apart(c, np.full(2, 0.4), np.full(2, 0.5), pen=1.0)
    Traceback (most recent call last):
    ...
    ValueError: no_overlap (--no-overlap) cannot hold: the pen (1 mm) is wider than the smallest packing disk (1 mm across), and 2 of the 2 drawn dots would touch: give a pen narrower than the packing disks, a larger picture (--width-mm) or fewer dots
    """
    radii = np.asarray(radii, np.float64)
    ink = radii if pen is None else np.maximum(radii, 0.5 * float(pen))
    count = int(np.count_nonzero(touching(centres, ink)))
    if not count:
        return
    head = "no_overlap (--no-overlap) cannot hold: "
    if pen is None or not np.any(0.5 * float(pen) > radii):   # the disks: not a packing
        raise ValueError(f"{head}{count} of the {len(radii)} drawn dots would touch although each "
                         f"is at most its disk: the disks overlap (an .svg holds the drawn "
                         f"dots, not the packing disks: export the .npz or .csv)")
    raise ValueError(f"{head}the pen ({float(pen):.3g} {unit}) is wider than the smallest packing "
                     f"disk ({2 * float(np.min(packing)):.3g} {unit} across), and {count} of the "
                     f"{len(radii)} drawn dots would touch: give a pen narrower than the packing "
                     f"disks, a larger picture (--width-mm) or fewer dots")


def ink_figures(centres, radii, packing, *, pen=None, no_overlap=False):
    """What the summary says of the drawn dots: the share that touch, and the ink
    ``no_overlap`` keeps.

    A dot's ink reaches its drawn radius, or half the pen for a dot not
    wider than the pen (one touch). With ``no_overlap`` each drawn radius is
    at most its packing radius (:func:`cap_radii`): the ink disks are then
    inside disjoint disks, unless a packing disk is narrower than the pen
    (its dot is still a pen touch, counted here if it touches).

    Parameters
    ----------
    centres : (n, 2) array
        Dot centres as drawn (mm).
    radii : (n,) array
        Drawn radii (mm) before the cap: the ink's outer edge, the pen's
        width included.
    packing : (n,) array
        The certified packing radii (mm).
    pen : float, optional
        Pen width (mm).
    no_overlap : bool
        Whether the radii drawn are capped.

    Returns
    -------
    dict
        ``touching_share`` (of the dots drawn: their ink touches another
        dot's), ``touching_share_uncapped`` (the same without the cap) and
        ``no_overlap_ink`` (the ink of the capped dots over that of the
        uncapped ones: what ``no_overlap`` keeps of the tone, whether or not
        it is on), ``median_spacing_mm`` (:func:`median_spacing`) and
        ``median_ink_mm`` (the median width of the dots' ink as drawn);
        None for fewer than 2 and no dots.

    Examples
    --------
    >>> c = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]])
    >>> figures = ink_figures(c, np.full(3, 0.6), np.full(3, 0.5), no_overlap=True)
    >>> figures["touching_share"], round(figures["touching_share_uncapped"], 3)
    (0.0, 0.667)
    """
    half_pen = 0.0 if pen is None else 0.5 * float(pen)
    ink = np.maximum(np.asarray(radii, np.float64), half_pen)
    ink_capped = np.maximum(cap_radii(radii, packing), half_pen)
    uncapped = float(touching(centres, ink).mean()) if len(ink) else 0.0
    share = float(touching(centres, ink_capped).mean()) if no_overlap and len(ink) else uncapped
    area = float(np.sum(ink * ink))
    drawn = ink_capped if no_overlap else ink
    spacing = median_spacing(centres)
    return {"touching_share": share, "touching_share_uncapped": uncapped,
            "no_overlap_ink": float(np.sum(ink_capped * ink_capped)) / area if area > 0 else 1.0,
            "median_spacing_mm": None if np.isnan(spacing) else spacing,
            "median_ink_mm": 2 * float(np.median(drawn)) if len(drawn) else None}
