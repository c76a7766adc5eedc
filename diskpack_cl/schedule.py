"""Stippling schedules and options: named schedules, their option defaults, one validated options object.

A schedule is a list of phases ``(kind, iterations)`` or ``("mix", iterations,
blend)`` with kind ``"pack"`` (disk packing), ``"lloyd"`` (density-weighted
centroids) or ``"mix"`` (a disk-packing move blended towards the centroid).
:class:`StippleOptions` holds every option of :func:`diskpack_cl.stipple`,
resolved from the schedule's defaults and checked, before any device work.
"""

from __future__ import annotations

import dataclasses
import numbers
from dataclasses import dataclass

import numpy as np

from ._checks import check_count, check_point_count, check_seed, count_text, seed_text
from .options import OptionConflict, check_fields, option

GAMMA_DEFAULT = 3.0   # exponent of the gray radius mapping (the paper's)

__all__ = ["SCHEDULES", "SCHEDULE_NAMES", "SCHEDULE_OPTIONS", "SPACING_BANDS", "default_band",
           "make_schedule", "StippleCount", "StippleOptions", "StipplePlan"]

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
# with the density-consistent radii, one band for every spacing. Measured in
# docs/stipple_quality.md.
SCHEDULES["classic"] = [("mix", 35, 0.5), ("mix", 12, 0.4)]
# The classic steps, shortened to 18 + 7, with features="detail":
# fewer packing steps leave the points less hexagonal (lower |psi6|), the
# feature-aware blend gives the tone back. Measured in docs/stipple_quality.md.
SCHEDULES["detail"] = [("mix", 18, 0.5), ("mix", 7, 0.4)]

#: The default schedule follows the dot spacing ``s = sqrt(width * height / n)``
#: (pixels): rows ``(s below, phases, options over the classic ones)``, the
#: first row whose bound exceeds ``s``.  Where dots are closer than the 3 px
#: over which the eye (and the tone measure) blurs, a short mix phase places
#: them and a few disk-packing steps restore the spacing and undo the
#: hexagonal order the centroid pulls build; where they are farther apart,
#: only centroid-pulling mix steps place them well enough, with the
#: feature-aware blend.  Every band ends with one step that leans on the
#: centroids (blend 0.5, 0.75 where dots are sparse): it puts the dots of an
#: outline back on the outline, which the packing steps round off. Where dots
#: are sparse, features thinner than their spacing (blades of grass) keep
#: their dots only with the centroids of the unblurred darkness and a
#: stronger pull off the white side (``support`` 16).
#: Measured in docs/stipple_quality.md.
SPACING_BANDS = (
    (2.5, [("mix", 16, 0.7), ("pack", 2), ("mix", 1, 0.5)], {"radius_sigma": 1.5}),
    (3.0, [("mix", 16, 0.7), ("pack", 1), ("mix", 1, 0.5)], {"radius_sigma": 1.5}),
    (6.0, [("mix", 18, 0.5), ("mix", 6, 0.4), ("mix", 1, 0.5)], {"features": "detail"}),
    (np.inf, [("mix", 20, 0.6), ("mix", 6, 0.4), ("mix", 1, 0.75)],
     {"features": "detail", "radius_sigma": 2.0, "support": 16.0, "density_sigma": 0.0}),
)

#: Largest blur of the centroid density, as a fraction of the dot spacing
#: on full black, ``sqrt(ink / n)``.  Where a drawing's thin lines carry
#: more than one dot per pixel, a blur wider than that spreads each line's
#: centroids, and so its dots, onto the paper beside it.
BLACK_SPACING_BLUR = 0.5

#: Every schedule name :func:`make_schedule` takes.
SCHEDULE_NAMES = ("default", *sorted(SCHEDULES))


