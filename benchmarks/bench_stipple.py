"""Seconds per stipple iteration and per stage, both methods.

For n in --n (default 5k, 20k, 50k) on the 512x512 sample photograph and a
2048x2048 upscale of it, runs a few disk-packing and Lloyd iterations and
prints the median seconds per iteration and per stage (the grid's power
labels, the MIC step: :data:`MIC_STAGES`, the centroids), plus the
error-diffusion start, and the anchor: scipy's ``Voronoi`` of n uniform
random points timed in the same run (the median of three, before the
stipplings of that n), with each method's seconds per iteration over it
(``ratio``).
Methods: ``diskpack`` (paper disk-packing steps), ``mix`` (the default
schedule's step: disk packing blended with power-cell centroids, with the
default's options), ``mix-before`` (the same without ``support`` and
``capacity``) and ``lloyd``.

    python benchmarks/bench_stipple.py [--n 5000 20000 50000] [--sizes 512 2048]
        [--iters 5] [--device pocl] [--json rows.jsonl] [--profile]

``--profile`` adds the device seconds of the kernels per iteration (OpenCL
events): all of them (``kernel``) and, in the JSON, per kernel.

With ``--end-to-end N``: whole runs at N dots on the sample instead, the
default schedule, the default without ``support`` and ``capacity``,
``classic`` and the paper's Fig. 8 schedule (180 disk-packing and 30
Lloyd iterations: three rounds of 60 + 10), seconds from the image to the
certified result.

With ``--color``: whole CMYK stipplings (:func:`diskpack_cl.stipple_colors`)
against mono ones of the same n on the same joint density (the coverage of
all pens, what the colour run's first phases stipple), of the colour
photographs of ``tests/data/color/`` resized to each of ``--sizes``, each n
of ``--n``; ``--reps`` rounds, mono and CMYK interleaved (which runs first
alternates), each round's CMYK seconds over its mono seconds. Prints the
medians of the seconds and of those ratios, and the colour run's own stages
(separation, pen assignment, the pens' centroids):

    python benchmarks/bench_stipple.py --color --n 20000 50000 --sizes 512 --reps 5

In every mode ``--json`` appends a row per measurement (``kind``:
``iterations``, ``end-to-end`` or ``color``) with the context of
:mod:`perf_rows`; :func:`summary` and :func:`summary_end_to_end` make the
docs' tables of the first two.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.dithering import error_diffusion
from diskpack_cl.schedule import SCHEDULE_OPTIONS
from diskpack_cl.stipple import stipple
from perf_rows import append, count, medians, num
from stipple_large import voronoi_seconds


def image(size):
    from PIL import Image

    g = load_gray(sample_image_path())
    if size == g.shape[0]:
        return g
    im = Image.fromarray(g.astype(np.float32)).resize((size, size), Image.BICUBIC)
    return np.clip(np.asarray(im, dtype=np.float64), 0, 1)


def med(history, key):
    v = [h[key] for h in history if key in h]
    return float(np.median(v)) if v else float("nan")


#: The stages of a MIC step, on the cells route (per-cell kernel, host re-solve)
#: or the raster route (raster estimate, exact refinement).
MIC_STAGES = ("buckets_s", "device_s", "refine_s", "fallback_s", "mic_estimate_s", "exact_s")


def med_sum(history, keys):
    """Median over the steps that have any of `keys` of their sum."""
    v = [sum(h.get(k, 0.0) for k in keys) for h in history if any(k in h for k in keys)]
    return float(np.median(v)) if v else float("nan")


def summary(rows):
    """``(header, rows)`` of the docs' table: median seconds per iteration and stage per image, n, method."""
    values = ["s_per_iter", "mic_s", "centroids_s", "labels_s"]
    med = {(r["size"], r["n"], r["method"]): r
           for r in medians([r for r in rows if r["kind"] == "iterations"], ("size", "n", "method"), values)}
    anchored = [r for r in rows if r["kind"] == "iterations" and r.get("voronoi_s")]
    ratio = {(r["size"], r["n"], r["method"]): r
             for r in medians(anchored, ("size", "n", "method"), ["ratio"])}
    header = ["image", "n", "disk packing s/iter (MIC)", "default mix s/iter (MIC / labels and centroids)",
              "default mix / Voronoi(n)", "weighted Lloyd s/iter (labels and centroids)"]
    out = []
    for size, n in dict.fromkeys(key[:2] for key in med):
        pack, mix, lloyd = (med[size, n, m] for m in ("diskpack", "mix", "lloyd"))
        anchor = ratio.get((size, n, "mix"))
        out.append([f"{size} x {size}", count(n), f"{num(pack['s_per_iter'])} ({num(pack['mic_s'])})",
                    f"{num(mix['s_per_iter'])} ({num(mix['mic_s'])} / {num(_grid_s(mix))})",
                    num(anchor["ratio"]) if anchor else "-",
                    f"{num(lloyd['s_per_iter'])} ({num(_grid_s(lloyd))})"])
    return header, out


