"""The walks of a call through the package's modules: how far a reader follows it.

Usage: python benchmarks/walks.py [--n 2000] [--json]

Traces (``sys.setprofile``) two calls of the public API and counts, over
every call from one function of the package to another:

- *stays*: the callee is in the caller's module;
- *moves*: it is in another module; *across*: of those, into another
  folder (subpackage) of the package;
- *climbs back*: a move into a module already on the call stack below the
  caller (the callee's module called the caller's, which calls back);
- *rooms*: the modules visited, and the folders.

The walks: an image through :func:`diskpack_cl.stipple` (a 256 x 256 ramp,
``--n`` dots) and its result through ``write_stipple_outputs`` to
``.svg``, ``.png``, ``.npz`` and ``.csv`` (mono, and a two-pen colour
result). The script imports only public names, so that it runs on trees
from before and after a move of modules (run it from outside the tree with
``PYTHONPATH`` naming the tree).
"""

import argparse
import json
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

import diskpack_cl
from diskpack_cl import jobs

PACKAGE = Path(diskpack_cl.__file__).parent


def _module_of(code):
    """The package's module that defines `code` (``device/raster``), or None."""
    try:
        rel = Path(code.co_filename).resolve().relative_to(PACKAGE)
    except ValueError:
        return None
    return rel.with_suffix("").as_posix()


class Walk:
    """Counts of one traced call (see the module's docstring)."""

    def __init__(self):
        self.counts = Counter()
        self.rooms = Counter()
        self.stack = []   # the package's modules of the frames being run

    def __call__(self, frame, event, arg):
        if event not in ("call", "return"):
            return
        module = _module_of(frame.f_code)
        if event == "return":
            if self.stack and self.stack[-1][0] is frame:
                self.stack.pop()
            return
        if module is None:
            return
        caller = self.stack[-1][1] if self.stack else None
        if caller is not None:
            self._count(caller, module)
        self.rooms[module] += 1
        self.stack.append((frame, module))

    def _count(self, caller, module):
        if module == caller:
            self.counts["stays"] += 1
            return
        self.counts["moves"] += 1
        if Path(module).parent != Path(caller).parent:
            self.counts["across"] += 1
        if module in (m for _, m in self.stack[:-1]):
            self.counts["climbs back"] += 1

    def summary(self):
        folders = {Path(m).parent.as_posix() for m in self.rooms}
        return {**{k: self.counts[k] for k in ("stays", "moves", "across", "climbs back")},
                "rooms": len(self.rooms), "folders": len(folders),
                "modules": sorted(self.rooms)}


def traced(fn, *args, **kwargs):
    """``(fn's result, its Walk)``."""
    walk = Walk()
    sys.setprofile(walk)
    try:
        out = fn(*args, **kwargs)
    finally:
        sys.setprofile(None)
    return out, walk


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--json", action="store_true", help="one JSON line per walk")
    args = ap.parse_args(argv)
    gray = np.tile(np.linspace(0.05, 0.95, 256), (256, 1))
    colour_gray = np.dstack([gray, gray[::-1], np.full_like(gray, 0.5)])
    result, stippling = traced(diskpack_cl.stipple, gray, args.n, seed=1)
    colour = diskpack_cl.stipple_colors(colour_gray, args.n, "black=#000,red=#c00",
                                        seed=1)
    with tempfile.TemporaryDirectory() as folder:
        outs = [os.path.join(folder, f"s{ext}") for ext in (".svg", ".png", ".npz", ".csv")]
        _, mono = traced(jobs.write_stipple_outputs, result, gray, outs)
        _, pens = traced(jobs.write_stipple_outputs, colour, None, outs[:2])
    for name, walk in (("image through stipple()", stippling),
                       ("result through the writers (mono)", mono),
                       ("result through the writers (colour)", pens)):
        s = walk.summary()
        if args.json:
            print(json.dumps({"walk": name, **s}))
        else:
            print(f"{name}: {s['rooms']} modules in {s['folders']} folders; "
                  f"{s['stays']} stays, {s['moves']} moves ({s['across']} across folders), "
                  f"{s['climbs back']} climbs back\n  {' '.join(s['modules'])}")


if __name__ == "__main__":
    main()
