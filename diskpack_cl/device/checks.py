"""Known-answer checks: a device is trusted with a program once it gave the host's answers.

A driver that builds a kernel may still compile it wrong (pip's PoCL 3.0 on
AMD Zen 4 returns garbage or crashes in kernels that pass 512-bit vectors
to its builtins).  So before a program's results are used on a device,
each program runs on small fixed inputs that take its code paths (full
vectors, partial tiles, image edges, ties, periodic seams) and its answers
are compared with the host's (numpy and scipy, float64).  The checks run in
**child processes**, one a core, each over its share of the programs one
after another, each program under a time limit: a crash or a hang there is
a verdict, not the end of the user's run.

Verdicts are kept in the user's cache folder (:func:`cache_dir`), one file
per driver version, device, kernel sources and package version, so the
checks run once on a machine.  A program that failed is not used on that
device: its stage runs on the host (:class:`UntrustedProgram` tells the
stage), and a device whose core programs fail (:data:`CORE`) is passed
over by :func:`diskpack_cl.get_context`.

Two things are chosen by the checks, not by the device's name:

- ``WIDE_BUILTINS`` (``kernels/wide.h``): 512-bit vectors through the
  builtins where the wide build of every vector program gives the known
  answers, else 256-bit halves (and 8-lane tiles);
- a fresh kernel-cache entry: a program whose build crashed or came back
  without kernels (a broken entry in PoCL's cache) is built and checked once
  more with a salt define that PoCL's cache has never seen.

``diskpack devices --check`` prints the table (:func:`check_table`).

Examples
--------
>>> from diskpack_cl import get_context
>>> v = verdict_of(get_context())
>>> sorted(v.programs) == sorted(PROGRAMS)
True
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from .._cores import usable_cores
from ..io import atomic_write
from .cache import cache_dir   # (one of the checks' names too: where the verdicts are)

__all__ = ["PROGRAMS", "CORE", "VECTOR_PROGRAMS", "Verdict", "UntrustedProgram", "DeviceWarning",
           "cache_dir", "verdict_of", "warn_fallback", "check_table", "checks_enabled", "use_verdict"]

#: Every program the package runs on a device, and what it computes.
PROGRAMS = {
    "raster_labels": "labels of the discrete power diagram (tile and item layouts)",
    "raster_mic": "raster MIC estimates (per-cell maxima of the distance map)",
    "raster_sums": "density sums of the cells (label runs and fused tiles)",
    "cells": "MICs of 2D power cells (float64 simplex)",
    "cells_nearest": "nearest-neighbour distances",
    "cells3": "maximal inscribed spheres of 3D Voronoi cells",
    "parallel_darts": "rounds of parallel dart throwing",
    "blur": "Gaussian blurs of the stippling's fields",
}
#: Programs without which the device is passed over (the engine's every step needs them).
CORE = ("raster_labels", "raster_mic", "raster_sums", "cells")
#: Programs with 512-bit vectors through builtins in their wide build (``kernels/wide.h``).
VECTOR_PROGRAMS = ("raster_labels", "raster_sums", "blur")
#: The programs that need float64 (``cl_khr_fp64``); elsewhere they are not run at all.
FP64_PROGRAMS = ("cells", "cells_nearest", "cells3", "parallel_darts", "blur")

_FORMAT = 1
#: Seconds one program's check may take (a cold build included) before it counts as a hang.
TIME_LIMIT_S = 120.0
#: Seconds the probe of 512-bit builtins may take (``kernels/checks_wide_probe.cl``).
PROBE_LIMIT_S = 10.0

#: Each program's share of the checks' time with a cold kernel cache (mostly its builds):
#: the checks are dealt by it to one child process a core (:func:`_in_children`).  Programs
#: that one stage builds together are one entry, checked in one child (a raster stage builds
#: the three raster programs, the nearest-neighbour pass's engine the MIC program too), so
#: that no program is built twice at once.
CHECK_COST = {("raster_labels", "raster_mic", "raster_sums"): 18.0, ("cells", "cells_nearest"): 5.2,
              ("parallel_darts",): 3.7, ("cells3",): 3.3, ("blur",): 2.6}


class UntrustedProgram(RuntimeError):
    """A program failed its known-answer check on this device: its stage runs on the host.

    Examples
    --------
    >>> issubclass(UntrustedProgram, RuntimeError)
    True
    """


class DeviceWarning(UserWarning):
    """One line: a program or a device passed over, and why.

    Examples
    --------
    >>> issubclass(DeviceWarning, UserWarning)
    True
    """


def warn_fallback(exc, instead):
    """One line: a program refused on a device (`exc`), and what runs `instead`.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as seen:
    ...     warnings.simplefilter("always")
    ...     warn_fallback(UntrustedProgram("blur failed its check on X: wrong"), "blurs on the host")
    >>> str(seen[0].message)
    'blur failed its check on X: wrong; blurs on the host'
    """
    warnings.warn(DeviceWarning(f"{exc}; {instead}"), stacklevel=3)


def checks_enabled():
    """False where ``DISKPACK_CL_DEVICE_CHECKS=0`` (simulators such as Oclgrind, whose
    every kernel is checked by the tests themselves) or inside the checks' child.

    Examples
    --------
    >>> checks_enabled() in (True, False)
    True
    """
    return os.environ.get("DISKPACK_CL_DEVICE_CHECKS", "1") != "0" and _CHILD not in os.environ


#: Set in the child's environment: no check there (nor in anything it starts) starts another.
_CHILD = "DISKPACK_CL_IN_DEVICE_CHECK"
#: In the child: the verdict under check (the build switches the stages read).
_CHILD_VERDICT = None


@dataclass
class Verdict:
    """What the checks said of one device.

    Attributes
    ----------
    device : str
        The device and its platform, as :func:`diskpack_cl.describe` names them.
    wide : bool
        Whether the programs are built with 512-bit vectors through builtins.
    programs : dict
        Per program ``{"ok": bool, "why": str, "seconds": float, "salt": int}``.
    seconds : float
        What the checks cost when they ran (0 for a verdict read from the cache).
    cached : bool
        Read from the cache folder rather than run now.
    notes : list of str
        What was retried and why.

    Examples
    --------
    >>> v = Verdict("cpu", False, {"cells": {"ok": False, "why": "wrong", "seconds": 0.1, "salt": 0}})
    >>> v.refused("cells"), v.core_failure(), v.defines("cells")
    ('wrong', 'cells: wrong', {'WIDE_BUILTINS': 0})
    """

    device: str
    wide: bool
    programs: dict
    seconds: float = 0.0
    cached: bool = False
    notes: list = field(default_factory=list)

    @classmethod
    def trusting(cls, device, wide, stems=PROGRAMS, salt=0):
        """A verdict that trusts every program of `stems` on `device` (no checks run, or
        the child's verdict under check), built with `wide` and `salt`.

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> cpu = SimpleNamespace(name="cpu", platform=SimpleNamespace(name="PoCL"))
        >>> v = Verdict.trusting(cpu, False, ["cells"], salt=7)
        >>> v.device, v.core_failure(), v.defines("cells")
        ('cpu (PoCL)', None, {'WIDE_BUILTINS': 0, 'DISKPACK_SALT': 7})
        """
        return cls(_describe(device), bool(wide),
                   {s: {"ok": True, "why": "", "seconds": 0.0, "salt": salt} for s in stems})

    def refused(self, stem):
        """Why program `stem` may not run here, or None."""
        entry = self.programs.get(stem)
        return None if entry is None or entry["ok"] else entry["why"]

    def defines(self, stem):
        """The build-time defines the checks chose for `stem`: ``WIDE_BUILTINS``, and
        ``DISKPACK_SALT`` where the program needed a fresh kernel-cache entry."""
        out = {"WIDE_BUILTINS": int(self.wide)}
        salt = self.programs.get(stem, {}).get("salt", 0)
        if salt:
            out["DISKPACK_SALT"] = salt
        return out

    def core_failure(self):
        """``"program: why"`` for the first core program that failed, or None."""
        for stem in CORE:
            why = self.refused(stem)
            if why is not None:
                return f"{stem}: {why}"
        return None


def _describe(device):
    """As :func:`diskpack_cl.describe` names a context's device (that module reads this one)."""
    return f"{device.name.strip()} ({device.platform.name.strip()})"


def _reports_wide(device):
    """Whether the device says its vectors are 512 bits (16 floats): the first guess."""
    return device.native_vector_width_float >= 16


@functools.lru_cache(maxsize=None)
def _sources_hash():
    """Of the kernel sources and the checks: read once a process (every stage asks)."""
    from .programs import kernel_dir

    h = hashlib.sha256()
    for p in sorted(kernel_dir().iterdir()):
        if p.suffix in (".cl", ".h"):
            h.update(p.name.encode() + b"\0" + p.read_bytes())
    for name in ("checks.py", "known_answers.py"):   # the checks themselves
        h.update((Path(__file__).parent / name).read_bytes())
    return h.hexdigest()


def _key(device):
    """What a verdict holds for: the driver, the device and the kernel sources."""
    import pyopencl as cl

    from .. import __version__

    p = device.platform
    parts = [str(_FORMAT), __version__, cl.VERSION_TEXT, p.name, p.vendor, p.version, device.name,
             device.vendor, device.version, device.driver_version, _sources_hash()]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:32]