def default_band(spacing):
    """Phases and option overrides of the default schedule at dot spacing `spacing` px.

    Examples
    --------
    >>> default_band(512 / 50000 ** 0.5)[0]
    [('mix', 16, 0.7), ('pack', 2), ('mix', 1, 0.5)]
    >>> default_band(512 / 20000 ** 0.5)[1]
    {'features': 'detail'}
    """
    spacing = float(spacing)
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"the dot spacing must be a positive number, got {spacing}")
    for bound, phases, options in SPACING_BANDS:
        if spacing < bound:
            return list(phases), dict(options)
    raise AssertionError("the last band is unbounded")  # pragma: no cover

#: Option defaults that come with a named schedule; explicit keyword arguments
#: of :func:`stipple` override them. ``method="lloyd"`` uses ``"lloyd"``'s, and
#: a schedule built from ``beta``/``lloyd``/``rounds`` uses ``"paper"``'s.
_PAPER_OPTIONS = {"radii": "gray", "floor": 0.1, "blend": 0.0, "radius_sigma": 0.0,
                  "density_sigma": 0.0, "k_quantile": 0.0}
SCHEDULE_OPTIONS = {
    "paper": dict(_PAPER_OPTIONS),
    "lloyd": dict(_PAPER_OPTIONS),
    "pack": dict(_PAPER_OPTIONS),
    "classic": {"radii": "density", "floor": 0.01, "blend": 0.5, "radius_sigma": 3.0,
                "density_sigma": 0.5, "k_quantile": 0.15},
}
SCHEDULE_OPTIONS["detail"] = dict(SCHEDULE_OPTIONS["classic"], features="detail")
# the default's base options: each spacing band overrides some (SPACING_BANDS).
# Over classic's: a dot whose largest empty disk leaves its cell's ink moves
# to the centroid instead (support: white paper stays white, outlines stay
# sharp) and equal ink per dot (capacity). Measured in docs/stipple_quality.md.
SCHEDULE_OPTIONS["default"] = dict(SCHEDULE_OPTIONS["classic"], support=8.0, capacity=0.1)



def make_schedule(schedule="default", *, beta=None, lloyd=None, rounds=None, method="diskpack",
                  spacing=None):
    """The list of phases to run: ``(kind, iterations)`` or ``("mix", iterations, blend)``.

    ``schedule`` is a name in :data:`SCHEDULE_NAMES` (``"default"`` needs
    the dot `spacing` in pixels, ``sqrt(width * height / n)``, see
    :data:`SPACING_BANDS`) or a list of
    ``("pack" | "lloyd" | "mix", iterations)`` and ``("mix", iterations,
    blend)`` (a ``"mix"`` phase without its own blend uses the options'
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
    >>> make_schedule("classic")
    [('mix', 35, 0.5), ('mix', 12, 0.4)]
    >>> make_schedule("default", spacing=2.0)
    [('mix', 16, 0.7), ('pack', 2), ('mix', 1, 0.5)]
    >>> make_schedule([("mix", 3, 0.2), ("lloyd", 0), ("pack", 2)])
    [('mix', 3, 0.2), ('pack', 2)]
    """
    if method not in ("diskpack", "lloyd"):
        raise ValueError(f"method must be 'diskpack' or 'lloyd', got {method!r}")
    if method == "lloyd":
        # the baseline: Lloyd only; `lloyd` sets its length, else 50
        return [("lloyd", n) for n in [50 if lloyd is None else int(lloyd)] if n > 0]
    if beta is not None or lloyd is not None or rounds is not None:
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
    elif schedule == "default":
        if spacing is None:
            raise ValueError("the default schedule follows the dot spacing: give "
                             "spacing = sqrt(width * height / n) in pixels")
        phases = default_band(spacing)[0]
    elif isinstance(schedule, str):
        if schedule not in SCHEDULES:
            raise ValueError(f"unknown schedule {schedule!r}; choose from {list(SCHEDULE_NAMES)}")
        phases = list(SCHEDULES[schedule])
    else:
        phases = [_phase(ph) for ph in schedule]
    return [tuple(p) for p in phases if p[1] > 0]


