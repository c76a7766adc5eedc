"""Colour stippling: one certified packing of all pens' dots against the naive overlay.

``python benchmarks/color_quality.py`` stipples the colour photographs of
``tests/data/color/`` (astronaut, coffee, chelsea; 256 px, see
``benchmarks/make_color_set.py``) with CMYK (and astronaut with three pens)
two ways:

* **multi-class**: :func:`diskpack_cl.multipen.stipple_colors` (area-mix
  separation, all dots in one packing, certified disjoint);
* **naive**: every layer stippled alone with the mono default
  (:func:`diskpack_cl.stipple`, as many dots as the multi-class run gives
  that pen) and the layers overlaid, from the same (area-mix) separation
  (``naive``: the same layers, only the placement differs) and, for CMYK,
  from the textbook overprint separation (``naive-overprint``: what tools
  that stipple each channel alone do; independent layers overlap at random,
  so their inks multiply on average, and saturated secondaries such as red
  come from overlapping magenta and yellow dots).

Measures (:func:`diskpack_cl.color_measures.color_measures`): mean CIELAB Delta E
after a blur of one dot spacing, tone SSIM per layer, spacing P01 per pen
and of all dots; the seconds of each run and of a mono run of the same
total n on the joint density (and that run's P01) (both after a mono run of that size, so that
neither pays for allocating the OpenCL buffers). Rows go to ``docs/perf/color_quality.jsonl``; crops
(photograph, naive overlays, multi-class) to ``docs/figures/color_crop_*.png``;
``--table FILE`` prints the markdown table of ``docs/color.md``.

``--black-generation G [G ...]`` measures CMYK's black generation instead:
each photograph and a dark, saturated version of it (:func:`dark_saturated`)
stippled at every setting G (and with ``--pen-share-exponent A [A ...]`` at
every share of dots among pens, :func:`diskpack_cl.multipen.pen_counts`);
per-channel correlation (sRGB) and mean CIEDE2000 of the blurred drawing
and, as ``separation``, of the perfect area mix of the layers against the
photograph (:func:`preview_measures`), and the ink each pen's drawn dots
keep (:func:`ink_kept`); rows to ``--out`` if given, the markdown table of
``docs/color.md`` to stdout. ``--palettes PENS [PENS ...]`` measures the
same way other pens against CMYK (``cmyk``, ``auto:N``: black and N - 1 of
the image's hues, :func:`diskpack_cl.palette.auto_palette`, or
``NAME=COLOR,...``; :func:`palette_table`). The photographs of ``DARK``
(retina, hubble_deep_field) are dark already and are measured as they are
(variant ``dark (photograph)``), without a synthetic dark version; these
modes stipple all five photographs unless ``--images`` is given. With
``--floor``, every row also gets the noise floor of its image
(:func:`channel_floor`): per channel, what that channel stippled alone
with all n dots reaches, black dots on white paper and white on black.
``--paper black`` draws light pens on black paper (``stipple_colors(...,
invert=True)``; palettes for white paper, ``cmyk`` and ``cmy``, are refused
there and get no row).
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from diskpack_cl import stipple
from diskpack_cl.picture_measures import spacing
from diskpack_cl.color_measures import color_measures, render_pens
from diskpack_cl.colorspace import linear_to_srgb, srgb_to_linear
from diskpack_cl.image import load_rgb
from diskpack_cl.pen_radii import pen_ink_radii
from diskpack_cl.pens import PALETTES, PEN_SHARE_EXPONENT, check_paper
from diskpack_cl.separation import separate
from diskpack_cl.drawing.color_writers import write_color_png
from diskpack_cl.multipen import hex_color, stipple_colors

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ("astronaut", "coffee", "chelsea")
DARK = ("retina", "hubble_deep_field")   # dark, saturated photographs: measured as they are
PENS = "black=#000,red=#c00,blue=#06c"


def naive(image, palette, counts, model, seed=0):
    """Each layer of `model`'s separation stippled alone (mono default) with ``counts[p]`` dots, overlaid."""
    sep = separate(image, palette, model=model)
    pts, pen = [], []
    for p, (a, c) in enumerate(zip(sep.layers, counts)):
        if c > 1:   # a layer of 0 or 1 dots is left empty
            pts.append(stipple(1.0 - a, int(c), seed=seed + p).points)
            pen.append(np.full(int(c), p))
    pen, pts = np.concatenate(pen), np.concatenate(pts)
    return SimpleNamespace(points=pts, pen=pen, names=sep.names, colors=sep.colors,
                           layers=sep.layers, width=sep.layers.shape[2], height=sep.layers.shape[1],
                           pen_radius=pen_ink_radii(pts, pen, sep.layers), radii=np.ones(len(pen)))


