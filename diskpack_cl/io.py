"""File input and output: point sets and atomic writes.

Point files hold an ``(n, 2)`` array of float64 coordinates ``x, y``:

=========== ==========================================================
extension   layout
=========== ==========================================================
``.npz``    numpy archive; the key ``points`` holds the array, other
            keys (``rho``, ``radii``, ...) may sit beside it
``.npy``    a single numpy array of shape ``(n, 2)``
``.csv``    a header line ``x,y`` then one ``x,y`` pair a line; more
            columns may follow ``x`` and ``y``, a headerless file of
            exactly two columns is also read
``.txt``    two numbers a line separated by white space; ``#`` starts
``.xy``     a comment
=========== ==========================================================

Writers go through :func:`atomic_write`: an interrupted or failed write leaves
no partial file and no temporary file behind, and an existing file is kept.
Text formats are written with 17 significant digits, so float64 coordinates
round-trip exactly.
"""

from __future__ import annotations

import contextlib
import contextvars
from glob import escape as glob_escape
import io as _stdio
import os
import signal
import tempfile
import warnings
import zipfile
from pathlib import Path

import numpy as np

__all__ = [
    "POINT_FORMATS",
    "OutputIsInputError",
    "atomic_write",
    "atomic_writes",
    "remove_partial_files",
    "check_not_inputs",
    "check_points_path",
    "check_writable",
    "json_default",
    "load_npz",
    "read_points",
    "validate_points",
    "write_points",
]

#: Extensions understood by :func:`read_points` and :func:`write_points`.
POINT_FORMATS = (".npz", ".npy", ".csv", ".txt", ".xy")

# (temporary, target) pairs of the innermost atomic_writes(), or None outside one
_PENDING = contextvars.ContextVar("diskpack_cl_pending_writes", default=None)


@contextlib.contextmanager
def atomic_write(path, mode="wb"):
    """Open a temporary file beside `path` and move it over `path` on success.

    Nothing is left behind when the body raises: the temporary file is removed
    and an existing `path` is untouched; an ``OSError`` of the write (a
    read-only or full file system, `path` a folder) names `path`, not the
    temporary file. A new file gets the permissions that ``open(path, "w")``
    would give it (``0o666`` less the umask); a replaced file keeps its
    permissions.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "a.txt")
    >>> with atomic_write(p, "w") as f:
    ...     _ = f.write("hello")
    >>> Path(p).read_text()
    'hello'
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(f"output directory does not exist: {directory}")
    tmp = None
    try:
        # signals held while the file is created and named: one in between would leave it
        with _signals_held():
            try:
                fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=directory)
            except OSError as exc:
                raise _named(exc, path) from exc
        # mkstemp creates 0600 files; give the result the mode a plain open() would
        # (or keep the mode of the file being replaced)
        try:
            perms = path.stat().st_mode & 0o7777
        except OSError:
            perms = 0o666 & ~_umask()
        with contextlib.suppress(OSError):  # e.g. a file system without modes
            os.chmod(tmp, perms)
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        pending = _PENDING.get()
        if pending is None:
            os.replace(tmp, path)
        else:  # renamed with the others at the end of atomic_writes()
            pending.append((tmp, path))
    except BaseException as exc:
        if tmp is None:   # mkstemp failed (its error names `path`) or was interrupted
            raise
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.errno and exc.filename in (None, tmp):
            raise _named(exc, path) from exc
        raise


def remove_partial_files(path):
    """Remove the temporary files that :func:`atomic_write` left beside `path`.

    A writer that ends normally, raises or takes SIGTERM removes its own; one
    killed outright (SIGKILL, the out-of-memory killer) cannot, and whoever
    stopped it calls this for the outputs it was writing. Returns the
    number removed.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> open(os.path.join(d, ".a.npz.x1y2.part"), "w").close()
    >>> remove_partial_files(os.path.join(d, "a.npz")), os.listdir(d)
    (1, [])
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    removed = 0
    for tmp in directory.glob(f".{glob_escape(path.name)}.*.part"):
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
            removed += 1
    return removed


