"""Stippling a picture larger than one process holds: tiles, seams stippled again, one certificate.

:func:`stipple_tiled` stipples one picture in R x C tiles, on worker
processes or a Dask cluster (:func:`diskpack_cl.jobs.executors.map_tasks`). The
picture is read once, strip by strip, into a gray raster on disk (a
``.npy`` file in the work folder); every task reads only its window of it.

1. **Plan.** One pass over the raster gives the picture's ink (its summed
   darkness), each tile's ink and the median darkness. The options are
   planned for the whole picture (:meth:`StippleOptions.plan`: schedule,
   supersampling, blurs, the detail scale), and the ``n`` dots are shared
   among the tiles in proportion to their ink (largest remainders): every
   tile draws its part of the one tone.
2. **Tiles.** Each tile is stippled alone, its dots inside it, from the
   error diffusion of the tile (its own seed, :func:`derive_seeds`), with
   the fields (radius field, centroid density, detail weight, ink)
   computed over the tile and a margin wider than their blurs, so that
   inside the tile they are the whole picture's fields.
3. **Seams.** A tile's dots are packed against its border as against the
   picture's. Each seam between two columns of tiles is then stippled
   again: the dots within ``seam_band`` dot spacings of it move (the whole
   schedule once more), and the dots around them, to ``halo`` spacings
   further, hold still, so that the band meets the dots between which it
   lies. Then each seam between two rows, across the whole width. Seams of
   one direction lie far apart and run at once.
4. **Certificate.** The radii come from the fields at the final positions,
   and the largest ``k`` over all dots is found and certified
   (:func:`diskpack_cl.radii.certified_k`): no two disks overlap anywhere,
   seams included, and every disk lies inside the picture.

Every task is a function of its inputs only, so the result does not
depend on how many workers ran it, nor where. Each finished task is saved
in the work folder; a rerun of the same job there does only what is left.
Measured in ``docs/guide/performance.md`` ("Large pictures in tiles").
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import sys
import tempfile
import time
import warnings
import zipfile
from dataclasses import dataclass

import numpy as np

from .._timing import Stopwatch
from ..domain import Domain
from ..engine import make_engine
from .executors import peak_rss_mib, map_tasks
from ..image import ToneOptions, gray_strips
from ..io import atomic_write
from .items import derive_seeds
from ..options import check_fields, option
from ..radii import certified_k, detail_scale
from ..schedule import StippleOptions
from ..dithering import error_diffusion
from ..memory import freed_memory_kept, give_back
from ..stipple import StippleResult, field_margin, StippleState, make_stage, run_schedule, dot_radii

__all__ = ["TileOptions", "tile_grid", "stipple_tiled", "WorkFolderBusy", "WorkFolderWarning"]

_TILES = "tiles (one large picture in parts, on --jobs workers or a Dask cluster)"

_GRID = re.compile(r"^\s*(\d+)\s*[xX]\s*(\d+)\s*$")
_SIZE = re.compile(r"^\s*(\d+)\s*px\s*$")


def _check_tiles(text):
    if not isinstance(text, str) or not (_GRID.match(text) or _SIZE.match(text)):
        raise ValueError(f"tiles must be ROWSxCOLUMNS (2x2) or a tile size in pixels (4096px), "
                         f"got {text!r}")


@dataclass(frozen=True)
class TileOptions:
    """How :func:`stipple_tiled` cuts a picture: tiles, seam band, halo, work folder.

    Examples
    --------
    >>> TileOptions(tiles="2x3").grid(900, 400)
    (2, 3)
    >>> TileOptions(tiles="4096px").grid(10000, 4000)
    (1, 3)
    """

    tiles: str = option(None, "stipple the picture in parts: ROWSxCOLUMNS tiles (2x2) or tiles "
                        "of at most N pixels a side (4096px); each worker holds one tile, the "
                        "seams are stippled again and the whole is certified as one",
                        check=_check_tiles, metavar="RxC", group=_TILES)
    seam_band: float = option(3.0, "dots within this many dot spacings of a seam are stippled "
                              "again with their neighbours across it (default 3)",
                              lo=0.5, hi=50, metavar="S", group=_TILES)
    halo: float = option(8.0, "around a seam's band, dots within this many further dot spacings "
                         "hold still while the band moves (default 8)",
                         lo=1, hi=100, metavar="S", group=_TILES)
    work_dir: str = option(None, "folder of a tiled run's raster and finished tiles; a rerun of "
                           "the same job there resumes (default: OUT.tiles beside the first "
                           "output; removed when the run is done)", metavar="DIR", group=_TILES)

    def __post_init__(self):
        check_fields(self)

    def replace(self, **overrides):
        """A copy with ``overrides`` (field names), checked again."""
        return dataclasses.replace(self, **overrides)

    def grid(self, width, height):
        """``(rows, columns)`` of tiles for a `width` x `height` picture."""
        return tile_grid(self.tiles or "1x1", width, height)


def tile_grid(tiles, width, height):
    """``(rows, columns)`` of ``"RxC"`` or ``"Npx"`` for a `width` x `height` picture.

    Raises
    ------
    ValueError
        A bad text, or more tiles than pixels.

    Examples
    --------
    >>> tile_grid("2x2", 100, 80), tile_grid("30px", 100, 80)
    ((2, 2), (3, 4))
    """
    _check_tiles(tiles)
    m = _GRID.match(tiles)
    if m:
        rows, cols = int(m.group(1)), int(m.group(2))
    else:
        size = int(_SIZE.match(tiles).group(1))
        if size < 1:
            raise ValueError(f"tiles: a tile size must be at least 1 pixel, got {tiles!r}")
        rows, cols = -(-height // size), -(-width // size)
    if not (1 <= rows <= height and 1 <= cols <= width):
        raise ValueError(f"tiles {tiles}: a {width}x{height} picture has room for 1 to {height} "
                         f"rows and 1 to {width} columns")
    return rows, cols


def _edges(size, parts):
    return [round(i * size / parts) for i in range(parts + 1)]


# ------------------------------------------------------------------ raster


#: The files of a work folder: the raster and its digest, the job's key, the lock, the mark
#: of a folder a run made, and one per finished part; no other file there is read or removed.
RASTER = "diskpack-gray.npy"
RASTER_DIGEST = "diskpack-gray.sha256"
KEY = "diskpack-job.json"
LOCK = "diskpack-lock.json"
MADE = "diskpack-made"
_OURS = re.compile(r"diskpack-(gray\.npy|gray\.sha256|job\.json|lock\.json|made|"
                   r"(tile|seam-x|seam-y)-\d+\.npz)")
_CHUNK = 1 << 20


def _file_digest(path):
    """The sha256 of a file's bytes, read a MiB at a time."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(_CHUNK), b""):
            h.update(block)
    return h.hexdigest()