def _row(name, palette, n, method, res, rgb, seconds):
    m = color_measures(res.points, res.pen, res.layers, res.colors, rgb)
    return {"image": name, "palette": palette, "n": n, "method": method, "seconds": seconds,
            "pens": list(res.names), "counts": np.bincount(res.pen, minlength=len(res.names)).tolist(),
            **m}


def crop(name, results, box, out, scale=2):
    """Photograph and each result side by side, box (x, y, size) at `scale`."""
    import tempfile

    from PIL import Image

    x, y, s = box
    tiles = [Image.open(ROOT / "tests/data/color" / f"{name}.png").convert("RGB")
             .crop((x, y, x + s, y + s)).resize((s * scale, s * scale), Image.LANCZOS)]
    with tempfile.TemporaryDirectory() as tmp:
        for res in results:
            write_color_png(Path(tmp) / "t.png", res, png_scale=scale)
            tiles.append(Image.open(Path(tmp) / "t.png").crop(
                (x * scale, y * scale, (x + s) * scale, (y + s) * scale)))
    sheet = Image.new("RGB", (len(tiles) * s * scale + 8 * (len(tiles) - 1), s * scale), "white")
    for i, t in enumerate(tiles):
        sheet.paste(t, (i * (s * scale + 8), 0))
    sheet.save(out, optimize=True)


BOXES = {"astronaut": (50, 10, 128), "coffee": (64, 40, 128), "chelsea": (70, 20, 128),
         "retina": (64, 64, 128), "hubble_deep_field": (64, 64, 128)}


def paper_crop(name, n, out, palette="auto:3", seed=0):
    """The photograph, `palette` on white paper and on black paper (light pens) side by side:
    the crop ``BOXES[name]`` of stipplings of `n` dots."""
    path = ROOT / "tests/data/color" / f"{name}.png"
    crop(name, [stipple_colors(path, n, palette, seed=seed, invert=black)
                for black in (False, True)], BOXES[name], out)


def run(name, palette, n, figures, seed=0, overlays=True):
    path = ROOT / "tests/data/color" / f"{name}.png"
    rgb = load_rgb(path)
    gray = 1.0 - separate(path, palette).darkness
    stipple(gray, n)   # OpenCL buffers of this size allocated before either clock
    t = time.perf_counter()
    multi = stipple_colors(path, n, palette, seed=seed)
    t_multi = time.perf_counter() - t
    assert multi.certificate.valid
    t = time.perf_counter()
    mono = stipple(gray, n, seed=seed)
    t_mono = time.perf_counter() - t
    rows, naives = [], []
    for model in ("area", "overprint") if overlays and palette in PALETTES else ("area",) * overlays:
        t = time.perf_counter()
        naives.append(naive(path, palette, multi.counts, model, seed=seed))
        method = "naive" if model == "area" else "naive-overprint"
        rows.append(_row(name, palette, n, method, naives[-1], rgb, time.perf_counter() - t))
    rows.append(dict(_row(name, palette, n, "multi-class", multi, rgb, t_multi), mono_seconds=t_mono,
                     mono_p01=spacing(mono.points, 1.0 - gray).p01, seed=seed))
    if figures:
        crop(name, naives + [multi], BOXES[name], ROOT / "docs/figures" / f"color_crop_{name}.png")
    return rows


def dark_saturated(rgb):
    """A dark, saturated version of a photograph: Pillow's colour enhancement x2, then brightness x0.4."""
    from PIL import Image, ImageEnhance

    im = Image.fromarray(np.round(rgb * 255).astype(np.uint8))
    im = ImageEnhance.Brightness(ImageEnhance.Color(im).enhance(2.0)).enhance(0.4)
    return np.asarray(im, dtype=np.float64) / 255.0


def preview_measures(drawn, rgb, sigma):
    """Per-channel correlation (sRGB R, G, B) and mean CIEDE2000 of a drawing (linear light)
    against the photograph (sRGB), both blurred by `sigma` px in linear light."""
    from scipy import ndimage
    from skimage.color import deltaE_ciede2000, rgb2lab

    a, b = (linear_to_srgb(ndimage.gaussian_filter(x, (sigma, sigma, 0), mode="reflect"))
            for x in (drawn, srgb_to_linear(rgb)))
    corr = [float(np.corrcoef(a[..., c].ravel(), b[..., c].ravel())[0, 1]) for c in range(3)]
    return {"corr_rgb": corr, "ciede2000": float(deltaE_ciede2000(rgb2lab(a), rgb2lab(b)).mean())}


