"""Batch throughput: images per minute with --jobs 1 and 2 and on a Dask LocalCluster.

Builds 12 photographs from the three test photographs (each as is, resized
to 384 and 640 px, and a 400 x 300 crop), stipples them at ``-n`` dots with
the default schedule through :func:`diskpack_cl.jobs.batch.stipple_many` with
``jobs=1``, ``jobs=2`` and a ``distributed.LocalCluster`` (2 process
workers, 1 thread each, PoCL capped like ``--jobs 2``), checks that the three
runs wrote identical files, and reports images per minute and the Dask
overhead per item against ``jobs=2``. Then ``poisson --count`` sets per
second (same three ways) and the peak memory per worker (from the manifest's
``peak_rss_mib``) at each ``--memory-n``. The overhead per item is the worker
time not spent inside items (start-up, dispatch, the idle tail):
``(wall * workers - sum of item seconds) / items``; the jobs 2 run includes
spawning its workers, the cluster is started before it is timed.

    python benchmarks/bench_batch.py [-n 20000] [--count 1000] [--memory-n 20000 200000]
        [--skip stipple poisson memory] [--json rows.jsonl]

``--json`` appends a row per run (``part``: ``stipple``, ``poisson`` or
``memory``) with the context of :mod:`perf_rows`; :func:`summary` and
:func:`summary_memory` make the docs' tables of them.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image

from diskpack_cl.jobs.batch import poisson_many, stipple_many
from diskpack_cl.jobs.executors import POCL_THREAD_VARS, default_jobs
from perf_rows import append, count, medians, num

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"


def photographs(folder):
    """12 images: the three test photographs, two resizes and a crop of each."""
    paths = []
    for name in ("astronaut", "camera", "coffee"):
        im = Image.open(DATA / f"{name}.png").convert("RGB")
        variants = {"": im, "_384": im.resize((384, 384), Image.LANCZOS),
                    "_640": im.resize((640, 640), Image.LANCZOS),
                    "_crop": im.crop((56, 100, 456, 400))}
        for suffix, v in variants.items():
            p = Path(folder) / f"{name}{suffix}.png"
            v.save(p)
            paths.append(str(p))
    return paths


def timed(batch):
    t = time.perf_counter()
    records = list(batch)
    seconds = time.perf_counter() - t
    bad = [r for r in records if r["status"] != "ok"]
    if bad:
        raise SystemExit(f"failed items: {[(r['input'], r['error']) for r in bad]}")
    return seconds, records


def same_files(a, b):
    names = sorted(p.name for p in Path(a).iterdir() if p.name != "manifest.jsonl")
    return names == sorted(p.name for p in Path(b).iterdir() if p.name != "manifest.jsonl") \
        and all((Path(a) / n).read_bytes() == (Path(b) / n).read_bytes() for n in names)


def cluster():
    import distributed

    # the workers inherit the PoCL cap that --jobs 2 gives its workers
    for var in POCL_THREAD_VARS:
        os.environ.setdefault(var, str(max(1, default_jobs() // 2)))
    lc = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None)
    return lc, distributed.Client(lc)


def bench_stipple(work, n, client):
    """Rows of the three stipple runs (each with ``identical_files``), after a printed comparison."""
    photos = photographs(work)
    out, rows = {}, {}
    for label, run, workers in (("jobs 1", dict(jobs=1), 1), ("jobs 2", dict(jobs=2), 2),
                                ("LocalCluster 2x1", dict(client=client), 2)):
        folder = Path(work) / label.replace(" ", "_")
        folder.mkdir()
        seconds, recs = timed(stipple_many(photos, [str(folder / "{stem}.svg"),
                                                    str(folder / "{stem}.npz")], n=n, **run))
        item_seconds = sum(r["seconds"] for r in recs)
        rows[label] = {"part": "stipple", "run": label, "n": n, "items": len(photos), "workers": workers,
                       "seconds": seconds, "images_per_minute": 60 * len(photos) / seconds,
                       "item_seconds_sum": item_seconds,
                       # worker time not spent in items: start-up, dispatch, idle tail
                       "overhead_per_item_s": (seconds * workers - item_seconds) / len(photos),
                       "peak_rss_mib_max": max(r["peak_rss_mib"] for r in recs)}
        out[label] = folder
        print(f"stipple n={n} {label:17s} {seconds:7.1f} s  "
              f"{rows[label]['images_per_minute']:6.2f} images/min  "
              f"(sum of item times {item_seconds:.1f} s, overhead per item "
              f"{rows[label]['overhead_per_item_s']:.2f} s)", flush=True)
    identical = same_files(out["jobs 1"], out["jobs 2"]) and same_files(out["jobs 1"], out["LocalCluster 2x1"])
    local, dask = rows["jobs 2"]["seconds"], rows["LocalCluster 2x1"]["seconds"]
    per_item = rows["jobs 2"]["item_seconds_sum"] / len(photos)
    print(f"identical files: {identical}; wall time Dask - jobs 2: {(dask - local) / len(photos):+.2f} s "
          f"per item ({100 * (dask - local) / local:+.1f} %); Dask overhead "
          f"{100 * rows['LocalCluster 2x1']['overhead_per_item_s'] / per_item:.1f} % of an item's time",
          flush=True)
    return [dict(r, identical_files=identical) for r in rows.values()]


def bench_poisson(work, count, n, client):
    """Rows of the three ``poisson --count`` runs."""
    rows = []
    for label, run in (("jobs 1", dict(jobs=1)), ("jobs 2", dict(jobs=2)),
                       ("LocalCluster 2x1", dict(client=client))):
        folder = Path(work) / f"sets_{label.replace(' ', '_')}"
        folder.mkdir()
        seconds, _ = timed(poisson_many(count, n, [str(folder / "{i:04d}.npz")], seed=7,
                                        **run))
        rows.append({"part": "poisson", "run": label, "count": count, "points": n, "seconds": seconds,
                     "sets_per_second": count / seconds})
        print(f"poisson --count {count} -n {n} {label:17s} {seconds:7.1f} s  "
              f"{count / seconds:7.1f} sets/s", flush=True)
    return rows


def bench_memory(work, sizes):
    """Rows of the peak resident memory of one worker process stippling the sample at each n."""
    rows = []
    for n in sizes:
        folder = Path(work) / f"mem_{n}"
        folder.mkdir()
        side = 512 if n <= 50000 else 2048
        img = folder / f"sample_{side}.png"
        Image.open(DATA / "astronaut.png").convert("L").resize((side, side), Image.LANCZOS) \
            .save(img)
        code = ("import json, sys\nfrom diskpack_cl.jobs.executors import run_item\nfrom diskpack_cl.jobs.items import plan_stipple\n"
                f"item = plan_stipple([{str(img)!r}], [{str(folder / 'o.npz')!r}], n={n})[0]\n"
                "rec = run_item(item)\n"
                "print(json.dumps({k: rec.get(k) for k in ('status', 'error', 'seconds', "
                "'peak_rss_mib')}))")
        rec = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                        check=True).stdout.splitlines()[-1])
        rows.append({"part": "memory", "n": n, **rec, "image": f"{side} x {side}"})
        print(f"memory n={n} ({side}x{side}): peak {rec['peak_rss_mib']} MiB in "
              f"{rec['seconds']:.1f} s ({rec['status']})", flush=True)
    return rows


#: How the tables name the runs.
SHOWN = {"jobs 1": "--jobs 1 (in the process, PoCL on both cores)",
         "jobs 2": "--jobs 2 (two spawned workers, one PoCL thread each)",
         "LocalCluster 2x1": "Dask LocalCluster, 2 process workers x 1 thread"}


def summary(rows):
    """``(header, rows)`` of the docs' throughput table: medians per run of stippling and ``poisson --count``."""
    values = ["seconds", "images_per_minute", "overhead_per_item_s", "item_seconds_sum", "items"]
    stip = {r["run"]: r for r in medians([r for r in rows if r["part"] == "stipple"], ("run",), values)}
    sets = {r["run"]: r for r in medians([r for r in rows if r["part"] == "poisson"], ("run",),
                                         ["sets_per_second"])}
    identical = all(r["identical_files"] for r in rows if r["part"] == "stipple")
    header = ["run", "wall time", "images per minute", "overhead per item", "overhead / item time",
              "poisson sets per second", "files identical across runs"]
    return header, [[SHOWN[run], num(r["seconds"], " s"), num(r["images_per_minute"]),
                     num(r["overhead_per_item_s"], " s"),
                     num(100 * r["overhead_per_item_s"] * r["items"] / r["item_seconds_sum"], " %"),
                     num(sets.get(run, {}).get("sets_per_second")), "yes" if identical else "no"]
                    for run, r in stip.items()]