_MEMO: dict = {}


def verdict_of(ctx, *, refresh=False):
    """The :class:`Verdict` of the context's device: from this process, the cache folder,
    or the checks run now in child processes (and then kept in the cache).

    Parameters
    ----------
    ctx : pyopencl.Context
    refresh : bool
        Run the checks again even where a verdict is cached.

    Examples
    --------
    >>> from diskpack_cl import get_context
    >>> verdict_of(get_context()).core_failure() is None
    True
    """
    if _CHILD_VERDICT is not None:
        return _CHILD_VERDICT
    if not checks_enabled():
        return Verdict.trusting(ctx.devices[0], _reports_wide(ctx.devices[0]))
    device = ctx.devices[0]
    key = _key(device)
    if key in _MEMO and not refresh:
        return _MEMO[key]
    path = cache_dir() / "device-checks" / f"{key}.json"
    verdict = None if refresh else _read(path)
    if verdict is None:
        verdict = _run_checks(device)
        _write(path, verdict)
    _MEMO[key] = verdict
    return verdict


def _read(path):
    """A cached verdict, or None where the file is missing or not one (it is then rerun)."""
    try:
        data = json.loads(path.read_text())
        programs = data["programs"]
        if data.get("format") != _FORMAT or set(programs) != set(PROGRAMS) or not all(
                isinstance(v.get("ok"), bool) for v in programs.values()):
            return None
        return Verdict(data["device"], bool(data["wide"]), programs, float(data.get("seconds", 0.0)),
                       True, list(data.get("notes", [])))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def _write(path, verdict):
    """Write the verdict atomically (a reader never sees half a file); a cache folder that
    cannot be written costs a rerun next time, nothing else."""
    data = {"format": _FORMAT, "device": verdict.device, "wide": verdict.wide,
            "programs": verdict.programs, "seconds": verdict.seconds, "notes": verdict.notes}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(path, "w") as f:
            json.dump(data, f, indent=1)
    except OSError:
        pass