def channel_floor(rgb, n, seed=0, paper="white"):
    """Per channel (sRGB R, G, B), the correlation of :func:`preview_measures` that the channel
    reaches stippled alone with all n dots: the noise of one pen at that n and blur.

    Each channel, in linear light, is stippled as a gray image with the mono default
    (:func:`diskpack_cl.stipple`, as :func:`naive` stipples a layer) and drawn at its ink
    radius (:func:`diskpack_cl.pen_radii.pen_ink_radii`, :func:`diskpack_cl.color_measures.render_pens`,
    as the colour rows are drawn): on white paper, black dots where the channel is dark
    (what the area-mix pens do); on black paper, white dots where it is light.

    Examples
    --------
    >>> rgb = load_rgb(ROOT / "tests/data/color/chelsea.png")   # doctest: +SKIP
    >>> channel_floor(rgb, 5000)   # doctest: +SKIP
    [0.96..., 0.91..., 0.88...]
    """
    if paper not in ("white", "black"):
        raise ValueError(f"paper must be 'white' or 'black', got {paper!r}")
    sigma = float(np.sqrt(rgb.shape[0] * rgb.shape[1] / n))
    out = []
    for c in range(3):
        light = srgb_to_linear(rgb[..., c])
        layer = 1.0 - light if paper == "white" else light   # what the dots draw
        pts = stipple(1.0 - layer, n, seed=seed).points
        pen = np.zeros(len(pts), dtype=int)
        drawn = render_pens(pts, pen, pen_ink_radii(pts, pen, layer[None]), np.zeros((1, 3)),
                            layer.shape)
        drawn = drawn if paper == "white" else 1.0 - drawn   # white dots: light is their cover
        out.append(preview_measures(drawn, np.repeat(rgb[..., c:c + 1], 3, axis=2), sigma)["corr_rgb"][0])
    return out


def black_generation_rows(name, n, settings, seed=0, exponents=(1.0,), palettes=("cmyk",),
                          floor=False, paper="white"):
    """Rows of stipplings of `name` and its :func:`dark_saturated` version (of `name` alone if it
    is in ``DARK``) with each palette (``"cmyk"``, ``"auto:N"``, pens), CMYK at each black
    generation, every palette at each pen share exponent (``pen_share_exponent`` of
    :func:`stipple_colors`); with `floor`, each row gets its image's :func:`channel_floor` on
    white paper (``floor_rgb``) and on black (``floor_black_rgb``). On black `paper`, light
    pens (``stipple_colors(..., invert=True)``, drawn by ``render_pens(..., invert=True)``);
    a palette made for white paper is refused there and skipped."""
    photo = load_rgb(ROOT / "tests/data/color" / f"{name}.png")
    variants = ((("dark (photograph)", photo),) if name in DARK
                else (("bright", photo), ("dark", dark_saturated(photo))))
    for variant, rgb in variants:
        sigma = float(np.sqrt(rgb.shape[0] * rgb.shape[1] / n))
        extra = ({"floor_rgb": channel_floor(rgb, n, seed),
                  "floor_black_rgb": channel_floor(rgb, n, seed, "black")} if floor else {})
        for palette, a in itertools.product(palettes, exponents):
            for g in settings if palette == "cmyk" else (1.0,):   # G is CMYK's alone
                black = paper == "black"
                try:
                    check_paper(palette, black)
                except ValueError as exc:
                    print(f"{name} {variant} {palette}: {exc}", flush=True)
                    continue
                t = time.perf_counter()
                res = stipple_colors(rgb, n, palette, black_generation=g, pen_share_exponent=a,
                                     seed=seed, invert=black)
                seconds = time.perf_counter() - t
                drawn = render_pens(res.points, res.pen, res.pen_radius, res.colors, rgb.shape[:2],
                                    invert=black)
                ideal = srgb_to_linear(separate(rgb, palette, black_generation=g,
                                                invert=black).render())
                yield {"image": name, "variant": variant, "paper": paper, "n": n, "seed": seed,
                       "palette": palette, "black_generation": g, "pen_share_exponent": a,
                       "pens": list(res.names), "colors": [hex_color(c) for c in res.colors],
                       "seconds": seconds,
                       "counts": np.asarray(res.counts).tolist(), "ink_kept": ink_kept(res),
                       **preview_measures(drawn, rgb, sigma),
                       "separation": preview_measures(ideal, rgb, sigma), **extra}


