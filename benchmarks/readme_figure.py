"""The picture at the top of the README and the docs: a stippling beside its photograph,
and a Poisson disk set beside its spectrum.

    python benchmarks/readme_figure.py [--out docs/figures/readme_hero.png]

Deterministic by seed; about 15 s on two CPU cores with PoCL. The PNG is
palette-reduced (the figure is grey but for the spectrum), so that the
README's picture stays small.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from diskpack_cl import load_gray, poisson_disk, sample_image_path, stipple  # noqa: E402
from diskpack_cl.analysis import periodogram  # noqa: E402
from diskpack_cl.picture_measures import render_dots

ROOT = Path(__file__).resolve().parents[1]


def panels(n_dots=12000, n_points=2048):
    """The four images: photograph, stippling (equal-ink dots), point set, log spectrum."""
    gray = load_gray(sample_image_path())[16:400, 96:480]      # the astronaut's head and badge
    res = stipple(gray, n_dots, seed=0)
    ink = 1 - np.clip(render_dots(res.points, res.tone_radius, gray.shape), 0, 1)
    pts = poisson_disk(n_points, seed=0)
    freqs, power = periodogram(pts.points, kmax=96)
    return gray, ink, res, pts, power


def draw(out):
    """Write the figure to ``out`` as a palette PNG."""
    gray, ink, res, pts, power = panels()
    fig, axes = plt.subplots(1, 4, figsize=(12, 3.3), dpi=100)
    axes[0].imshow(gray, cmap="gray", vmin=0, vmax=1)
    axes[0].set_title("photograph")
    axes[1].imshow(ink, cmap="gray", vmin=0, vmax=1)
    axes[1].set_title(f"stippled, {len(res.points)} dots")
    axes[2].plot(pts.points[:, 0], pts.points[:, 1], ".", ms=1.5, color="k")
    axes[2].set_xlim(0, 1)
    axes[2].set_ylim(0, 1)
    axes[2].set_aspect("equal")
    axes[2].set_title(f"Poisson disk set, rho {pts.rho:.2f}")
    axes[3].imshow(np.log10(power + 1e-3), cmap="magma", vmin=-1.5, vmax=0.7)
    axes[3].set_title("its spectrum (blue noise)")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    buf.seek(0)
    Image.open(buf).convert("RGB").quantize(colors=64, dither=Image.Dither.NONE).save(out, optimize=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "readme_hero.png"))
    args = ap.parse_args(argv)
    draw(args.out)
    print(args.out, Path(args.out).stat().st_size, "bytes")


if __name__ == "__main__":
    main()