def _phase(ph):
    """One phase of an explicit schedule, checked; the message names the part that is wrong.

    Examples
    --------
    >>> _phase(["mix", 3, 0.25])
    ('mix', 3, 0.25)
    >>> _phase(("pack", -5))
    Traceback (most recent call last):
    ...
    ValueError: bad schedule phase ('pack', -5): iterations must be an integer >= 0, got -5
    """
    shape = "(kind, iterations) or ('mix', iterations, blend)"
    if isinstance(ph, str) or not isinstance(ph, (tuple, list)) or len(ph) not in (2, 3):
        raise ValueError(f"bad schedule phase {ph!r}: {shape}")
    kind, it, *blend = ph
    if kind not in ("pack", "lloyd", "mix"):
        raise ValueError(f"bad schedule phase {tuple(ph)!r}: kind must be 'pack', 'mix' or "
                         f"'lloyd', got {kind!r}")
    if not (isinstance(it, numbers.Real) and not isinstance(it, bool) and it >= 0
            and float(it).is_integer()):
        raise ValueError(f"bad schedule phase {tuple(ph)!r}: iterations must be an integer "
                         f">= 0, got {it!r}")
    if not blend:
        return kind, int(it)
    if kind != "mix":
        raise ValueError(f"bad schedule phase {tuple(ph)!r}: only 'mix' takes a blend; {shape}")
    if not (isinstance(blend[0], numbers.Real) and 0.0 <= blend[0] <= 1.0):
        raise ValueError(f"bad schedule phase {tuple(ph)!r}: blend must be in [0, 1], "
                         f"got {blend[0]!r}")
    return kind, int(it), float(blend[0])


#: Grid cells per dot that the automatic supersampling aims at: about
#: :data:`CELLS_PER_DOT` per power cell over the whole image, and at least
#: :data:`CELLS_PER_BLACK_DOT` (the fewest :meth:`StippleOptions.plan`
#: accepts on average) per power cell on full black, where the dots are
#: densest.  A mostly white drawing puts all its dots on its few inked
#: pixels, whose power cells would otherwise span two grid cells: their
#: centroids and labels would be the raster's, not the cells'.
CELLS_PER_DOT, CELLS_PER_BLACK_DOT = 16.0, 4.0


def auto_supersample(n, width, height, ink=None):
    """Grid cells per pixel side for `n` dots on a `width` x `height` image, at most 8.

    About :data:`CELLS_PER_DOT` grid cells per average power cell, and, with
    the image's `ink` (its total darkness, in pixels of full black), at
    least :data:`CELLS_PER_BLACK_DOT` per power cell on full black.

    Examples
    --------
    >>> auto_supersample(20000, 512, 512)
    2

    Thin black lines over 7 % of the image hold all the dots:

    >>> auto_supersample(50000, 384, 384, ink=0.074 * 384 * 384)
    5
    """
    cells = CELLS_PER_DOT * n / (width * height)
    if ink is not None and ink > 0:
        cells = max(cells, CELLS_PER_BLACK_DOT * n / ink)
    return int(min(8, max(1, np.ceil(np.sqrt(cells)))))


def _schedule_defaults(schedule, beta, lloyd, rounds, method, spacing):
    """The option defaults of the schedule asked for (see :data:`SCHEDULE_OPTIONS`;
    the default's depend on the dot `spacing`, :data:`SPACING_BANDS`)."""
    if method == "lloyd":
        return dict(SCHEDULE_OPTIONS["lloyd"])
    opts = dict(SCHEDULE_OPTIONS["paper"])
    if beta is None and lloyd is None and rounds is None and isinstance(schedule, str):
        opts.update(SCHEDULE_OPTIONS.get(schedule, {}))
        if schedule == "default":
            opts.update(default_band(spacing)[1])
    return opts


STIPPLING_GROUP = "stippling (the paper's parameters)"


