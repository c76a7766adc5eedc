"""Tone against spacing along the blend of the default's own band: can a photograph have both?

For each (photograph, n) the default's band at that dot spacing
(:func:`diskpack_cl.schedule.default_band`) is run with the blend of every
mix phase set to each value of ``--blends`` (0: disk packing only, 1: every
mix step goes all the way to the centroid), from the same start and seed as
Lloyd's run, and measured like ``benchmarks/stipple_quality.py``. The plot
shows tone minus Lloyd's against P01, one curve per pair: where no point of
the curve lies in the shaded corner (tone at least Lloyd's, P01 >= 0.85),
this family of schedules cannot give that photograph both. Filled markers
have |psi6| below Lloyd's; the star is the default itself.

``--table`` prints, per pair, the default, the blends that meet the whole
condition and, where none does, what binds (|psi6|, tone with P01, or tone);
``--map`` draws the same as one coloured cell per pair. Every row also has
``p01_pair``, P01 read against the pair's mean spacing
(``picture_measures.spacing(normalize="pair")``), and the share of the P01 tail on
tone edges.

    python benchmarks/stipple_tradeoff.py astronaut:5000 camera:5000 astronaut:50000 \\
        --jsonl rows.jsonl -o docs/figures/stipple_tradeoff.png
    python benchmarks/stipple_tradeoff.py --rows rows.jsonl -o plot.png   # plot only
    python benchmarks/stipple_tradeoff.py --rows benchmarks/data/stipple_blend_frontier.jsonl --table \\
        --map docs/figures/stipple_frontier_map.png
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


def close_pairs(points, darkness, change=0.25):
    """Where the close pairs are, and P01 with the pair's spacing as the unit.

    A dot is *on an edge* where the expected darkness (blurred by 3 px, as in
    :func:`diskpack_cl.picture_measures.spacing`) changes by more than ``change``
    (relative) over one local dot spacing ``1 / sqrt(rho_i)``: there its
    nearest neighbour may sit on the denser side, at that side's spacing.
    Returns ``{"edge_tail": share of edge dots among the dots below the 1st
    percentile of the normalized spacing, "edge_all": share among all dots,
    "p01_pair": P01 of spacing(normalize="pair")}``.
    """
    from scipy import ndimage

    from diskpack_cl.picture_measures import spacing

    sp = spacing(points, darkness)
    gy, gx = np.gradient(ndimage.gaussian_filter(darkness, 3.0, mode="reflect"))
    at = [points[:, 1] - 0.5, points[:, 0] - 0.5]
    grad = ndimage.map_coordinates(np.hypot(gx, gy), at, order=1, mode="nearest")
    # the blurred darkness at the dots, from the density spacing() read there
    d = np.maximum(sp.density * darkness.sum() / len(points), 1e-9)
    rho = len(points) * d / darkness.sum()
    edge = grad / d / np.sqrt(rho) > change
    tail = sp.values <= sp.p01
    pair = spacing(points, darkness, normalize="pair").p01
    return {"edge_tail": round(float(edge[tail].mean()), 3), "edge_all": round(float(edge.mean()), 3),
            "p01_pair": round(pair, 4)}


def sweep(pairs, blends=BLENDS, seed=0, jsonl=None):
    """Rows of Lloyd, the default and each blend for every ``(image, n)``; rows carry ``blend``.

    ``blend`` is None in the rows of Lloyd and of the default (their
    ``config`` names them).
    """
    rows = []
    for image, n in pairs:
        runs = [("lloyd", None), ("default", None)] + [(band_spec(image, n, b), b) for b in blends]
        for spec, blend in runs:
            r = dict(sq.run(image, n, spec, seed=seed, measure=close_pairs), blend=blend)
            rows.append(r)
            label = spec if blend is None else f"blend {blend:.2f}"
            print(f"{image:13s} {n:6d} {label:10s} tone {r['tone']:.4f} P01 {r['p01']:.4f} "
                  f"psi6 {r['psi6']:.4f} P01 pair {r['p01_pair']:.4f} on edges: P01 tail "
                  f"{r['edge_tail']:.2f}, all {r['edge_all']:.2f}", flush=True)
            if jsonl:
                with open(jsonl, "a") as f:
                    f.write(json.dumps(r) + "\n")
    return rows


def frontier(rows):
    """Per (image, n): the default, the blends that meet the condition, and what binds where none does.

    Returns
    -------
    list of dict
        ``image``, ``part``, ``n``, ``lloyd`` and ``default`` (their rows),
        ``default_meets``, ``meeting`` (the blends whose row meets the
        condition against Lloyd's), ``best_p01`` (the highest P01 among the
        blends with tone at least Lloyd's, None if none has) with its blend
        ``best_p01_blend``, and ``binds``: "" where a blend meets, "psi6"
        where a blend has the tone and P01 but none also |psi6|, "tone"
        where no blend has Lloyd's tone, and "tone+P01" where some have the
        tone but none of those P01 >= 0.85.
    """
    out = []
    for image, n in dict.fromkeys((r["image"], r["n"]) for r in rows):
        own = [r for r in rows if (r["image"], r["n"]) == (image, n)]
        ref = next((r for r in own if r["config"] == "lloyd"), None)
        dflt = next((r for r in own if r["config"] == "default"), None)
        if ref is None or dflt is None:
            continue
        blends = sorted((r for r in own if r["blend"] is not None), key=lambda r: r["blend"])
        toned = [r for r in blends if r["tone"] >= ref["tone"]]
        spaced = [r for r in toned if r["p01"] >= sq.P01_TARGET]
        meeting = [r["blend"] for r in spaced if r["psi6"] < ref["psi6"]]
        best = max(toned, key=lambda r: r["p01"], default=None)
        binds = "" if meeting else "psi6" if spaced else "tone+P01" if toned else "tone"
        out.append({"image": image, "part": ref["part"], "n": n, "lloyd": ref, "default": dflt,
                    "default_meets": sq.meets_condition(dflt, ref), "meeting": meeting,
                    "best_p01": None if best is None else best["p01"],
                    "best_p01_blend": None if best is None else best["blend"], "binds": binds})
    return out


def print_frontier(table):
    """:func:`frontier` as a Markdown table and counts."""
    print("| pair | part | Lloyd tone / P01 / \\|psi6\\| | default tone / P01 / \\|psi6\\| | default meets "
          "| blends that meet | best P01 with tone >= Lloyd's (blend) | binds | P01 pair: Lloyd / default "
          "| default's P01 tail on edges (all dots) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for t in table:
        L, D = t["lloyd"], t["default"]
        best = "none" if t["best_p01"] is None else f"{t['best_p01']:.3f} ({t['best_p01_blend']:g})"
        meeting = ", ".join(f"{b:g}" for b in t["meeting"]) or "none"
        print(f"| {t['image']} {t['n']} | {t['part']} | {L['tone']:.3f} / {L['p01']:.3f} / {L['psi6']:.3f} "
              f"| {D['tone']:.3f} / {D['p01']:.3f} / {D['psi6']:.3f} | {'yes' if t['default_meets'] else 'no'} "
              f"| {meeting} | {best} | {t['binds'] or '-'} | {L['p01_pair']:.3f} / {D['p01_pair']:.3f} "
              f"| {D['edge_tail']:.0%} ({D['edge_all']:.0%}) |")
    print()
    for part in dict.fromkeys(t["part"] for t in table):
        ts = [t for t in table if t["part"] == part]
        binds = {k: sum(t["binds"] == k for t in ts) for k in ("psi6", "tone+P01", "tone")}
        short = [t for t in ts if t["default"]["p01"] < sq.P01_TARGET]
        paired = sum(t["default"]["p01_pair"] >= sq.P01_TARGET for t in short)
        print(f"{part}: {len(ts)} pairs; the default meets {sum(t['default_meets'] for t in ts)}, "
              f"some blend {sum(bool(t['meeting']) for t in ts)}; where none does, what binds: "
              f"{binds['psi6']} |psi6|, {binds['tone+P01']} tone with P01, {binds['tone']} tone alone; "
              f"the default's P01 < {sq.P01_TARGET} on {len(short)}, of which {paired} have "
              f"P01 pair >= {sq.P01_TARGET}")


def plot(rows, path):
    """One curve per (image, n): tone - Lloyd's against P01 along the blend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pairs = list(dict.fromkeys((r["image"], r["n"]) for r in rows))
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for (image, n), color in zip(pairs, plt.cm.tab10.colors):
        ref = [r for r in rows if (r["image"], r["n"]) == (image, n) and r["config"] == "lloyd"]
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
        for r in rows:
            if (r["image"], r["n"], r["config"]) == (image, n, "default"):
                ax.plot(r["p01"], r["tone"] - ref["tone"], "*", color=color, ms=11,
                        mfc=color if r["psi6"] < ref["psi6"] else "white")
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
                 "written beside it\nx: Lloyd (same start and seed), star: the default. Filled: |psi6| below Lloyd's; "
                 "hollow: above", fontsize=9)
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    tmp = Path(path).with_name(Path(path).stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    tmp.replace(path)
    plt.close(fig)


#: Colours of :func:`plot_map`, one per outcome of a pair.
MAP_OUTCOMES = {
    "default": ("the default meets the condition", "#4daf4a"),
    "blend": ("only some blend does", "#b8e186"),
    "psi6": ("a blend has tone and P01, none also |psi6|", "#80b1d3"),
    "tone+P01": ("tone >= Lloyd's with P01 >= 0.85: no blend", "#fdb462"),
    "tone": ("tone >= Lloyd's: no blend", "#fb8072"),
}


def outcome(t):
    """The :data:`MAP_OUTCOMES` key of a :func:`frontier` entry."""
    return "default" if t["default_meets"] else "blend" if t["meeting"] else t["binds"]


def plot_map(table, path):
    """One cell per (photograph, n), coloured by :func:`outcome`, with the default's tone margin and P01."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    images = list(dict.fromkeys(t["image"] for t in table))
    ns = sorted({t["n"] for t in table})
    fig, ax = plt.subplots(figsize=(3.0 + 1.5 * len(ns), 1.9 + 0.34 * len(images)))
    for t in table:
        x, y = ns.index(t["n"]), images.index(t["image"])
        ax.add_patch(plt.Rectangle((x, y), 1, 1, color=MAP_OUTCOMES[outcome(t)][1], ec="white"))
        D, L = t["default"], t["lloyd"]
        ax.text(x + 0.5, y + 0.5, f"tone {D['tone'] - L['tone']:+.3f}\nP01 {D['p01']:.4f}",
                ha="center", va="center", fontsize=6.5, linespacing=1.1)
    parts = {t["image"]: t["part"] for t in table}
    ax.set_xlim(0, len(ns))
    ax.set_ylim(len(images), 0)
    ax.set_xticks([i + 0.5 for i in range(len(ns))], [f"n = {n}" for n in ns])
    ax.set_yticks([i + 0.5 for i in range(len(images))], [f"{im} ({parts[im]})" for im in images],
                  fontsize=8)
    ax.tick_params(length=0)
    for i in range(1, len(images)):
        if parts[images[i]] != parts[images[i - 1]]:
            ax.axhline(i, color="k", lw=1.2)
    ax.set_title("Each pair (seed 0): the default, or the blend family of its band\n"
                 "text: the default's tone minus Lloyd's, and its P01", fontsize=9)
    ax.legend(handles=[Patch(color=c, label=lab) for lab, c in MAP_OUTCOMES.values()],
              fontsize=7, loc="upper center", bbox_to_anchor=(0.4, -0.04), ncol=2, frameon=False)
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
    ap.add_argument("--map", help="write the per-pair outcome map here (PNG; rows need Lloyd's and the default's)")
    ap.add_argument("--table", action="store_true",
                    help="print the per-pair frontier table (rows need Lloyd's and the default's)")
    a = ap.parse_args(argv)
    if a.rows:
        rows = sq.read_rows(a.rows)
    elif a.pairs:
        rows = sweep(a.pairs, a.blends, a.seed, a.jsonl)
    else:
        ap.error("give image:n pairs or --rows")
    if a.output:
        plot(rows, a.output)
    if a.table:
        print_frontier(frontier(rows))
    if a.map:
        plot_map(frontier(rows), a.map)
    return 0


if __name__ == "__main__":
    sys.exit(main())