def _write_raster(image, path, tone, invert, paper_tone, allow_large):
    """The toned gray picture as a float32 ``.npy`` at `path`, written strip by strip, and
    its digest beside it (:data:`RASTER_DIGEST`), read back before a rerun uses it."""
    tmp = path + ".part"
    try:
        shape, strips = gray_strips(image, allow_large=allow_large)
        out = np.lib.format.open_memmap(tmp, mode="w+", dtype=np.float32, shape=shape)
        for y0, g in strips:
            g = tone.adjust(g, copy=False)   # a strip of its own
            if invert:
                g = 1.0 - g
            if paper_tone > 0:
                g = g * (1.0 - paper_tone)
            out[y0:y0 + len(g)] = g
        out.flush()
        del out
        with atomic_write(os.path.join(os.path.dirname(path), RASTER_DIGEST), "w") as fh:
            fh.write(_file_digest(tmp))
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _raster_fault(path):
    """Why the raster at `path` cannot be used (None: it can): missing, its digest missing
    or not its bytes', or not a 2-D float32 ``.npy``."""
    if not os.path.exists(path):
        return "missing"
    try:
        with open(os.path.join(os.path.dirname(path), RASTER_DIGEST)) as fh:
            digest = fh.read().strip()
        if _file_digest(path) != digest:
            return "its bytes are not those written (truncated or changed)"
        gray = np.load(path, mmap_mode="r")
        shape, fortran, dtype = gray.shape, np.isfortran(gray), gray.dtype
    except (OSError, ValueError) as exc:
        return str(exc) or type(exc).__name__
    if len(shape) != 2 or fortran or dtype != np.float32:
        return f"not a 2-D float32 raster ({dtype}, shape {shape})"
    return None


