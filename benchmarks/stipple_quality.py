"""Stippling quality over the validation set: tone SSIM (sigma 3 and 1.5), P01, |psi6|.

Runs configurations of :func:`diskpack_cl.stipple.stipple` (the default, the
Lloyd baseline, the paper's schedule, ablations) from the same error-diffusion
start and seed on the validation photographs (``tests/data/`` and
``tests/data/validation/``, split into a tuning and a held-out part, see
``tests/data/validation/README.md``), checks that every output is certified,
and prints one row per run and a summary over seeds with the spacing
condition (tone at least Lloyd's, P01 >= 0.85, |psi6| below Lloyd's).

    python benchmarks/stipple_quality.py [--set heldout] [-n 5000 20000 50000]
        [--seeds 0 1 2] [--configs default lloyd] [--images coins text ...]
        [--jsonl rows.jsonl] [--markdown]
    python benchmarks/stipple_quality.py --summary rows.jsonl [--markdown]

A configuration is a name of :data:`CONFIGS`, optionally with keyword
arguments of ``stipple`` after a colon, separated by ``;`` (values are Python
literals): ``default:radius_sigma=1.5;blend=0.6``.  With ``--jsonl`` every
row is appended to the file as it is measured (an interrupted run keeps its
rows, and ``--skip-done`` does not measure them again); ``--summary`` prints
the summary of such files without running anything.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
import time
from pathlib import Path

import numpy as np

from diskpack_cl.picture_measures import stipple_measures
from diskpack_cl.image import load_gray
from diskpack_cl.stipple import stipple

ROOT = Path(__file__).resolve().parents[1] / "tests" / "data"

#: The validation set: name -> (file, part). See tests/data/validation/README.md.
IMAGES = {
    "astronaut": ("astronaut.png", "tuning"),
    "camera": ("camera.png", "tuning"),
    "coffee": ("coffee.png", "tuning"),
    "chelsea": ("validation/chelsea.png", "tuning"),
    "brick": ("validation/brick.png", "tuning"),
    "hubble_left": ("validation/hubble_left.png", "tuning"),
    "retina_left": ("validation/retina_left.png", "tuning"),
    "coins": ("validation/coins.png", "heldout"),
    "clock": ("validation/clock.png", "heldout"),
    "cell": ("validation/cell.png", "heldout"),
    "grass": ("validation/grass.png", "heldout"),
    "gravel": ("validation/gravel.png", "heldout"),
    "text": ("validation/text.png", "heldout"),
    "hubble_right": ("validation/hubble_right.png", "heldout"),
    "retina_right": ("validation/retina_right.png", "heldout"),
    # the second held-out part: added, and measured once, after the spacing bands were fixed
    "ihc": ("validation/ihc.png", "heldout2"),
    "hopper": ("validation/hopper.png", "heldout2"),
    "terrain": ("validation/terrain.png", "heldout2"),
    "hubble_bottom": ("validation/hubble_bottom.png", "heldout2"),
    "retina_bottom": ("validation/retina_bottom.png", "heldout2"),
    # line art and a silhouette (benchmarks/make_lineart.py)
    "shapes": ("lineart/shapes.png", "lineart"),
    "lines": ("lineart/lines.png", "lineart"),
    "horse": ("lineart/horse.png", "lineart"),
}
SETS = {
    "test": ["astronaut", "coffee", "camera"],
    "tuning": [k for k, v in IMAGES.items() if v[1] == "tuning"],
    "heldout": [k for k, v in IMAGES.items() if v[1] == "heldout"],
    "heldout2": [k for k, v in IMAGES.items() if v[1] == "heldout2"],
    "lineart": [k for k, v in IMAGES.items() if v[1] == "lineart"],
    "photos": [k for k, v in IMAGES.items() if v[1] != "lineart"],
    "all": list(IMAGES),
}

CONFIGS = {
    # the error-diffusion start, no iteration (no certificate computed)
    "start": dict(schedule=[]),
    # weighted Voronoi stippling (Secord 2002), 50 Lloyd iterations
    "lloyd": dict(method="lloyd"),
    # the paper's loop: 40 pack, 10 Lloyd, 40, 10, 20 pack; gray radii, gamma 3
    "paper": dict(schedule="paper"),
    # disk packing only, 60 iterations (gray radii)
    "pack": dict(schedule="pack"),
    # the default: its phases and options follow the dot spacing
    # (schedule.SPACING_BANDS)
    "default": dict(schedule="default"),
    # the default before the spacing bands: 35 + 12 mix steps, radius blur 3 px
    # (rows measured before the change are stored under this name)
    "classic": dict(schedule="classic"),
    # classic with feature-aware mix steps (radii.detail_fields)
    "detail": dict(schedule="classic", features="detail"),
    # the "detail" schedule: 18 + 7 mix steps with features="detail"
    "detail-schedule": dict(schedule="detail"),
    # ablations of classic (one change each)
    "default-gray": dict(schedule="classic", radii="gray", floor=0.1),
    "default-pack": dict(schedule="classic", blend=0.0,
                         schedule_override=[("pack", 47)]),
    "default-lloyd-end": dict(schedule="classic", schedule_override=[("mix", 35, 0.5), ("mix", 12, 0.5)]),
    "mix-voronoi": dict(schedule="classic", blend_cell="voronoi"),
    # a candidate for dense stipplings (tuned at n = 50000 on 512 px
    # photographs): 12 mix steps for the tone, then 3 disk-packing steps,
    # which restore the spacing and lower |psi6|; radii blurred by 1 px
    "mix-pack": dict(schedule="classic", schedule_override=[("mix", 12, 0.6), ("pack", 3)],
                     radius_sigma=1.0),
    # the spacing bands without their closing step (s = sqrt(W * H / n), the dot
    # spacing in pixels; tuned on the tuning part, seed 0): s < 2.5
    # "spacing-dense", 2.5 <= s < 3 "spacing-dense2", 3 <= s < 6
    # "detail-schedule", s >= 6 "spacing-coarse"
    "spacing-dense": dict(schedule="classic", schedule_override=[("mix", 16, 0.7), ("pack", 3)],
                          radius_sigma=1.5),
    "spacing-dense2": dict(schedule="classic", schedule_override=[("mix", 16, 0.7), ("pack", 2)],
                           radius_sigma=1.5),
    "spacing-coarse": dict(schedule="classic", schedule_override=[("mix", 35, 0.6), ("mix", 12, 0.4)],
                           features="detail", radius_sigma=2.0),
    # the default without support and capacity (BANDS_BEFORE, no support
    # rule, no capacity), and with equal ink per dot (capacity gain 0.1)
    "before": dict(schedule="before", support=0.0, capacity=0.0),
    "capacity": dict(schedule="before", support=0.0, capacity=0.1),
}

#: The default's spacing bands without their closing centroid step, with
#: classic's options (no ``support``, no ``capacity``): configurations with
#: ``schedule="before"`` run the band of the dot spacing.
BANDS_BEFORE = (
    (2.5, [("mix", 16, 0.7), ("pack", 3)], {"radius_sigma": 1.5}),
    (3.0, [("mix", 16, 0.7), ("pack", 2)], {"radius_sigma": 1.5}),
    (6.0, [("mix", 18, 0.5), ("mix", 7, 0.4)], {"features": "detail"}),
    (np.inf, [("mix", 35, 0.6), ("mix", 12, 0.4)], {"features": "detail", "radius_sigma": 2.0}),
)


def before_band(kw, width, height, n):
    """`kw` with ``schedule="before"`` replaced by the :data:`BANDS_BEFORE` band's phases and options."""
    from diskpack_cl.schedule import SCHEDULE_OPTIONS

    spacing = np.sqrt(width * height / n)
    phases, options = next((ph, op) for bound, ph, op in BANDS_BEFORE if spacing < bound)
    out = dict(SCHEDULE_OPTIONS["classic"], **options)
    out.update({k: v for k, v in kw.items() if k != "schedule"})
    return dict(out, schedule=phases)