def summary_memory(rows):
    """``(header, rows)`` of the docs' table of one worker's peak resident memory per n."""
    runs = medians([r for r in rows if r["part"] == "memory"], ("n", "image"), ["peak_rss_mib", "seconds"])
    return ["n", "image", "peak resident memory", "seconds"], \
        [[count(r["n"]), r["image"], num(r["peak_rss_mib"], " MiB"), num(r["seconds"], " s")] for r in runs]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", type=int, default=20000)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--points", type=int, default=1024)
    ap.add_argument("--memory-n", type=int, nargs="+", default=[20000, 200000])
    ap.add_argument("--skip", nargs="*", default=[], choices=("stipple", "poisson", "memory"))
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    print(f"cores {default_jobs()}, load average {os.getloadavg()[0]:.2f} at the start", flush=True)

    def record(rows):   # each part's rows as soon as it ends, with the load of that time
        for row in rows:
            append(a.json, row)

    with tempfile.TemporaryDirectory(prefix="bench-batch-") as work:
        lc = client = None
        if not {"stipple", "poisson"} <= set(a.skip):
            lc, client = cluster()
        try:
            if "stipple" not in a.skip:
                record(bench_stipple(work, a.n, client))
            if "poisson" not in a.skip:
                record(bench_poisson(work, a.count, a.points, client))
        finally:
            if client is not None:
                client.close()
                lc.close()
        if "memory" not in a.skip:
            record(bench_memory(work, a.memory_n))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
