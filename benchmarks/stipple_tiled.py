"""A large picture in tiles against the same picture in one piece: time, memory, seams.

Usage: python benchmarks/stipple_tiled.py [--size 8192] [--n 1000000] [--tiles 2x2] [--jobs 2]
                                          [--dask] [--no-untiled] [--crop FIGURE.png]
                                          [--json rows.jsonl]

The picture is the bundled sample photograph scaled up (Lanczos) to
``--size`` pixels a side, written once as a PNG; the package's bytecode is
compiled first, as ``pip install .`` leaves it.  Each run is the command a
user types, timed as a whole process (``diskpack stipple BIG.png -n N -o
out.npz``, then with ``--tiles`` and ``--jobs``, or with ``--dask`` on a
local Dask cluster of ``--jobs`` process workers started here), with the
peak resident memory of its largest process (the command's and its
workers', from ``wait4`` and the workers' own reports).  Beside them,
``scipy.spatial.Voronoi`` of ``n`` random points in the same run (in a
child process: :func:`voronoi_seconds`).

Seam measures: the dots within three dot spacings of a tile border inside
the picture (the seams), their count and the median and 1st percentile of
their nearest-neighbour distances, for the tiled and the untiled run in the
same band; and, as a control within the tiled run, the same measures along
the tile centre lines.  ``--crop`` saves the two stipplings around a seam
crossing side by side.  ``--json`` appends the run as a row with the
context of :mod:`perf_rows`; :func:`summary` makes the docs' table.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image
from scipy.spatial import cKDTree

from diskpack_cl.image import load_gray, sample_image_path
from diskpack_cl.memory import HOST_BYTES_PER_CELL
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.jobs.tiles import tile_grid
from perf_rows import append, count, installed_bytecode, medians, num

CACHE = os.path.join(tempfile.gettempdir(), "diskpack-bench")


def picture(size):
    """The sample photograph scaled to `size` px a side, as a PNG (made once)."""
    path = os.path.join(CACHE, f"sample-{size}.png")
    if not os.path.exists(path):
        os.makedirs(CACHE, exist_ok=True)
        g = load_gray(sample_image_path())
        img = Image.fromarray((g * 255).astype(np.uint8)).resize((size, size), Image.LANCZOS)
        img.save(path + ".part.png")
        os.replace(path + ".part.png", path)
    return path


def timed(args):
    """Run `args`; ``(seconds, peak RSS GiB of its largest process, largest part's GiB, summary)``.

    The command's own peak comes from ``wait4`` (the largest of it and the
    workers it spawned and waited for); the parts' from the summary."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=err, text=True)
        out = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - t0
        if os.waitstatus_to_exitcode(status):
            err.seek(0)
            raise SystemExit(f"{' '.join(args)} failed:\n{err.read()}")
    summary = json.loads(out.strip().splitlines()[-1])
    return seconds, usage.ru_maxrss / 2**20, (summary.get("peak_rss_mib") or 0) / 1024, summary


