"""Outputs of ``diskpack stipple`` on the sample and the test photographs, and of single
``poisson`` and ``relax`` runs, for a byte comparison.

A structural change must not change a result. Run this once with the tree
before the change and once with the tree after it, then compare::

    git worktree add /tmp/base 96d3bd5
    cp benchmarks/byte_identity.py /tmp && cd /tmp   # so that '' on sys.path is not the tree
    PYTHONPATH=/tmp/base DISKPACK_TEST_DATA=$OLDPWD/tests/data python byte_identity.py make /tmp/out_base
    cd -
    python benchmarks/byte_identity.py make /tmp/out_new
    python benchmarks/byte_identity.py compare /tmp/out_base /tmp/out_new

``make`` writes, per image and case, the ``.npz``, ``.svg``, ``.png`` and
``.csv`` outputs and the ``--json`` line without its timings (``timings``,
``seconds``, ``write_seconds``: they differ between any two runs).
The ``poisson`` and ``relax`` cases (:data:`POINT_CASES`) write ``.npz`` and
``.csv`` sets and the ``--json`` line without ``seconds``,
``seconds_per_iteration``, ``stage_seconds`` and ``init_seconds``; ``relax``
reads a start set this script writes with a fixed seed.
``compare`` prints each file as identical or different and the count, and
exits 1 when any differs or is missing. The cases keep the SVG's dot order
independent of the machine's speed (``--pen-path auto`` is given 2 s, which
a few thousand dots need not reach).
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import subprocess
import sys
from pathlib import Path

#: The test photographs; the script may run from a copy outside the tree (see above).
DATA = Path(os.environ.get("DISKPACK_TEST_DATA", Path(__file__).resolve().parents[1] / "tests" / "data"))
IMAGES = {"sample": "sample", "astronaut": str(DATA / "astronaut.png"),
          "camera": str(DATA / "camera.png"), "coffee": str(DATA / "coffee.png")}
CASES = {"default": ["-n", "2000"],
         "pen": ["-n", "6000", "--pen-path", "hilbert", "--width-mm", "150", "--pen-mm", "0.4"],
         "cmyk": ["-n", "3000", "--colors", "cmyk"]}
EXTENSIONS = (".npz", ".svg", ".png", ".csv")
UNTIMED = ("timings", "seconds", "write_seconds", "seconds_per_iteration", "stage_seconds",
           "init_seconds")
#: Single runs of ``poisson`` and ``relax`` (``start.npy``: 300 uniform points, seed 0).
POINT_CASES = {
    "poisson_torus": ["poisson", "-n", "1024", "--seed", "5"],
    "poisson_random": ["poisson", "-n", "400", "--init", "random", "--seed", "6", "--eps", "0.75"],
    "poisson_file": ["poisson", "--init", "start.npy", "--seed", "1"],
    "poisson_file_box": ["poisson", "--init", "start.npy", "--box", "1x1", "--seed", "1"],
    "poisson_box": ["poisson", "-n", "500", "--box", "2x1", "--seed", "3"],
    "poisson_dim3": ["poisson", "-n", "300", "--dim", "3", "--seed", "2"],
    "relax": ["relax", "start.npy"],
    "relax_box": ["relax", "start.npy", "--box", "1x1", "--eps", "0.7"],
}
#: Batches of ``poisson`` and ``relax``: their sets (the manifest, with its times, is removed).
BATCH_CASES = {
    "poisson_count": ["poisson", "-n", "256", "--count", "2", "--seed", "4",
                      "-o", "poisson_count_{i}.npz"],
    "relax_batch": ["relax", "start.npy", "start2.npy", "-o", "relax_batch_{stem}.npz"],
}


def make(folder):
    """Stipple every image in every case into `folder`."""
    folder = os.path.abspath(folder)
    os.makedirs(folder, exist_ok=True)
    for name, image in IMAGES.items():
        for case, args in CASES.items():
            stem = os.path.join(folder, f"{name}_{case}")
            # outputs named relative to the folder, so that two folders' summaries compare
            cmd = [sys.executable, "-m", "diskpack_cl.cli", "stipple", image, *args, "--json",
                   "-q", *(arg for ext in EXTENSIONS for arg in ("-o", f"{name}_{case}{ext}"))]
            line = subprocess.run(cmd, check=True, capture_output=True, text=True,
                                  cwd=folder).stdout
            summary = json.loads(line)
            summary["image"] = os.path.basename(summary["image"])   # the tree's sample or not
            _write_summary(summary, folder, stem + ".json")
            print(stem, flush=True)
    make_points(folder)


def _write_summary(summary, folder, path):
    """`summary` without its timings, its paths relative to `folder` (the outputs are
    reported absolute), so that two folders' summaries compare."""
    for key in UNTIMED:
        summary.pop(key, None)
    text = json.dumps(summary, indent=1, sort_keys=True).replace(folder + os.sep, "")
    with open(path, "w") as fh:
        fh.write(text)


def make_points(folder):
    """Run every case of :data:`POINT_CASES` in `folder`."""
    import numpy as np

    np.save(os.path.join(folder, "start.npy"), np.random.default_rng(0).random((300, 2)))
    np.save(os.path.join(folder, "start2.npy"), np.random.default_rng(1).random((200, 2)))
    for case, args in BATCH_CASES.items():
        subprocess.run([sys.executable, "-m", "diskpack_cl.cli", *args, "-q"], check=True,
                       cwd=folder)
        os.remove(os.path.join(folder, "manifest.jsonl"))
    for case, args in POINT_CASES.items():
        outputs = [arg for ext in (".npz", ".csv") for arg in ("-o", f"{case}{ext}")]
        runs = [outputs[2 * k:2 * k + 2] for k in range(2)]   # one output per run
        for k, out in enumerate(runs):
            cmd = [sys.executable, "-m", "diskpack_cl.cli", *args, *out, "--json", "-q"]
            line = subprocess.run(cmd, check=True, capture_output=True, text=True,
                                  cwd=folder).stdout
            if k == 0:
                _write_summary(json.loads(line), folder, os.path.join(folder, f"{case}.json"))
        print(os.path.join(folder, case), flush=True)


def compare(a, b):
    """The exit status: 0 when every file of `a` is in `b` with the same bytes."""
    names = sorted(set(os.listdir(a)) | set(os.listdir(b)))
    same = 0
    for name in names:
        pa, pb = os.path.join(a, name), os.path.join(b, name)
        ok = os.path.exists(pa) and os.path.exists(pb) and filecmp.cmp(pa, pb, shallow=False)
        same += ok
        print(f"{'identical' if ok else 'DIFFERENT'} {name}")
    print(f"{same} of {len(names)} files identical")
    return 0 if same == len(names) else 1


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    m = sub.add_parser("make")
    m.add_argument("folder")
    m.add_argument("--points-only", action="store_true", help="only the poisson and relax cases")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    args = p.parse_args(argv)
    if args.command == "make":
        if args.points_only:
            os.makedirs(args.folder, exist_ok=True)
            make_points(os.path.abspath(args.folder))
        else:
            make(args.folder)
        return 0
    return compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