def ink_kept(res, scale=3):
    """Per pen, the ink its dots put on the paper (each pen alone, coverage clipped at 1 as
    :func:`render_pens` draws it) over its layer's ink: below 1 where its dots overlap;
    then the paper covered by all pens together over all layers' ink (below 1 where
    dots of different pens overlap too)."""
    from diskpack_cl.picture_measures import render_dots

    H, W = res.layers.shape[1:]
    out, total = [], 0.0
    for p, layer in enumerate(res.layers):
        mine = res.pen == p
        cover = np.minimum(render_dots(res.points[mine] * scale, res.pen_radius[p] * scale,
                                       (H * scale, W * scale)), 1.0)
        total = total + cover
        out.append(float(cover.sum() / scale**2 / max(layer.sum(), 1e-12)) if mine.any() else None)
    out.append(float(np.minimum(total, 1.0).sum() / scale**2 / res.layers.sum()))
    return out


def black_generation_table(rows):
    """Markdown rows of :func:`black_generation_rows`: per image, variant, G and exponent, the
    mean over seeds (CIEDE2000 ± half its range over seeds; ink kept of black and of all pens)."""
    out = ["| image | G | A | dots Y/C/M/K | ink kept K, all | correlation R / G / B | "
           "CIEDE2000 | separation alone: correlation, CIEDE2000 |", "| --- " * 8 + "|"]
    groups = {}
    for r in rows:
        key = (r["image"], r["variant"], r["black_generation"], r.get("pen_share_exponent", 1.0))
        groups.setdefault(key, []).append(r)
    for (image, variant, g, a), rs in groups.items():
        de = [r["ciede2000"] for r in rs]
        spread = f" ± {(max(de) - min(de)) / 2:.1f}" if len(rs) > 1 else ""
        kept = (np.mean([r["ink_kept"][3:] for r in rs], axis=0) if "ink_kept" in rs[0]
                else [None] * 2)
        sep = rs[0]["separation"]
        out.append(f"| {image} ({variant}) | {g:g} | {a:g} | {'/'.join(map(str, rs[0]['counts']))} | "
                   f"{_cells(kept)} | {_cells(np.mean([r['corr_rgb'] for r in rs], axis=0))} | "
                   f"{np.mean(de):.1f}{spread} | {_cells(sep['corr_rgb'])}, {sep['ciede2000']:.1f} |")
    return "\n".join(out)


def palette_table(rows):
    """Markdown rows of :func:`black_generation_rows` over palettes: per image, variant and
    palette, the pens, the means over seeds (CIEDE2000 ± half its range over seeds), the
    separation alone and, where the rows have it, the mean :func:`channel_floor` on white and
    on black paper."""
    floor = "floor_rgb" in rows[0]
    out = ["| image | pens | dots per pen | correlation R / G / B | CIEDE2000 | "
           "separation alone: correlation, CIEDE2000 |"
           + " floor R / G / B, white paper | black paper |" * floor, "| --- " * (6 + 2 * floor) + "|"]
    groups = {}
    for r in rows:
        variant = r["variant"] + (", black paper" if r.get("paper") == "black" else "")
        groups.setdefault((r["image"], variant, r.get("palette", "cmyk")), []).append(r)
    for (image, variant, palette), rs in groups.items():
        de = [r["ciede2000"] for r in rs]
        spread = f" ± {(max(de) - min(de)) / 2:.1f}" if len(rs) > 1 else ""
        sep = rs[0]["separation"]
        pens = (palette if palette in PALETTES else
                f"{'' if '=' in palette else palette + ': '}{' '.join(rs[0]['colors'])}")
        out.append(f"| {image} ({variant}) | {pens} | {'/'.join(map(str, rs[0]['counts']))} | "
                   f"{_cells(np.mean([r['corr_rgb'] for r in rs], axis=0))} | "
                   f"{np.mean(de):.1f}{spread} | {_cells(sep['corr_rgb'])}, {sep['ciede2000']:.1f} |"
                   + "".join(f" {_cells(np.mean([r[k] for r in rs], axis=0))} |"
                             for k in ("floor_rgb", "floor_black_rgb") if floor))
    return "\n".join(out)


def _cells(values):
    return " / ".join("-" if v is None else f"{v:.2f}" for v in values)


