"""Image stippling by unequal disk packing on power diagrams (paper Algorithm 2).

Coordinates are pixel units: origin at the top-left pixel corner, x to the
right, y down, so pixel (row r, col c) covers [c, c+1) x [r, r+1). Gray values
are floats in [0, 1] with 1 = white; darkness is ``1 - gray``.

The stage is split by concept:

- :mod:`diskpack_cl.dithering`: the start, :func:`error_diffusion`.
- :mod:`diskpack_cl.radii`: radius mappings (:func:`radius_field`) and the
  certified scale ``k`` (:func:`largest_valid_k`, :func:`certified_k`).
- :mod:`diskpack_cl.schedule`: named schedules, their option defaults and
  :class:`StippleOptions`, every option resolved and checked at once.
- :mod:`diskpack_cl.engine`: MICs and centroids, OpenCL or exact.
- this module: :func:`stipple`, a short driver over the steps
  :func:`pack_step` (disk packing, and mix) and :func:`lloyd_step`, each
  taking a :class:`StippleState` and returning the next one with its
  measurements (one history entry).

One iteration:

1. Start: :func:`error_diffusion` of the darkness gives exactly ``n`` points.
2. Disk-packing step: base radius ``r_i`` from the radius field at the pixel
   holding point ``i``, weights ``w_i = (k r_i)^2``; the engine gives the
   maximal inscribed circle (MIC) of each power cell in the image rectangle
   (OpenCL raster estimate refined to the exact float64 Chebyshev centre, or
   exact from the start), points move to the MIC centres, and ``k`` becomes
   the ``k_quantile`` quantile of ``R_i / r_i`` (0: the minimum, the paper's).
3. Mix step (the default schedule): a disk-packing step whose move is
   blended with the density-weighted centroid of the *same power cell*:
   ``x <- m + blend * (c - m)``, ``m`` the MIC centre, ``c`` the centroid.
   ``blend = 0`` is a disk-packing step. With ``support > 0`` the blend of a
   dot whose MIC centre lies off its cell's ink rises towards 1
   (:func:`off_support`), and a dot whose power cell holds no ink at all
   is put beside the dot of the heaviest cell (:func:`reseat_dead`).
   With ``capacity > 0`` every packing or mix step also moves each dot's
   radius factor towards the same ink (darkness) in every power cell
   (:func:`equal_ink`, capacity-constrained weights).
4. Lloyd step: density-weighted centroids of the Voronoi cells on the same
   grid (Secord 2002); ``k`` is then the largest valid one.
5. Final: radii re-sampled at the final positions and ``k`` set to the
   largest value for which all disks ``k r_i`` lie inside the image and are
   pairwise disjoint, certified by :func:`diskpack_cl.certify_disks`.

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

The default schedule follows the dot spacing ``s = sqrt(W H / n)`` px
(:data:`diskpack_cl.schedule.SPACING_BANDS`): below 3 px, 16 mix steps at
blend 0.7, one or two disk-packing steps with radii blurred by 1.5 px, and a
last step at blend 0.5; from 3 to 6 px 18 + 6 mix steps, feature-aware, and
a last one at 0.5; from 6 px on 20 + 6 mix steps, feature-aware, radii
blurred by 2 px, the centroids of the unblurred darkness, ``support=16``
and a last step three quarters of the way to the centroids. All use
density radii (floor 0.01), ``k`` from the 15% quantile of ``R_i / r_i``
and ``capacity=0.1`` (equal ink per dot); below 6 px, centroid density
blurred by 0.5 px and ``support=8`` (a dot whose largest empty disk leaves
its cell's ink, or loses an eighth of its tone, goes to the centroid: white
paper stays white, outlines stay sharp). The schedules ``"classic"`` and
``"detail"`` use one band for every spacing. Options that come with a
named schedule are in :data:`SCHEDULE_OPTIONS`; explicit keyword arguments
override them. Measured in ``docs/stipple_quality.md``.

Empty power cells (possible with unequal weights) keep their point where it
is; they are counted in the history (``"empty"``), never produce NaN and
never lose a point.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ._cores import on_cores
from ._timing import Stopwatch
from .device.blur import DeviceBlur
from .device.checks import UntrustedProgram, warn_fallback
from .device.stage import has_fp64
from .picture_measures import tone_radius
from .preview import Previewable
from .progress import running, stage as run_stage
from .dithering import least_k, error_diffusion
from .domain import Domain
from .radii import (blurs, certified_k, density_radius, detail_blend, detail_ell, detail_sigmas, dilation_radius,
                    disk_dilation, field_at, fields_at, gaussian_blur, largest_valid_k, radius_field)
from .schedule import StippleOptions, StipplePlan
from .engine import HOST_DEVICE, engine_record, make_engine, stage_record
from .image import to_gray
from .memory import PageReserve, drop_pages, freed_memory_kept, give_back

__all__ = ["StippleResult", "StippleState", "StippleStage", "stipple", "pack_step", "lloyd_step",
           "equal_ink", "off_support", "reseat_dead"]


@dataclass
class StippleResult(Previewable):
    """Result of :func:`stipple`. A notebook shows its picture (``_repr_png_``), as
    :meth:`preview` returns it: the dots as the writers draw them, 400 px wide.

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
        The radius field (:func:`diskpack_cl.radii.radius_field`) at the
        final positions, times the dots' ink factors with ``capacity > 0``.
    certificate : Certificate
        The :func:`diskpack_cl.certify_disks` certificate.
    history : list of dict
        One entry per iteration: ``kind`` ("pack", "mix" or "lloyd"),
        ``iteration``, ``k``, ``empty`` (empty power cells), ``moved`` (mean
        displacement, px), ``seconds`` and the seconds of each engine stage
        that ran in it, ``<stage>_s`` (the stages of
        :mod:`diskpack_cl.engine`: ``raster_labels_s``, ``exact_s``,
        ``centroids_s``, ...; with ``profile``, ``kernel_s`` and
        ``kernel_<name>_s``).
    width, height : int
        Image size in pixels.
    timings : dict
        Total seconds per stage: ``load``, ``start``, ``setup`` (the engine,
        the radius field and the other fields the steps read), the engine's
        stages, ``certify`` and ``total``.
    params : dict
        The parameters used (for reports and ``--json``).
    engine : str
        ``"opencl"`` or ``"exact"``: the engine's backend (see :mod:`diskpack_cl.engine`).
    tone_radius : float
        Radius (px) at which n equal dots hold the image's darkness as ink
        (:func:`diskpack_cl.picture_measures.tone_radius`; the darkness without
        ``paper_tone``): what the writers draw by default.
    stages : dict
        Where each stage ran (:attr:`StippleStage.stages`): ``engine`` (the
        MICs and centroids) and ``blur`` (the fields' Gaussian blurs), each a
        :func:`~diskpack_cl.engine.stage_record` (``backend``, ``device``,
        and ``fallback``: why it ran on the host, where it did so for want
        of a usable device).

    Examples
    --------
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> res = stipple(g, 60, schedule=[("mix", 3, 0.5)], backend="exact")
    >>> res.points.shape, res.radii.shape, (res.width, res.height), len(res.history)
    ((60, 2), (60,), (48, 32), 3)
    >>> res.summary()["certificate"]["valid"]
    True
    >>> res.summary()["stages"]["engine"]
    {'backend': 'exact', 'device': 'cpu (scipy)', 'route': 'exact'}
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
    engine: str = "opencl"
    tone_radius: float = None
    stages: dict = field(default_factory=dict)

    @property
    def n(self):
        return len(self.points)

    def summary(self):
        """A JSON-ready dict: sizes, k, certificate fields, timings."""
        return result_summary(
            self, empty_cells_total=int(sum(h.get("empty", 0) for h in self.history)))


def result_summary(result, **extra):
    """The JSON-ready summary of a stippling (one pen or several): sizes, k, radii,
    iterations, `extra`, where each stage ran, the certificate's fields, timings and params.

    Examples
    --------
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> s = result_summary(stipple(g, 60, schedule=[("mix", 2, 0.5)], backend="exact"))
    >>> s["iterations"], s["stages"]["blur"]["backend"]
    (2, 'exact')
    """
    return {
        "n": int(result.n),
        "width": int(result.width),
        "height": int(result.height),
        "k": float(result.k),
        "min_radius": float(result.radii.min()),
        "max_radius": float(result.radii.max()),
        "iterations": len(result.history),
        **extra,
        "stages": result.stages,
        "certificate": result.certificate.as_dict(),
        "timings": {k: float(v) for k, v in result.timings.items()},
        "params": result.params,
    }




@dataclass(frozen=True)
class StippleState:
    """The loop's state between steps: points, the scale ``k``, packing steps done.

    ``ink`` (``capacity > 0``): per-dot factors on the radius field that
    :func:`equal_ink` adjusts each step; None means all 1.

    Examples
    --------
    The start of a stippling loop, as :func:`stipple` makes it (exact engine):

    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> opt = StippleOptions().plan(60, 48, 32)
    >>> engine = make_engine(Domain.rect(48, 32), 60, "exact", grid=opt.grid_shape(48, 32))
    >>> stage = make_stage(g, opt, engine)
    >>> state = StippleState(_start_points(g, opt, None), float(opt.k0))

    >>> state.points.shape, state.packs
    ((60, 2), 0)
    """

    points: np.ndarray
    k: float
    packs: int = 0
    ink: np.ndarray = None


@dataclass(frozen=True)
class StippleStage:
    """What every step works against: engine, options, radius field, centroid density.

    Examples
    --------
    The stage of a 48 x 32 gray ramp, as :func:`stipple` makes it (exact engine):

    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> opt = StippleOptions().plan(60, 48, 32)
    >>> engine = make_engine(Domain.rect(48, 32), 60, "exact", grid=opt.grid_shape(48, 32))
    >>> stage = make_stage(g, opt, engine)
    >>> state = StippleState(_start_points(g, opt, None), float(opt.k0))

    >>> stage.size, stage.radius_field.shape == stage.density.shape == g.shape
    ((48, 32), True)
    """

    engine: object
    options: StipplePlan
    radius_field: np.ndarray
    density: np.ndarray
    blend_weight: object = None  # features="detail": per-pixel weight, see radii.detail_fields
    ink: np.ndarray = None       # darkness per pixel blurred by INK_SIGMA (support > 0)
    #: Where the stage's parts ran: ``{"engine": ..., "blur": ...}``, each a
    #: :func:`~diskpack_cl.engine.stage_record` (the results' ``stages``).
    stages: dict = None

    @property
    def size(self):
        H, W = self.radius_field.shape
        return W, H


def _finite_rows(a):
    """Rows of an (n, 2) array whose both values are finite: ``np.all(np.isfinite(a), axis=1)``,
    column by column (a reduction along the short axis is several times slower).

    Examples
    --------
    >>> _finite_rows(np.array([[0.0, 1.0], [np.nan, 1.0], [2.0, np.inf]])).tolist()
    [True, False, False]
    """
    fin = np.isfinite(a)
    return fin[:, 0] & fin[:, 1]


def _moved(old, new):
    """Mean displacement: ``sqrt(dx^2 + dy^2)``, not ``np.hypot`` (a few times slower; no
    overflow to guard against at pixel coordinates, and within an ulp of it)."""
    d = new - old
    d *= d
    s = d[:, 0] + d[:, 1]
    return float(np.mean(np.sqrt(s, out=s)))


def _where_rows(keep, a, b):
    """``np.where(keep[:, None], a, b)`` for (n, 2) arrays, by a copy of `a` and its few rows
    that are not kept (the broadcast where walks rows of two: several times slower)."""
    out = a.copy()
    drop = np.flatnonzero(~keep)
    out[drop] = b[drop]
    return out


#: Blur (px) of the darkness that :func:`off_support` reads: a thin line's
#: ink reaches the pixels beside it, where its cell's centroid and centre fall.
INK_SIGMA = 1.0

#: Bounds of :func:`equal_ink`'s factors: per step (so that a cell whose mass
#: jumps when a neighbour moves does not make its dot's radius oscillate) and
#: overall (so that a cell that stays empty cannot take its radius far from
#: the field).
INK_STEP, INK_RANGE = 1.25, 4.0


def dot_radii(state, stage, points):
    """Base radii at `points`: the radius field, times the state's ink factors."""
    return _radii_and_detail(state, stage, points, False)[0]


def _radii_and_detail(state, stage, points, detail):
    """:func:`dot_radii` at `points` and, with `detail`, the blend weight there (else None):
    the pixels found once for both fields."""
    r, weight = fields_at([stage.radius_field, stage.blend_weight if detail else None], points)
    return (r if state.ink is None else r * state.ink), weight


def equal_ink(ink, mass, gain):
    """Per-dot radius factors after one step, towards the same ink in every power cell.

    Each factor is multiplied by ``(mean mass / cell mass) ** gain`` (a cell
    holding more darkness than its share shrinks its dot's weight; an empty
    cell grows it), bounded by :data:`INK_STEP` per step and
    :data:`INK_RANGE` overall, then all are divided by their geometric mean
    so that ``k`` keeps its meaning. This is a damped step of the weight
    update of capacity-constrained (optimal-transport) stippling, applied to
    the disk-packing weights ``(k r_i)^2``.

    Examples
    --------
    >>> equal_ink(np.ones(2), np.array([1.0, 4.0]), 0.5).round(4).tolist()
    [1.25, 0.8]
    """
    mean = mass.sum() / len(mass)
    # the floor only keeps the ratio finite: the step bound clips it anyway
    floor = max(1e-12 * mean, np.finfo(float).tiny)   # also where every mass is subnormal
    # the plain formula's values, each pass in place in one array (a few fewer whole-set
    # temporaries): where(mass > 0, (mean / max(mass, floor)) ** gain, INK_STEP), clipped
    # to the step bound, times the factors, clipped to the range, over its geometric mean
    f = np.maximum(mass, floor)
    np.divide(mean, f, out=f)
    f **= gain
    f[~(mass > 0)] = INK_STEP
    np.clip(f, 1 / INK_STEP, INK_STEP, out=f)
    if ink is not None:
        f *= ink
    np.clip(f, 1 / INK_RANGE, INK_RANGE, out=f)
    f /= np.exp(np.mean(np.log(f)))
    return f


def off_support(ink, mic_centers, centroids, gain=1.0):
    """How far each MIC centre has left the ink of its cell, in [0, 1].

    ``gain * (1 - D(m) / D(c))`` clipped to [0, 1], ``D`` the darkness field
    `ink` at the MIC centre ``m`` and at the cell's density-weighted
    centroid ``c``: 0 where the centre lies in the tone of the cell's ink, 1
    where it lies on white paper, or, with ``gain > 1``, where it has lost
    a fraction ``1 / gain`` of the tone. A power cell that straddles the
    outline of a dark shape has its largest empty disk on the white side,
    where nothing bounds it; its centroid stays on the ink.

    Examples
    --------
    >>> ink = np.zeros((4, 8)); ink[:, :4] = 1.0; ink[:, 4] = 0.5
    >>> m, c = np.array([[6.0, 2.0], [1.0, 2.0], [4.5, 2.0]]), np.array([[2.0, 2.0]] * 3)
    >>> off_support(ink, m, c).tolist()
    [1.0, 0.0, 0.5]
    >>> off_support(ink, m, c, gain=4).tolist()
    [1.0, 0.0, 1.0]
    """
    dm, dc = field_at(ink, mic_centers), field_at(ink, centroids)
    # a centroid off the ink (the cell of a curved thin line): only a centre off the ink too moves
    ratio = np.divide(dm, dc, out=(dm > 0).astype(np.float64), where=dc > 0)
    # clip(gain * (1 - ratio), 0, 1) in place
    np.subtract(1.0, ratio, out=ratio)
    ratio *= gain
    return np.clip(ratio, 0.0, 1.0, out=ratio)


#: A power cell holding less than this fraction of the mean ink per cell holds
#: none: its dot is dead (:func:`reseat_dead`).
DEAD_INK = 0.01

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def reseat_dead(points, mass, disk, ink, size):
    """Dots whose power cell holds no ink, put beside the dots of the heaviest cells.

    A dot whose cell holds less than :data:`DEAD_INK` of the mean ink per
    cell lies on white paper with no ink to pull it back: its centroid is
    the middle of the paper around it (Lloyd's dead points), and a plotter
    inks it there. Line art with more dots than its thin lines and small
    dots carry sheds such dots. Each is put half a disk radius (`disk`)
    from the dot of one of the heaviest cells, in golden-angle directions,
    with that dot's ink factor: the next step splits that cell between the
    two (the move of Linde, Buzo and Gray).

    Parameters
    ----------
    points : (n, 2) ndarray
    mass : (n,) ndarray
        Ink of each dot's power cell (NaN or below 0 for none: not moved).
    disk : (n,) ndarray
        Disk radius of each dot.
    ink : (n,) ndarray or None
        Ink factors (:func:`equal_ink`).
    size : (W, H)
        The image; the moved dots stay inside it.

    Returns
    -------
    points, ink, count
        New arrays where a dot moved (the inputs otherwise) and how many moved.

    Examples
    --------
    >>> p = np.array([[1.0, 1.0], [5.0, 5.0], [9.0, 9.0]])
    >>> q, _, count = reseat_dead(p, np.array([2.0, 5.0, 0.0]), np.ones(3), None, (10, 10))
    >>> count, q[2].tolist()
    (1, [5.5, 5.0])
    """
    live = mass >= DEAD_INK * np.mean(mass[mass >= 0])
    dead = np.flatnonzero(~live & (mass >= 0))
    if not dead.size:
        return points, ink, 0
    order = _heaviest(mass, live, dead.size)
    heavy = order[np.arange(dead.size) % order.size]
    angle = _GOLDEN_ANGLE * np.arange(dead.size)
    step = 0.5 * disk[heavy, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    points = points.copy()
    points[dead] = np.clip(points[heavy] + step, 0.0, np.asarray(size, dtype=np.float64))
    if ink is not None:
        ink = ink.copy()
        ink[dead] = ink[heavy]
    return points, ink, int(dead.size)


#: Values from which :func:`_quantile` looks for its two order statistics among a bracket.
QUANTILE_BRACKET = 1 << 16


def _quantile(values, q, *, small=QUANTILE_BRACKET):
    """``np.quantile(values, q)`` (the linear method) of a 1-D float64 array, which it may
    reorder: the same float, bit for bit.

    np.quantile partitions all the values at the two order statistics it
    interpolates (and at the least and the largest). Here, from `small` values on,
    a strided sample of 16384 brackets them: the values within the bracket are
    gathered (some 6% of them) and partitioned alone, and the values below
    it counted (1M values: about 3 against 12 ms). A bracket that misses them (an
    unlucky sample) or values with NaN go to np.quantile.

    Examples
    --------
    >>> v = np.random.default_rng(0).random(100_000)
    >>> _quantile(v.copy(), 0.15) == float(np.quantile(v, 0.15))
    True
    """
    n = len(values)
    virtual = (n - 1) * q   # numpy's virtual index and weight of the linear method
    i = int(np.floor(virtual))
    if n < max(small, 2) or not 0.0 < q < 1.0 or np.isnan(values).any():
        return float(np.quantile(values, q, overwrite_input=True))
    sample = np.sort(values[::max(n // 16384, 1)])
    # the quantile's rank in the sample spreads by sqrt(len(sample) q (1 - q)) <= sqrt(len) / 2:
    # the bracket reaches 8 of those either side
    at, margin = int(q * len(sample)), int(4 * np.sqrt(len(sample))) + 8
    lo, hi = sample[max(at - margin, 0)], sample[min(at + margin, len(sample) - 1)]
    below = int(np.count_nonzero(values < lo))
    inside = values[(values >= lo) & (values <= hi)]
    if not below <= i < below + len(inside) - 1:
        return float(np.quantile(values, q, overwrite_input=True))
    inside.partition([i - below, i + 1 - below])
    a, b = float(inside[i - below]), float(inside[i + 1 - below])
    gamma, diff = virtual - i, b - a   # numpy's _lerp: from the nearer end
    return b - diff * (1.0 - gamma) if gamma >= 0.5 else a + diff * gamma


def _heaviest(mass, live, k):
    """The `k` heaviest dots of `live` (a mask), heaviest first, ties in index order: the
    indices ``least_k(-mass[live], k)`` name among the live dots.

    Where `k` is small, the dots at least as heavy as the `k`-th heaviest of every 8th
    live dot are found first (the `k` heaviest of all are among them, in the same order),
    and only these few are ranked: a partition of an eighth of the dots instead of all
    (1M dots).

    Examples
    --------
    >>> _heaviest(np.array([1.0, 5.0, 3.0, 5.0]), np.array([True, True, True, False]), 2).tolist()
    [1, 2]
    """
    idx = np.flatnonzero(live)
    m = mass[idx]
    if 16 * k < len(m):
        sample = m[::8]   # more than 2k: its k-th heaviest is at most all dots' k-th heaviest
        least = np.partition(sample, len(sample) - k)[len(sample) - k]
        keep = np.flatnonzero(m >= least)
        idx, m = idx[keep], m[keep]
    return idx[least_k(-m, k)]


def _blend_weights(stage, detail, mic_centers, cen, blend):
    """Per-dot move ``a`` of ``m + a (c - m)``: the blend, raised by detail (`detail`: the blend
    weight at the dots, None without one; it becomes ``a``) and by leaving the ink."""
    if detail is None:
        a = np.full(len(mic_centers), float(blend))
    else:   # blend + (1 - blend) * detail, in place
        a = detail
        a *= 1.0 - blend
        a += blend
    if stage.options.support > 0:
        np.maximum(a, off_support(stage.ink, mic_centers, cen, gain=stage.options.support), out=a)
    return a


def pack_step(state, stage, blend=0.0, *, reseat=True):
    """One disk-packing step, blended towards the power-cell centroids when ``blend > 0`` (mix).

    With ``support > 0`` a dot whose MIC centre leaves its cell's ink moves
    towards the centroid instead (:func:`off_support`), and, with
    `reseat`, a dot whose cell holds no ink goes beside the dot of a
    heavy cell (:func:`reseat_dead`; not in a schedule's last step, which
    leaves no step to space the two). Returns ``(state, entry)``: the next
    state and this step's measurements (``moved``, ``empty``, and
    ``reseated`` with ``support``); see the module docstring.

    Examples
    --------
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> opt = StippleOptions().plan(60, 48, 32)
    >>> engine = make_engine(Domain.rect(48, 32), 60, "exact", grid=opt.grid_shape(48, 32))
    >>> stage = make_stage(g, opt, engine)
    >>> state = StippleState(_start_points(g, opt, None), float(opt.k0))

    >>> state, entry = pack_step(state, stage, blend=0.5)
    >>> state.packs, entry["empty"], entry["moved"] > 0
    (1, 0, True)
    """
    x, opt = state.points, stage.options
    # the blend weight at the dots (features="detail") read with their radii
    r, detail = _radii_and_detail(state, stage, x, blend > 0 and stage.blend_weight is not None)
    w = (state.k * r) ** 2
    refine = bool(opt.refine_every) and state.packs % opt.refine_every == 0
    need_power = opt.capacity > 0 or opt.support > 0 or (blend > 0 and opt.blend_cell == "power")
    # the centroids' pass begun before an exact MIC step (on the cells route it runs
    # beside the MICs' work); after an estimate, which may label the grid for it
    power = stage.engine.start_centroids(x, w, stage.density) if need_power and refine else None
    # the result is certified at the end; each step starts from the last one's bases
    mic = stage.engine.mic(x, w, exact=refine, certify=False, warm=True)
    entry = {}
    ok = ~mic.empty & _finite_rows(mic.centers)
    newx = _where_rows(ok, mic.centers, x)
    if need_power:
        power = power() if power is not None else stage.engine.centroids(x, w, stage.density)
    ink = state.ink
    if opt.capacity > 0:
        ink = equal_ink(ink, power[1], opt.capacity)
        entry["ink_spread"] = float(np.std(power[1]) / np.mean(power[1]))
    if blend > 0 or opt.support > 0:
        cen, mass = power if opt.blend_cell == "power" or blend == 0 else \
            stage.engine.centroids(x, np.zeros(len(x)), stage.density)
        okc = ok & (mass > 0) & _finite_rows(cen)
        cen = _where_rows(okc, cen, newx)   # no move where the cell has no centroid
        a = _blend_weights(stage, detail, newx, cen, blend)
        step = cen - newx
        for col in step.T:   # a column at a time: a (n, 2) by (n, 1) broadcast walks rows of two
            col *= a
        newx += step
    if opt.support > 0:
        entry["reseated"] = 0
        if reseat:
            mass = np.where(ok, power[1], -1.0)   # an empty cell is hidden, not dead
            newx, ink, entry["reseated"] = reseat_dead(newx, mass, state.k * r, ink, stage.size)
    entry["moved"] = _moved(x, newx)
    k = state.k
    if np.any(ok):
        ratio = mic.radii[ok] / r[ok]
        # the ratios are this step's own: the quantile may reorder them
        k = _quantile(ratio, opt.k_quantile) if opt.k_quantile > 0 else float(np.min(ratio))
    entry["empty"] = int(np.count_nonzero(~ok))
    return StippleState(newx, k, state.packs + 1, ink), entry


def lloyd_step(state, stage, new_k=True):
    """One Lloyd step: every point to its Voronoi cell's density-weighted centroid.

    With `new_k`, ``k`` becomes the largest valid one at the new positions
    (at least 1e-6), which the next disk-packing step starts from; without,
    it is kept (Lloyd steps do not use it, and finding it is an exact pair
    search).  Returns ``(state, entry)`` like :func:`pack_step`.

    Examples
    --------
    >>> g, opt = np.tile(np.linspace(0.0, 1.0, 48), (32, 1)), StippleOptions().plan(60, 48, 32)
    >>> stage = make_stage(g, opt, make_engine(Domain.rect(48, 32), 60, "exact", grid=(32, 48)))
    >>> new, entry = lloyd_step(StippleState(_start_points(g, opt, None), float(opt.k0)), stage)
    >>> new.packs, entry["empty"], bool(new.k > 0)
    (0, 0, True)
    """
    x = state.points
    cen, mass = stage.engine.centroids(x, np.zeros(len(x)), stage.density)
    entry = {}
    ok = (mass > 0) & _finite_rows(cen)
    newx = _where_rows(ok, cen, x)
    entry["moved"] = _moved(x, newx)
    entry["empty"] = int(np.count_nonzero(~ok))
    k = state.k
    if new_k:
        W, H = stage.size
        k = max(largest_valid_k(newx, dot_radii(state, stage, newx), W, H), 1e-6)
    return StippleState(newx, k, state.packs, state.ink), entry


def run_schedule(state, stage, callback, *, first=0, before=None):
    """Every phase of the schedule; returns (final state, history).

    Each history entry holds the seconds of the engine stages that ran in
    its step (``<stage>_s``), read off the engine's one collector; its
    ``iteration`` counts from `first`. ``before(state, index, total)``, if
    given, runs before each step (within its time) and returns None or a
    function that the stepped state goes through (the colour stippling's
    pull to each pen's centroid)."""
    watch = stage.engine.timings
    total = sum(ph[1] for ph in stage.options.phases)
    with run_stage("iterations", total) as advance:
        return _steps(state, stage, callback, first, before, watch, total, advance)


def _steps(state, stage, callback, first, before, watch, total, advance):
    """The body of :func:`run_schedule`; ``advance(done)`` after each step."""
    history = []
    for phase in stage.options.phases:
        kind, iters = phase[0], phase[1]
        blend = float(phase[2]) if len(phase) == 3 else stage.options.blend
        for it in range(iters):
            t0, mark = time.perf_counter(), watch.mark()
            after = None if before is None else before(state, len(history), total)
            if kind == "lloyd":
                # only the phase's last step sets k, for the packing after it
                state, step = lloyd_step(state, stage, new_k=it == iters - 1)
            else:
                state, step = pack_step(state, stage, blend if kind == "mix" else 0.0,
                                        reseat=len(history) < total - 1)
            if after is not None:
                state = after(state)
            entry = {"kind": kind, "iteration": first + len(history), **step,
                     "k": float(state.k)}
            entry.update({f"{name}_s": secs for name, secs in watch.since(mark).items()})
            entry["seconds"] = time.perf_counter() - t0
            history.append(entry)
            advance(len(history))
            if callback is not None:
                callback(entry)
    return state, history


def _start_points(gray, opt, start):
    """Error diffusion with the options' seed, or the given start, checked."""
    H, W = gray.shape
    if start is None:
        return error_diffusion(gray, opt.n, seed=opt.seed)
    x = np.array(start, dtype=np.float64)
    if x.shape != (opt.n, 2) or not np.all(np.isfinite(x)):
        raise ValueError(f"start must be a finite ({opt.n}, 2) array")
    if np.any(x < 0) or np.any(x[:, 0] > W) or np.any(x[:, 1] > H):
        raise ValueError("start points must lie inside the image")
    return x


def _blurred(darkness, sigma, blur):
    return blur(darkness, sigma) if sigma > 0 else darkness


def _field_blur(engine):
    """``(blur, record)``: the fields' Gaussian blur and where it runs (a
    :func:`~diskpack_cl.engine.stage_record`). On the engine's OpenCL device where it has
    float64 (:class:`~diskpack_cl.device.blur.DeviceBlur`, scipy's values, a few times faster on
    a large picture), else scipy's on the host (:func:`~diskpack_cl.radii.gaussian_blur`);
    the record says why where the engine's device could not take it."""
    ctx = getattr(engine, "ctx", None)
    if ctx is None:   # the exact engine: its record says why, where it fell back
        return gaussian_blur, stage_record("exact", HOST_DEVICE)
    if not has_fp64(ctx):
        why = f"{engine.device} has no float64 (cl_khr_fp64)"
        return gaussian_blur, stage_record("exact", HOST_DEVICE, fallback=why)
    try:
        blur = DeviceBlur(ctx)
    except UntrustedProgram as exc:
        warn_fallback(exc, "blurs on the host")
        return gaussian_blur, stage_record("exact", HOST_DEVICE, fallback=str(exc))
    return blur, stage_record("opencl", blur.device_name)


def centroid_density(darkness, opt, blur=gaussian_blur):
    """Density of the centroid integrals per grid cell: blurred darkness, upsampled; float32
    (half the memory and the reads of every step; the engines sum it in float64)."""
    return _density_of(_blurred(darkness, opt.density_sigma, blur), opt.supersample)


def _density_of(blurred, s, out=None):
    """:func:`centroid_density` of the blurred darkness, upsampled `s` times (into `out`)."""
    if s == 1:
        return np.maximum(blurred, 1e-6, out=np.empty(blurred.shape, np.float32) if out is None else out)
    d = np.maximum(blurred, 1e-6, out=np.empty(blurred.shape, np.float32))
    d = np.repeat(np.repeat(d, s, axis=0), s, axis=1)
    if out is not None:
        out[...] = d
    return d if out is None else out


def _toned(gray, paper_tone):
    """``(toned, ink, picture_ink)``: the gray image under the paper tone (refused when
    white), its ink (the summed darkness) and the picture's own, without the paper tone (the
    tone dots' ink); no darkness image is made (a whole picture's fresh memory)."""
    picture_ink = float(gray.size - gray.sum())
    if paper_tone > 0:
        gray = gray * (1.0 - paper_tone)
    if not 1.0 - gray.min() > 1e-9:
        raise ValueError("nothing to stipple: the image is white")
    return gray, float(gray.size - gray.sum()) if paper_tone > 0 else picture_ink, picture_ink


#: Bytes a pixel of the picture whose pages are touched while the run starts
#: (:class:`~diskpack_cl.memory.PageReserve`): 12 of the 16 the stage's fields take
#: (float32 radius field, blend weight, ink and density). The start's temporaries, freed
#: into the kept heap, give the fields the rest: a whole reserve beside them and the gray
#: picture set the run's peak (1.99-2.03 GiB at 1M on 8192 x 8192, against 1.82 in the steps).
RESERVED_BYTES_PER_PIXEL = 12

#: Rows of a large picture whose fields :func:`make_stage` makes at once: its blurs and
#: dilation then hold a band's temporaries, not the picture's (the peak memory of a run).
FIELD_BAND_ROWS = 512


def field_margin(plan, ell):
    """Pixels around a window within which every field's blur (4 sigma) and dilation reach
    (`ell`: the detail scale, :func:`~diskpack_cl.radii.detail_ell`).

    Examples
    --------
    >>> field_margin(StippleOptions().plan(1000, 200, 200), 4.0)
    12
    """
    sigmas = [plan.radius_sigma, plan.density_sigma, INK_SIGMA]
    dilation = 0
    if plan.features == "detail":
        sigmas.append(ell / 2.0)
        dilation = dilation_radius(ell)
    return int(math.ceil(4.0 * max(sigmas) + 0.5)) + dilation + 2


def _banded_stage(gray, opt, engine, bands):
    """:func:`make_stage` of a picture or of its window, its fields made ``bands.rows`` rows at a
    time, each band from itself and the margin its blurs and dilation reach (the same values);
    with ``bands.consume`` the rows of `gray` that no later band reads are dropped as they go."""
    H, W = gray.shape
    rows, cols = bands.window or (slice(0, H), slice(0, W))
    rows = range(H)[rows]
    ell = bands.ell
    if ell is None and opt.features == "detail":
        ell = detail_ell(gray, opt.n)
    m, s = field_margin(opt, ell), opt.supersample
    blur, blur_record = bands.blur or _field_blur(engine)
    fields = _empty_fields(opt, len(rows), len(range(W)[cols]))
    for y0 in range(rows.start, rows.stop, bands.rows):
        y1 = min(y0 + bands.rows, rows.stop)
        lo, hi = max(0, y0 - m), min(H, y1 + m)
        band = slice(y0 - rows.start, y1 - rows.start)
        out = {name: None if f is None else f[band if name != "density" else slice(band.start * s, band.stop * s)]
               for name, f in fields.items()}
        _make_fields(gray[lo:hi], opt, blur, ell, (slice(y0 - lo, y1 - lo), cols), out)
        if bands.consume:   # the fields grow as the picture shrinks: their sum stays the peak
            drop_pages(gray[max(0, y0 - m):max(0, y1 - m)])
    stages = {"engine": engine_record(engine), "blur": blur_record}
    return StippleStage(engine, opt, *fields.values(), stages=stages)


class _Bands(NamedTuple):
    """How :func:`_banded_stage` goes: `rows` a band, the `window` of the picture and its
    detail scale `ell` (None: the whole picture's), the `blur`, whether to `consume` it."""

    rows: int
    window: tuple
    ell: float
    blur: tuple
    consume: bool


def _empty_fields(opt, H, W):
    """The stage's fields of an `H` x `W` picture, in :class:`StippleStage`'s order, unfilled
    (None where the options make none). The fields read at the dots alone are float32 (half
    the memory: 7 digits are more than a radius or a blend needs); so is the density
    (:func:`centroid_density`)."""
    s = opt.supersample
    return {"radius_field": np.empty((H, W), np.float32),
            "density": np.empty((H * s, W * s), np.float32),
            "blend_weight": np.empty((H, W), np.float32) if opt.features == "detail" else None,
            "ink": np.empty((H, W), np.float32) if opt.support > 0 else None}


def _field_sigmas(opt, ell):
    """``{name: sigma}``: the blurs of the darkness that the stage's fields are made of."""
    sigmas = {"radius": opt.radius_sigma if opt.radii == "density" else 0.0,
              **(detail_sigmas(ell) if opt.features == "detail" else {}),
              "ink": INK_SIGMA if opt.support > 0 else 0.0,
              "density": opt.density_sigma}
    return {name: sigma for name, sigma in sigmas.items() if sigma > 0}


#: Values of a band from which :func:`_make_fields` shares its arithmetic between the cores.
FIELD_PART = 1 << 21


def _make_fields(gray, opt, blur, ell, window, out):
    """Write the fields of `window` (``(rows, cols)`` slices) of the float64 picture `gray` to
    `out` (:func:`_empty_fields` of the window, or views of them), each from the blurs of one
    darkness (:func:`~diskpack_cl.radii.blurs`: a device blur reads it once).

    The arithmetic after the blurs is shared by the cores, in row runs of at least
    :data:`FIELD_PART` values (:func:`~diskpack_cl._cores.on_cores`; it had left a core idle while the device
    waited): pixel by pixel (:func:`_pixel_fields`), then the radius field's dilation, whose
    runs read the radius rows around them (:func:`_dilated_rows`). The same values as one run."""
    H, W = gray.shape
    rows = window[0]
    rad = dilation_radius(ell) if opt.features == "detail" else 0
    # the radius rows that the dilation reads: the window's and rad more on each side
    lo, hi = max(rows.start - rad, 0), min(rows.stop + rad, H)
    rfield = np.empty((hi - lo, W), np.float32) if rad else None
    _blurred_pixels(gray, opt, blur, ell, window, out, rfield, lo, hi)
    if rad:
        n = len(range(H)[rows])
        on_cores(lambda r: _dilated_rows(rfield, lo, rad, rows.start + r.start, rows.start + r.stop, H,
                                         out["radius_field"][r], window[1]), n, n * W, FIELD_PART)


def _blurred_pixels(gray, opt, blur, ell, window, out, rfield, lo, hi):
    """The darkness of `gray` and its blurs, then :func:`_pixel_fields` of rows `lo` ..
    `hi` on every core (the darkness and blurs are dropped on return, before the
    dilation)."""
    darkness = np.empty(gray.shape, np.result_type(gray, 1.0))
    on_cores(lambda r: np.subtract(1.0, gray[r], out=darkness[r]), len(gray), gray.size, FIELD_PART)
    sigmas = _field_sigmas(opt, ell)
    blurred = dict(zip(sigmas, blurs(blur, darkness, list(sigmas.values()))))
    on_cores(lambda r: _pixel_fields(gray, darkness, blurred, opt, window, out, rfield,
                                     slice(lo + r.start, lo + r.stop), lo),
             hi - lo, (hi - lo) * gray.shape[1], FIELD_PART)


def _pixel_fields(gray, darkness, blurred, opt, window, out, rfield, band, lo):
    """:func:`_make_fields`' pixel-by-pixel work on the picture's rows `band`: the density,
    ink and blend weight of the window's rows among them, and the radius of each (into
    `rfield`, whose first row is row `lo`, for the dilation; straight into the radius field
    without one). The darkness and blurs of those rows are lost (made in place)."""
    rows, cols = window
    s = opt.supersample
    a, b = max(band.start, rows.start), min(band.stop, rows.stop)   # the window's rows here
    if a < b:
        src, dst = slice(a, b), slice(a - rows.start, b - rows.start)
        _density_of(blurred.get("density", darkness)[src, cols], s,
                    out["density"][dst.start * s:dst.stop * s])
        if opt.support > 0:   # off_support's
            np.copyto(out["ink"][dst], blurred["ink"][src, cols], casting="same_kind")
        if opt.features == "detail":
            pair = {name: blurred[name][src] for name in ("sharp", "coarse") if name in blurred}
            np.copyto(out["blend_weight"][dst], detail_blend(darkness[src], pair)[:, cols],
                      casting="same_kind")
    if opt.radii == "density":   # the darkness's last use: made in place
        r = density_radius(blurred["radius"][band] if "radius" in blurred else darkness[band], opt.floor)
    else:
        r = radius_field(gray[band], radii=opt.radii, gamma=opt.gamma, floor=opt.floor)
    if rfield is not None:
        # rounded to float32, then dilated: a maximum of the rounded values is the rounded
        # maximum, in half the bytes
        np.copyto(rfield[band.start - lo:band.stop - lo], r, casting="same_kind")
    elif a < b:
        np.copyto(out["radius_field"][a - rows.start:b - rows.start], r[a - band.start:b - band.start, cols],
                  casting="same_kind")


def _dilated_rows(rfield, lo, rad, a, b, H, out, cols):
    """Rows `a` .. `b` of the picture's radius field dilated (:func:`disk_dilation`), into
    `out`: from the radius rows within `rad` of them (`rfield`, from row `lo`), which the
    dilation reflects only at the picture's (or band's) edges, rows 0 and `H`, as one
    dilation of all of them does."""
    s0, s1 = max(a - rad, 0), min(b + rad, H)
    d = disk_dilation(rfield[s0 - lo:s1 - lo], rad)
    np.copyto(out, d[a - s0:b - s0, cols], casting="same_kind")


def make_stage(gray, opt, engine, *, window=None, ell=None, band_rows=FIELD_BAND_ROWS, blur=None,
               consume=False):
    """The :class:`StippleStage` of a float64 gray image: radius field, centroid density, ink.

    With `window` (``(rows, cols)`` slices of `gray`) the fields are those
    of that part of `gray`, computed with the margin around it, and `ell`
    is the detail scale of the whole picture (:func:`~diskpack_cl.jobs.tiles.stipple_tiled`).
    A picture, or a window, of more than twice `band_rows` rows has its fields made in bands;
    `consume`: `gray` is the caller's to lose (its pages are given back, as zeros, as the
    bands no longer read them).
    `blur`: the ``(blur, record)`` of :func:`_field_blur` (default: the engine's)."""
    if len(range(gray.shape[0])[window[0] if window else slice(None)]) > 2 * band_rows:
        return _banded_stage(gray, opt, engine, _Bands(band_rows, window, ell, blur, consume))
    blur, blur_record = blur or _field_blur(engine)
    H, W = gray.shape
    window = window or (slice(0, H), slice(0, W))
    if ell is None and opt.features == "detail":
        ell = detail_ell(gray, opt.n)
    fields = _empty_fields(opt, len(range(H)[window[0]]), len(range(W)[window[1]]))
    _make_fields(gray, opt, blur, ell, window, fields)
    stages = {"engine": engine_record(engine), "blur": blur_record}
    return StippleStage(engine, opt, *fields.values(), stages=stages)


def _certified_result(state, r, record, history, t_start, ink):
    """The :class:`StippleResult` of the final state: radii at the largest certified k
    (`r`: the base radii at its dots; `record`: the stage's :func:`_stage_record`; `ink`: the
    picture's summed darkness without the paper tone, for the tone radius)."""
    watch, backend, options, stages, (W, H) = record
    with watch("certify"), run_stage("certificate"):
        k, radii, cert = certified_k(state.points, r, W, H, Domain.rect(W, H))
    watch.add("total", time.perf_counter() - t_start)
    return StippleResult(
        points=state.points, radii=radii, k=float(k), base_radii=r, certificate=cert,
        history=history, width=W, height=H, timings=watch.seconds,
        params=options.params(), engine=backend, tone_radius=tone_radius(len(state.points), ink),
        stages=stages,
    )


def _stage_record(stage):
    """What the result keeps of a stage: its timings, engine name, options, where its parts
    ran and its size (not its fields nor the engine's buffers)."""
    return stage.engine.timings, stage.engine.backend, stage.options, stage.stages, stage.size


def stipple(image, n, options=None, *, start=None, callback=None, progress=None, device=None,
            backend="auto", verify=False, profile=False, **overrides):
    """Stipple an image with ``n`` dots by unequal disk packing (paper Algorithm 2).

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A file path, a Pillow image, or a gray/RGB(A) array (see
        :func:`diskpack_cl.image.to_gray`; float arrays are gray in [0, 1],
        1 = white).
    n : int
        Number of stipples.
    options : StippleOptions, optional
        The stippling options (default: ``StippleOptions()``); every field
        is described there (:func:`diskpack_cl.options.describe`).
    start : (n, 2) array_like, optional
        Start points instead of error diffusion (must lie inside the image).
    callback : callable, optional
        Called with each history entry (a dict) after every iteration.
    progress : callable or RunProgress, optional
        ``progress(stage, done, total)`` as each stage of the run starts,
        advances and ends (:mod:`diskpack_cl.progress`: ``load``, ``device``,
        ``start``, ``setup``, ``iterations``, ``certificate``); the stage
        ``device`` (the OpenCL device, its checks on a first run, its
        programs) is ``setup``'s with ``backend="exact"``.
    device : str or pyopencl.Context, optional
        OpenCL device (see :func:`diskpack_cl.get_context`).
    backend : {"auto", "opencl", "exact"}
        Engine (:mod:`diskpack_cl.engine`): ``opencl`` (MICs from
        the float64 per-cell kernel checked on the host, or on devices
        without float64 raster estimates refined exactly; labels and
        centroids on the device), ``exact`` (no OpenCL: exact MICs and host
        labels), ``auto``: opencl when a device exists.
    verify : bool, optional
        Check every MIC step against :func:`diskpack_cl.exact_mic` (radii
        to 1e-9 of the image size, the same empty cells); RuntimeError on a
        mismatch.  Slow: for testing.
    profile : bool, optional
        Time the OpenCL kernels with events: each history entry then has
        ``kernel_s`` (device seconds of the step's kernels) and
        ``kernel_<name>_s`` per kernel, and ``timings`` their totals
        (``kernel``, ``kernel_<name>``).  No effect on the result.
    **overrides
        Fields of :class:`~diskpack_cl.schedule.StippleOptions` that replace
        those of `options` (``gamma``, ``schedule``, ``k_quantile``, ...);
        all are checked before any device work.

    Returns
    -------
    StippleResult

    Raises
    ------
    ValueError
        n < 1, n too large for the grid, gamma <= 0, a white image, bad
        schedule, bad start, an option out of its range, an unknown backend.
    NoOpenCLError
        ``backend="opencl"`` (or a `device`) and no OpenCL device.

    Examples
    --------
    >>> g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    >>> res = stipple(g, 60, schedule=[("mix", 3, 0.5)], backend="exact")
    >>> res.n, res.certificate.valid, res.engine
    (60, True, 'exact')

    The stages as they end:

    >>> def show(stage, done, total):
    ...     if done == total:
    ...         print(stage, done)
    >>> res = stipple(g, 60, schedule=[("mix", 3, 0.5)], backend="exact", progress=show)
    load 1
    start 1
    setup 1
    iterations 3
    certificate 1
    """
    options = (options or StippleOptions()).replace(**overrides)
    with freed_memory_kept(), running(progress):   # the run makes and drops many whole-picture arrays
        # (in a function of its own: its arrays are freed before the block gives memory back)
        return _stipple(image, n, options, start, callback,
                        dict(device=device, backend=backend, profile=profile, verify=verify))


def _stipple(image, n, options, start, callback, engine_args):
    """The body of :func:`stipple`."""
    t_start = time.perf_counter()
    watch = Stopwatch()   # the run's one collector: its own stages and the engine's
    with watch("load"), run_stage("load"):
        # the caller's gray array itself where it is one (nothing here changes it): no copy
        gray = to_gray(image, invert=options.invert, copy=False)
        H, W = gray.shape
        # the pages of the stage's fields, touched on another core while this one starts
        reserve = PageReserve(RESERVED_BYTES_PER_PIXEL * W * H)
        gray, toned_ink, ink = _toned(gray, options.paper_tone)
        opt = options.plan(n, W, H, ink=toned_ink)
    with watch("start"), run_stage("start"):
        x = _start_points(gray, opt, start)
    with watch("setup"):
        reserve.release()
        exact = engine_args["backend"] == "exact"   # no device: the engine is part of the setup
        with run_stage("setup" if exact else "device"):
            engine = make_engine(Domain.rect(W, H), opt.n, grid=opt.grid_shape(W, H), timings=watch,
                                 **engine_args)
        with run_stage("setup", 0 if exact else 1):
            # the run's own gray image (made from 8-bit pixels, or toned) is consumed
            stage = make_stage(gray, opt, engine, consume=gray is not image and gray.flags.owndata)
    del gray   # the stage holds every field the steps read
    give_back()   # the gray image where the run made it (from 8-bit pixels), and the bands'
    state, history = run_schedule(StippleState(x, float(opt.k0)), stage, callback)
    r, record = dot_radii(state, stage, state.points), _stage_record(stage)
    # the fields and the engine's buffers go before the certificate, which then reuses
    # their memory (the run's peak at a million dots)
    del stage, engine
    return _certified_result(state, r, record, history, t_start, ink)