def _check_schedule(schedule):
    if isinstance(schedule, str):
        if schedule not in SCHEDULE_NAMES:
            raise ValueError(f"unknown schedule {schedule!r}; choose from {list(SCHEDULE_NAMES)}")
    else:
        make_schedule(schedule)  # an explicit list of phases: checked now


def _check_dots(n):
    if n != "tone":
        check_point_count(n)


def _dots_text(text):
    """The command line's dot count: an integer >= 2 or ``tone``."""
    return count_text(text, "tone")


#: Title of the fields that say how many dots (the command line takes one of them).
COUNT = "count"


@dataclass(frozen=True)
class StippleCount:
    """How many dots a stippling has (:func:`diskpack_cl.jobs.items.plan_stipple`,
    :func:`diskpack_cl.stipple_many`, ``diskpack stipple``): ``n``, or a density
    per megapixel of each image or per cm^2 of the print.

    Examples
    --------
    >>> StippleCount(n="tone").n
    'tone'
    >>> StippleCount(n=1)
    Traceback (most recent call last):
    ...
    ValueError: need at least 2 points, got 1
    """

    n: object = option(None, "number of dots (at least 2), or 'tone' with --dot-mm or --pen-mm: "
                       "as many dots as give the image's ink on the paper", check=_check_dots,
                       cli_type=_dots_text, metavar="N", flag="-n", group=COUNT)
    density: float = option(None, "instead of -n: D dots per megapixel of each image", lo=0,
                            lo_open=True, metavar="D", group=COUNT)
    dots_per_cm2: float = option(None, "instead of -n: D dots per cm^2 of the print (needs "
                                 "--width-mm, --height-mm or --dpi)", lo=0, lo_open=True,
                                 metavar="D", group=COUNT)

    def __post_init__(self):
        check_fields(self)

    def kwargs(self):
        """The keyword arguments of :func:`diskpack_cl.jobs.items.plan_stipple`."""
        return {"n": self.n, "density": self.density, "dots_per_cm2": self.dots_per_cm2}