def _grid_s(row):
    """A row's seconds on the grid cells: labels and centroid sums (on CPUs one pass, in ``labels_s``)."""
    return (row["labels_s"] or 0.0) + (row["centroids_s"] or 0.0)


def summary_end_to_end(rows):
    """``(header, rows)`` of the docs' table of whole stipplings: median seconds per schedule and n."""
    runs = medians([r for r in rows if r["kind"] == "end-to-end"], ("schedule", "n"), ["iterations", "seconds"])
    header = ["schedule", "n", "steps", "seconds to the certified result", "s/iter"]
    return header, [[r["schedule"], count(r["n"]), count(r["iterations"]), num(r["seconds"]),
                     num(r["seconds"] / r["iterations"])] for r in runs]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[5000, 20000, 50000])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 2048])
    ap.add_argument("--iters", type=int, default=5)
    ap.add_argument("--device")
    ap.add_argument("--json")
    ap.add_argument("--end-to-end", type=int, metavar="N")
    ap.add_argument("--profile", action="store_true", help="device seconds of the kernels")
    ap.add_argument("--color", action="store_true", help="CMYK against mono, interleaved")
    ap.add_argument("--images", nargs="+", default=["astronaut"], help="--color: photographs")
    ap.add_argument("--reps", type=int, default=5, help="--color: rounds")
    a = ap.parse_args(argv)
    if a.end_to_end:
        return end_to_end(a.end_to_end, a.device, a.json)
    if a.color:
        return color_against_mono(a)
    hdr = (f"{'size':>5s} {'n':>7s} {'method':8s} {'start':>7s} {'s/iter':>7s} {'labels':>7s} {'mic':>7s} "
           f"{'centr':>7s} {'ratio':>6s}")
    hdr += f" {'kernel':>7s}" if a.profile else ""
    print(hdr)
    for size in a.sizes:
        g = image(size)
        for n in a.n:
            t = time.perf_counter()
            error_diffusion(g, n, seed=0)
            t_start = time.perf_counter() - t
            voronoi_s = float(np.median([voronoi_seconds(n)[0] for _ in range(3)]))
            for method, sched in (("diskpack", [("pack", a.iters + 1)]),
                                  ("mix", [("mix", a.iters + 1)]), ("mix-before", [("mix", a.iters + 1)]),
                                  ("lloyd", None)):
                if method.startswith("mix"):
                    # the default schedule's step: packing + power-cell centroids, its options
                    # (mix-before: without support and capacity)
                    kw = dict(SCHEDULE_OPTIONS["default"], schedule=sched)
                    if method == "mix-before":
                        kw.update(support=0.0, capacity=0.0)
                else:
                    kw = dict(schedule=sched) if sched else dict(method="lloyd", lloyd=a.iters + 1)
                res = stipple(g, n, seed=0, device=a.device, profile=a.profile, **kw)
                hist = res.history[1:]  # the first iteration includes kernel builds
                row = {"size": size, "n": n, "method": method, "start_s": t_start,
                       "s_per_iter": med(hist, "seconds"), "labels_s": med(hist, "raster_labels_s"),
                       "mic_s": med_sum(hist, MIC_STAGES), "centroids_s": med(hist, "centroids_s"),
                       "first_iter_s": res.history[0]["seconds"], "certify_s": res.timings["certify"],
                       "supersample": res.params["supersample"], "voronoi_s": voronoi_s}
                row["ratio"] = row["s_per_iter"] / voronoi_s
                kernels = sorted({k for h in hist for k in h if k.startswith("kernel")})
                row.update({k: med(hist, k) for k in kernels})
                append(a.json, {"kind": "iterations", "iters": a.iters, **row})
                print(f"{size:5d} {n:7d} {method:8s} {t_start:7.3f} {row['s_per_iter']:7.3f} "
                      f"{row['labels_s']:7.3f} {row['mic_s']:7.3f} {row['centroids_s']:7.3f} {row['ratio']:6.3f}"
                      + (f" {row['kernel_s']:7.3f}" if a.profile else ""), flush=True)
    return 0