# -- the parent: children, time limits, verdicts ------------------------------------------

def _device_address(device):
    """``(platform index, device index)`` of `device`, for the child to find it again."""
    import pyopencl as cl

    for ip, p in enumerate(cl.get_platforms()):
        for idev, d in enumerate(p.get_devices()):
            if d.int_ptr == device.int_ptr:
                return ip, idev
    raise LookupError(f"device {device.name} not found among the platforms")


def _run_checks(device):
    """Every program's verdict on `device`, the wide build first where the device reports
    512-bit vectors and the 256-bit build where any vector program fails wide."""
    start = time.perf_counter()
    address = _device_address(device)
    fp64 = "cl_khr_fp64" in device.extensions
    stems = [s for s in PROGRAMS if fp64 or s not in FP64_PROGRAMS]
    wide = _reports_wide(device) and fp64
    notes = []
    if wide:
        # a fresh build each time (a crashed one leaves a broken cache entry), and a short
        # limit: the right answer takes a second; a driver that miscompiles it runs away
        probe = _children(address, ["checks_wide_probe"], True, salt=_salt(),
                          limit=PROBE_LIMIT_S)["checks_wide_probe"]
        if not probe["ok"]:
            wide = False
            notes.append(f"512-bit vectors through builtins failed (checks_wide_probe: {probe['why']}); "
                         "built with 256-bit halves")
    results, more = _checked(address, stems, wide)
    notes += more
    if wide and any(not results[s]["ok"] for s in VECTOR_PROGRAMS if s in results):
        # the vector programs, and any that failed with them (a stage builds several)
        again = [s for s in results if s in VECTOR_PROGRAMS or not results[s]["ok"]]
        narrow, more = _checked(address, again, False)
        if all(v["ok"] for v in narrow.values()):
            failed = [f"{s} ({results[s]['why']})" for s in VECTOR_PROGRAMS
                      if s in narrow and not results[s]["ok"]]
            notes.append(f"512-bit vectors through builtins failed: {'; '.join(failed)}; "
                         "built with 256-bit halves")
            results.update(narrow)
            notes += more
            wide = False
    no_fp64 = {"ok": False, "why": "the device has no float64", "seconds": 0.0, "salt": 0}
    results = {s: results.get(s) or dict(no_fp64) for s in PROGRAMS}
    return Verdict(_describe(device), wide, results, time.perf_counter() - start, False, notes)