#: Reference configuration of the spacing condition (:func:`meets_condition`).
REFERENCE = "lloyd"
P01_TARGET = 0.85


def meets_condition(r, ref):
    """The spacing condition: tone at least ``ref``'s, P01 >= 0.85, |psi6| below ``ref``'s.

    ``r`` and ``ref`` are dicts with ``tone``, ``p01`` and ``psi6`` (rows or means).

    Examples
    --------
    >>> meets_condition(dict(tone=.91, p01=.86, psi6=.54), dict(tone=.9, psi6=.55))
    True
    """
    return bool(r["tone"] >= ref["tone"] and r["p01"] >= P01_TARGET and r["psi6"] < ref["psi6"])


def parse_config(spec):
    """``"name:key=value;key=value"`` -> (name, stipple keyword overrides).

    Examples
    --------
    >>> parse_config("default:radius_sigma=1.5;blend=0.6")
    ('default', {'radius_sigma': 1.5, 'blend': 0.6})
    """
    name, _, rest = spec.partition(":")
    if name not in CONFIGS:
        raise ValueError(f"unknown configuration {name!r}; choose from {sorted(CONFIGS)}")
    extra = {}
    for item in filter(None, (s.strip() for s in rest.split(";"))):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError(f"bad override {item!r} in {spec!r}: key=value")
        extra[key.strip()] = ast.literal_eval(value.strip())
    return name, extra