def voronoi_seconds(n):
    """Seconds of ``scipy.spatial.Voronoi`` of `n` random points, in a child process.

    A child, because a process's peak memory passes to the processes it
    starts (Linux keeps the peak across fork and exec): after a Voronoi of
    millions of points here, every command and worker started later would
    report this process's peak as its own."""
    code = ("import time, numpy as np; from scipy.spatial import Voronoi; "
            f"p = np.random.default_rng(0).random(({n}, 2)); t = time.perf_counter(); Voronoi(p); "
            "print(time.perf_counter() - t)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(done.stdout)


def seam_measures(points, edges_x, edges_y, spacing, width=3.0):
    """Count, median and 1st percentile NN distance of the dots within `width` spacings of
    the inner lines at `edges_x` (x) and `edges_y` (y)."""
    d, _ = cKDTree(points).query(points, 2)
    d = d[:, 1]
    near = np.zeros(len(points), bool)
    for e in edges_x:
        near |= np.abs(points[:, 0] - e) < width * spacing
    for e in edges_y:
        near |= np.abs(points[:, 1] - e) < width * spacing
    return {"count": int(near.sum()), "median": float(np.median(d[near])),
            "p01": float(np.percentile(d[near], 1))}


def save_crop(path, tiled, untiled, center, half, radius_scale=1.0):
    """The two stipplings around `center` (+- `half` px), untiled left, tiled right."""
    from diskpack_cl.picture_measures import render_dots

    panels = []
    for pts, r in (untiled, tiled):
        box = np.all(np.abs(pts - center) < half + 4 * r.max(), axis=1)
        local = pts[box] - (center - half)
        ink = render_dots(local, radius_scale * r[box], (2 * half, 2 * half))
        panels.append(np.clip(255 * (1 - ink), 0, 255).astype(np.uint8))
    gap = np.full((2 * half, 8), 255, np.uint8)
    Image.fromarray(np.hstack([panels[0], gap, panels[1]])).resize(
        (2 * (4 * half + 8), 4 * half), Image.NEAREST).save(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--tiles", default="2x2")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--dask", action="store_true", help="a local Dask cluster of --jobs workers")
    ap.add_argument("--no-untiled", action="store_true", help="skip the untiled run")
    ap.add_argument("--crop", default=None, help="save a crop across a seam crossing here")
    ap.add_argument("--json", default=None, help="append the run as a JSON line to this file")
    args = ap.parse_args()
    installed_bytecode()
    image = picture(args.size)
    with tempfile.TemporaryDirectory(prefix="diskpack-tiled-") as out:   # both runs' outputs
        measure(args, image, out)


def measure(args, image, out):
    """The runs of :func:`main` on the picture file `image`, their outputs in the folder
    `out`: the row, printed and appended to ``--json``."""
    W = H = args.size
    rows, cols = tile_grid(args.tiles, W, H)
    spacing = np.sqrt(W * H / args.n)
    xs = [round(i * W / cols) for i in range(1, cols)]
    ys = [round(i * H / rows) for i in range(1, rows)]
    mid_x = [round((i + 0.5) * W / cols) for i in range(cols)]
    mid_y = [round((i + 0.5) * H / rows) for i in range(rows)]
    cmd = [sys.executable, "-m", "diskpack_cl.cli", "stipple", image, "-n", str(args.n),
           "--allow-large", "--json", "--quiet"]
    row = {"size": args.size, "n": args.n, "tiles": args.tiles, "jobs": args.jobs,
           "where": "dask" if args.dask else "processes"}
    row["voronoi"] = voronoi_seconds(args.n)
    print(f"Voronoi({args.n}): {row['voronoi']:.1f} s", flush=True)
    tiled_cmd = cmd + ["-o", os.path.join(out, "tiled.npz"), "--tiles", args.tiles]
    cluster = None
    if args.dask:
        import distributed
        cluster = distributed.LocalCluster(n_workers=args.jobs, threads_per_worker=1,
                                           processes=True, dashboard_address=":0",
                                           memory_limit=0)
        tiled_cmd += ["--scheduler", cluster.scheduler_address]
    else:
        tiled_cmd += ["--jobs", str(args.jobs)]
    secs, own, workers, summ = timed(tiled_cmd)
    if cluster is not None:
        client = distributed.Client(cluster)
        workers = max(client.run(_worker_peak_gib).values())
        client.close()
        cluster.close()
    # a worker's peak so far: after the tiles (which run first), before any seam
    tile_gib = max(p["peak_rss_mib"] for p in summ["parts"] if p["kind"] == "tile") / 1024
    row.update(tiled=secs, tiled_driver_gib=own, tiled_worker_gib=workers, tiled_tile_gib=tile_gib,
               tiled_valid=summ["certificate"]["valid"], parts=summ.get("parts"))
    print(f"tiled {args.tiles} on {row['where']} x{args.jobs}: {secs:.1f} s, driver "
          f"{own:.2f} GiB, largest worker {workers:.2f} GiB (after the tiles {tile_gib:.2f}), "
          f"valid {row['tiled_valid']}", flush=True)
    with np.load(os.path.join(out, "tiled.npz")) as z:
        tiled = z["points"], z["radii"]
    row["seam_tiled"] = seam_measures(tiled[0], xs, ys, spacing)
    row["centre_tiled"] = seam_measures(tiled[0], mid_x, mid_y, spacing)
    cells = StippleOptions().plan(args.n, W, H).supersample ** 2 * W * H
    row["untiled_estimate_gib"] = HOST_BYTES_PER_CELL * cells / 2**30
    if not args.no_untiled:
        secs, own, _, summ = timed(cmd + ["-o", os.path.join(out, "untiled.npz")])
        row.update(untiled=secs, untiled_gib=own, untiled_valid=summ["certificate"]["valid"])
        print(f"untiled: {secs:.1f} s, {own:.2f} GiB", flush=True)
        with np.load(os.path.join(out, "untiled.npz")) as z:
            untiled = z["points"], z["radii"]
        row["seam_untiled"] = seam_measures(untiled[0], xs, ys, spacing)
        if args.crop:
            half = int(12 * spacing)
            save_crop(args.crop, tiled, untiled, np.array([xs[0], ys[0]], float), half)
    for key in ("seam_tiled", "seam_untiled", "centre_tiled"):
        if key in row:
            print(f"  {key}: {row[key]}")
    append(args.json, row)


def _worker_peak_gib():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _pair(tiled, untiled, fmt):
    """``"tiled / untiled"``, or ``"tiled / not run"``."""
    return f"{fmt(tiled)} / {'not run' if untiled is None else fmt(untiled)}"


def summary(rows):
    """``(header, rows)`` of the docs' table: medians per picture, n, tiling and where."""
    flat = []
    for r in rows:
        f = dict(r)
        for key in ("seam_tiled", "seam_untiled", "centre_tiled"):
            for k, v in (r.get(key) or {}).items():
                f[f"{key}_{k}"] = v
        flat.append(f)
    values = ["voronoi", "tiled", "tiled_worker_gib", "tiled_driver_gib", "untiled", "untiled_gib",
              "untiled_estimate_gib", "seam_tiled_count", "seam_untiled_count", "seam_tiled_median",
              "seam_untiled_median", "seam_tiled_p01", "seam_untiled_p01", "centre_tiled_median",
              "centre_tiled_p01"]
    runs = medians(flat, ("size", "n", "tiles", "jobs", "where"), values)
    header = ["picture", "n", "tiles", "workers", "tiled", "untiled", "Voronoi(n)",
              "largest process tiled / untiled", "untiled estimate",
              "seam dots tiled / untiled", "seam NN median tiled / untiled",
              "seam NN 1st percentile tiled / untiled", "tile centre lines NN median, 1st percentile"]
    out = []
    for r in runs:
        largest = max(x for x in (r["tiled_worker_gib"], r["tiled_driver_gib"]) if x is not None)
        out.append([f"{r['size']} x {r['size']}", count(r["n"]), r["tiles"],
                    f"{r['jobs']} {r['where']}", num(r["tiled"], " s"), num(r["untiled"], " s"),
                    num(r["voronoi"], " s"),
                    _pair(largest, r["untiled_gib"], lambda v: num(v, " GiB")),
                    num(r["untiled_estimate_gib"], " GiB"),
                    _pair(r["seam_tiled_count"], r["seam_untiled_count"], count),
                    _pair(r["seam_tiled_median"], r["seam_untiled_median"], num),
                    _pair(r["seam_tiled_p01"], r["seam_untiled_p01"], num),
                    f"{num(r['centre_tiled_median'])}, {num(r['centre_tiled_p01'])}"])
    return header, out


if __name__ == "__main__":
    main()
