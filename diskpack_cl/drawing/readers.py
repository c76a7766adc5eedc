"""Validating readers of stippling files: ``.npz``, ``.csv`` and ``.svg``.

:func:`read_stipple` is the one door through which a stippling comes back
(``diskpack export``, ``diskpack analyze``, the Python API). It trusts
nothing in the file: it checks the structure and the types, that every
number is finite, that radii are > 0, that the picture has a size > 0 and
that every dot lies in it, that the rows hold what the header names, and it
runs the exact certificate (:func:`diskpack_cl.geometry.certify_disks`)
again on the packing disks of an ``.npz`` or ``.csv``: overlapping dots or
dots outside the picture are refused. An ``.svg`` holds the drawn dots, not
the packing, so only its centres are checked against the picture. Every
refusal is one ``ValueError`` line that names the file, the row or field,
and the rule.

Pen names are stored escaped (percent-encoding in a ``.csv``, XML escapes in
an ``.svg``), so every name that can be written reads back.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path
from types import SimpleNamespace
from urllib.parse import quote, unquote

import numpy as np
from scipy.spatial import cKDTree

from diskpack_cl.io import load_npz
from diskpack_cl.pens import check_paper, palette_of, parse_pens
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import Certificate, certify_disks

__all__ = ["CSV_TAG", "check_stippling", "csv_name", "read_stipple"]

#: The first line of a stippling CSV starts with this (then ``key=value`` fields).
CSV_TAG = "# diskpack_cl stippling "

# the largest picture side accepted (pixels): beyond it no image was stippled
_MAX_SIDE = 2**31


class _Refused(ValueError):
    """A rule the file breaks: the message names the row or field and the rule."""


class _Overlap(_Refused):
    """Two disks overlap: not a packing."""


def csv_name(name):
    """A pen name as a stippling ``.csv`` stores it: percent-encoded (no ``,;:=`` or space).

    Examples
    --------
    >>> csv_name("c<d> & e")
    'c%3Cd%3E%20%26%20e'
    """
    return quote(str(name), safe="")


def read_stipple(path):
    """Read a stippling written by :func:`diskpack_cl.write_stipple`: ``.npz``, ``.csv`` or ``.svg``.

    A result read back writes again identically: :func:`write_stipple` with
    the same format and options gives the same file (the same arrays for
    ``.npz``, whose zip entries carry a time stamp). What each format holds:

    - ``.npz``: everything (the certificate's scalar fields as a namespace);
    - ``.csv``: ``points``, ``radii``, ``width``, ``height``, ``k``,
      ``tone_radius`` and ``params["invert"]`` (from the first line; a CSV
      without it gets the smallest size holding its dots); a UTF-8
      byte-order mark is read past;
    - ``.svg``: the drawing in pen-path order: ``points`` (from the mm
      coordinates, 4 decimals), ``radii`` the drawn dot radii (a pen touch:
      half the pen, unless all dots have one size), ``tone_radius`` (the
      result's, else the dots' one size); the layout comes from its
      ``<metadata>``.

    What is read is checked (see the module docstring): the packing of an
    ``.npz`` or ``.csv`` is certified again.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    types.SimpleNamespace or None
        ``points`` ((n, 2) float64, pixels), ``radii`` ((n,) float64),
        ``width`` and ``height`` (int pixels), ``k`` (float, nan when not
        stored), ``tone_radius``, ``base_radii`` and ``certificate`` (or
        None) and ``params`` (a dict, empty when not stored). None for a
        ``.npz`` point set without ``radii``, ``width`` or ``height`` (as
        :func:`diskpack_cl.io.write_points` writes it).

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ValueError
        Another extension (a ``.png`` preview holds no dots), or a file that
        is not a valid stippling of its format: one line naming the file,
        the row or field and the rule.

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl import write_stipple
    >>> res = SimpleNamespace(points=np.array([[2.0, 3.0]]), radii=np.array([1.0]),
    ...                       width=8, height=6)
    >>> out = os.path.join(tempfile.mkdtemp(), "s.csv")
    >>> write_stipple(out, res)
    {'n': 1}
    >>> back = read_stipple(out)
    >>> back.points.tolist(), back.width, back.height
    ([[2.0, 3.0]], 8, 6)
    >>> _ = Path(out).write_text("x,y,r\\n2,3,-1\\n")
    >>> read_stipple(out)
    Traceback (most recent call last):
    ...
    ValueError: .../s.csv: row 0: the radius must be > 0, got -1
    """
    ext = Path(os.fspath(path)).suffix.lower()
    readers = {".npz": _read_npz, ".csv": _read_csv, ".svg": _read_svg}
    if ext not in readers:
        raise ValueError(f"{path}: read_stipple reads {', '.join(readers)} files"
                         + ("; a .png preview holds no dots" if ext == ".png" else ""))
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file")
    try:
        # what overflows becomes inf (refused by the checks), without a warning
        with np.errstate(all="ignore"):
            res = readers[ext](path)
            return None if res is None else _checked(res, packing=ext != ".svg")
    except _Refused as exc:
        raise ValueError(_one_line(f"{path}: {exc}")) from None
    except (OSError, ValueError, KeyError, IndexError, EOFError, SyntaxError, TypeError,
            AttributeError, OverflowError, LookupError) as exc:   # LookupError: an XML encoding
        text = str(exc)
        if not text.startswith(str(path)):   # load_npz's own message names the file
            text = f"{path}: unreadable {ext} file ({type(exc).__name__}: {text})"
        raise ValueError(_one_line(text)) from None


def check_stippling(result, path, *, packing):
    """Refuse to write what :func:`read_stipple` would refuse to read: the writers' check.

    The rules of the module docstring, on a result about to be written to
    `path`; with `packing` (a format that holds the packing: ``.npz``,
    ``.csv``) the disks are certified too, unless the result carries its own
    valid :class:`~diskpack_cl.geometry.Certificate` (what
    :func:`~diskpack_cl.stipple` returns: certified as it was made).

    Raises
    ------
    ValueError
        One line: `path`, that it is not written, the row or field and the rule.

    Examples
    --------
    >>> res = SimpleNamespace(points=np.array([[2.0, 3.0]]), radii=np.array([-1.0]),
    ...                       width=8, height=6)
    >>> check_stippling(res, "s.svg", packing=False)
    Traceback (most recent call last):
    ...
    ValueError: s.svg: not written (read_stipple would refuse it): row 0: the radius must be > 0, got -1
    """
    cert = getattr(result, "certificate", None)
    trusted = isinstance(cert, Certificate) and cert.valid
    pens = {} if getattr(result, "pen", None) is None else {
        "pen": np.asarray(result.pen), "names": tuple(result.names), "colors": result.colors,
        "pen_radius": getattr(result, "pen_radius", None)}
    tone, base = getattr(result, "tone_radius", None), getattr(result, "base_radii", None)
    try:
        with np.errstate(all="ignore"):
            _checked(_stippling(result.points, result.radii, result.width, result.height,
                                k=float(getattr(result, "k", math.nan)),
                                tone_radius=None if tone is None else float(tone),
                                base_radii=None if base is None else np.asarray(base),
                                params=getattr(result, "params", None) or {}, **pens),
                     packing=packing and not trusted)
    except _Refused as exc:
        hint = ("; these are not packing disks (an .svg holds the dots as drawn, which may "
                "overlap): write the .npz or .csv from the stippling's own .npz or .csv"
                if isinstance(exc, _Overlap) else "")
        raise ValueError(_one_line(f"{path}: not written (read_stipple would refuse it): "
                                   f"{exc}{hint}")) from None


def _one_line(text):
    return " ".join(str(text).split())


def _stippling(points, radii, width, height, **extra):
    """The namespace :func:`read_stipple` returns (checked by :func:`_checked`)."""
    fields = dict(k=float("nan"), tone_radius=None, base_radii=None, certificate=None, params={})
    # None keeps a default; a field without one (a colour stippling's pen_radius) stays None,
    # so that every colour stippling has the same attributes whatever file it came from
    fields.update({key: v for key, v in extra.items() if v is not None or key not in fields})
    return SimpleNamespace(points=_numbers(points, "points"), radii=_numbers(radii, "radii"),
                           width=_side(width, "width"), height=_side(height, "height"), **fields)


def _numbers(value, field):
    """`value` as a float64 array, refused unless it holds numbers."""
    a = np.asarray(value)
    if a.dtype.kind not in "biuf":
        raise _Refused(f"{field} must be numbers, got {a.dtype}")
    return a.astype(np.float64)


def _side(value, field):
    """A picture side in pixels: a whole number in [1, 2**31)."""
    a = _numbers(value, field)
    if a.size != 1:
        raise _Refused(f"{field} must be one number, got shape {a.shape}")
    v = float(a.reshape(()))
    if not (1 <= v < _MAX_SIDE and v == math.floor(v)):
        raise _Refused(f"{field} must be a whole number of pixels in [1, {_MAX_SIDE}), got {v:g}")
    return int(v)


def _checked(res, *, packing):
    """`res` if it is a valid stippling, else :class:`_Refused` naming the first fault."""
    p, r = res.points, res.radii
    if p.ndim != 2 or p.shape[1] != 2:
        raise _Refused(f"points must have shape (n, 2), got {p.shape}")
    if r.shape != (len(p),):
        raise _Refused(f"radii must have shape ({len(p)},) like the points, got {r.shape}")
    _first(~np.isfinite(p).all(axis=1), "the coordinates must be finite", p)
    _first(~np.isfinite(r), "the radius must be finite", r)
    _first(~(r > 0), "the radius must be > 0", r)
    size = np.array([res.width, res.height], np.float64)
    _first(((p < 0) | (p > size)).any(axis=1),
           f"the centre lies outside the {res.width}x{res.height} px picture", p)
    for field in ("tone_radius", "k"):
        v = getattr(res, field)
        if not (v is None or _is_number(v) and v > 0 or field == "k" and v != v):
            raise _Refused(f"{field} must be a finite number > 0, got {v!r}")
    if res.base_radii is not None and np.shape(res.base_radii) != r.shape:
        raise _Refused(f"base_radii must have shape {r.shape}, got {np.shape(res.base_radii)}")
    if getattr(res, "pen", None) is not None:
        _check_pens(res)
    if packing:
        _certify(p, r, res.width, res.height)
    return res


def _first(bad, rule, values):
    """Refuse the first row where `bad` holds, naming it, its value and `rule`."""
    if np.any(bad):
        i = int(np.argmax(bad))
        shown = ", ".join(f"{v:g}" for v in np.atleast_1d(values[i]))
        raise _Refused(f"row {i}: {rule}, got {shown}")


def _check_pens(res):
    """A colour stippling's pens: one index per dot in range, a colour per name."""
    m = len(res.names)
    if len(set(res.names)) != m:
        raise _Refused(f"pen names must differ, got {', '.join(res.names)}")
    colors = np.asarray(res.colors)
    if colors.shape != (m, 3):
        raise _Refused(f"pen_colors must be {m} sRGB colours, got shape {colors.shape}")
    _first(~((colors >= 0) & (colors <= 1)).all(axis=1), "pen colour must be in [0, 1]", colors)
    pen = np.asarray(res.pen)
    if pen.shape != res.radii.shape:
        raise _Refused(f"pen must hold one index a dot ({len(res.radii)}), got {pen.shape}")
    _first((pen < 0) | (pen >= m), f"pen index must be in [0, {m})", res.radii)
    pen_radius = getattr(res, "pen_radius", None)
    if pen_radius is not None:
        pr = np.asarray(pen_radius)
        if pr.shape != (m,) or not np.all(np.isfinite(pr) & (pr > 0)):
            raise _Refused(f"pen_radius must be {m} finite numbers > 0, got "
                           f"{', '.join(f'{v:g}' for v in np.ravel(pr)[:8])}")
    if res.params.get("invert"):
        try:   # a named palette's pens were separated for white paper, not for black
            check_paper(palette_of(res.names, colors), True)
        except ValueError as exc:
            raise _Refused(f"made for black paper (invert) with pens {', '.join(res.names)}, "
                           f"but {exc}") from None


def _certify(p, r, width, height):
    """The exact certificate again: every disk inside the picture, no two overlapping."""
    cert = certify_disks(p, r, Domain.rect(width, height))
    if not cert.inside:
        edge = np.minimum.reduce([p[:, 0], width - p[:, 0], p[:, 1], height - p[:, 1]]) - r
        _first(edge < 0, f"the dot sticks out of the {width}x{height} px picture "
                         f"(certificate: inside)", p)
    if not cert.disjoint:
        i, j, gap = _overlap(p, r)
        raise _Overlap(f"rows {i} and {j}: the dots overlap by {-gap:.6g} px (certificate: "
                       f"disjoint)")


def _overlap(p, r):
    """``(i, j, gap)`` of the pair of dots with the smallest gap (< 0: they overlap)."""
    pairs = cKDTree(p).query_pairs(2 * float(r.max()), output_type="ndarray")
    gaps = np.hypot(*(p[pairs[:, 0]] - p[pairs[:, 1]]).T) - r[pairs[:, 0]] - r[pairs[:, 1]]
    k = int(np.argmin(gaps))
    return int(pairs[k, 0]), int(pairs[k, 1]), float(gaps[k])


# ------------------------------------------------------------------------------ .npz

def _read_npz(path):
    z = load_npz(path)
    if not {"points", "radii", "width", "height"} <= set(z):
        return None
    params = {}
    if "params" in z:
        try:
            params = json.loads(str(z["params"]))
        except ValueError:
            params = {}
    params = params if isinstance(params, dict) else {}
    cert = {k[len("certificate_"):]: _scalar(z[k], k) for k in z if k.startswith("certificate_")}
    opt = {k: (_numbers(z[k], k) if k == "base_radii" else _scalar(z[k], k))
           for k in ("k", "tone_radius", "base_radii") if k in z}
    return _stippling(z["points"], z["radii"], z["width"], z["height"], params=params,
                      certificate=SimpleNamespace(**cert) if cert else None, **opt,
                      **_read_pens(z))


def _scalar(a, field):
    """One number of an archive, as a Python float."""
    a = _numbers(a, field)
    if a.size != 1:
        raise _Refused(f"{field} must be one number, got shape {a.shape}")
    return float(a.reshape(()))


def _read_pens(z):
    """A colour stippling's ``pen``, ``names``, ``colors``, ``pen_radius`` from an archive."""
    if "pen" not in z:
        return {}
    pen = np.asarray(z["pen"])
    if pen.dtype.kind not in "iu":
        raise _Refused(f"pen must hold integer indices, got {pen.dtype}")
    missing = [key for key in ("pen_names", "pen_colors") if key not in z]
    if missing:
        raise _Refused(f"pen is given without {' and '.join(missing)}")
    names = np.asarray(z["pen_names"])
    if names.dtype.kind != "U" or names.ndim != 1:
        raise _Refused("pen_names must be a list of names")
    return {"pen": pen.astype(np.int64), "names": tuple(str(v) for v in names),
            "colors": _numbers(z["pen_colors"], "pen_colors"),
            "pen_radius": _numbers(z["pen_radius"], "pen_radius") if "pen_radius" in z else None}


# ------------------------------------------------------------------------------ .csv

def _read_csv(path):
    lines = Path(path).read_text(encoding="utf-8-sig").splitlines()
    meta = _csv_tag(lines.pop(0)[len(CSV_TAG):]) if lines and lines[0].startswith(CSV_TAG) else {}
    if meta.get("invert", 0) not in (0, 1):
        raise _Refused(f"first line: invert must be 0 or 1, got {meta['invert']:g}")
    # the paper it was made for, when it says (a colour stippling always does)
    meta["params"] = {"invert": meta.pop("invert") == 1} if "invert" in meta else {}
    pens = meta.pop("pens", None)
    if pens is not None:
        return _read_pen_csv(lines, pens, meta)
    if not lines or lines[0].replace(" ", "").lower() != "x,y,r":
        raise _Refused("the header line must be x,y,r")
    data = _csv_table(lines[1:], 3, "x,y,r")
    _first(~np.isfinite(data).all(axis=1), "values must be finite", data)
    # a CSV without the first line: the smallest picture that holds its dots
    ext = np.ceil(np.max(data[:, :2] + data[:, 2:], axis=0, initial=1))
    width, height = (meta.get(side, v) for side, v in zip(("width", "height"), ext))
    return _stippling(data[:, :2], data[:, 2], width, height, k=meta.get("k"),
                      tone_radius=meta.get("tone_radius"), params=meta["params"])


def _csv_tag(tag):
    """The ``key=value`` fields of the first line: numbers, and ``pens`` as text."""
    meta = {}
    for field in tag.split():
        key, sep, value = field.partition("=")
        if not sep:
            raise _Refused(f"first line: field {field[:40]!r} is not key=value")
        if key in ("pens", "pen_radius"):   # lists, read with the pens
            meta[key] = value
            continue
        try:
            meta[key] = float(value)
        except ValueError:
            raise _Refused(f"first line: {key} must be a number, got {value[:40]!r}") from None
    return meta


def _csv_table(rows, columns, header):
    """The data rows as an (n, columns) float array; a row of another length is refused."""
    rows = [row for row in rows if row.strip() and not row.lstrip().startswith("#")]
    if not rows:
        return np.zeros((0, columns))
    try:
        data = np.loadtxt(rows, delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise _Refused(f"the rows under the header {header} are not {columns} numbers each: "
                       f"{str(exc).split('; use `usecols`')[0]}") from None
    if data.shape[1] != columns:
        raise _Refused(f"the header {header} names {columns} columns, the rows have "
                       f"{data.shape[1]} values")
    return data


def _read_pen_csv(lines, pens, meta):
    """A colour stippling's CSV: dots, pens (percent-encoded names), their colours."""
    coded, colors = parse_pens(pens.replace(":", "=").replace(";", ","))
    names = tuple(unquote(name) for name in coded)
    if not lines or lines[0].replace(" ", "").lower() != "x,y,r,pen":
        raise _Refused("the header line of a colour stippling must be x,y,r,pen")
    rows = [line.rsplit(",", 1) for line in lines[1:] if line.strip()]
    bad = [k for k, row in enumerate(rows) if len(row) != 2]
    if bad:
        raise _Refused(f"row {bad[0]}: a colour stippling's row must be x,y,r,pen")
    index = {name: i for i, name in enumerate(names)}
    data = _csv_table([row[0] for row in rows], 3, "x,y,r,pen")
    pen = np.array([index.get(unquote(row[1].strip()), -1) for row in rows], np.int64)
    if np.any(pen < 0):
        i = int(np.argmax(pen < 0))
        raise _Refused(f"row {i}: the pen must be one of the first line's pens "
                       f"({', '.join(coded)}), got {rows[i][1].strip()[:40]!r}")
    if "width" not in meta or "height" not in meta:
        raise _Refused("the first line must give width= and height=")
    return _stippling(data[:, :2], data[:, 2], meta["width"], meta["height"], k=meta.get("k"),
                      tone_radius=meta.get("tone_radius"), params=meta["params"], pen=pen, names=names,
                      colors=colors, pen_radius=_pen_radius_field(meta.get("pen_radius")))


def _pen_radius_field(text):
    """The first line's ``pen_radius=R;...`` (each pen's tone radius), None when absent."""
    if text is None:
        return None
    try:
        return np.array([float(v) for v in text.split(";")])
    except ValueError:
        raise _Refused(f"first line: pen_radius must be numbers separated by ';', got "
                       f"{text[:40]!r}") from None


# ------------------------------------------------------------------------------ .svg

_SVG_NS = "{http://www.w3.org/2000/svg}"
_NUMBER = re.compile(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")
_HEX = re.compile(r"#[0-9a-fA-F]{6}")


def _read_svg(path):
    import xml.etree.ElementTree as ET  # not loaded at start-up

    root = ET.parse(path).getroot()
    meta = _svg_metadata(root)
    layers = {g.get("{http://www.inkscape.org/namespaces/inkscape}label"): g
              for g in root.iter(f"{_SVG_NS}g")}
    names = meta.get("pens", [meta["layer"]])   # a colour stippling: one layer per pen
    missing = [name for name in names if name not in layers]
    if missing:
        raise _Refused(f"no layer {missing[0]!r} of dots")
    pen = meta["pen_mm"] or 0.0
    centres, radii, pens = [], [], []
    for i, name in enumerate(names):
        got = _svg_layer_dots(name, layers[name], pen, centres, radii)
        pens += [i] * got
    s = meta["mm_per_px"]
    points = (np.array(centres).reshape(-1, 2) - meta["offset_mm"]) / s
    radii = np.full(len(radii), 0.5 * meta["dot_mm"]) if meta["dot_mm"] else np.array(radii)
    tone = meta["tone_radius"] or (0.5 * meta["dot_mm"] / s if meta["dot_mm"] else None)
    extra = {} if "pens" not in meta else {
        "pen": np.array(pens, np.int64), "names": tuple(names),
        "colors": np.array([_stroke(n, layers[n]) for n in names]).reshape(-1, 3)}
    return _stippling(points, radii / s, meta["width"], meta["height"], k=meta["k"],
                      tone_radius=tone, params={"invert": meta["invert"]}, **extra)


#: The ``<metadata>`` fields and their rules: (test, what it must be).
_META = {
    "width": (lambda v: _is_number(v) and v > 0, "a number > 0"),
    "height": (lambda v: _is_number(v) and v > 0, "a number > 0"),
    "mm_per_px": (lambda v: _is_number(v) and 0 < v < math.inf, "a number > 0"),
    "offset_mm": (lambda v: isinstance(v, list) and len(v) == 2 and all(map(_is_number, v)),
                  "two numbers"),
    "pen_mm": (lambda v: v is None or _is_number(v) and 0 < v < math.inf, "null or a number > 0"),
    "dot_mm": (lambda v: v is None or _is_number(v) and 0 < v < math.inf, "null or a number > 0"),
    "tone_radius": (lambda v: v is None or _is_number(v) and 0 < v < math.inf,
                    "null or a number > 0"),
    "k": (lambda v: v is None or _is_number(v), "null or a number"),
    "invert": (lambda v: isinstance(v, bool), "true or false"),
    "layer": (lambda v: isinstance(v, str), "a name"),
}


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _svg_metadata(root):
    """The ``<metadata id="diskpack_cl">`` JSON object, every field checked."""
    el = root.find(f"{_SVG_NS}metadata[@id='diskpack_cl']")
    if el is None:
        raise _Refused("not written by diskpack_cl (no <metadata id=\"diskpack_cl\">)")
    try:
        meta = json.loads(el.text or "")
    except ValueError as exc:
        raise _Refused(f"<metadata>: not JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise _Refused(f"<metadata>: must be a JSON object, got a {type(meta).__name__}")
    for key, (test, want) in _META.items():
        if key not in meta:
            raise _Refused(f"<metadata>: no field {key!r}")
        if not test(meta[key]):
            raise _Refused(f"<metadata>: {key} must be {want}, got {json.dumps(meta[key])[:40]}")
    pens = meta.get("pens", [])
    if not (isinstance(pens, list) and all(isinstance(v, str) for v in pens)):
        raise _Refused("<metadata>: pens must be a list of names")
    return meta


def _svg_layer_dots(name, layer, pen, centres, radii):
    """Append the centres and radii (mm) of one layer's dots; return how many."""
    before = len(centres)
    for k, el in enumerate(layer):
        try:
            if el.tag == f"{_SVG_NS}circle":
                centres.append((float(el.get("cx")), float(el.get("cy"))))
                radii.append(float(el.get("r")) + 0.5 * pen)
            elif el.tag == f"{_SVG_NS}path":
                x, y, third = (float(v) for v in _NUMBER.findall(el.get("d"))[:3])
                touch = " h " in el.get("d")
                centres.append((x + 0.5 * third if touch else x - third, y))
                radii.append(0.5 * pen if touch else third + 0.5 * pen)
        except (TypeError, ValueError):
            raise _Refused(f"layer {name!r}, element {k}: a <{el.tag.split('}')[-1]}> dot "
                           f"needs numeric cx, cy and r (a <path>: d)") from None
    return len(centres) - before


def _stroke(name, layer):
    """A pen layer's colour (its ``stroke``, ``#rrggbb``) as sRGB in [0, 1]."""
    stroke = layer.get("stroke") or ""
    if not _HEX.fullmatch(stroke):
        raise _Refused(f"layer {name!r}: stroke must be #rrggbb, got {stroke[:20]!r}")
    return [int(stroke[k:k + 2], 16) / 255 for k in (1, 3, 5)]