def load(image):
    """Gray image of a validation photograph (a name of :data:`IMAGES`) or of a file."""
    path = ROOT / IMAGES[image][0] if image in IMAGES else Path(image)
    return load_gray(path)


def stipple_kwargs(name, extra, size=None):
    """Keyword arguments of ``stipple`` for configuration ``name`` with ``extra`` overrides.

    ``size = (width, height, n)`` picks the band of ``schedule="before"``
    (:func:`before_band`).
    """
    kw = dict(CONFIGS[name])
    kw.update(extra)
    override = kw.pop("schedule_override", None)
    if override is not None:
        # the named schedule's options with another phase list
        from diskpack_cl.schedule import SCHEDULE_OPTIONS

        opts = dict(SCHEDULE_OPTIONS[kw.pop("schedule")])
        opts.update(kw)
        kw = dict(opts, schedule=override)
    if kw.get("schedule") == "before":
        kw = before_band(kw, *size)
    return kw


def run(image, n, spec, seed=0, measure=None):
    """Stipple ``image`` with ``n`` dots under configuration ``spec`` and measure it.

    ``measure(points, darkness)``, when given, returns a dict of more
    measures for the row.

    Returns
    -------
    dict
        ``image``, ``part``, ``config`` (the spec), ``n``, ``seed``,
        ``tone`` (SSIM at sigma 3), ``tone15`` (sigma 1.5), ``p01``,
        ``p01_pair`` (P01 of ``spacing(normalize="pair")``, a diagnostic), ``psi6``,
        ``certified`` (None for the start), ``iterations``, ``seconds``
        (stippling wall time) and ``measure_seconds``.
    """
    name, extra = parse_config(spec)
    gray = load(image)
    kw = stipple_kwargs(name, extra, (gray.shape[1], gray.shape[0], n))
    t = time.perf_counter()
    if kw.get("schedule") == []:
        from diskpack_cl.dithering import error_diffusion

        pts = error_diffusion(gray, n, seed=seed)
        valid, iters = None, 0
    else:
        res = stipple(gray, n, seed=seed, **kw)
        pts, valid, iters = res.points, bool(res.certificate.valid), len(res.history)
    secs = time.perf_counter() - t
    dark = 1.0 - gray
    m = stipple_measures(pts, dark)
    more = {} if measure is None else measure(pts, dark)
    return {"image": image, "part": IMAGES.get(image, ("", "file"))[1], "config": spec,
            "n": int(n), "seed": int(seed), "tone": round(m["tone_ssim"], 4),
            "tone15": round(m["tone_ssim_fine"], 4), "p01": round(m["spacing_p01"], 4),
            "p01_pair": round(m["spacing_p01_pair"], 4), "psi6": round(m["psi6_mean"], 4),
            "stray": round(m["stray_per_10k"], 2), "edge": _round(m["edge_ssim"]),
            "holes": round(m["holes_per_10k"], 2), "certified": valid, "iterations": iters,
            "seconds": round(secs, 2), "measure_seconds": round(time.perf_counter() - t - secs, 2),
            **more}


