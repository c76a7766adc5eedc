"""Stray dots on line art: the default against plain weighted Lloyd at the dot counts a plotter uses.

Runs the default and Lloyd (``stipple_quality.py``'s ``lloyd``: 50 weighted
Lloyd iterations from the same error-diffusion start and seed) on the
line-art tuning drawings (``tests/data/lineart/``) and the held-out ones
(``make_lineart.HELDOUT``, drawn in memory), and prints one row per run
and a Markdown table of the means over seeds: stray dots per 10 000
(:func:`~diskpack_cl.picture_measures.stray_dots`), edge fidelity and tone
σ3, with the line-art target (stray at most Lloyd's + 5 per 10 000, edge at
least Lloyd's − 0.01).

    python benchmarks/lineart_stray.py [-n 5000 8000 20000] [--seeds 0 1]
        [--images poster lines ...] [--configs default lloyd] [--jsonl rows.jsonl]
    python benchmarks/lineart_stray.py --summary rows.jsonl
    python benchmarks/lineart_stray.py --images sketch -n 5000 --seeds 0 \
        --figure docs/figures/lineart_stray_sketch.png --box 0 0 512 190

A drawing carries ``n`` dots when the dot spacing on its ink,
``sqrt(ink / n)`` px (``ink`` its total darkness in pixels of full black),
is at least :data:`CARRY_SPACING`: closer than that, its lines hold more
than about half a dot per pixel of their length and width, and any
stippling puts dots on the paper beside them. Such rows are measured and
checked, and marked as beyond what the drawing carries.

``--figure OUT`` draws, for the first drawing, n and seed, one panel per
configuration (top to bottom, inside ``--box X Y W H``): the drawing in
light gray, every dot in blue, the stray dots ringed in red, and the
configuration and its stray count as a label.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_lineart  # noqa: E402
import stipple_quality as sq  # noqa: E402

from diskpack_cl.io import atomic_write  # noqa: E402
from diskpack_cl.picture_measures import stipple_measures  # noqa: E402
from diskpack_cl.stipple import stipple  # noqa: E402

#: Smallest dot spacing on the ink (px) at which a drawing carries its dots.
CARRY_SPACING = 1.5

#: The drawings: the tuning ones of ``stipple_quality.py``'s line-art set, then the held-out ones.
TUNING = sq.SETS["lineart"]
HELDOUT = list(make_lineart.HELDOUT)


def darkness(name):
    """Darkness in [0, 1] of a drawing of :data:`TUNING` or :data:`HELDOUT`."""
    if name in make_lineart.HELDOUT:
        gray = np.asarray(make_lineart.HELDOUT[name](), dtype=np.float64) / 255.0
    else:
        gray = sq.load(name)
    return 1.0 - gray


def ink_spacing(dark, n):
    """Dot spacing on full black, ``sqrt(ink / n)`` px.

    Examples
    --------
    >>> ink_spacing(np.ones((10, 10)), 25)
    2.0
    """
    return float(np.sqrt(dark.sum() / n))


def run(name, n, spec, seed, stamp):
    """Stipple drawing `name` with `n` dots under configuration `spec`; one row."""
    config, extra = sq.parse_config(spec)
    dark = darkness(name)
    H, W = dark.shape
    kw = sq.stipple_kwargs(config, extra, (W, H, n))
    t = time.perf_counter()
    res = stipple(1.0 - dark, n, seed=seed, **kw)
    secs = time.perf_counter() - t
    m = stipple_measures(res.points, dark)
    s = ink_spacing(dark, n)
    return {"image": name, "part": "heldout" if name in make_lineart.HELDOUT else "tuning",
            "n": int(n), "seed": int(seed), "config": spec, "ink_spacing": round(s, 3),
            "carries": bool(s >= CARRY_SPACING), "stray": round(m["stray_per_10k"], 2),
            "edge": sq._round(m["edge_ssim"]), "tone": round(m["tone_ssim"], 4),
            "p01_pair": round(m["spacing_p01_pair"], 4), "certified": bool(res.certificate.valid),
            "seconds": round(secs, 2), **stamp}


def _stamp():
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parent).stdout.strip()
    return {"commit": commit, "date": datetime.now(timezone.utc).strftime("%Y-%m-%d")}


def summarize(rows, configs=("default", "lloyd")):
    """Means over the seeds both configurations have, per (image, n): the table's rows.

    Returns
    -------
    list of dict
        ``image``, ``part``, ``n``, ``seeds``, ``ink_spacing``, ``carries``,
        ``stray``, ``edge``, ``tone`` (tuples over `configs`) and
        ``meets``: the line-art target (stray at most the last
        configuration's + 5, edge at least its − 0.01).

    Examples
    --------
    >>> r = [dict(image="a", part="heldout", n=9, seed=0, config=c, ink_spacing=2.0, carries=True,
    ...           stray=s, edge=.9, tone=.99) for c, s in (("default", 7.0), ("lloyd", 1.0))]
    >>> summarize(r)[0]["meets"]
    False
    """
    by = {}
    for r in rows:
        by.setdefault((r["image"], r["n"]), {}).setdefault(r["config"], {})[r["seed"]] = r
    out = []
    for (image, n), cfg in by.items():
        if not all(c in cfg for c in configs):
            continue
        seeds = sorted(set.intersection(*(set(cfg[c]) for c in configs)))
        if not seeds:
            continue
        first = cfg[configs[0]][seeds[0]]

        def mean(key):
            return tuple(float(np.mean([np.nan if cfg[c][s][key] is None else cfg[c][s][key]
                                        for s in seeds])) for c in configs)

        s = {"image": image, "part": first["part"], "n": n, "seeds": len(seeds),
             "ink_spacing": first["ink_spacing"], "carries": first["carries"],
             "stray": mean("stray"), "edge": mean("edge"), "tone": mean("tone")}
        edge_ok = np.isnan(s["edge"][0] + s["edge"][-1]) or s["edge"][0] >= s["edge"][-1] - 0.01
        s["meets"] = bool(s["stray"][0] <= s["stray"][-1] + 5.0 and edge_ok)
        out.append(s)
    return out


def print_table(summary):
    """The summary as a Markdown table (values as ``default / lloyd``)."""
    print("| drawing | part | n | spacing on ink (px) | carries | seeds | stray /10k | edge | tone σ3 | target |")
    print("|" + " --- |" * 10)
    for s in summary:
        def pair(key, fmt):
            return " / ".join("–" if v != v else format(v, fmt) for v in s[key])

        meets = "meets" if s["meets"] else "**misses**"
        carries = "yes" if s["carries"] else "no"
        print(f"| {s['image']} | {s['part']} | {s['n']} | {s['ink_spacing']:.2f} | {carries} | {s['seeds']} | "
              f"{pair('stray', '.1f')} | {pair('edge', '.3f')} | {pair('tone', '.3f')} | {meets} |")


def figure(name, n, seed, configs, box, out):
    """Panels of the stray dots of each configuration (see the module docstring), written to `out`."""
    from PIL import Image, ImageDraw   # only the figure draws

    from diskpack_cl.picture_measures import stray_dots

    dark = darkness(name)
    x0, y0, w, h = box
    panels = []
    for spec in configs:
        config, extra = sq.parse_config(spec)
        kw = sq.stipple_kwargs(config, extra, (dark.shape[1], dark.shape[0], n))
        p = stipple(1.0 - dark, n, seed=seed, **kw).points - (x0, y0)
        stray = stray_dots(p + (x0, y0), dark).mask
        im = Image.fromarray((255 - 70 * dark[y0:y0 + h, x0:x0 + w]).astype(np.uint8)).convert("RGB")
        d = ImageDraw.Draw(im)
        for (x, y), s in zip(p, stray):
            d.ellipse([x - 0.8, y - 0.8, x + 0.8, y + 0.8], fill=(20, 40, 170))
            if s:
                d.ellipse([x - 4, y - 4, x + 4, y + 4], outline=(220, 0, 0), width=2)
        d.text((4, h - 14), f"{spec}: {int(stray.sum())} stray of {n}", fill=(0, 0, 0))
        panels.append(im)
    sheet = Image.new("RGB", (w, len(panels) * (h + 4) - 4), (128, 128, 128))
    for i, im in enumerate(panels):
        sheet.paste(im, (0, i * (h + 4)))
    with atomic_write(out) as f:
        sheet.save(f, format="PNG", optimize=True)
    return sheet


def read_rows(paths):
    return [json.loads(line) for p in paths for line in Path(p).read_text().splitlines() if line.strip()]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", type=int, nargs="+", default=[5000, 8000, 20000])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--images", nargs="+", default=TUNING + HELDOUT,
                    help="drawings (default: %(default)s)")
    ap.add_argument("--configs", nargs="+", default=["default", "lloyd"],
                    help="configurations of stipple_quality.py (name[:key=value;...]); the table "
                         "compares the first with the last")
    ap.add_argument("--jsonl", help="append every row to this file as it is measured")
    ap.add_argument("--skip-done", action="store_true", help="with --jsonl: skip rows the file holds")
    ap.add_argument("--summary", nargs="+", metavar="JSONL", help="print the table of these files; run nothing")
    ap.add_argument("--figure", metavar="PNG", help="draw the stray dots of the first drawing, n and seed; "
                                                    "measure nothing")
    ap.add_argument("--box", type=int, nargs=4, metavar=("X", "Y", "W", "H"),
                    help="with --figure: the part drawn (default: the whole drawing)")
    a = ap.parse_args(argv)
    for spec in a.configs:
        sq.parse_config(spec)   # fail before any work
    for name in a.images:
        if name not in TUNING + HELDOUT:
            raise ValueError(f"unknown drawing {name!r}; choose from {TUNING + HELDOUT}")
    configs = (a.configs[0], a.configs[-1])
    if a.summary:
        print_table(summarize(read_rows(a.summary), configs))
        return 0
    if a.figure:
        H, W = darkness(a.images[0]).shape
        box = a.box or (0, 0, W, H)
        if box[2] < 1 or box[3] < 1 or box[0] < 0 or box[1] < 0 or box[0] + box[2] > W or box[1] + box[3] > H:
            raise ValueError(f"--box must lie inside the {W}x{H} drawing with a positive size, got {box}")
        figure(a.images[0], a.n[0], a.seeds[0], a.configs, box, a.figure)
        print(a.figure)
        return 0
    done = set()
    if a.jsonl and a.skip_done and Path(a.jsonl).exists():
        done = {(r["image"], r["n"], r["config"], r["seed"]) for r in read_rows([a.jsonl])}
    stamp, rows = _stamp(), []
    for n in a.n:
        for name in a.images:
            for seed in a.seeds:
                for spec in a.configs:
                    if (name, n, spec, seed) in done:
                        continue
                    r = run(name, n, spec, seed, stamp)
                    rows.append(r)
                    print(f"{name:9s} {n:6d} {seed:2d} {spec:24s} spacing {r['ink_spacing']:5.2f} "
                          f"stray {r['stray']:6.1f} edge {r['edge']} tone {r['tone']:.4f} "
                          f"{r['seconds']:5.1f}s", flush=True)
                    if a.jsonl:
                        with open(a.jsonl, "a") as f:
                            f.write(json.dumps(r) + "\n")
    print()
    print_table(summarize(read_rows([a.jsonl]) if a.jsonl else rows, configs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