def table(path):
    """Markdown rows of a results file: per image, palette and n, each method's measures."""
    rows = [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]
    out = ["| image | pens | n | method | Delta E | P01 all dots | P01 per pen | SSIM per layer | seconds |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        sec = f"{r['seconds']:.1f}" + (f" (mono {r['mono_seconds']:.1f})" if "mono_seconds" in r else "")
        joint = f"{r['p01_joint']:.3f}" + (f" (mono {r['mono_p01']:.3f})" if "mono_p01" in r else "")
        out.append(f"| {r['image']} | {'/'.join(r['pens'])} | {r['n']} | {r['method']} | "
                   f"{r['delta_e']:.1f} | {joint} | {_cells(r['p01'])} | "
                   f"{_cells(r['ssim'])} | {sec} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--table", metavar="JSONL", help="print the markdown table of a results file and stop")
    ap.add_argument("--n", type=int, nargs="+", default=[5000, 15000])
    ap.add_argument("--images", nargs="+", help="photographs of tests/data/color (default: "
                    f"{', '.join(IMAGES)}; with --black-generation or --palettes also {', '.join(DARK)})")
    ap.add_argument("--out", help="results file (default docs/perf/color_quality.jsonl; none with "
                    "--black-generation)")
    ap.add_argument("--black-generation", type=float, nargs="+", metavar="G",
                    help="measure CMYK at these black generations on bright and dark photographs")
    ap.add_argument("--pen-share-exponent", type=float, nargs="+", default=[PEN_SHARE_EXPONENT],
                    metavar="A", help="with --black-generation or --palettes: dots per pen in "
                    "proportion to ink**A, at each A (default: the library's)")
    ap.add_argument("--palettes", nargs="+", metavar="PENS",
                    help="measure these pens (cmyk, auto:N, NAME=COLOR,...) on bright and dark "
                    "photographs as --black-generation does, CMYK at the black generations given "
                    "(default 1); prints the table of pens")
    ap.add_argument("--no-figures", action="store_true")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0],
                    help="stipple each pair with these seeds (the spread over seeds is the noise)")
    ap.add_argument("--paper", choices=("white", "black"), default="white",
                    help="with --black-generation or --palettes: the paper (black: light pens, "
                    "stipple_colors(..., invert=True); cmyk and cmy are refused there)")
    ap.add_argument("--floor", action="store_true", help="with --black-generation or --palettes: "
                    "each image's noise floor per channel (channel_floor)")
    ap.add_argument("--paper-figure", nargs="+", metavar="IMAGE",
                    help="write docs/figures/color_crop_paper_IMAGE.png (paper_crop, auto:3 at the "
                    "first --n) and stop")
    ap.add_argument("--multi-only", action="store_true",
                    help="the multi-class runs alone, without the naive overlays")
    args = ap.parse_args(argv)
    if args.table:
        print(table(args.table))
        return
    for name in args.paper_figure or ():
        paper_crop(name, args.n[0], ROOT / "docs/figures" / f"color_crop_paper_{name}.png")
    if args.paper_figure:
        return
    if args.black_generation or args.palettes:
        rows = []
        images = args.images or IMAGES + DARK
        for name, n, seed in itertools.product(images, args.n, args.seeds):
            for row in black_generation_rows(name, n, args.black_generation or [1.0], seed,
                                             args.pen_share_exponent, args.palettes or ["cmyk"],
                                             args.floor, args.paper):
                rows.append(row)
                print(f"{name} {row['variant']} {row['palette']} seed {seed}: corr "
                      f"{_cells(row['corr_rgb'])} CIEDE2000 {row['ciede2000']:.2f} "
                      f"{row['seconds']:.1f} s"
                      + (f" floor {_cells(row['floor_rgb'])}, on black {_cells(row['floor_black_rgb'])}"
                         if args.floor else ""), flush=True)
        if args.out:
            Path(args.out).write_text("".join(json.dumps(r) + "\n" for r in rows))
        print((palette_table if args.palettes else black_generation_table)(rows))
        return
    images = args.images or IMAGES
    jobs = [(name, "cmyk", n) for name in images for n in args.n]
    jobs += [("astronaut", PENS, n) for n in args.n if "astronaut" in images]
    with open(args.out or ROOT / "docs/perf/color_quality.jsonl", "w") as fh:
        for (name, palette, n), seed in itertools.product(jobs, args.seeds):
            figures = not args.no_figures and palette == "cmyk" and n == max(args.n) and seed == args.seeds[0]
            for row in run(name, palette, n, figures, seed, not args.multi_only):
                fh.write(json.dumps(row) + "\n")
                fh.flush()
                r = lambda v: "-" if v is None else f"{v:.3f}"   # noqa: E731
                print(f"{name} {palette} n={n} seed={seed} {row['method']}: dE {row['delta_e']:.2f} "
                      f"P01 joint {row['p01_joint']:.3f} per pen "
                      + " ".join(map(r, row["p01"])) + " SSIM " + " ".join(map(r, row["ssim"]))
                      + f" {row['seconds']:.1f} s", flush=True)


if __name__ == "__main__":
    main()