def _round(x):
    return None if x != x else round(x, 4)   # NaN (no strong edge) as null in JSON


#: Measures averaged over seeds in :func:`summarize` (rows without one, from
#: before it existed, give NaN).
MEASURES = ("tone", "tone15", "p01", "p01_pair", "psi6", "stray", "edge", "holes",
            "iterations", "seconds")

#: The picture target, against Lloyd (``ref``) and, on
#: photographs, ``--capacity 0.1`` (``cap``: its tone and the configuration's
#: own, ``own``, on the seeds both have): each check returns True, False, or
#: None where a side lacks the measure (an image without strong edges).
TARGET = {
    "stray": lambda s, ref, cap: s["stray"] <= ref["stray"] + 5.0,
    "edge": lambda s, ref, cap: None if np.isnan(s["edge"] + ref["edge"]) else s["edge"] >= ref["edge"] - 0.01,
    "tone": lambda s, ref, cap: s["tone"] >= ref["tone"] and (cap is None or cap["own"] >= cap["tone"]),
    "p01_pair": lambda s, ref, cap: s["p01_pair"] >= ref["p01_pair"] + 0.05,
    "psi6": lambda s, ref, cap: s["psi6"] <= ref["psi6"] + 0.01,
    "certified": lambda s, ref, cap: s["certified"] is not False,
}


def target_misses(s, ref, cap=None):
    """The names of the :data:`TARGET` checks that summary `s` misses against `ref` (and `cap`).

    Examples
    --------
    >>> ref = dict(tone=.9, p01_pair=.8, psi6=.55, stray=0.0, edge=.8, certified=True)
    >>> s = dict(ref, tone=.91, p01_pair=.86, psi6=.57, stray=3.0, edge=float("nan"))
    >>> target_misses(s, ref)
    ['psi6']
    >>> target_misses(s, ref, dict(tone=.92, own=.91))
    ['tone', 'psi6']
    """
    return [name for name, check in TARGET.items() if check(s, ref, cap) is False]


def _means(by_seed, seeds):
    out = {}
    for key in MEASURES:
        vals = [by_seed[x].get(key) for x in seeds]
        out[key] = float(np.mean([np.nan if v is None else v for v in vals]))
    cert = [by_seed[x]["certified"] for x in seeds]
    out["certified"] = None if any(c is None for c in cert) else all(cert)
    return out


def summarize(rows, reference=REFERENCE, capacity="capacity"):
    """Mean over seeds per (image, n, config), and the picture target (:data:`TARGET`).

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`run`.
    reference : str
        The configuration of the target's baseline (Lloyd).
    capacity : str
        The configuration whose tone a photograph's result must also reach
        (on the seeds both have; not applied to the line art, nor where it
        was not run).

    Returns
    -------
    list of dict
        One per (image, n, config), in first-seen order: the means of
        :data:`MEASURES` over the seeds both sides have, ``seeds``,
        ``certified`` (all seeds), the differences to the reference
        (``d_tone``, ``d_p01_pair``, ``d_psi6``, ``d_stray``, ``d_edge``) and
        ``misses``: the target checks missed (None for the reference itself
        and where it was not run).

    Examples
    --------
    >>> r = [dict(image="a", n=5, config=c, seed=0, tone=t, tone15=t, p01=p, p01_pair=p, psi6=s,
    ...           stray=0.0, edge=e, holes=0.0, certified=True, iterations=1, seconds=1.0)
    ...      for c, t, p, s, e in [("lloyd", .9, .7, .55, .8), ("default", .91, .86, .54, .6)]]
    >>> [s["misses"] for s in summarize(r)]
    [None, ['edge']]
    """
    groups = {}
    for r in rows:
        groups.setdefault((r["image"], r["n"], r["config"]), {})[r["seed"]] = r
    out = []
    for (image, n, config), by_seed in groups.items():
        ref = groups.get((image, n, reference)) if config != reference else None
        seeds = sorted(by_seed) if ref is None else sorted(set(by_seed) & set(ref)) or sorted(by_seed)
        s = {"image": image, "part": by_seed[seeds[0]].get("part", ""), "n": n, "config": config,
             "seeds": len(seeds), **_means(by_seed, seeds), "misses": None}
        if ref is not None and set(seeds) <= set(ref):
            rm = _means(ref, seeds)
            cap = groups.get((image, n, capacity))
            common = sorted(set(seeds) & set(cap or ()))
            cm = None
            if common and config != capacity and s["part"] != "lineart":
                cm = {"tone": _means(cap, common)["tone"], "own": _means(by_seed, common)["tone"]}
            for key in ("tone", "p01_pair", "psi6", "stray", "edge"):
                s[f"d_{key}"] = s[key] - rm[key]
            s["misses"] = target_misses(s, rm, cm)
        out.append(s)
    return out


