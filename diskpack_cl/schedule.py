"""Stippling schedules and options: named schedules, their option defaults, one validated options object.

A schedule is a list of phases ``(kind, iterations)`` or ``("mix", iterations,
blend)`` with kind ``"pack"`` (disk packing), ``"lloyd"`` (density-weighted
centroids) or ``"mix"`` (a disk-packing move blended towards the centroid).
:class:`StippleOptions` holds every option of :func:`diskpack_cl.stipple`,
resolved from the schedule's defaults and checked, before any device work.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import check_count

GAMMA_DEFAULT = 3.0   # exponent of the gray radius mapping (the paper's)

__all__ = ["SCHEDULES", "SCHEDULE_NAMES", "SCHEDULE_OPTIONS", "SPACING_BANDS", "default_band",
           "make_schedule", "StippleOptions"]

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
# with the density-consistent radii; the default until the spacing bands
# below (issue 11). Measured in docs/stipple_quality.md.
SCHEDULES["classic"] = [("mix", 35, 0.5), ("mix", 12, 0.4)]
# The classic steps, shortened to 18 + 7, with features="detail" (issue 11):
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
#: centroids (blend 0.5, 1 where dots are sparse): it puts the dots of an
#: outline back on the outline, which the packing steps round off.
#: Measured in docs/stipple_quality.md.
SPACING_BANDS = (
    (2.5, [("mix", 16, 0.7), ("pack", 2), ("mix", 1, 0.5)], {"radius_sigma": 1.5}),
    (3.0, [("mix", 16, 0.7), ("pack", 1), ("mix", 1, 0.5)], {"radius_sigma": 1.5}),
    (6.0, [("mix", 18, 0.5), ("mix", 6, 0.4), ("mix", 1, 0.5)], {"features": "detail"}),
    (np.inf, [("mix", 20, 0.6), ("mix", 6, 0.4), ("mix", 1, 1.0)],
     {"features": "detail", "radius_sigma": 2.0}),
)

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
SCHEDULE_OPTIONS["default"] = dict(SCHEDULE_OPTIONS["classic"], support=1.0, capacity=0.1)



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
    return [tuple(p) for p in phases if p[1] > 0]


def auto_supersample(n, width, height):
    """Grid cells per pixel side: about 16 grid cells per average power cell, at most 8.

    Examples
    --------
    >>> auto_supersample(20000, 512, 512)
    2
    """
    # more where the image is dark is left to the user (supersample=)
    return int(min(8, max(1, np.ceil(np.sqrt(16.0 * n / (width * height))))))


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


def _check_range(name, value, lo, hi=np.inf, *, lo_open=False, hi_open=False, text=None):
    ok = np.isfinite(value) and (value > lo if lo_open else value >= lo)
    ok = ok and (value < hi if hi_open else value <= hi)
    if not ok:
        raise ValueError(f"{name} must be {text}, got {value}")
    return float(value)


@dataclass(frozen=True)
class StippleOptions:
    """Every option of one stippling run, resolved and checked.

    Build it with :meth:`resolve`, which fills the options left as None
    from the schedule's defaults (:data:`SCHEDULE_OPTIONS`) and checks them
    all; see :func:`diskpack_cl.stipple` for what each option means.

    Examples
    --------
    >>> opt = StippleOptions.resolve(2000, 512, 512)
    >>> opt.radii, opt.floor, opt.supersample, opt.phases, opt.features
    ('density', 0.01, 1, (('mix', 20, 0.6), ('mix', 6, 0.4), ('mix', 1, 1.0)), 'detail')
    >>> StippleOptions.resolve(2000, 512, 512, schedule="paper").radii
    'gray'
    >>> StippleOptions.resolve(2000, 512, 512, blend=2)
    Traceback (most recent call last):
    ...
    ValueError: blend must be in [0, 1], got 2.0
    """

    n: int
    gamma: float
    floor: float
    supersample: int
    seed: object
    method: str
    invert: bool
    phases: tuple
    refine_every: int
    radii: str
    radius_sigma: float
    blend: float
    blend_cell: str
    k_quantile: float
    density_sigma: float
    k0: float
    features: str = "none"
    capacity: float = 0.0
    support: float = 0.0
    paper_tone: float = 0.0

    @classmethod
    def resolve(cls, n, width, height, *, gamma=GAMMA_DEFAULT, floor=None, schedule="default", beta=None,
                lloyd=None, rounds=None, supersample=None, seed=0, method="diskpack", invert=False,
                refine_every=1, k0=1e-6, radii=None, radius_sigma=None, blend=None,
                blend_cell="power", k_quantile=None, density_sigma=None, features=None,
                capacity=None, support=None, paper_tone=0.0):
        """Options for `n` dots on a `width` x `height` image; None: the schedule's default.

        Raises
        ------
        ValueError
            An option out of its range, a bad schedule, n too large for the
            grid, or a `gamma` other than the default with density radii
            (which have no exponent).
        """
        n = check_count(n)
        if not (np.isfinite(gamma) and gamma > 0):
            raise ValueError(f"gamma must be > 0, got {gamma}")
        s = auto_supersample(n, width, height) if supersample is None else int(supersample)
        if s < 1:
            raise ValueError(f"supersample must be >= 1, got {supersample}")
        if 4 * n > (s * width) * (s * height):
            raise ValueError(
                f"n = {n} is too large for a {width}x{height} image at supersample {s}: at most "
                f"{(s * width) * (s * height) // 4} points (4 grid cells per point); raise supersample")
        spacing = np.sqrt(width * height / n)
        phases = make_schedule(schedule, beta=beta, lloyd=lloyd, rounds=rounds, method=method,
                               spacing=spacing)
        d = _schedule_defaults(schedule, beta, lloyd, rounds, method, spacing)

        def pick(name, value):
            return d[name] if value is None else value

        if float(gamma) != GAMMA_DEFAULT and pick("radii", radii) != "gray":
            # the density mapping has no exponent: a gamma there would be ignored
            raise ValueError(f"gamma = {gamma:g} has no effect with {pick('radii', radii)} radii "
                             f"(schedule {schedule!r}); it is the exponent of radii='gray', which "
                             "the 'paper', 'pack' and 'lloyd' schedules use")
        return cls(n=n, gamma=float(gamma), floor=float(pick("floor", floor)), supersample=s,
                   seed=seed, method=method, invert=bool(invert), phases=tuple(phases),
                   refine_every=refine_every, radii=pick("radii", radii),
                   radius_sigma=float(pick("radius_sigma", radius_sigma)),
                   blend=float(pick("blend", blend)), blend_cell=blend_cell,
                   k_quantile=float(pick("k_quantile", k_quantile)),
                   density_sigma=float(pick("density_sigma", density_sigma)), k0=k0,
                   features=d.get("features", "none") if features is None else features,
                   capacity=float(d.get("capacity", 0.0) if capacity is None else capacity),
                   support=float(d.get("support", 0.0) if support is None else support),
                   paper_tone=float(paper_tone))

    def __post_init__(self):
        _check_range("floor", self.floor, 0, 1, lo_open=True, text="in (0, 1]")
        _check_range("radius_sigma", self.radius_sigma, 0, text=">= 0")
        _check_range("density_sigma", self.density_sigma, 0, text=">= 0")
        if self.radii not in ("gray", "density"):
            raise ValueError(f"radii must be 'gray' or 'density', got {self.radii!r}")
        if not 0.0 <= self.blend <= 1.0:
            raise ValueError(f"blend must be in [0, 1], got {self.blend}")
        if self.blend_cell not in ("power", "voronoi"):
            raise ValueError(f"blend_cell must be 'power' or 'voronoi', got {self.blend_cell!r}")
        if self.features not in ("none", "detail"):
            raise ValueError(f"features must be 'none' or 'detail', got {self.features!r}")
        _check_range("capacity", self.capacity, 0, 1, text="in [0, 1]")
        _check_range("support", self.support, 0, 1, text="in [0, 1]")
        _check_range("paper_tone", self.paper_tone, 0, 1, hi_open=True, text="in [0, 1)")
        if not 0.0 <= self.k_quantile < 1.0:
            raise ValueError(f"k_quantile must be in [0, 1), got {self.k_quantile}")
        if not (np.isfinite(self.k0) and self.k0 > 0):
            raise ValueError(f"k0 must be > 0, got {self.k0}")
        if isinstance(self.refine_every, bool) or int(self.refine_every) != self.refine_every \
                or self.refine_every < 0:
            raise ValueError(f"refine_every must be an integer >= 0, got {self.refine_every!r}")

    def grid_shape(self, width, height):
        """Raster shape ``(ny, nx)`` for a `width` x `height` image."""
        return self.supersample * height, self.supersample * width

    def params(self):
        """The options as a JSON-ready dict (``StippleResult.params``)."""
        return {
            "n": self.n, "gamma": self.gamma, "floor": self.floor, "supersample": self.supersample,
            "seed": self.seed, "method": self.method, "invert": self.invert,
            "schedule": [list(p) for p in self.phases], "refine_every": int(self.refine_every),
            "radii": self.radii, "radius_sigma": self.radius_sigma, "blend": self.blend,
            "blend_cell": self.blend_cell, "k_quantile": self.k_quantile,
            "density_sigma": self.density_sigma, "features": self.features,
            "capacity": self.capacity, "support": self.support,
            "paper_tone": self.paper_tone,
        }
