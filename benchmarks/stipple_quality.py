"""Stippling quality: tone SSIM, spacing P01, |psi6| on the three test photographs.

Compares configurations of :func:`diskpack_cl.stipple.stipple` (the paper's
schedule, the Lloyd baseline, others) from the same error-diffusion start and
seed, and checks that every output is certified.

    python benchmarks/stipple_quality.py [-n 20000] [--images astronaut coffee camera]
        [--configs lloyd paper ...] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from diskpack_cl.analysis import stipple_measures
from diskpack_cl.image import load_gray
from diskpack_cl.stipple import stipple

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"

CONFIGS = {
    # the error-diffusion start, no iteration (no certificate computed)
    "start": dict(schedule=[]),
    # weighted Voronoi stippling (Secord 2002), 50 Lloyd iterations
    "lloyd": dict(method="lloyd"),
    # the paper's loop: 40 pack, 10 Lloyd, 40, 10, 20 pack; gray radii, gamma 3
    "paper": dict(schedule="paper"),
    # disk packing only, 60 iterations (gray radii)
    "pack": dict(schedule="pack"),
    # the default: 35 mix@0.5 + 12 mix@0.4, density radii (see stipple.SCHEDULE_OPTIONS)
    "default": dict(schedule="default"),
    # ablations of the default (one change each)
    "default-gray": dict(schedule="default", radii="gray", floor=0.1),
    "default-pack": dict(schedule="default", blend=0.0,
                         schedule_override=[("pack", 47)]),
    "default-lloyd-end": dict(schedule="default", schedule_override=[("mix", 35, 0.5), ("mix", 12, 0.5)]),
    "mix-voronoi": dict(schedule="default", blend_cell="voronoi"),
}


def run(image, n, name, seed=0, **extra):
    gray = load_gray(DATA / f"{image}.png")
    kw = dict(CONFIGS[name])
    kw.update(extra)
    override = kw.pop("schedule_override", None)
    if override is not None:
        # the default's options with another phase list
        from diskpack_cl.stipple import SCHEDULE_OPTIONS

        opts = dict(SCHEDULE_OPTIONS[kw.pop("schedule")])
        opts.update({k: v for k, v in kw.items()})
        kw = dict(opts, schedule=override)
    t = time.perf_counter()
    if kw.get("schedule") == []:
        from diskpack_cl.stipple import error_diffusion

        pts = error_diffusion(gray, n, seed=seed)
        valid, secs = None, time.perf_counter() - t
    else:
        res = stipple(gray, n, seed=seed, **kw)
        pts, valid, secs = res.points, bool(res.certificate.valid), time.perf_counter() - t
    m = stipple_measures(pts, 1.0 - gray)
    return {"image": image, "config": name, "n": n, "seconds": round(secs, 2),
            "tone_ssim": round(m["tone_ssim"], 4), "spacing_p01": round(m["spacing_p01"], 4),
            "psi6": round(m["psi6_mean"], 4), "certified": valid}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", type=int, default=20000)
    ap.add_argument("--images", nargs="+", default=["astronaut", "coffee", "camera"])
    ap.add_argument("--configs", nargs="+", default=["start", "lloyd", "paper", "default"],
                    choices=sorted(CONFIGS), help="configurations (rows), default: %(default)s")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    rows = []
    print(f"{'image':10s} {'config':18s} {'tone':>7s} {'P01':>7s} {'psi6':>7s} {'sec':>7s} cert")
    for im in a.images:
        for c in a.configs:
            r = run(im, a.n, c, seed=a.seed)
            rows.append(r)
            print(f"{im:10s} {c:18s} {r['tone_ssim']:7.4f} {r['spacing_p01']:7.4f} "
                  f"{r['psi6']:7.4f} {r['seconds']:7.1f} {r['certified']}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