def print_summary(summary, markdown=False):
    """Print :func:`summarize` as plain text or as a Markdown table, then the target's tally."""
    cols = ("tone", "tone15", "p01_pair", "psi6", "stray", "edge", "holes")
    if markdown:
        print("| image | n | config | seeds | tone σ3 | tone σ1.5 | P01 pair | \\|psi6\\| | stray /10k "
              "| edge SSIM | holes /10k | misses |")
        print("|" + " --- |" * 12)
    for s in summary:
        vals = " | ".join(f"{s[c]:.4f}" if c not in ("stray", "holes") else f"{s[c]:.1f}" for c in cols)
        miss = "" if s["misses"] is None else (", ".join(s["misses"]) or "none")
        if markdown:
            print(f"| {s['image']} | {s['n']} | {s['config']} | {s['seeds']} | {vals} | {miss} |")
        else:
            print(f"{s['image']:12s} {s['n']:6d} {s['config']:32s} {s['seeds']:2d} "
                  f"{vals.replace(' | ', ' ')} {miss}")
    by_config = {}
    for s in summary:
        if s["misses"] is not None:
            by_config.setdefault(s["config"], []).append(s)
    for config, ss in by_config.items():
        fails = [f"{s['image']}@{s['n']} ({', '.join(s['misses'])})" for s in ss if s["misses"]]
        print(f"{config}: meets the target on {len(ss) - len(fails)} of {len(ss)} (image, n)"
              + (f"; not on {'; '.join(fails)}" if fails else ""))


def print_comparison(summary, configs):
    """Markdown tables, one per n: every measure as ``a / b / c`` over `configs`, and the last one's misses."""
    by = {(s["image"], s["n"], s["config"]): s for s in summary}
    cols = (("tone", "tone σ3", 3), ("tone15", "tone σ1.5", 3), ("stray", "stray /10k", 0),
            ("edge", "edge", 3), ("holes", "holes /10k", 0), ("p01_pair", "P01 pair", 3),
            ("psi6", "\\|psi6\\|", 3))
    for n in sorted({s["n"] for s in summary}):
        images = [im for im in dict.fromkeys(s["image"] for s in summary if s["n"] == n)
                  if all((im, n, c) in by for c in configs)]
        if not images:
            continue
        print(f"\n**n = {n}** ({' / '.join(configs)}; seeds: {by[images[0], n, configs[-1]]['seeds']})\n")
        print("| image | " + " | ".join(c[1] for c in cols) + f" | {configs[-1]} misses |")
        print("|" + " --- |" * (len(cols) + 2))
        for im in images:
            cells = [" / ".join("–" if by[im, n, c][key] != by[im, n, c][key] else f"{by[im, n, c][key]:.{d}f}"
                                for c in configs) for key, _, d in cols]
            miss = by[im, n, configs[-1]]["misses"]
            print(f"| {im} | " + " | ".join(cells) + f" | {', '.join(miss) if miss else 'none'} |")