@dataclass(frozen=True)
class _Ink:
    """What the plan needs of the whole picture: its ink, each tile's, the median darkness."""

    total: float
    tiles: np.ndarray
    dmed: float


def _picture_ink(raster, ys, xs, strip=256):
    """:class:`_Ink` of the raster for tile edges `ys`, `xs`, read a strip at a time."""
    gray = np.load(raster, mmap_mode="r")
    tiles = np.zeros((len(ys) - 1, len(xs) - 1))
    hist = np.zeros(4096)
    for r in range(len(ys) - 1):
        cols = np.zeros(gray.shape[1])
        for y0 in range(ys[r], ys[r + 1], strip):
            d = 1.0 - np.asarray(gray[y0:min(y0 + strip, ys[r + 1])], dtype=np.float64)
            cols += d.sum(axis=0)
            hist += np.histogram(d[d > 0.05], bins=hist.size, range=(0.05, 1.0))[0]
        tiles[r] = np.add.reduceat(cols, xs[:-1])
    total = float(tiles.sum())
    if not total > 1e-9:
        raise ValueError("nothing to stipple: the image is white")
    return _Ink(total, tiles, _median_of(hist, 0.05, 1.0) if hist.sum() else total / gray.size)


def _median_of(hist, lo, hi):
    """The median of a histogram's values, linear within its bin (to 1/len(hist) of the range)."""
    cum = np.cumsum(hist)
    half = 0.5 * cum[-1]
    b = int(np.searchsorted(cum, half))
    before = cum[b - 1] if b else 0.0
    width = (hi - lo) / len(hist)
    return lo + width * (b + (half - before) / max(hist[b], 1.0))


def _shares(n, ink):
    """`n` dots shared in proportion to `ink` (largest remainders; ties to the first)."""
    exact = n * ink.ravel() / ink.sum()
    share = np.floor(exact).astype(np.int64)
    order = np.argsort(-(exact - share), kind="stable")
    share[order[:n - int(share.sum())]] += 1
    return share.reshape(ink.shape)


# ------------------------------------------------------------------- tasks


@dataclass(frozen=True)
class Part:
    """One task of a tiled run: a rectangle of the picture and the dots that move in it.

    A tile (``points`` None) is stippled from its error diffusion; a seam's
    window holds ``points`` (picture coordinates, with their ``ink``
    factors), of which those with ``moving`` move and the others hold still.
    """

    raster: str
    rect: tuple           # (x0, y0, x1, y1), pixels
    margin: int           # pixels of picture around rect the fields are computed with
    plan: object          # StipplePlan, n the dots in rect
    ell: float = None
    backend: str = "auto"
    device: str = None
    points: np.ndarray = None
    ink: np.ndarray = None
    moving: np.ndarray = None
    k: float = None


def run_part(part):
    """Stipple one :class:`Part`; a dict of the moved dots: ``points``, ``base_radii``, ``ink``, ``k``."""
    with freed_memory_kept():   # as a whole picture's run (in a function of its own: its
        return _run_part(part)  # arrays are freed before the block gives memory back)