@dataclass(frozen=True)
class StippleOptions:
    """The options of :func:`diskpack_cl.stipple`, each with its default, range and help.

    ``None`` leaves an option to the schedule (:data:`SCHEDULE_OPTIONS`).
    The ranges are checked and the contradictions refused
    (:class:`~diskpack_cl.options.OptionConflict`) on construction;
    :meth:`plan` resolves them for an image. :func:`diskpack_cl.options.describe`
    lists every field's help, ``diskpack stipple --help`` shows them.

    Examples
    --------
    >>> opt = StippleOptions(k_quantile=0.2)
    >>> opt.plan(2000, 512, 512).k_quantile
    0.2
    >>> StippleOptions(blend=2)
    Traceback (most recent call last):
    ...
    ValueError: blend must be in [0, 1], got 2.0
    >>> StippleOptions(method="lloyd", schedule="paper")
    Traceback (most recent call last):
    ...
    diskpack_cl.options.OptionConflict: method lloyd runs Lloyd iterations only (lloyd L), so schedule paper would be ignored; give one
    """

    gamma: float = option(
        None, "gamma: contrast exponent of the gray radius mapping, base radius "
        "r_i = max(gray, FLOOR)^(gamma/2) (default 3.0); only --radii gray has it (the "
        "paper, pack and lloyd schedules), so the default schedule's density radii refuse it",
        lo=0, lo_open=True, group=STIPPLING_GROUP)
    floor: float = option(
        None, "floor of the radius mapping, so that black (gray) or white (density) regions "
        "keep a finite radius (default: the schedule's, 0.1 for paper, pack and lloyd, 0.01 "
        "for default)", lo=0, hi=1, lo_open=True, group=STIPPLING_GROUP, metavar="FLOOR")
    radii: str = option(
        None, "radius mapping: gray = the paper's r_i = max(gray, FLOOR)^(gamma/2); density = "
        "r_i ~ darkness^(-1/2), the density Lloyd aims at (default: the schedule's, density "
        "for default)", choices=("gray", "density"), group=STIPPLING_GROUP)
    blend: float = option(
        None, "mix phases move to MIC + BLEND * (centroid - MIC) (default: the schedule's)",
        lo=0, hi=1, group=STIPPLING_GROUP, metavar="BLEND")
    features: str = option(
        None, "detail: feature-aware mix steps, where the image holds detail finer than the "
        "dot spacing dots move further towards their cell's centroid and the radii follow "
        "the detail (more tone, slightly less even spacing); default: the schedule's (detail "
        "for --schedule detail, and for the default where the dot spacing is 3 px or more)",
        choices=("none", "detail"), group=STIPPLING_GROUP)
    capacity: float = option(
        None, "equal ink per dot: after each step every dot's radius is scaled by (mean ink / "
        "its power cell's ink)^GAIN, as in capacity-constrained stippling; more tone, closer "
        "pairs across tone edges (default: the schedule's, 0.1 for default, 0 = off for the "
        "others)", lo=0, hi=1, group=STIPPLING_GROUP, metavar="GAIN")
    support: float = option(
        None, "keep dots on the ink: a dot whose largest empty disk leaves its cell's ink "
        "moves towards the cell's centroid instead, by S times how far it left, at most all "
        "the way (default: the schedule's, for default 8, or 16 where dots are 6 px or more "
        "apart; 0 for the others; 0 lets edge dots "
        "drift onto white paper and blurs edges)", lo=0, hi=16, group=STIPPLING_GROUP, metavar="S")
    paper_tone: float = option(
        0.0, "darkness T added under the whole image, so that white paper gets sparse dots "
        "too (default 0: white stays white)", lo=0, hi=1, hi_open=True, group=STIPPLING_GROUP,
        metavar="T")
    k_quantile: float = option(
        None, "during iterations, k is this quantile of R_i/r_i (0 = the paper's minimum; the "
        "output always uses the largest certified k)", lo=0, hi=1, hi_open=True,
        group=STIPPLING_GROUP, metavar="K_QUANTILE")
    schedule: object = option(
        None, "named schedule of disk-packing (pack) and Lloyd phases (default: default); "
        "the library also takes a list of phases, see make_schedule", check=_check_schedule,
        cli_choices=SCHEDULE_NAMES, group=STIPPLING_GROUP)
    beta: int = option(
        None, "beta: disk-packing iterations per round; with --lloyd and --rounds it replaces "
        "--schedule (missing ones: the paper's beta 40, lloyd 10, rounds 3; the last round is "
        "half as long)", integer=True, lo=0, group=STIPPLING_GROUP, metavar="BETA")
    lloyd: int = option(
        None, "Lloyd iterations between rounds (paper: 10); with --method lloyd: the number "
        "of Lloyd iterations (default 50)", integer=True, lo=0, group=STIPPLING_GROUP, metavar="L")
    rounds: int = option(
        None, "number of disk-packing rounds (paper: 3)", integer=True, lo=1,
        group=STIPPLING_GROUP, metavar="ROUNDS")
    method: str = option(
        "diskpack", "diskpack (default): the paper's disk packing; lloyd: weighted Voronoi "
        "stippling (Secord 2002), the baseline, from the same start",
        choices=("diskpack", "lloyd"), group=STIPPLING_GROUP)
    supersample: int = option(
        None, "raster cells per image pixel side (default: automatic, about 16 cells per dot "
        "and at least 4 per dot on black, at most 8)", integer=True, lo=1, group=STIPPLING_GROUP, metavar="S")
    refine_every: int = option(
        1, "refine the raster MIC estimate exactly every R disk-packing iterations (default "
        "1 = always; 0 = never); the output is always certified", integer=True, lo=0,
        group=STIPPLING_GROUP, metavar="R")
    seed: object = option(
        0, "seed of the error-diffusion start (default 0; same seed, same result)",
        check=check_seed, cli_type=seed_text, group=STIPPLING_GROUP, metavar="SEED")
    invert: bool = option(
        False, "stipple the light parts (light dots on a dark ground); with --colors/--pens, "
        "light pens on black paper (auto:N: white and N - 1 light pens; cmyk and cmy are for "
        "white paper)", group=STIPPLING_GROUP)
    k0: float = option(1e-6, "initial scale factor k (the paper: 1e-6, so that no disks "
                       "overlap)", lo=0, lo_open=True, cli=False)
    radius_sigma: float = option(None, "blur of the darkness in the density radius mapping",
                                 unit="px", lo=0, cli=False)
    density_sigma: float = option(None, "blur of the darkness used as the centroid density "
                                  "of Lloyd and mix steps", unit="px", lo=0, cli=False)
    blend_cell: str = option("power", "cells whose centroids a mix step blends towards: the "
                             "power cells of the grid or the Voronoi cells",
                             choices=("power", "voronoi"), cli=False)

    def __post_init__(self):
        check_fields(self)
        built = [k for k in ("beta", "rounds") if getattr(self, k) is not None]
        if self.method == "lloyd":
            for name in [k for k in ("schedule", *built) if getattr(self, k) is not None]:
                value = getattr(self, name)
                raise OptionConflict(f"{{}} lloyd runs Lloyd iterations only ({{}} L), so "
                                     f"{{}} {value} would be ignored; give one",
                                     "method", "lloyd", name)
        elif self.lloyd is not None:
            built.append("lloyd")
        if built and self.schedule is not None:
            raise OptionConflict(f"{'/'.join(['{}'] * len(built))} build the schedule the "
                                 f"paper's way, so {{}} {self.schedule} would be ignored; "
                                 f"give one", *built, "schedule")
        if self.gamma is not None and self.radii_for() != "gray":
            which = (f"{{}} {self.radii}",) if self.radii else (
                f"the {self.schedule or 'default'} schedule's {self.radii_for()} radii",)
            raise OptionConflict(
                f"{{}} = {self.gamma:g} has no effect with {self.radii_for()} radii ("
                + which[0] + "); it is the exponent of {} gray, which the paper, pack and "
                f"lloyd schedules use (e.g. {{}} paper {{}} {self.gamma:g}); {{}} sets the "
                "contrast on every schedule", "gamma", *(["radii"] if self.radii else []),
                "radii", "schedule", "gamma", "tone_gamma")

    def radii_for(self):
        """The radius mapping these options give: ``radii``, else the schedule's."""
        if self.radii is not None:
            return self.radii
        if self.method == "lloyd":
            return SCHEDULE_OPTIONS["lloyd"]["radii"]
        paper = any(getattr(self, k) is not None for k in ("beta", "lloyd", "rounds"))
        name = ("default" if self.schedule is None else
                self.schedule if isinstance(self.schedule, str) else "paper")
        return SCHEDULE_OPTIONS["paper" if paper else name]["radii"]

    def replace(self, **overrides):
        """A copy with ``overrides`` (field names), checked again."""
        return dataclasses.replace(self, **overrides)

    @classmethod
    def resolve(cls, n, width, height, options=None, *, ink=None, **overrides):
        """The :class:`StipplePlan` of ``options`` (default: all defaults) with ``overrides``
        (`ink` as for :meth:`plan`)."""
        return (options or cls()).replace(**overrides).plan(n, width, height, ink=ink)

    def plan(self, n, width, height, ink=None):
        """The options resolved for `n` dots on a `width` x `height` image.

        With the image's `ink` (its total darkness, in pixels of full black)
        the automatic choices also follow where the dots will be: the
        supersampling (:func:`auto_supersample`) and the schedule's blur of
        the centroid density, at most :data:`BLACK_SPACING_BLUR` of the dot
        spacing on full black.

        Raises
        ------
        ValueError
            n too large for the grid, or a bad schedule.
        """
        n = check_count(n)
        s = auto_supersample(n, width, height, ink) if self.supersample is None else self.supersample
        if 4 * n > (s * width) * (s * height):
            raise ValueError(
                f"n = {n} is too large for a {width}x{height} image at supersample {s}: at most "
                f"{(s * width) * (s * height) // 4} points (4 grid cells per point); raise supersample")
        spacing = np.sqrt(width * height / n)
        schedule = "default" if self.schedule is None else self.schedule
        phases = make_schedule(schedule, beta=self.beta, lloyd=self.lloyd, rounds=self.rounds,
                               method=self.method, spacing=spacing)
        d = _schedule_defaults(schedule, self.beta, self.lloyd, self.rounds, self.method,
                               spacing)
        if ink is not None and ink > 0:
            d["density_sigma"] = min(d["density_sigma"], BLACK_SPACING_BLUR * np.sqrt(ink / n))
        d.setdefault("features", "none")
        d.setdefault("capacity", 0.0)
        d.setdefault("support", 0.0)
        kept = {k: getattr(self, k) for k in PLAN_FIELDS if k in _OPTION_FIELDS}
        for k in d:   # the schedule's options, where these options leave them to it
            v = d[k] if kept[k] is None else kept[k]
            kept[k] = v if isinstance(v, str) else float(v)
        kept.update(gamma=GAMMA_DEFAULT if self.gamma is None else self.gamma, supersample=s)
        return StipplePlan(n=n, phases=tuple(phases), **kept)