def print_tally(summary, configs):
    """Markdown: per configuration and n, on how many images each check of :data:`TARGET` holds."""
    print(f"\n| configuration | n | images | {' | '.join(TARGET)} | all |")
    print("|" + " --- |" * (len(TARGET) + 4))
    for config in configs:
        for n in sorted({s["n"] for s in summary}):
            ss = [s for s in summary if s["n"] == n and s["config"] == config and s["misses"] is not None]
            if ss:
                counts = [sum(name not in s["misses"] for s in ss) for name in TARGET]
                print(f"| {config} | {n} | {len(ss)} | " + " | ".join(map(str, counts))
                      + f" | {sum(not s['misses'] for s in ss)} |")


def print_row(r):
    edge = "  nan" if r["edge"] is None else f"{r['edge']:.3f}"
    print(f"{r['image']:12s} {r['n']:6d} {r['seed']:4d} {r['config']:32s} {r['tone']:7.4f} "
          f"{r['tone15']:7.4f} {r['p01_pair']:7.4f} {r['psi6']:7.4f} {r['stray']:6.1f} {edge} "
          f"{r['holes']:6.1f} {r['seconds']:6.1f} {r['iterations']:4d} {r['certified']}", flush=True)


def read_rows(paths):
    rows = []
    for p in paths:
        for line in Path(p).read_text().splitlines():
            if line.strip():
                rows.append(json.loads(line))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", type=int, nargs="+", default=[5000, 20000, 50000])
    ap.add_argument("--set", choices=sorted(SETS), default="heldout",
                    help="images: %(choices)s (default: %(default)s); --images overrides")
    ap.add_argument("--images", nargs="+", help=f"names of {sorted(IMAGES)} or image files")
    ap.add_argument("--configs", nargs="+", default=["default", "lloyd"],
                    help=f"configurations (name[:key=value;...], names: {sorted(CONFIGS)}); "
                         "default: %(default)s")
    ap.add_argument("--seeds", "--seed", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--jsonl", help="append every row to this file as it is measured")
    ap.add_argument("--skip-done", action="store_true",
                    help="with --jsonl: do not measure again the rows the file already holds")
    ap.add_argument("--json", help="write all rows of this run to this file at the end")
    ap.add_argument("--summary", nargs="+", metavar="JSONL", help="summarize these files; run nothing")
    ap.add_argument("--reference", default=REFERENCE, help="configuration of the condition (default: lloyd)")
    ap.add_argument("--markdown", action="store_true", help="summary as a Markdown table")
    ap.add_argument("--compare", nargs="+", metavar="CONFIG",
                    help="with --summary: Markdown tables of every measure as a / b / c over these "
                         "configurations, one per n")
    a = ap.parse_args(argv)
    if a.summary:
        summary = summarize(read_rows(a.summary), a.reference)
        if a.compare:
            print_comparison(summary, a.compare)
            print_tally(summary, [c for c in a.compare if c != a.reference])
        else:
            print_summary(summary, a.markdown)
        return 0
    for spec in a.configs:
        parse_config(spec)  # fail before any work
    images = a.images or SETS[a.set]
    done = set()
    if a.jsonl and a.skip_done and Path(a.jsonl).exists():
        done = {(r["image"], r["n"], r["config"], r["seed"]) for r in read_rows([a.jsonl])}
    rows = []
    print(f"{'image':12s} {'n':>6s} {'seed':>4s} {'config':32s} {'tone':>7s} {'tone15':>7s} "
          f"{'P01pair':>7s} {'psi6':>7s} {'stray':>6s} {'edge':>5s} {'holes':>6s} {'sec':>6s} {'it':>4s} cert")
    for n in a.n:
        for im in images:
            for seed in a.seeds:
                for spec in a.configs:
                    if (im, n, spec, seed) in done:
                        continue
                    r = run(im, n, spec, seed=seed)
                    rows.append(r)
                    print_row(r)
                    if a.jsonl:
                        with open(a.jsonl, "a") as f:
                            f.write(json.dumps(r) + "\n")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    all_rows = read_rows([a.jsonl]) if a.jsonl else rows
    print()
    print_summary(summarize(all_rows, a.reference), a.markdown)
    return 0


if __name__ == "__main__":
    sys.exit(main())
