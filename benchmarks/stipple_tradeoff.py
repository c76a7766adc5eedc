"""Tone against spacing along the blend of the default's own band: can a photograph have both?

For each (photograph, n) the default's band at that dot spacing
(:func:`diskpack_cl.schedule.default_band`) is run with the blend of every
mix phase set to each value of ``--blends`` (0: disk packing only, 1: every
mix step goes all the way to the centroid), from the same start and seed as
Lloyd's run, and measured like ``benchmarks/stipple_quality.py``. The plot
shows tone minus Lloyd's against P01, one curve per pair: where no point of
the curve lies in the shaded corner (tone at least Lloyd's, P01 >= 0.85),
this family of schedules cannot give that photograph both. Filled markers
have |psi6| below Lloyd's.

    python benchmarks/stipple_tradeoff.py astronaut:5000 camera:5000 astronaut:50000 \\
        --jsonl rows.jsonl -o docs/figures/stipple_tradeoff.png
    python benchmarks/stipple_tradeoff.py --rows rows.jsonl -o plot.png   # plot only
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import stipple_quality as sq
from diskpack_cl.schedule import default_band

BLENDS = (0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0)


def band_spec(image, n, blend):
    """The stipple_quality spec of the default's band for ``image`` at ``n`` with every mix blend ``blend``."""
    H, W = sq.load(image).shape
    phases, options = default_band(np.sqrt(W * H / n))
    phases = [(p[0], p[1], blend) if p[0] == "mix" else tuple(p) for p in phases]
    extra = ";".join(f"{k}={v!r}" for k, v in sorted(options.items()))
    return f"classic:schedule_override={phases!r}" + (f";{extra}" if extra else "")


def edge_tail(points, darkness, change=0.25):
    """Where the close pairs are: the share of dots on a tone edge, in the P01 tail and overall.

    A dot is *on an edge* where the expected darkness (blurred by 3 px, as in
    :func:`diskpack_cl.analysis.spacing`) changes by more than ``change``
    (relative) over one local dot spacing ``1 / sqrt(rho_i)``: there its
    nearest neighbour may sit on the denser side, at that side's spacing.
    Returns ``{"edge_tail": share among the dots below the 1st percentile of
    the normalized spacing, "edge_all": share among all dots}``.
    """
    from scipy import ndimage

    from diskpack_cl.analysis import spacing

    sp = spacing(points, darkness)
    gy, gx = np.gradient(ndimage.gaussian_filter(darkness, 3.0, mode="reflect"))
    at = [points[:, 1] - 0.5, points[:, 0] - 0.5]
    grad = ndimage.map_coordinates(np.hypot(gx, gy), at, order=1, mode="nearest")
    # the blurred darkness at the dots, from the density spacing() read there
    d = np.maximum(sp.density * darkness.sum() / len(points), 1e-9)
    rho = len(points) * d / darkness.sum()
    edge = grad / d / np.sqrt(rho) > change
    tail = sp.values <= sp.p01
    return {"edge_tail": round(float(edge[tail].mean()), 3), "edge_all": round(float(edge.mean()), 3)}


def sweep(pairs, blends=BLENDS, seed=0, jsonl=None):
    """Lloyd's row and one row per blend for every ``(image, n)``; rows carry ``blend``."""
    rows = []
    for image, n in pairs:
        runs = [("lloyd", None)] + [(band_spec(image, n, b), b) for b in blends]
        for spec, blend in runs:
            r = dict(sq.run(image, n, spec, seed=seed, measure=edge_tail), blend=blend)
            rows.append(r)
            print(f"{image:12s} {n:6d} {'lloyd' if blend is None else f'blend {blend:.2f}':10s} "
                  f"tone {r['tone']:.4f} P01 {r['p01']:.4f} psi6 {r['psi6']:.4f} "
                  f"on edges: P01 tail {r['edge_tail']:.2f}, all {r['edge_all']:.2f}", flush=True)
            if jsonl:
                with open(jsonl, "a") as f:
                    f.write(json.dumps(r) + "\n")
    return rows


def plot(rows, path):
    """One curve per (image, n): tone - Lloyd's against P01 along the blend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pairs = list(dict.fromkeys((r["image"], r["n"]) for r in rows))
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for (image, n), color in zip(pairs, plt.cm.tab10.colors):
        ref = [r for r in rows if (r["image"], r["n"]) == (image, n) and r["blend"] is None]
        if not ref:
            continue
        ref = ref[0]
        own = sorted((r for r in rows if (r["image"], r["n"]) == (image, n) and r["blend"] is not None),
                     key=lambda r: r["blend"])
        x = [r["p01"] for r in own]
        y = [r["tone"] - ref["tone"] for r in own]
        ax.plot(x, y, "-", color=color, lw=1, label=f"{image}, n = {n}")
        for r, xi, yi in zip(own, x, y):
            ax.plot(xi, yi, "o", color=color, mfc=color if r["psi6"] < ref["psi6"] else "white")
            ax.annotate(f"{r['blend']:g}", (xi, yi), textcoords="offset points", xytext=(3, 3),
                        fontsize=7, color=color)
        ax.plot(ref["p01"], 0.0, "x", color=color, ms=8)
    hi = ax.get_ylim()[1]
    right = max(ax.get_xlim()[1], 0.95)
    ax.fill_between([sq.P01_TARGET, right], 0, max(hi, 0.01), color="0.85", zorder=0,
                    label="tone >= Lloyd's, P01 >= 0.85")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.axvline(sq.P01_TARGET, color="0.5", lw=0.8, ls="--")
    ax.set_xlim(right=right)
    ax.set_xlabel("P01 (density-normalized nearest-neighbour distance, 1st percentile)")
    ax.set_ylabel("tone SSIM (sigma 3) minus Lloyd's")
    ax.set_title("The default's band at each pair's dot spacing, every mix step at the blend "
                 "written beside it\nx: Lloyd (same start and seed). Filled: |psi6| below Lloyd's; "
                 "hollow: above", fontsize=9)
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    tmp = Path(path).with_name(Path(path).stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    tmp.replace(path)
    plt.close(fig)


def parse_pair(text):
    """``"image:n"`` -> ``(image, n)``.

    Examples
    --------
    >>> parse_pair("astronaut:5000")
    ('astronaut', 5000)
    """
    image, _, n = text.rpartition(":")
    if not image or not n.isdigit():
        raise argparse.ArgumentTypeError(f"bad pair {text!r}: image:n")
    return image, int(n)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("pairs", nargs="*", type=parse_pair, help="image:n (names of stipple_quality.IMAGES)")
    ap.add_argument("--blends", type=float, nargs="+", default=list(BLENDS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jsonl", help="append every row to this file")
    ap.add_argument("--rows", nargs="+", help="plot these jsonl files; run nothing")
    ap.add_argument("-o", "--output", help="write the plot here (PNG)")
    a = ap.parse_args(argv)
    if a.rows:
        rows = sq.read_rows(a.rows)
    elif a.pairs:
        rows = sweep(a.pairs, a.blends, a.seed, a.jsonl)
    else:
        ap.error("give image:n pairs or --rows")
    if a.output:
        plot(rows, a.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