def color_image(name, size):
    """A colour photograph of ``tests/data/color`` at `size` px (bicubic), sRGB in [0, 1]."""
    from pathlib import Path

    from PIL import Image

    im = Image.open(Path(__file__).resolve().parents[1] / "tests/data/color" / f"{name}.png").convert("RGB")
    return np.asarray(im.resize((size, size), Image.BICUBIC), dtype=np.float64) / 255.0


def color_against_mono(a):
    """CMYK stipplings against mono ones of the same n, interleaved (see the module docstring)."""
    from diskpack_cl.separation import separate
    from diskpack_cl.multipen import stipple_colors

    print(f"{'image':10s} {'size':>5s} {'n':>7s} {'mono s':>7s} {'cmyk s':>7s} {'ratio':>6s} "
          f"{'min':>5s} {'max':>5s}  cmyk stages (s)")
    for name, size, n in ((i, s, n) for i in a.images for s in a.sizes for n in a.n):
        rgb = color_image(name, size)
        gray = 1.0 - separate(rgb, "cmyk").darkness
        stipple(gray, n, device=a.device)   # buffers of this size made before any clock
        mono, cmyk, stages = [], [], []
        for rep in range(a.reps):
            for kind in ("mono", "cmyk") if rep % 2 == 0 else ("cmyk", "mono"):
                t = time.perf_counter()
                if kind == "mono":
                    stipple(gray, n, device=a.device)
                    mono.append(time.perf_counter() - t)
                else:
                    res = stipple_colors(rgb, n, "cmyk", device=a.device)
                    cmyk.append(time.perf_counter() - t)
                    stages.append(res.timings)
        ratio = np.array(cmyk) / np.array(mono)
        st = {k: float(np.median([s.get(k, 0.0) for s in stages])) for k in stages[0]}
        append(a.json, {"kind": "color", "image": name, "size": size, "n": n, "reps": a.reps, "mono_s": mono,
                        "cmyk_s": cmyk, "ratio_median": float(np.median(ratio)), "cmyk_stages_median": st})
        print(f"{name:10s} {size:5d} {n:7d} {np.median(mono):7.2f} {np.median(cmyk):7.2f} "
              f"{np.median(ratio):6.2f} {ratio.min():5.2f} {ratio.max():5.2f}  "
              + " ".join(f"{k} {v:.2f}" for k, v in st.items() if k != "total"), flush=True)
    return 0


def end_to_end(n, device, json_path):
    """Whole stipplings of the sample: the default schedule, without support and capacity, classic and the paper's Fig. 8."""
    runs = (("default", {}), ("default without support and capacity",
                              dict(support=0.0, capacity=0.0)),
            ("classic (the former default)", dict(schedule="classic")),
            ("paper Fig. 8 (3 x (60 pack + 10 Lloyd))", dict(schedule=[("pack", 60), ("lloyd", 10)] * 3)))
    # the kernels built and the device's buffers made before any clock, so
    # that the first schedule timed does not pay them
    stipple(sample_image_path(), n, seed=0, device=device, schedule=[("mix", 1), ("pack", 1), ("lloyd", 1)])
    for name, kw in runs:
        t = time.perf_counter()
        res = stipple(sample_image_path(), n, seed=0, device=device, **kw)
        total = time.perf_counter() - t
        append(json_path, {"kind": "end-to-end", "schedule": name, "n": n, "iterations": len(res.history),
                           "seconds": total, "valid": bool(res.certificate.valid)})
        print(f"n={n} {name}: {len(res.history)} iterations, {total:.1f} s to the certified result "
              f"({total / len(res.history):.3f} s/iter), certificate valid: {res.certificate.valid}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