def _run_part(part):
    t0 = time.perf_counter()
    x0, y0, x1, y1 = part.rect
    gray, window = _window(part.raster, part.rect, part.margin)
    plan = part.plan
    offset = np.array([x0, y0], dtype=np.float64)
    before = None
    if part.points is None:
        state = StippleState(_tile_start(gray, window, plan.n, plan.seed), float(plan.k0))
    else:
        state = StippleState(part.points - offset, float(part.k), 0, part.ink)
        before = _holding(~part.moving, state)
    engine = make_engine(Domain.rect(x1 - x0, y1 - y0), plan.n, part.backend, device=part.device,
                         grid=plan.grid_shape(x1 - x0, y1 - y0))
    # the window is this run's own copy: its bands consume it, and it is gone before the steps
    stage = make_stage(gray, plan, engine, window=window, ell=part.ell, consume=True)
    del gray
    give_back()
    state, history = run_schedule(state, stage, None, before=before)
    keep = slice(None) if part.moving is None else part.moving
    ink = np.ones(len(state.points)) if state.ink is None else state.ink
    return {"points": state.points[keep] + offset,
            "base_radii": dot_radii(state, stage, state.points)[keep], "ink": ink[keep],
            "k": float(state.k), "steps": len(history), "engine": engine.backend,
            # a string: the work folder's .npz holds no dicts
            "stages": json.dumps(stage.stages),
            "seconds": time.perf_counter() - t0, "peak_rss_mib": peak_rss_mib()}