def _checked(address, stems, wide):
    """Verdicts of `stems` (each retried once with a fresh kernel-cache entry where it
    crashed or its build failed), and the notes of those retries."""
    results = _in_children(address, stems, wide, salt=0)
    notes = []
    retry = [s for s in stems if not results[s]["ok"] and results[s].get("retry")]
    if retry:
        again = _in_children(address, retry, wide, salt=_salt())
        for s in retry:
            if again[s]["ok"]:
                notes.append(f"{s}: {results[s]['why']}; built again in a fresh kernel-cache entry")
                results[s] = again[s]
    for v in results.values():
        v.pop("retry", None)
    return results, notes


def _salt():
    return int.from_bytes(os.urandom(3), "little") + 1


def _in_children(address, stems, wide, salt):
    """:func:`_children` for `stems` dealt among child processes that run side by side,
    one a core: the checks' time is mostly single-threaded builds.  The results are in
    the order of `stems` whatever child gave them."""
    groups = _dealt(stems, usable_cores())
    if len(groups) < 2:
        return _children(address, stems, wide, salt)
    with ThreadPoolExecutor(len(groups)) as pool:
        parts = list(pool.map(lambda group: _children(address, group, wide, salt), groups))
    merged = {k: v for part in parts for k, v in part.items()}
    return {s: merged[s] for s in stems}


def _dealt(stems, workers):
    """`stems` dealt into at most `workers` lists of about equal :data:`CHECK_COST`, the
    costliest first (a program outside the table costs as much as the cheapest there); a
    list keeps the order of `stems`.

    Examples
    --------
    >>> _dealt(["raster_labels", "raster_sums", "cells", "blur", "cells3"], 2)
    [['raster_labels', 'raster_sums'], ['cells', 'blur', 'cells3']]
    >>> _dealt(["cells", "blur"], 1)
    [['cells', 'blur']]
    """
    cost = {s: c for group, c in CHECK_COST.items() for s in group}
    family = {s: group[0] for group in CHECK_COST for s in group}
    units = {}
    for s in stems:
        units.setdefault(family.get(s, s), []).append(s)
    cheapest = min(CHECK_COST.values())
    loads = [[0.0, []] for _ in range(max(1, min(workers, len(units))))]
    for unit in sorted(units, key=lambda u: -cost.get(u, cheapest)):
        least = min(loads, key=lambda load: load[0])
        least[0] += cost.get(unit, cheapest)
        least[1].extend(units[unit])
    return [sorted(group, key=stems.index) for _, group in loads if group]