#: What a :class:`StipplePlan` holds, in the order of its ``params()``: the count ``n``,
#: ``phases`` (the schedule, beta, lloyd and rounds made into phases) and the fields of
#: :class:`StippleOptions` resolved for the image (``k0`` is not in ``params()``).
PLAN_FIELDS = ("n", "gamma", "floor", "supersample", "seed", "method", "invert", "phases",
               "refine_every", "radii", "radius_sigma", "blend", "blend_cell", "k_quantile",
               "density_sigma", "k0", "features", "capacity", "support", "paper_tone")


class _Plan:
    """The methods of :class:`StipplePlan`."""

    def grid_shape(self, width, height):
        """Raster shape ``(ny, nx)`` for a `width` x `height` image."""
        return self.supersample * height, self.supersample * width

    def params(self):
        """The options as a JSON-ready dict (``StippleResult.params``)."""
        out = {}
        for name in PLAN_FIELDS:
            if name == "phases":
                out["schedule"] = [list(p) for p in self.phases]
            elif name != "k0":
                out[name] = getattr(self, name)
        return out


def _plan_field(name):
    """A field of :class:`StipplePlan` and its type: the option's, or ``n``'s, ``phases``'.

    Not the option's help, range and default: a plan holds values, it is no options
    object (:mod:`diskpack_cl.options` does not see it)."""
    return name, {"n": int, "phases": tuple}.get(name) or _OPTION_FIELDS[name].type


_OPTION_FIELDS = {f.name: f for f in dataclasses.fields(StippleOptions)}

StipplePlan = dataclasses.make_dataclass(
    "StipplePlan", [_plan_field(name) for name in PLAN_FIELDS], bases=(_Plan,), frozen=True,
    namespace={"__module__": __name__, "__doc__": """The options of one stippling run, resolved for its image (:meth:`StippleOptions.plan`).

    The fields of :data:`PLAN_FIELDS`: those of :class:`StippleOptions`, each
    with its value for this image, and ``n`` and ``phases``.

    Examples
    --------
    >>> opt = StippleOptions().plan(2000, 512, 512)
    >>> opt.radii, opt.floor, opt.supersample, opt.phases, opt.features
    ('density', 0.01, 1, (('mix', 20, 0.6), ('mix', 6, 0.4), ('mix', 1, 0.75)), 'detail')
    >>> StippleOptions(schedule="paper").plan(2000, 512, 512).radii
    'gray'
    """})