@contextlib.contextmanager
def atomic_writes():
    """Several :func:`atomic_write` calls that replace their files together, or not at all.

    Inside the block every :func:`atomic_write` leaves its finished
    temporary file beside its target; when the block ends normally all of
    them are renamed onto their targets (with Ctrl-C, SIGTERM and SIGHUP held
    back for those few renames). When the block raises, or is interrupted,
    only the temporaries are removed: every file that existed before is left
    as it was, and no new one appears.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> with atomic_writes():
    ...     for name in ("a.txt", "b.txt"):
    ...         with atomic_write(os.path.join(d, name), "w") as f:
    ...             _ = f.write(name)
    ...     os.path.exists(os.path.join(d, "a.txt"))
    False
    >>> sorted(os.listdir(d))
    ['a.txt', 'b.txt']
    """
    pending = []
    token = _PENDING.set(pending)
    try:
        yield
        # the renames inside the try: a signal just before them still removes the temporaries
        with _signals_held():
            for tmp, path in pending:
                os.replace(tmp, path)
    except BaseException:
        for tmp, _ in pending:   # (a signal held over the renames finds them renamed)
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        raise
    finally:
        _PENDING.reset(token)


@contextlib.contextmanager
def _signals_held():
    """Hold back SIGINT, SIGTERM and SIGHUP in the block (a few renames): POSIX only."""
    held = {signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", signal.SIGTERM)}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    except (AttributeError, OSError, ValueError):  # pragma: no cover - not POSIX
        old = None
    try:
        yield
    finally:
        if old is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _named(exc, path):
    """The OSError `exc` (of a temporary file) as one that names the target `path`."""
    return type(exc)(exc.errno, exc.strerror or str(exc), str(path))


def _umask():
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _suffix(path):
    return Path(path).suffix.lower()


def check_writable(path):
    """Raise unless :func:`atomic_write` can create `path`: checked before any work.

    The folder must exist, `path` must not be a folder, and a real probe file
    is created in the folder (where :func:`atomic_write` puts its temporary
    file) and removed again, so a read-only file system, a folder without
    write permission or a full disk is found before a long computation.

    Raises
    ------
    FileNotFoundError
        The output folder does not exist.
    ValueError
        `path` is a folder, or the probe cannot be created (the message
        gives the reason, e.g. ``Read-only file system``).

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> check_writable(os.path.join(d, "out.svg"))
    >>> os.listdir(d)
    []
    >>> check_writable(d)
    Traceback (most recent call last):
    ...
    ValueError: ... is a folder, not a file name
    """
    path = Path(os.fspath(path))
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(f"{path}: output directory does not exist: {directory}")
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a file name")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=directory)
    except OSError as exc:
        raise ValueError(f"{path}: cannot write in {directory}: "
                         f"{exc.strerror or exc}") from None
    os.close(fd)
    os.unlink(probe)


class OutputIsInputError(ValueError):
    """An output of a run would replace one of its inputs (the command line's status 2).

    Examples
    --------
    >>> issubclass(OutputIsInputError, ValueError)
    True
    """


def _file_identity(path):
    """``(st_dev, st_ino)`` of the file `path` reaches, or None where there is none."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):  # missing, a symlink loop, a NUL in the name
        return None
    return st.st_dev, st.st_ino


def check_not_inputs(outputs, inputs):
    """Refuse, before any work, an output that would replace an input of the same run.

    An output is refused when its path, with symlinks resolved, is an
    input's, or when both exist and are the same file (a hard link, a bind
    mount). The one rule of every command: an output never destroys what
    the run was given.

    Parameters
    ----------
    outputs, inputs : iterable of str or os.PathLike
        The run's output and input paths (``None`` entries are skipped).

    Raises
    ------
    OutputIsInputError
        A ``ValueError`` naming the output and the input.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> photo = os.path.join(d, "photo.png")
    >>> open(photo, "w").close()
    >>> check_not_inputs([os.path.join(d, "out.svg")], [photo])
    >>> check_not_inputs([os.path.join(d, ".", "photo.png")], [photo])
    Traceback (most recent call last):
    ...
    diskpack_cl.io.OutputIsInputError: output .../photo.png would replace the input .../photo.png: write it elsewhere
    """
    given = [os.fspath(x) for x in inputs if x is not None]
    known = {}
    for x in given:
        known.setdefault(os.path.realpath(x), x)
        ident = _file_identity(x)
        if ident is not None:
            known.setdefault(ident, x)
    for out in (os.fspath(x) for x in outputs if x is not None):
        ident = _file_identity(out)
        hit = known.get(os.path.realpath(out)) or (ident and known.get(ident))
        if hit is not None:
            raise OutputIsInputError(f"output {out} would replace the input {hit}: write it "
                                     f"elsewhere")


def check_points_path(path, *, for_writing=False):
    """Return the lower-case extension of `path`, or raise if it is unknown.

    With ``for_writing=True`` also check that the file can be written
    (:func:`check_writable`), so a command can fail before a long computation
    rather than after it.

    Raises
    ------
    ValueError
        The extension is not one of :data:`POINT_FORMATS`, or (``for_writing``)
        the path is a folder or its folder is not writable.
    FileNotFoundError
        ``for_writing`` and the output folder does not exist.

    Examples
    --------
    >>> check_points_path("out/points.NPZ")
    '.npz'
    """
    suffix = _suffix(path)
    if suffix not in POINT_FORMATS:
        raise ValueError(
            f"{path}: unknown point file extension {suffix or '(none)'!r}; "
            f"use one of {', '.join(POINT_FORMATS)}")
    if for_writing:
        check_writable(path)
    return suffix


def validate_points(points, *, min_points=2, domain=None, source=None, dims=(2,)):
    """Check a point array and return it as a C-contiguous ``(n, 2)`` float64 array.

    Parameters
    ----------
    points : array_like
        Coordinates, shape ``(n, 2)``.
    min_points : int, optional
        Smallest accepted ``n``.
    domain : diskpack_cl.Domain, optional
        For a bounded domain (``periodic=False``), every point must lie in the
        closed rectangle ``[0, W] x [0, H]``. Periodic domains accept any
        finite coordinates; callers wrap them onto the torus.
    source : str or path, optional
        Named in error messages (the file the points came from).
    dims : tuple of int, optional
        Accepted numbers of coordinates (``(2, 3)`` for the writers).

    Raises
    ------
    ValueError
        Not numeric, not two columns, fewer than `min_points` rows, NaN or
        infinite coordinates, or points outside a bounded `domain`.

    Examples
    --------
    >>> validate_points([[0.1, 0.2], [0.3, 0.4]]).shape
    (2, 2)
    >>> validate_points([[0.1, float("nan")], [0.3, 0.4]])
    Traceback (most recent call last):
    ...
    ValueError: points: 1 point has NaN or infinite coordinates (first: row 0)
    """
    name = str(source) if source is not None else "points"
    try:
        p = np.asarray(points)
        if p.dtype.kind not in "biuf":
            raise TypeError(f"dtype {p.dtype}")
        p = np.ascontiguousarray(p, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: points must be numeric ({exc})") from None
    if p.ndim != 2 or p.shape[1] not in dims:
        want = " or ".join(f"(n, {d})" for d in dims)
        raise ValueError(f"{name}: points must have shape {want}, got {p.shape}")
    n = p.shape[0]
    if n < min_points:
        raise ValueError(f"{name}: has {n} point{'s' if n != 1 else ''}, "
                         f"need at least {min_points}")
    # the whole array first: a row-wise test runs numpy's inner loop two values long,
    # so it is only paid where some row is bad
    if not np.isfinite(p).all():
        bad = ~np.isfinite(p).all(axis=1)
        k = int(bad.sum())
        raise ValueError(f"{name}: {k} point{'s have' if k > 1 else ' has'} NaN or infinite "
                         f"coordinates (first: row {int(np.argmax(bad))})")
    if domain is not None and not domain.periodic:
        size = np.array([domain.width, domain.height])
        if n and (p.min() < 0 or p[:, 0].max() > size[0] or p[:, 1].max() > size[1]):
            out = ((p < 0) | (p > size)).any(axis=1)
            k = int(out.sum())
            raise ValueError(
                f"{name}: {k} point{'s lie' if k > 1 else ' lies'} outside the domain "
                f"[0, {domain.width:g}] x [0, {domain.height:g}] "
                f"(first: row {int(np.argmax(out))})")
    return p


def load_npz(path):
    """Every array of the ``.npz`` archive `path`, read in full: the one reader of the format.

    Refuses, with one line naming the file, what is not a numpy zip archive
    (a truncated or corrupt one, another file renamed) and arrays that would
    need pickles.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        Not a readable ``.npz`` archive; the message names the file.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "a.npz")
    >>> np.savez(p, points=np.zeros((2, 2)))
    >>> sorted(load_npz(p))
    ['points']
    >>> _ = Path(p).write_bytes(b"not a zip")
    >>> load_npz(p)
    Traceback (most recent call last):
    ...
    ValueError: ...a.npz: unreadable .npz file: not a numpy .npz archive (a zip of .npy arrays)
    """
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file")
    try:
        # our own handle: np.load leaks its file when the zip is broken
        with open(path, "rb") as fh:
            if fh.read(4) != b"PK\x03\x04":
                raise ValueError("not a numpy .npz archive (a zip of .npy arrays)")
            fh.seek(0)
            with np.load(fh, allow_pickle=False) as archive:
                return {key: archive[key] for key in archive.files}
    except ValueError as exc:
        detail = str(exc)
        if "allow_pickle" in detail:
            detail = "holds an array of Python objects, which is not read"
        raise ValueError(f"{path}: unreadable .npz file: {_one_line(detail)}") from None
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - zipfile, zlib and numpy's header parser raise any kind
        raise ValueError(f"{path}: unreadable .npz file: truncated or corrupt "
                         f"({_one_line(exc)})") from None


def _one_line(text):
    """`text` (or an exception's) as one line."""
    return " ".join(str(text).split())


def _header_columns(path, names, columns):
    """Indices of the columns to read from a .csv header (x and y unless `columns` names others)."""
    if columns is None:
        if "z" in names:
            raise ValueError(f"{path}: has a z column (3D points?); these are read as 2D: choose "
                             f"two columns (--columns x,y, or columns=('x', 'y'))")
        columns = ("x", "y")
    if not isinstance(columns[0], str):
        return tuple(columns)
    missing = [c for c in columns if c.lower() not in names]
    if missing:
        raise ValueError(f"{path}: no column {missing[0]!r} (columns: {','.join(names)})")
    return tuple(names.index(c.lower()) for c in columns)


def _read_text(path, suffix, columns=None):
    """Parse a csv/txt/xy file with numpy's C reader; return a float array.

    `columns`: two column names (a .csv header) or indices to read; a .csv
    header with a ``z`` column (3D points) needs them.
    """
    usecols = None if columns is None or isinstance(columns[0], str) else tuple(columns)
    skiprows, names = 0, None
    delimiter = "," if suffix == ".csv" else None
    # utf-8-sig: a byte-order mark (spreadsheets write one) is read past
    with open(path, encoding="utf-8-sig", errors="strict") as fh:
        for lineno, line in enumerate(fh):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            fields = [f.strip() for f in text.split(delimiter)]
            try:
                [float(f) for f in fields]
            except ValueError:
                if suffix != ".csv":
                    raise ValueError(
                        f"{path}: malformed {suffix} file: line {lineno + 1} is not "
                        f"two numbers: {text[:60]!r}") from None
                names = [f.lower() for f in fields]
                if "x" not in names or "y" not in names:
                    raise ValueError(
                        f"{path}: malformed .csv file: header must name columns x,y, "
                        f"got {text[:60]!r}") from None
                usecols = _header_columns(path, names, columns)
                skiprows = lineno + 1
            break
    # under a header every row is read whole: a row of more values than it names is refused
    picked, usecols = (usecols, None) if names is not None else (None, usecols)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(path, dtype=np.float64, delimiter=delimiter, comments="#",
                              skiprows=skiprows, usecols=usecols, ndmin=2, encoding="utf-8-sig")
    except ValueError as exc:
        detail = str(exc).split("; use `usecols`")[0]
        raise ValueError(f"{path}: malformed {suffix} file: {_one_line(detail)}") from None
    if data.size == 0:
        return data.reshape(0, 2)
    if names is not None:
        if data.shape[1] != len(names):
            raise ValueError(f"{path}: malformed .csv file: the header names {len(names)} "
                             f"columns ({','.join(names)}), the rows have {data.shape[1]} values")
        data = data[:, list(picked)]
    return data


def read_points(path, *, min_points=2, domain=None, columns=None):
    """Read an ``(n, 2)`` float64 point array from a ``.npz/.npy/.csv/.txt/.xy`` file.

    Parameters
    ----------
    path : str or os.PathLike
        Point file; the format follows the extension (see the module docstring).
    min_points : int, optional
        Smallest accepted number of points.
    domain : diskpack_cl.Domain, optional
        Passed to :func:`validate_points`.
    columns : pair of str or int, optional
        The two columns to read: names of a ``.csv`` header or indices (any
        format).  Needed where a file has more coordinates (a ``.csv`` with
        a ``z`` column, an array of three columns), which are refused.

    Returns
    -------
    points : ndarray, shape (n, 2), float64

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        Unknown extension, unreadable or malformed file, wrong shape, too few
        points, NaN/inf coordinates. The message names the file.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> p = os.path.join(tempfile.mkdtemp(), "pts.csv")
    >>> write_points(p, np.array([[0.25, 0.5], [0.75, 0.125]]))
    >>> Path(p).read_text().splitlines()[0]
    'x,y'
    >>> read_points(p)
    array([[0.25 , 0.5  ],
           [0.75 , 0.125]])
    """
    suffix = check_points_path(path)
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if not p.is_file():
        raise ValueError(f"{path}: not a regular file")
    try:
        if suffix == ".npz":
            archive = load_npz(p)
            if "points" not in archive:
                raise ValueError(f"{path}: .npz file has no array 'points' "
                                 f"(keys: {', '.join(archive) or 'none'})")
            data = archive["points"]
        elif suffix == ".npy":
            with open(p, "rb") as fh:
                if fh.read(6) != b"\x93NUMPY":
                    raise ValueError(f"{path}: unreadable .npy file: not a numpy array file")
            try:
                data = np.load(p, allow_pickle=False)
            except MemoryError:
                raise
            except Exception as exc:  # noqa: BLE001 - numpy's header parser raises any kind
                raise ValueError(f"{path}: unreadable .npy file: {type(exc).__name__}: "
                                 f"{_one_line(exc)}") from None
        else:
            data = _read_text(p, suffix, columns)
        if columns is not None and suffix in (".npz", ".npy"):
            data = np.asarray(data)[:, list(columns)]
    except ValueError as exc:
        msg = str(exc)
        if not msg.startswith(str(path)):
            msg = f"{path}: unreadable {suffix} file: {msg}"
        raise ValueError(msg) from None
    except (OSError, EOFError, zipfile.BadZipFile, UnicodeDecodeError, IndexError) as exc:
        raise ValueError(f"{path}: unreadable {suffix} file: {exc}") from None
    return validate_points(data, min_points=min_points, domain=domain, source=path)


def box_record(path, domain):
    """``{"box": (W, H)}`` for a box set written to an ``.npz`` (what ``diskpack analyze``
    reads back to treat it as a box, not a torus); ``{}`` for a torus or another format.

    Examples
    --------
    >>> from diskpack_cl.domain import Domain
    >>> box_record("a.npz", Domain.rect(2, 1))["box"].tolist(), box_record("a.csv", Domain.rect(2, 1))
    ([2.0, 1.0], {})
    """
    if domain.periodic or not str(path).lower().endswith(".npz"):
        return {}
    return {"box": np.asarray(domain.size, dtype=np.float64)}


def write_points(path, points, /, **extra):
    """Write an ``(n, 2)`` (or 3D ``(n, 3)``) point array atomically; the format follows the extension.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.npz/.npy/.csv/.txt/.xy``).
    points : array_like, shape (n, 2)
        Finite coordinates, ``n >= 1``.
    **extra : array_like
        Additional arrays. ``.npz`` stores them under their keyword names.
        ``.csv`` stores 1-D arrays of length n as extra columns after ``x,y``.
        The other formats hold points only and raise ``ValueError`` if extras
        are given.

    Raises
    ------
    ValueError
        Unknown extension, invalid points, or extras the format cannot hold.
    FileNotFoundError
        The output folder does not exist.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> p = os.path.join(tempfile.mkdtemp(), "pts.npz")
    >>> write_points(p, np.zeros((3, 2)), rho=np.array([0.7, 0.8]))
    >>> sorted(np.load(p).files)
    ['points', 'rho']
    """
    suffix = check_points_path(path)
    pts = validate_points(points, min_points=1, source=path, dims=(2, 3))
    if "points" in extra:
        raise ValueError(f"{path}: 'points' is reserved; pass it as the points argument")
    if suffix == ".npz":
        arrays = {"points": pts}
        for key, value in extra.items():
            arr = np.asarray(value)
            if arr.dtype.kind == "O":
                raise ValueError(f"{path}: extra array {key!r} is not numeric")
            arrays[key] = arr
        with atomic_write(path, "wb") as fh:
            np.savez(fh, **arrays)
        return
    if extra and suffix != ".csv":
        raise ValueError(f"{path}: {suffix} files hold points only; "
                         f"use .npz or .csv to also store {', '.join(extra)}")
    columns = [pts]
    names = ["x", "y", "z"][:pts.shape[1]]
    for key, value in extra.items():
        col = np.asarray(value, dtype=np.float64)
        if col.shape != (pts.shape[0],):
            raise ValueError(f"{path}: extra column {key!r} must have shape "
                             f"({pts.shape[0]},), got {col.shape}")
        columns.append(col[:, None])
        names.append(str(key))
    if suffix == ".npy":
        with atomic_write(path, "wb") as fh:
            np.save(fh, pts)
        return
    table = np.hstack(columns)
    buf = _stdio.StringIO()
    if suffix == ".csv":
        np.savetxt(buf, table, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
    else:
        np.savetxt(buf, table, fmt="%.17g", delimiter=" ")
    with atomic_write(path, "wb") as fh:
        fh.write(buf.getvalue().encode("utf-8"))


def json_default(obj):
    """``json.dumps(..., default=json_default)``: numpy scalars and arrays as numbers and lists.

    Examples
    --------
    >>> import json
    >>> json.dumps({"k": np.float32(0.5), "a": np.arange(2)}, default=json_default)
    '{"k": 0.5, "a": [0, 1]}'
    """
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)