def _children(address, stems, wide, salt, limit=None):
    """Run the checks of `stems` in child processes: one child until it ends; a program
    whose child crashed or overran its time is failed, and the rest go to a new child."""
    results = {}
    todo = list(stems)
    while todo:
        got, running, why = _one_child(address, todo, wide, salt, limit)
        results.update(got)
        todo = [s for s in todo if s not in results]
        if running is not None and running not in results:
            # a crash may be a broken kernel-cache entry (built again fresh); a hang is not
            results[running] = {"ok": False, "why": why, "seconds": 0.0, "salt": salt,
                                "retry": not why.startswith("no answer")}
            todo.remove(running)
        elif todo:   # the child ended without naming what it ran: fail the rest alike
            for s in todo:
                results[s] = {"ok": False, "why": why or "the check's process ended early",
                              "seconds": 0.0, "salt": salt, "retry": True}
            todo = []
    return results


def _one_child(address, stems, wide, salt, limit=None):
    """One child over `stems`: ``(results, program running when it ended, why it ended)``."""
    cmd = [sys.executable, "-m", "diskpack_cl.device.known_answers", "--child",
           f"{address[0]}:{address[1]}",
           "--wide", str(int(wide)), "--salt", str(salt), *stems]
    limit = float(os.environ.get("DISKPACK_CL_CHECK_TIME_LIMIT_S", TIME_LIMIT_S) if limit is None else limit)
    results, running = {}, None
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, stdin=subprocess.DEVNULL,
                                env={**os.environ, _CHILD: "1"}, text=True, start_new_session=True)
        deadline = time.monotonic() + limit
        try:
            for line in _lines(proc, lambda: deadline):
                msg = json.loads(line)
                if "start" in msg:
                    running, deadline = msg["start"], time.monotonic() + limit
                else:
                    results[msg["stem"]] = {k: msg[k] for k in ("ok", "why", "seconds", "salt")}
                    results[msg["stem"]]["retry"] = msg.get("retry", False)
                    running = None
        except TimeoutError:
            _kill(proc)
            return results, running, f"no answer in {limit:g} s (killed)"
        finally:
            if proc.poll() is None:
                _kill(proc)
            proc.stdout.close()
        rc = proc.wait()
        if rc == 0:
            return results, running, None
        err.seek(0)
        tail = [ln.strip() for ln in err.read().splitlines() if ln.strip()]
        why = (f"crashed ({signal.Signals(-rc).name})" if rc < 0 else f"the check's process exited {rc}")
        return results, running, why + (f": {tail[-1][:200]}" if tail and rc > 0 else "")


def _lines(proc, deadline):
    """The child's stdout lines, raising TimeoutError past ``deadline()``."""
    import selectors

    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    buf = ""
    while True:
        left = deadline() - time.monotonic()
        if left <= 0:
            raise TimeoutError
        if not sel.select(min(left, 1.0)):
            continue
        chunk = os.read(proc.stdout.fileno(), 65536).decode()
        if not chunk:
            return
        buf += chunk
        *done, buf = buf.split("\n")
        yield from (ln for ln in done if ln.strip())


def _kill(proc):
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.wait()


# -- the table ----------------------------------------------------------------------------

def check_table(verdict):
    """Lines of text: one per program (ok or why not, seconds), the layout, the notes.

    Examples
    --------
    >>> ok = {"ok": True, "why": "", "seconds": 0.5, "salt": 0}
    >>> print(check_table(Verdict("cpu", True, {s: ok for s in PROGRAMS}))[1])
      raster_labels     ok         0.50 s  labels of the discrete power diagram (tile and item layouts)
    """
    rows = [f"{verdict.device}: vectors {'512' if verdict.wide else '256'}-bit through builtins; "
            f"checks {'cached' if verdict.cached else 'run now'} "
            f"({verdict.seconds:.1f} s when they ran)"]
    for stem in PROGRAMS:
        v = verdict.programs[stem]
        state = "ok" if v["ok"] else "FAILED"
        rows.append(f"  {stem:<17} {state:<7} {v['seconds']:7.2f} s  {v['why'] or PROGRAMS[stem]}")
    rows += [f"  note: {n}" for n in verdict.notes]
    return rows


def use_verdict(verdict):
    """Make `verdict` the one every stage of this process reads (the checks' child: the
    build switches under check).

    Examples
    --------
    >>> use_verdict(None)   # back to the verdicts of the cache folder
    """
    global _CHILD_VERDICT
    _CHILD_VERDICT = verdict
