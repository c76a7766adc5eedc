"""Colour stippling: one certified packing of the dots of every pen (multi-class stippling).

:func:`stipple_colors` separates the image into pen layers
(:func:`diskpack_cl.separation.separate`) and places all dots together:

1. **Joint placement.** The mono stippling's steps (:func:`diskpack_cl.stipple`:
   error-diffusion start, the schedule of the dot spacing) run the first
   ``joint`` share (0.3) of the schedule's iterations on the *joint* density,
   that of the dots of all pens together (:func:`dot_density`): every dot,
   whatever its pen, is spaced from every other (one power diagram over all
   dots).
2. **Pens.** :func:`assign_pens` gives every dot a pen by vector error
   diffusion on the dots (Floyd-Steinberg on a point set): visited along a
   Hilbert path, each dot takes the pen most owed there (its layer's share
   of the local ink plus the error it received), and passes what is left
   to its nearest dots visited after it, so that every neighbourhood holds
   each pen in its layer's share, spread out as error diffusion spreads
   dots. The path is cut into pieces of :data:`SEGMENT` dots walked side
   by side, so that one numpy step visits a dot of every piece. Dot counts
   per pen follow the ink of the layers to a power (:func:`pen_counts`) or
   are given (:func:`dots_per_pen`); the dots go where each pen's ink,
   weighted by its dots per unit of ink, asks for them (:func:`dot_density`,
   the density of the joint placement), and each pen's dots are drawn at
   the size that holds its layer's ink
   (:func:`diskpack_cl.pen_radii.pen_ink_radii`).
3. **Class-aware moves.** The rest of the schedule runs on the power
   diagram over all dots with the joint radii (the packing keeps every pair
   apart); after each step every dot also moves towards the centroid of its
   Voronoi cell among *its own pen's* dots, under its pen's layer (a
   per-class Lloyd move, as in multi-class blue noise, Wei 2010), so that
   each pen's dots follow their layer and spread among themselves. That
   pull falls from ``pen_pull`` to 0 over the first :data:`PULL_UNTIL` of
   these steps; the last ones restore the spacing of all dots together.
4. **Certificate.** The final disks of all dots together are certified
   inside the image and pairwise disjoint (:func:`diskpack_cl.radii.certified_k`),
   as for one pen.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ._timing import Stopwatch
from .picture_measures import tone_radius
from .colorspace import hex_color
from .pen_radii import pen_ink_radii
from .pens import ColorOptions, PALETTES, parse_auto
from .separation import separate
from .dithering import error_diffusion
from .domain import Domain
from .radii import certified_k, field_at
from .schedule import StippleOptions
from ._checks import check_count
from .stipple import (StippleResult, StippleState, centroid_density, make_stage, run_schedule,
                      dot_radii, result_summary)
from .engine import engine_record, make_engine
from .drawing.pen_path import pen_path_order
from .progress import stage as run_stage, unreported

__all__ = ["ColorStippleResult", "assign_pens", "dot_density", "dots_per_pen", "pen_counts",
           "stipple_colors"]

#: Share of the class-aware phases over which the pull towards the pens' own
#: centroids falls to 0 (the rest restores the spacing of all dots together).
PULL_UNTIL = 0.7
#: The pens' own Voronoi diagrams (:func:`_pen_centroids`) are labelled on a
#: raster this many times coarser per side than the diagram of all dots
#: (their cells are larger): the measures of docs/color.md moved by at most
#: 0.03, with 4 times fewer grid cells to label per pen and step.
PEN_COARSEN = 2
#: Nearest dots that a dot's error goes to in :func:`assign_pens`.
DIFFUSE = 6
#: Dots per piece of the Hilbert path in :func:`assign_pens`: the pieces are
#: walked at once, one wave per dot of a piece. With 64 the per-layer SSIM of
#: black on chelsea (5000 dots) was 0.01 below the unbroken path's; 256 and
#: 1024 matched it within the spread over seeds.
SEGMENT = 256
#: ``capacity`` of colour stippling unless given: off. The one-pen default
#: (0.1) lowered every measure of docs/color.md here (per-pen SSIM of black
#: by 0.04 to 0.06, Delta E by 0.2 to 0.6 at 5000 dots).
COLOR_CAPACITY = 0.0


@dataclass(kw_only=True)
class ColorStippleResult(StippleResult):
    """Result of :func:`stipple_colors`: all dots, each with its pen.

    Attributes
    ----------
    points, radii, base_radii, k, certificate, history, width, height,
    timings, params, engine, tone_radius
        As :class:`diskpack_cl.StippleResult`, over all dots together (the
        certificate covers every pair, whatever the pens).
    stages
        As :class:`diskpack_cl.StippleResult`, with ``pens``: the engine of
        the pull of each dot to its own pen's centroid.
    pen : (n,) int64
        Pen index of each dot.
    names : tuple of str
        Pen names.
    colors : (P, 3) float64
        Pen colours, sRGB in [0, 1].
    layers : (P, H, W) float64
        The separated layers (:class:`diskpack_cl.separation.Separation`).
    pen_radius : (P,) float64
        Drawn dot radius per pen (px): its dots then hold its layer's ink
        (:func:`diskpack_cl.pen_radii.pen_ink_radii`); what the writers draw.

    Examples
    --------
    >>> from diskpack_cl import stipple_colors
    >>> img = np.dstack([np.tile(np.linspace(0, 1, 32), (24, 1)), np.full((24, 32), 0.3), np.full((24, 32), 0.8)])
    >>> res = stipple_colors(img, 80, "cmyk", backend="exact", schedule=[("mix", 3, 0.5)])
    >>> res.names, int(res.counts.sum()), res.certificate.valid
    (('yellow', 'cyan', 'magenta', 'black'), 80, True)
    >>> sorted(set(res.pen.tolist())) == list(range(len(res.names)))
    True
    """

    pen: np.ndarray
    names: tuple
    colors: np.ndarray
    layers: np.ndarray
    pen_radius: np.ndarray

    @property
    def counts(self):
        """Dots per pen."""
        return np.bincount(self.pen, minlength=len(self.names))

    def summary(self):
        """A JSON-ready dict: sizes, k, pens and their counts, certificate, timings."""
        return result_summary(self, pens=[{"name": name, "color": hex_color(c), "n": int(m)}
                                          for name, c, m in zip(self.names, self.colors,
                                                                self.counts)])


def pen_counts(layers, n, exponent=1.0):
    """Dots per pen in proportion to the ink of each layer to the power `exponent` (largest
    remainders), summing to n.

    With ``exponent`` 1 every pen's dots are the same size; below 1 the pens
    with less ink get more, smaller dots (each keeps its ink through its own
    dot size, :func:`diskpack_cl.pen_radii.pen_ink_radii`).

    Examples
    --------
    >>> pen_counts(np.array([np.full((2, 2), 0.1), np.full((2, 2), 0.3)]), 9).tolist()
    [2, 7]
    >>> pen_counts(np.array([np.full((2, 2), 0.1), np.full((2, 2), 0.9)]), 8, 0.5).tolist()
    [2, 6]
    """
    if not 0.0 <= exponent <= 1.0:
        raise ValueError(f"the pen share exponent must be in [0, 1], got {exponent}")
    ink = np.asarray(layers, dtype=np.float64).reshape(len(layers), -1).sum(axis=1)
    if not ink.sum() > 0:
        raise ValueError("nothing to stipple: every layer is empty")
    weight = np.where(ink > 0, ink ** exponent, 0.0)
    share = n * weight / weight.sum()
    counts = np.floor(share).astype(np.int64)
    counts[np.argsort(counts - share, kind="stable")[: n - counts.sum()]] += 1
    return counts


def dot_density(layers, counts):
    """Where the dots go: each layer weighted by its pen's dots per unit of ink, summed,
    scaled to a largest weight of 1 (the joint darkness when dots follow ink).

    A pen with more dots than its share of the ink (:func:`pen_counts` below
    exponent 1, or counts given) asks for more dots where its ink is, so that
    its dots, at its own tone size, hold its layer's ink there.

    Returns
    -------
    density : (H, W) float64
        In [0, 1].
    weight : (P,) float64
        Dots per unit of ink of each pen, the largest 1 (0 for a pen without ink).

    Examples
    --------
    >>> d, w = dot_density(np.array([np.full((1, 2), 0.1), np.full((1, 2), 0.4)]), [2, 2])
    >>> w.tolist(), d.round(3).tolist()
    ([1.0, 0.25], [[0.2, 0.2]])
    """
    a = np.asarray(layers, dtype=np.float64)
    ink = a.reshape(len(a), -1).sum(axis=1)
    weight = np.divide(np.asarray(counts, dtype=np.float64), ink, out=np.zeros(len(a)),
                       where=ink > 0)
    if not weight.max() > 0:
        raise ValueError("every dot goes to a pen without ink: give dots to a pen with ink")
    weight /= weight.max()
    return np.clip(np.tensordot(weight, a, axes=1), 0.0, 1.0), weight


def _take(e, left):
    """Pens for the dots of one wave (rows of `e`, what each pen is owed at each):
    the most owed pen with dots left, the pen's dots going to the rows that owe it
    most where more ask for it than it has left; `left` is decreased in place."""
    pen = np.full(len(e), -1, dtype=np.int64)
    todo = np.arange(len(e))
    while len(todo):
        want = np.argmax(np.where(left > 0, e[todo], -np.inf), axis=1)
        for p in np.unique(want):
            rows = todo[want == p]
            if len(rows) > left[p]:   # the pen fills up: those that owe it most get it
                rows = rows[np.argsort(-e[rows, p], kind="stable")[: left[p]]]
            pen[rows] = p
            left[p] -= len(rows)
        todo = todo[pen[todo] < 0]
    return pen


def _receivers(nbr, dist, rank):
    """Where each dot's error goes: ``(to, weight)``, both (n, k + 1).

    The dot at `rank` ``r`` on the Hilbert path is in wave ``r %``
    :data:`SEGMENT` (the path cut into pieces of that many dots, walked all at
    once). Its error goes to its nearest dots of later waves by inverse
    distance, or where there are none to the next dot of its piece (the
    carry along the path of Floyd-Steinberg on a path).
    """
    wave = rank % SEGMENT
    w = np.where(wave[nbr] > wave[:, None], 1.0 / np.maximum(dist, 1e-12), 0.0)
    total = w.sum(axis=1, keepdims=True)
    w = np.divide(w, total, out=np.zeros_like(w), where=total > 0)
    by_rank = np.argsort(rank)
    nxt = by_rank[np.minimum(rank + 1, len(rank) - 1)]
    carry = (total[:, 0] == 0) & (wave < SEGMENT - 1) & (rank + 1 < len(rank))
    return np.column_stack([nbr, nxt]), np.column_stack([w, carry.astype(np.float64)])


def _diffuse(nbr, dist, q, left, rank):
    """The waves of :func:`assign_pens`, each at once (numpy over the dots of a wave).

    Each dot takes the pen (with dots left) of the largest ``err + q``; the
    difference between that and the pen it got goes on as
    :func:`_receivers` says.
    """
    n, P = q.shape
    to, w = _receivers(nbr, dist, rank)
    order = np.lexsort((rank, rank % SEGMENT))
    bounds = np.searchsorted((rank % SEGMENT)[order], np.arange(SEGMENT + 1))
    err = np.zeros((n, P))
    pen = np.empty(n, dtype=np.int64)
    for a, b in zip(bounds[:-1], bounds[1:]):
        dots = order[a:b]
        e = err[dots] + q[dots]
        pen[dots] = _take(e, left)
        e[np.arange(len(dots)), pen[dots]] -= 1.0
        np.add.at(err, to[dots].ravel(), w[dots].reshape(-1, 1) * np.repeat(e, to.shape[1], axis=0))
    return pen


def assign_pens(points, share, counts):
    """A pen for every dot: vector error diffusion along a Hilbert path, in pieces walked
    at once (see the module docstring and :func:`_receivers`).

    Parameters
    ----------
    points : (n, 2) array_like
        All dots (well spaced together).
    share : (n, P) array_like
        Each pen's share of the ink at each dot (rows summing to 1).
    counts : (P,) array_like of int
        Dots per pen, summing to n.

    Returns
    -------
    (n,) int64
        Pen per dot, with exactly ``counts[p]`` dots of pen ``p``.

    Examples
    --------
    >>> p = np.random.default_rng(0).random((200, 2)) * 20
    >>> pen = assign_pens(p, np.tile([0.25, 0.75], (200, 1)), [50, 150])
    >>> np.bincount(pen).tolist()
    [50, 150]
    """
    x = np.asarray(points, dtype=np.float64)
    q = np.asarray(share, dtype=np.float64)
    left = np.array(counts, dtype=np.int64)
    n, P = q.shape
    if left.shape != (P,) or left.sum() != n or np.any(left < 0):
        raise ValueError(f"counts must be {P} non-negative integers summing to {n}, got {counts}")
    if n < 2:
        return np.repeat(np.arange(P), left)
    k = min(DIFFUSE, n - 1)
    dist, nbr = cKDTree(x).query(x, k=list(range(2, k + 2)))   # without the dot itself
    rank = np.empty(n, dtype=np.int64)
    with unreported():   # an order that ranks the dots, no pen path of the run's
        rank[pen_path_order(x, method="hilbert")[0]] = np.arange(n)
    return _diffuse(nbr, dist, q, left, rank)


def _pen_centroids(engine, dens, x, pen):
    """Each dot's centroid in the Voronoi cell of its own pen's dots, under its pen's
    layer (`dens`, one density per pen on `engine`'s raster)."""
    c = x.copy()
    for p in np.unique(pen):
        m = np.flatnonzero(pen == p)
        if len(m) > 1:
            cp, mass = engine.centroids(x[m], np.zeros(len(m)), dens[p])
            ok = (mass > 0) & np.all(np.isfinite(cp), axis=1)
            c[m[ok]] = cp[ok]
    return c


def _pen_pull(timings, pen, pens, pull):
    """The class-aware steps (``before`` of :func:`~diskpack_cl.stipple.run_schedule`): after
    every step of the schedule on all dots, each dot moves a share of the way to
    its own pen's centroid (:func:`_pen_centroids` with `pens`, its engine and
    the pens' densities on that engine's raster, timed as one stage ``pens`` in
    `timings`): `pull` at the first step, falling linearly to 0 at
    :data:`PULL_UNTIL` of the phases, so that the last steps are on all dots alone."""
    def before(state, index, total):
        b = pull * max(0.0, 1.0 - index / (PULL_UNTIL * total))
        with timings("pens"):   # the pens' engine keeps its own stages apart
            c = _pen_centroids(*pens, state.points, pen) if b > 0 else None
        return None if c is None else (
            lambda stepped: replace(stepped, points=stepped.points + b * (c - stepped.points)))

    return before


def _split(phases, first):
    """The phases cut after `first` iterations: (head, tail)."""
    head, tail, left = [], [], int(first)
    for ph in phases:
        a = min(left, ph[1])
        if a:
            head.append((ph[0], a, *ph[2:]))
        if ph[1] - a:
            tail.append((ph[0], ph[1] - a, *ph[2:]))
        left -= a
    return head, tail


def _phases(stage, phases):
    """`stage` running `phases` only."""
    return replace(stage, options=replace(stage.options, phases=tuple(phases)))


def _pen_share(layers, weight, points, sigma):
    """Each pen's share of the dots at each point, (n, P): its (blurred) ink times its
    dots per unit of ink (`weight`, :func:`dot_density`)."""
    blurred = np.stack([ndimage.gaussian_filter(a, sigma, mode="reflect") for a in layers])
    dots = np.stack([w * field_at(b, points) for w, b in zip(weight, blurred)], axis=1) + 1e-9
    return dots / dots.sum(axis=1, keepdims=True)


def dots_per_pen(names, layers, n, counts=None, exponent=1.0):
    """Dots per pen: by the ink of each layer (to the power `exponent`), or as given (all
    pens, or some by name).

    Parameters
    ----------
    names : sequence of str
        The pens.
    layers : (P, H, W) array_like
        Their layers (:func:`pen_counts` shares dots by their ink).
    n : int
        Dots of all pens together.
    counts : sequence of int or mapping of str to int, optional
        ``None``: every pen by its ink (:func:`pen_counts`). A sequence: the
        dots of every pen, summing to n. A mapping ``{name: dots}``: those
        pens get that many and the others share the rest by their ink (to the
        power `exponent`); when it names every pen it must sum to n.
    exponent : float in [0, 1]
        The pens shared by ink get dots in proportion to ink to this power
        (:func:`pen_counts`).

    Returns
    -------
    (P,) int64

    Raises
    ------
    ValueError
        A pen not in `names`, a negative or non-integer count, counts that
        do not add up to n, or dots left for pens without ink.

    Examples
    --------
    >>> layers = np.array([np.full((2, 2), 0.1), np.full((2, 2), 0.3), np.full((2, 2), 0.2)])
    >>> dots_per_pen(("cyan", "magenta", "black"), layers, 100, {"cyan": 40}).tolist()
    [40, 36, 24]
    """
    P = len(names)
    if counts is None:
        return pen_counts(layers, n, exponent)
    if not isinstance(counts, Mapping):
        c = np.asarray(counts)
        if c.shape != (P,) or not np.issubdtype(c.dtype, np.integer) or np.any(c < 0) or c.sum() != n:
            raise ValueError(f"counts must be {P} non-negative integers summing to n = {n}, got {counts}")
        return c.astype(np.int64)
    unknown = [name for name in counts if name not in names]
    if unknown:
        raise ValueError(f"counts name {', '.join(map(str, unknown))}, not one of the pens "
                         f"({', '.join(names)})")
    bad = {k: v for k, v in counts.items() if isinstance(v, bool) or int(v) != v or v < 0}
    if bad:
        raise ValueError(f"dots per pen must be non-negative integers, got {bad}")
    given = sum(int(v) for v in counts.values())
    rest = [p for p, name in enumerate(names) if name not in counts]
    if given > n or (not rest and given != n):
        raise ValueError(f"the dots per pen sum to {given}, but n = {n}"
                         + ("" if given > n else "; name fewer pens or give n = the sum"))
    out = np.array([int(counts.get(name, 0)) for name in names], dtype=np.int64)
    if rest and n > given:
        out[rest] = pen_counts(np.asarray(layers)[rest], n - given, exponent)
    return out


def _objects(colors, options, overrides):
    """The :class:`~diskpack_cl.pens.ColorOptions` and
    :class:`~diskpack_cl.schedule.StippleOptions` of :func:`stipple_colors`: `colors` (an
    object, or the pens; cmyk unless it names some) and `options`, each with the
    `overrides` of its fields on top."""
    if not isinstance(colors, ColorOptions):
        pens = "cmyk" if colors is None else colors
        palette = isinstance(pens, str) and (pens.lower() in PALETTES or parse_auto(pens) is not None)
        colors = ColorOptions(colors=pens.lower()) if palette else ColorOptions(pens=pens)
    mine = {k: overrides.pop(k) for k in [*overrides] if k in _COLOR_FIELDS}
    color = replace(colors, **mine)
    if color.separation() is None:
        color = replace(color, colors="cmyk")
    return color, (options or StippleOptions()).replace(**overrides)


_COLOR_FIELDS = frozenset(f.name for f in fields(ColorOptions))


def _separate(image, n, color, counts, joint, pen_pull, options):
    """Check the arguments of :func:`stipple_colors`; the separation, the options resolved,
    the counts and :func:`dot_density`."""
    if options.paper_tone:
        raise ValueError("paper_tone is for one pen: colour stippling draws on white or, with "
                         "invert, black paper")
    for name, v in (("joint", joint), ("pen_pull", pen_pull)):
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"{name} must be in [0, 1], got {v}")
    separation = color.separation()
    if counts is not None and separation["counts"] is not None:
        raise ValueError("give the dots per pen once: counts or pen_dots, not both")
    sep = separate(image, separation["colors"], black_generation=color.black_generation,
                   clean_black=color.clean_black, clean_white=color.clean_white,
                   invert=options.invert)
    if not sep.darkness.max() > 1e-9:
        raise ValueError(f"nothing to stipple: the image is {'black' if options.invert else 'white'}")
    if options.capacity is None:   # measured: equal ink per dot costs tone per pen
        options = options.replace(capacity=COLOR_CAPACITY)
    counts = dots_per_pen(sep.names, sep.layers, check_count(n),
                          separation["counts"] if counts is None else counts,
                          color.pen_share_exponent)
    density, weight = dot_density(sep.layers, counts)
    # the dots' density is what the first phases stipple: its ink sizes the raster
    opt = options.plan(n, sep.layers.shape[2], sep.layers.shape[1], ink=float(density.sum()))
    return sep, opt, counts, density, weight