def _tile_start(gray, window, n, seed):
    """`n` start points in the tile `window` of `gray`: the error diffusion of all of `gray`.

    Error diffusion leaves too few points along the edges where it starts
    and ends (a third fewer within half a dot spacing): in the margin here,
    not along the seams. The points inside the tile are kept; the few too
    many or too few are dropped at random, or drawn from the tile's darkness.
    """
    rows, cols = window
    core = 1.0 - gray[window]
    share = core.sum()
    want = n if share <= 0 else max(n, int(round(n * (1.0 - gray).sum() / share)))
    rng = np.random.default_rng(seed)
    points = error_diffusion(gray, want, seed=rng) - [cols.start, rows.start]
    h, w = core.shape
    points = points[(points[:, 0] >= 0) & (points[:, 0] < w) & (points[:, 1] >= 0) & (points[:, 1] < h)]
    if len(points) > n:
        return points[np.sort(rng.choice(len(points), n, replace=False))]
    if len(points) < n:
        p = core.ravel() / share if share > 0 else None
        pixel = rng.choice(core.size, n - len(points), p=p)
        extra = np.column_stack([pixel % w, pixel // w]) + rng.random((len(pixel), 2))
        points = np.concatenate([points, extra])
    return points


def _window(raster, rect, margin):
    """The raster around `rect` (float64) and the slices of `rect` in it."""
    gray = np.load(raster, mmap_mode="r")
    H, W = gray.shape
    x0, y0, x1, y1 = rect
    wx0, wy0, wx1, wy1 = max(0, x0 - margin), max(0, y0 - margin), min(W, x1 + margin), \
        min(H, y1 + margin)
    window = (slice(y0 - wy0, y1 - wy0), slice(x0 - wx0, x1 - wx0))
    return np.array(gray[wy0:wy1, wx0:wx1], dtype=np.float64), window


def _holding(held, start):
    """The `before` hook of the stippling loop: after each step the `held` dots are back."""
    ink0 = np.ones(len(held)) if start.ink is None else start.ink

    def before(state, index, total):
        def after(s):
            points = np.where(held[:, None], start.points, s.points)
            ink = None if s.ink is None else np.where(held, ink0, s.ink)
            return StippleState(points, s.k, s.packs, ink)
        return after
    return before


# ------------------------------------------------------------------ driver


def _job_key(image, n, options, tiling, tone, backend):
    """What makes two runs the same job: the picture's bytes (a file's or an array's, hashed)
    and the options. A file's size and time do not tell another picture of the same size
    written in the same second."""
    if isinstance(image, (str, os.PathLike)):
        picture = _file_digest(image)
    else:
        a = np.ascontiguousarray(image)
        picture = [hashlib.sha256(a.tobytes()).hexdigest(), list(a.shape), str(a.dtype)]
    job = {"picture": picture, "n": int(n), "options": dataclasses.asdict(options),
           "tiles": [tiling.tiles, tiling.seam_band, tiling.halo], "tone": tone.params(),
           "backend": backend}
    return json.loads(json.dumps(job, default=str))


class WorkFolderBusy(ValueError):
    """Another run holds the work folder (its lock names that run).

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> with _WorkFolder(folder, {"job": 1}):
    ...     try:
    ...         _WorkFolder(folder, {"job": 1})
    ...     except WorkFolderBusy as exc:
    ...         print(str(exc).split(" (")[0].endswith("is in use by another run"))
    True
    >>> import shutil; shutil.rmtree(folder)
    """


class _WorkFolder:
    """The work folder of one job, held by one run at a time: its key, raster and finished tasks.

    Stale contents (another job's) are cleared; every part is checked when read
    (:meth:`done`). Used as a context manager: the lock is released at its end,
    and :meth:`remove` (after the outputs are written) leaves nothing behind.
    """

    def __init__(self, path, key, *, made=False):
        self.path, self.broken = path, []
        if not os.path.isdir(path):
            os.makedirs(path)
            made = True
        self._lock = _lock_folder(self.file(LOCK))
        if made:
            open(self.file(MADE), "wb").close()
        self.job = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()
        if _read_json(self.file(KEY)) != key:
            self._clear(keep=(LOCK, MADE))
            with atomic_write(self.file(KEY), "w") as fh:
                json.dump(key, fh)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._lock is not None:
            self._lock.close()   # (the kernel releases its lock)
            self._lock = None

    def file(self, name):
        return os.path.join(self.path, name)

    def done(self, name, check):
        """A finished task's result, or None (missing: it runs again).

        A result that cannot be read, is another job's or part's, or fails
        ``check(result)`` (a text: what is wrong) is removed and announced
        with ``(path, why)`` in :attr:`broken`; it runs again too.
        """
        path = self.file(f"diskpack-{name}.npz")
        if not os.path.exists(path):
            return None
        try:
            with open(path, "rb") as fh, np.load(fh) as z:   # (np.load leaks a bad zip's file)
                result = {k: (z[k] if z[k].ndim else z[k].item()) for k in z.files}
            why = _part_fault(result, self.job, name) or check(result)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            why = f"unreadable ({type(exc).__name__}: {exc})"
        if why is None:
            return result
        os.remove(path)
        self.broken.append((path, why))
        return None

    def save(self, name, result):
        """Save a task's result with the job, its name and a digest of its arrays."""
        marked = dict(result, job=self.job, part=name)
        marked["digest"] = _arrays_digest(marked)
        with atomic_write(self.file(f"diskpack-{name}.npz"), "wb") as fh:
            np.savez(fh, **marked)

    def _clear(self, keep=()):
        for name in os.listdir(self.path):
            if _OURS.fullmatch(name) and name not in keep:
                os.remove(self.file(name))

    def remove(self):
        """Remove this job's files, and the folder where a run made it and it is empty."""
        made = os.path.exists(self.file(MADE))
        self._clear()   # the lock file too, while held: a run that opened it finds it taken
        if made and not os.listdir(self.path):
            os.rmdir(self.path)


def _read_json(path):
    """A JSON file's value, or None where it is missing or unreadable."""
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _lock_folder(path):
    """Hold the lock file at `path` (``fcntl.flock``) and name this run in it; its open file.

    Raises
    ------
    WorkFolderBusy
        Another live run holds it; the message names that run.
    """
    try:
        import fcntl   # POSIX: elsewhere a folder is not locked
    except ImportError:  # pragma: no cover - not POSIX
        return None
    while True:
        fh = open(path, "a+")
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            raise WorkFolderBusy(f"the work folder {os.path.dirname(path)} is in use by another "
                                 f"run ({_holder(path)}); wait for it to end, or give another "
                                 f"work folder") from None
        try:
            same = os.fstat(fh.fileno()).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:   # else the run that held it removed it meanwhile: take the new one
            break
        fh.close()
    fh.seek(0)
    fh.truncate()
    json.dump({"pid": os.getpid(), "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
               "command": " ".join(sys.argv)}, fh)
    fh.flush()
    return fh


def _holder(path):
    """The run named in a lock file: ``pid P, started T: COMMAND``."""
    who = _read_json(path)
    if not isinstance(who, dict):
        return "a run that has not named itself yet"
    return f"pid {who.get('pid')}, started {who.get('started')}: {who.get('command')}"


def _arrays_digest(result):
    """The sha256 of a result's entries (names, types, shapes and bytes), ``digest`` left out."""
    h = hashlib.sha256()
    for key in sorted(result):
        if key != "digest":
            a = np.asarray(result[key])
            h.update(f"{key}:{a.dtype.str}:{a.shape}:".encode())
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


#: The arrays of a task's result and their columns (None: one value a dot).
_PER_DOT = {"points": 2, "base_radii": None, "ink": None}


def _part_fault(result, job, name):
    """What is wrong with a saved result (None: nothing): its job, part, digest, arrays."""
    if result.get("job") != job or result.get("part") != name:
        return "another job's or part's result"
    if result.get("digest") != _arrays_digest(result):
        return "its contents do not match their digest"
    m = None
    for key, cols in _PER_DOT.items():
        a = np.asarray(result.get(key))
        if a.dtype.kind != "f" or a.ndim != (1 if cols is None else 2) \
                or (cols is not None and a.shape[1] != cols) or (m is not None and len(a) != m):
            return f"{key}: not one float{' pair' if cols else ''} a dot"
        if not np.all(np.isfinite(a)):
            return f"{key}: not finite"
        m = len(a)
    if not np.all(result["base_radii"] > 0) or not (float(result.get("k", 0)) > 0):
        return "radii or k not positive"
    return None


def _part_check(part):
    """``check(result)`` for :meth:`_WorkFolder.done`: the dots of `part`, inside its rect."""
    n = part.plan.n if part.moving is None else int(part.moving.sum())
    x0, y0, x1, y1 = part.rect

    def check(result):
        p = result["points"]
        if len(p) != n:
            return f"{len(p)} dots where the part has {n}"
        if not np.all((p >= (x0, y0)) & (p <= (x1, y1))):
            return f"dots outside the part's rectangle {part.rect}"
        return None
    return check


def _phase(work, name, parts, run, progress, records, note):
    """Results of `parts` (saved ones read back and checked), the others run with `run`
    (map_tasks); ``note(text)`` for each saved one that was broken."""
    results = [work.done(f"{name}-{i}", _part_check(part)) for i, part in enumerate(parts)]
    while work.broken:
        path, why = work.broken.pop(0)
        note(f"{path}: {why}; computing that part again")
    todo = [i for i, r in enumerate(results) if r is None]
    for j, result in run([parts[i] for i in todo]):
        i = todo[j]
        work.save(f"{name}-{i}", result)
        results[i] = result
        if progress is not None:
            progress(name, sum(r is not None for r in results), len(parts))
    for i, r in enumerate(results):
        records.append({"kind": name, "part": i, "n": int(len(r["points"])),
                        **{k: r[k] for k in ("steps", "seconds", "peak_rss_mib", "engine")},
                        "stages": json.loads(r["stages"])})
    return results


def _merged_stages(parts):
    """Where each stage of a tiled run ran: the one :func:`~diskpack_cl.engine.stage_record`
    its parts share, or the list of their different records (parts on several devices,
    or some that fell back).

    Examples
    --------
    >>> a, b = {"backend": "opencl"}, {"backend": "exact"}
    >>> _merged_stages([{"engine": a, "blur": b}, {"engine": a, "blur": a}])
    {'engine': {'backend': 'opencl'}, 'blur': [{'backend': 'exact'}, {'backend': 'opencl'}]}
    """
    out = {}
    for stages in parts:
        for name, record in stages.items():
            seen = out.setdefault(name, [])
            if record not in seen:
                seen.append(record)
    return {name: seen[0] if len(seen) == 1 else seen for name, seen in out.items()}


def _seam_parts(points, ink, k, edges, axis, size, band, halo, base):
    """The parts of the seams at `edges` along `axis` (0: between columns, x; 1: rows, y)."""
    parts, moving_index = [], []
    for e in edges[1:-1]:
        lo, hi = max(0, int(math.floor(e - band - halo))), min(size[axis], int(math.ceil(e + band + halo)))
        c = points[:, axis]
        inside = np.flatnonzero((c > lo) & (c < hi))
        moving = np.abs(c[inside] - e) < band
        if not moving.any():   # white paper along this seam
            continue
        rect = (lo, 0, hi, size[1]) if axis == 0 else (0, lo, size[0], hi)
        parts.append(dataclasses.replace(base, rect=rect, plan=dataclasses.replace(base.plan, n=len(inside)),
                                         points=points[inside], ink=ink[inside], moving=moving, k=k))
        moving_index.append(inside[moving])
    return parts, moving_index


def stipple_tiled(image, n, options=None, tiling=None, *, tone=None, jobs=1, client=None,
                  devices=None, backend="auto", allow_large=False, progress=None, finish=None,
                  note=None, **overrides):
    """Stipple a large picture in tiles with ``n`` dots: one certified stippling.

    Parameters
    ----------
    image : str, os.PathLike or array_like
        The picture (as for :func:`diskpack_cl.stipple`); a file is decoded
        once and kept as a gray raster in the work folder.
    n : int
        Number of dots in the whole picture.
    options : StippleOptions, optional
        The stippling options, planned for the whole picture.
    tiling : TileOptions, optional
        Tiles, seam band, halo, work folder (default: 1 x 1, a temporary folder).
    tone : ToneOptions, optional
        Tone controls applied to the picture first.
    jobs, client, devices
        Where the tasks run (:func:`diskpack_cl.jobs.executors.map_tasks`): this
        process, ``jobs`` spawned workers, or a Dask cluster (its workers
        must see the work folder).
    backend : {"auto", "opencl", "exact"}
    allow_large : bool
        Lift Pillow's decompression-bomb limit.
    progress : callable, optional
        ``progress(phase, done, total)`` after each task.
    finish : callable, optional
        ``finish(result)``, called while the work folder is still held, before
        it is removed: write the outputs there, so that a failure or a signal
        while they are written leaves the finished parts for a rerun.
    note : callable, optional
        ``note(text)``: a broken part of the work folder (unreadable, another
        job's, or with wrong contents) named and computed again (default:
        a :class:`WorkFolderWarning`).
    **overrides
        Fields of :class:`StippleOptions`.

    Returns
    -------
    StippleResult
        ``history`` holds one entry per task (``kind`` ``tile``, ``seam-x``
        or ``seam-y``, its dots, steps, seconds, peak memory and stages);
        ``stages`` those of all tasks (one record per stage, or a list of the
        different records of its tasks).

    Raises
    ------
    WorkFolderBusy
        Another run holds the work folder (one run at a time: a lock file in
        it names the run that holds it).

    Examples
    --------
    >>> g = np.tile(np.linspace(0.0, 1.0, 96), (64, 1))
    >>> res = stipple_tiled(g, 400, tiling=TileOptions(tiles="1x2", halo=2, seam_band=1),
    ...                     schedule=[("mix", 3, 0.5)], backend="exact")
    >>> res.n, res.certificate.valid, sorted({h["kind"] for h in res.history})
    (400, True, ['seam-x', 'tile'])
    """
    t_start = time.perf_counter()
    options = (options or StippleOptions()).replace(**overrides)
    tiling, tone = tiling or TileOptions(), tone or ToneOptions()
    key = _job_key(image, n, options, tiling, tone, backend)
    folder = tiling.work_dir or tempfile.mkdtemp(prefix="diskpack-tiles-")
    with _WorkFolder(folder, key, made=tiling.work_dir is None) as work:
        try:
            result = _stipple_in(work, image, n, options, tiling, tone, jobs=jobs,
                                 client=client, devices=devices, backend=backend,
                                 allow_large=allow_large, progress=progress, note=note or _warn)
            result.timings["total"] = time.perf_counter() - t_start
            if finish is not None:
                finish(result)
        except BaseException:
            if tiling.work_dir is None:   # a folder of a random name: no rerun finds it
                work.remove()
            raise
        work.remove()
    return result


class WorkFolderWarning(UserWarning):
    """A broken part of a tiled run's work folder, computed again (when no ``note`` is given).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _warn("diskpack-tile-0.npz: unreadable; computing that part again")
    >>> caught[0].category.__name__
    'WorkFolderWarning'
    """


def _warn(text):
    warnings.warn(WorkFolderWarning(text), stacklevel=4)


def _stipple_in(work, image, n, options, tiling, tone, *, jobs, client, devices, backend,
                allow_large, progress, note):
    """:func:`stipple_tiled` in the held work folder `work`."""
    watch = Stopwatch()
    with watch("load"):
        raster = work.file(RASTER)
        fault = _raster_fault(raster)
        if fault is not None:
            if fault != "missing":
                note(f"{raster}: {fault}; reading the picture again")
            _write_raster(image, raster, tone, options.invert, options.paper_tone, allow_large)
        H, W = np.load(raster, mmap_mode="r").shape
    rows, cols = tiling.grid(W, H)
    xs, ys = _edges(W, cols), _edges(H, rows)
    with watch("plan"):
        ink = _picture_ink(raster, ys, xs)
        plan = options.plan(n, W, H, ink=ink.total)
        ell = detail_scale(ink.total, n, ink.dmed) if plan.features == "detail" else None
    spacing = math.sqrt(W * H / n)
    band, halo = tiling.seam_band * spacing, tiling.halo * spacing
    _check_room(xs, ys, band + halo)
    # a margin of at least 4 dot spacings: the tile's error diffusion starts and ends in it
    margin = max(field_margin(plan, ell), int(math.ceil(4 * spacing)))
    base = Part(raster, (0, 0, W, H), margin, plan, ell, backend,
                devices[0] if devices and client is None else None)
    records = []

    def run(parts):
        return map_tasks(run_part, parts, jobs=jobs, client=client, devices=devices)

    with watch("tiles"):
        parts = _tile_parts(base, xs, ys, _shares(n, ink.tiles), plan.seed)
        done = _phase(work, "tile", parts, run, progress, records, note)
    points = np.concatenate([r["points"] for r in done])
    radii = np.concatenate([r["base_radii"] for r in done])
    inks = np.concatenate([r["ink"] for r in done])
    k = float(np.median([r["k"] for r in done]))
    with watch("seams"):
        for axis, edges, name in ((0, xs, "seam-x"), (1, ys, "seam-y")):
            parts, index = _seam_parts(points, inks, k, edges, axis, (W, H), band, halo, base)
            for i, r in zip(index, _phase(work, name, parts, run, progress, records, note)):
                points[i], radii[i], inks[i] = r["points"], r["base_radii"], r["ink"]
    with watch("certify"):
        k, disks, cert = certified_k(points, radii, W, H, Domain.rect(W, H))
    params = dict(plan.params(), tiles=f"{rows}x{cols}", seam_band=tiling.seam_band,
                  halo=tiling.halo)
    return StippleResult(points=points, radii=disks, k=float(k), base_radii=radii,
                         certificate=cert, history=records, width=W, height=H,
                         timings=watch.seconds, params=params,
                         engine=records[0]["engine"] if records else backend,
                         tone_radius=math.sqrt(ink.total / (n * math.pi)),
                         stages=_merged_stages(r["stages"] for r in records))


def _tile_parts(base, xs, ys, shares, seed):
    """One part per tile that holds dots, each with its share and its seed."""
    seeds = derive_seeds(seed, shares.size)
    parts = []
    for r in range(len(ys) - 1):
        for c in range(len(xs) - 1):
            share = int(shares[r, c])
            if share:
                plan = dataclasses.replace(base.plan, n=share, seed=seeds[r * (len(xs) - 1) + c])
                parts.append(dataclasses.replace(base, rect=(xs[c], ys[r], xs[c + 1], ys[r + 1]),
                                                 plan=plan))
    return parts


def _check_room(xs, ys, reach):
    """Seams of one direction must not share dots: tiles wider than twice a seam's reach."""
    for edges, what in ((xs, "wide"), (ys, "tall")):
        size = min(b - a for a, b in zip(edges, edges[1:]))
        if len(edges) > 2 and size <= 2 * reach:
            raise ValueError(f"tiles of {size} px are too small: a seam reaches {reach:.0f} px on "
                             f"each side (--seam-band + --halo dot spacings), so tiles must be more "
                             f"than {2 * reach:.0f} px {what}; use fewer tiles")