def stipple_colors(image, n, colors=None, options=None, *, counts=None, joint=0.3, pen_pull=1.0,
                   callback=None, device=None, backend="auto", **overrides):
    """Stipple a colour image with ``n`` dots of several pens, all certified disjoint.

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A colour image (:func:`diskpack_cl.image.load_rgb`).
    n : int
        Number of dots of all pens together.
    colors : ColorOptions, str or sequence of (name, colour), optional
        The separation (:class:`diskpack_cl.pens.ColorOptions`: the pens,
        black generation, cleaning, dots per pen), or the pens alone:
        ``"cmyk"``, ``"cmy"``, ``"auto:N"`` or ``"NAME=COLOR,..."``
        (:func:`diskpack_cl.separation.separate`); cmyk where none are named.
        Its ``pen_share_exponent`` sets the dots per pen unless given
        (:func:`pen_counts`): in proportion to each layer's ink to that
        power; below 1 the pens with less ink get more, smaller dots. The
        dots go where each pen's ink asks for them (:func:`dot_density`),
        and every pen's dots are drawn at the size that holds its layer's
        ink.
    options : StippleOptions, optional
        The stippling options, as for :func:`diskpack_cl.stipple`, applied
        to the joint density; ``capacity`` defaults to
        :data:`COLOR_CAPACITY` (off). ``invert``: light pens on black
        paper (:func:`diskpack_cl.separation.separate`; ``auto:N`` chooses white
        and N - 1 light pens, ``cmyk`` and ``cmy`` are refused);
        ``paper_tone`` is refused.
    counts : sequence of int or mapping of str to int, optional
        Dots per pen (:func:`dots_per_pen`): all (summing to n), or some by
        name, the others sharing the rest by their ink to the power of the
        pen share exponent; the
        :class:`~diskpack_cl.pens.ColorOptions`' ``pen_dots`` as numbers
        (give one of the two).
    joint : float in [0, 1]
        Share of the schedule's iterations run on all dots as one class
        before the pens are assigned (default 0.3).
    pen_pull : float in [0, 1]
        In the class-aware steps, each dot moves this share of the way to
        the centroid of its Voronoi cell among its own pen's dots (under its
        layer), falling to 0 over the first :data:`PULL_UNTIL` of them
        (default 1).
    callback, device, backend
        As for :func:`diskpack_cl.stipple`.
    **overrides
        Fields of :class:`~diskpack_cl.pens.ColorOptions`
        (``black_generation``, ``clean_black``, ``clean_white``,
        ``pen_share_exponent``, ``pen_dots``) over those of `colors`, and of
        :class:`~diskpack_cl.schedule.StippleOptions` (``schedule``,
        ``seed``, ...) over those of `options`.

    Returns
    -------
    ColorStippleResult

    Examples
    --------
    >>> img = np.zeros((32, 48, 3)); img[..., 0] = np.linspace(0, 1, 48); img[..., 2] = 0.6
    >>> res = stipple_colors(img, 120, "cmy", schedule=[("mix", 4, 0.5)], backend="exact")
    >>> res.names, int(res.counts.sum()), res.certificate.valid
    (('yellow', 'cyan', 'magenta'), 120, True)

    The same with the options objects:

    >>> from diskpack_cl.pens import ColorOptions
    >>> from diskpack_cl.schedule import StippleOptions
    >>> again = stipple_colors(img, 120, ColorOptions(colors="cmy"),
    ...                        StippleOptions(schedule=[("mix", 4, 0.5)]), backend="exact")
    >>> bool(np.array_equal(again.points, res.points))
    True

    Light pens on black paper:

    >>> dark = stipple_colors(img, 120, "auto:3", invert=True, schedule=[("mix", 4, 0.5)],
    ...                       backend="exact")
    >>> dark.names, dark.params["invert"]
    (('#4600ff', '#ff00a4', 'white'), True)
    """
    t_start = time.perf_counter()
    watch = Stopwatch()   # the run's one collector: its stages, the main engine's and "pens"
    with watch("separate"), run_stage("load"):   # the run's stages (diskpack_cl.progress)
        color, options = _objects(colors, options, overrides)
        sep, opt, counts, density, weight = _separate(image, n, color, counts, joint, pen_pull,
                                                      options)
    P, H, W = sep.layers.shape
    gray = 1.0 - density
    with run_stage("setup" if backend == "exact" else "device"):
        engine = make_engine(Domain.rect(W, H), opt.n, backend, device=device,
                             grid=opt.grid_shape(W, H), timings=watch)
    with run_stage("setup"):
        stage = make_stage(gray, opt, engine)
    head, tail = _split(opt.phases, round(joint * sum(ph[1] for ph in opt.phases)))
    with run_stage("start"):
        start = StippleState(error_diffusion(gray, opt.n, seed=opt.seed), float(opt.k0))
    state, history = run_schedule(start, _phases(stage, head), callback)
    with watch("assign"), run_stage("iterations", 0):   # between the phases: their time
        pen = assign_pens(state.points,
                          _pen_share(sep.layers, weight, state.points, 0.5 * np.sqrt(W * H / opt.n)),
                          counts)
    coarse = replace(opt, supersample=max(1, opt.supersample // PEN_COARSEN))
    with run_stage("setup", 0):   # the pens' engine and densities: more setup
        pens = (make_engine(Domain.rect(W, H), opt.n, backend, device=device,
                            grid=coarse.grid_shape(W, H), timings=Stopwatch()),
                [centroid_density(a, coarse) for a in sep.layers])
    state, more = run_schedule(state, _phases(stage, tail), callback, first=len(history),
                       before=_pen_pull(stage.engine.timings, pen, pens, pen_pull))
    with watch("certify"), run_stage("certificate"):
        r = dot_radii(state, stage, state.points)
        k, radii, cert = certified_k(state.points, r, W, H, Domain.rect(W, H))
    with run_stage("certificate", 0):   # the drawn radii, beside the certified ones
        pen_radius = pen_ink_radii(state.points, pen, sep.layers)
    watch.add("total", time.perf_counter() - t_start)
    params = dict(opt.params(), colors=list(sep.names), black_generation=color.black_generation,
                  clean_black=color.clean_black, clean_white=color.clean_white,
                  pen_share_exponent=color.pen_share_exponent, joint=joint, pen_pull=pen_pull,
                  counts=counts.tolist())
    return ColorStippleResult(
        points=state.points, radii=radii, pen=pen, names=sep.names, colors=sep.colors, k=float(k),
        base_radii=r, certificate=cert, layers=sep.layers,
        pen_radius=pen_radius, width=W, height=H,
        history=history + more,
        timings=watch.seconds, params=params, engine=engine.backend,
        tone_radius=tone_radius(opt.n, sep.darkness),
        stages=dict(stage.stages, pens=engine_record(pens[0])))
