"""Batch jobs: folders of images and many point sets, resumable, in parallel, on Dask.

A batch is a list of :class:`Item` (one input image, point file or seed, its
parameters and its output paths, rendered from templates). :func:`run_batch`
runs the items in this process, in ``jobs`` spawned worker processes, or on a
``dask.distributed`` cluster, and yields one record (a JSON-ready dict) per
item as it finishes. Each item writes its outputs atomically; then the
coordinating process appends one line to the manifest (``manifest.jsonl``).
A rerun skips the items whose manifest line matches and whose outputs exist.

:func:`stipple_many`, :func:`poisson_many` and :func:`relax_many` plan and run
the three kinds of batch. This module uses only the public API of the
package, so it follows the engine as it changes.

Examples
--------
>>> import tempfile, os
>>> folder = tempfile.mkdtemp()
>>> records = list(poisson_many(3, 64, outputs=[os.path.join(folder, "{i:02d}.npz")],
...                             seed=7, backend="exact"))
>>> [r["status"] for r in records], sorted(os.listdir(folder))
(['ok', 'ok', 'ok'], ['00.npz', '01.npz', '02.npz', 'manifest.jsonl'])
>>> [r["status"] for r in poisson_many(3, 64, outputs=[os.path.join(folder, "{i:02d}.npz")],
...                                    seed=7, backend="exact")]
['skipped', 'skipped', 'skipped']
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import string
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

__all__ = [
    "TEMPLATE_FIELDS", "IMAGE_SUFFIXES", "POCL_THREAD_VARS", "DASK_HINT",
    "Batch", "Item", "Manifest", "expand_inputs", "render_template", "check_outputs",
    "derive_seeds", "default_manifest", "json_default", "default_jobs", "dots_for_image",
    "write_stipple_outputs", "stipple_item", "relax_item", "poisson_start", "run_item",
    "run_batch",
    "plan_stipple", "plan_poisson", "plan_relax",
    "stipple_many", "poisson_many", "relax_many",
]

TEMPLATE_FIELDS = ("stem", "name", "parent", "n", "seed", "i")
"""Fields of an output template: ``{stem}`` (input file name without its
extension), ``{name}`` (with it), ``{parent}`` (the input's folder name),
``{n}`` (points or dots), ``{seed}`` and ``{i}`` (the item's index, from 0).
Format specs work as in :meth:`str.format`: ``{i:04d}``."""

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".gif")
"""Extensions that a folder given as input contributes (case-insensitive)."""

POCL_THREAD_VARS = ("POCL_MAX_PTHREAD_COUNT", "POCL_CPU_MAX_CU_NUM")
"""PoCL's CPU thread count: ``POCL_MAX_PTHREAD_COUNT`` up to PoCL 3 (the
pip build: its device then reports that many compute units),
``POCL_CPU_MAX_CU_NUM`` in later releases. Both are set for each worker."""

DASK_HINT = 'the Dask path needs the dask extra: pip install "diskpack_cl[dask]"'

MANIFEST_NAME = "manifest.jsonl"


# ------------------------------------------------------------------- items

@dataclass(frozen=True)
class Item:
    """One unit of a batch.

    Attributes
    ----------
    kind : {"stipple", "poisson", "relax"}
    i : int
        Index in the batch (the ``{i}`` of the templates).
    input : str or None
        Input file (an image, or a point file for ``relax``); None for ``poisson``.
    seed : int or None
        Seed of the item (``stipple``: the error-diffusion jitter; ``poisson``:
        the start set, so ``diskpack poisson --seed SEED`` recreates it alone).
    params : dict
        Parameters of the computation (JSON values).
    write : dict
        Options of the writers (stipple: SVG/PNG options).
    outputs : tuple of str
        Output paths.
    error : str or None
        Set when planning already failed (the item is recorded as failed
        without running).

    Examples
    --------
    >>> import os, tempfile
    >>> item = plan_poisson(3, 64, [os.path.join(tempfile.mkdtemp(), "{i:02d}.npz")], seed=1)[2]
    >>> item.kind, item.i, item.input, os.path.basename(item.outputs[0])
    ('poisson', 2, None, '02.npz')
    """

    kind: str
    i: int
    input: str | None
    seed: int | None
    params: dict
    outputs: tuple
    write: dict = field(default_factory=dict)
    error: str | None = None

    def identity(self):
        """The fields a manifest line must match for the item to be skipped.

        The input's size and modification time stand for its content. The
        index ``i`` is not among them (a file added to a folder shifts the
        indices of the others); a template with ``{i}`` puts it in the outputs.

        Examples
        --------
        >>> Item("poisson", 0, None, 7, {"n": 64}, ("a.npz",)).identity()["outputs"]
        ['a.npz']
        """
        ident = {"kind": self.kind, "input": self.input, "seed": self.seed,
                 "params": self.params, "write": self.write, "outputs": list(self.outputs)}
        if self.input is not None:
            try:
                st = os.stat(self.input)
                ident["input_size"], ident["input_mtime_ns"] = st.st_size, st.st_mtime_ns
            except OSError:
                ident["input_size"] = ident["input_mtime_ns"] = None
        return json.loads(json.dumps(ident))


def expand_inputs(inputs, *, recursive=False):
    """Input paths with every folder replaced by its images, sorted.

    Files are kept as given (a missing one fails as an item, not the batch).

    Raises
    ------
    ValueError
        A folder holds no image (with an extension of :data:`IMAGE_SUFFIXES`).

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp(); os.mkdir(os.path.join(d, "sub"))
    >>> for name in ("b.png", "a.JPG", "notes.txt", "sub/c.png"):
    ...     open(os.path.join(d, name), "w").close()
    >>> [os.path.relpath(p, d) for p in expand_inputs([d])]
    ['a.JPG', 'b.png']
    >>> [os.path.relpath(p, d) for p in expand_inputs([d], recursive=True)]
    ['a.JPG', 'b.png', 'sub/c.png']
    """
    paths = []
    for given in inputs:
        given = os.fspath(given)
        if not os.path.isdir(given):
            paths.append(given)
            continue
        found = Path(given).rglob("*") if recursive else Path(given).iterdir()
        images = sorted(str(p) for p in found
                        if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()
                        and not any(part.startswith(".") for part in p.relative_to(given).parts))
        if not images:
            raise ValueError(f"no images in folder {given} (extensions "
                             f"{', '.join(IMAGE_SUFFIXES)}"
                             + ("" if recursive else "; --recursive for subfolders") + ")")
        paths.extend(images)
    return paths


def render_template(template, *, input=None, n=None, seed=None, i=0):
    """Fill an output template with an item's fields (see :data:`TEMPLATE_FIELDS`).

    Raises
    ------
    ValueError
        An unknown field, or a field the item does not have (``{stem}``
        without an input file, ``{n}`` before the count is known).

    Examples
    --------
    >>> render_template("out/{parent}/{stem}_{n}.svg", input="photos/cat.jpg", n=20000)
    'out/photos/cat_20000.svg'
    >>> render_template("sets/{i:04d}.npz", i=7)
    'sets/0007.npz'
    """
    p = Path(input) if input is not None else None
    values = {"stem": p.stem if p else None, "name": p.name if p else None,
              "parent": (p.resolve().parent.name if p else None), "n": n, "seed": seed, "i": i}
    fields = {}
    for _, name, _, _ in string.Formatter().parse(template):
        if name is None:
            continue
        if name not in values:
            raise ValueError(f"unknown field {{{name}}} in output template {template!r}; "
                             f"use {', '.join('{' + f + '}' for f in TEMPLATE_FIELDS)}")
        if values[name] is None:
            what = "an input file" if name in ("stem", "name", "parent") else "a value here"
            raise ValueError(f"output template {template!r}: {{{name}}} needs {what}")
        fields[name] = values[name]
    try:
        return template.format(**fields)
    except (ValueError, IndexError) as exc:
        raise ValueError(f"output template {template!r}: {exc}") from None


def check_outputs(items, check_path, *, make_folders=True):
    """Refuse, before any work, outputs that two items (or one item twice) would write,
    and outputs that would replace an input of any item
    (:func:`diskpack_cl.io.check_not_inputs`).

    ``check_path(path)`` checks each path (extension, folder); with
    `make_folders` (a batch) missing folders of the rendered paths are
    created first, without (a single input) a missing folder is refused.

    Raises
    ------
    ValueError
        The message names both inputs and the shared output.
    diskpack_cl.io.OutputIsInputError
        An output is an input of the run (by path or by file).

    Examples
    --------
    >>> a = Item("stipple", 0, "x/cat.jpg", 0, {}, ("out/cat.svg",))
    >>> b = Item("stipple", 1, "y/cat.jpg", 0, {}, ("out/cat.svg",))
    >>> check_outputs([a, b], lambda p: None)
    Traceback (most recent call last):
    ...
    ValueError: the output templates map x/cat.jpg and y/cat.jpg to out/cat.svg; add {parent} or {i} to tell them apart
    """
    from diskpack_cl.io import check_not_inputs

    owner = {}
    for item in items:
        for out in item.outputs:
            key = os.path.normpath(os.path.abspath(out))
            if key in owner:
                other = owner[key]
                if other is item:
                    raise ValueError(f"output given twice: {out}")
                names = [str(x.input if x.input is not None else f"item {x.i}")
                         for x in (other, item)]
                raise ValueError(f"the output templates map {names[0]} and {names[1]} to "
                                 f"{out}; add {_telling_apart(other, item)} to tell them apart")
            owner[key] = item
    check_not_inputs([out for item in items for out in item.outputs],
                     [path for item in items for path in _item_inputs(item)])
    for item in items:
        for out in item.outputs:
            folder = os.path.dirname(out)
            if folder and make_folders:
                os.makedirs(folder, exist_ok=True)
            check_path(out)


def _item_inputs(item):
    """The files an item reads: its input and a start set's file (``init``)."""
    init = item.params.get("init")
    return [item.input] + ([init] if init not in (None, "dart", "random") else [])


def _telling_apart(a, b):
    """The template fields that differ between two items' inputs, e.g. ``{name} or {i}``.

    Examples
    --------
    >>> _telling_apart(Item("stipple", 0, "p/cat.jpg", 0, {}, ()),
    ...                Item("stipple", 1, "p/cat.png", 0, {}, ()))
    '{name} or {i}'
    """
    fields = []
    if a.input is not None and b.input is not None:
        pa, pb = Path(a.input), Path(b.input)
        if pa.name != pb.name:
            fields.append("{name}")
        if pa.resolve().parent.name != pb.resolve().parent.name:
            fields.append("{parent}")
    return " or ".join(fields + ["{i}"])


def default_manifest(templates):
    """``manifest.jsonl`` in the folder of the first output template.

    A folder part with template fields is cut at the first of them.

    Examples
    --------
    >>> default_manifest(["out/{parent}/{stem}.svg"])
    'out/manifest.jsonl'
    >>> default_manifest(["{stem}.png"])
    'manifest.jsonl'
    """
    parts = []
    for part in Path(os.path.dirname(templates[0])).parts:
        if "{" in part:
            break
        parts.append(part)
    return os.path.join(*parts, MANIFEST_NAME)


def derive_seeds(seed, count):
    """``count`` independent seeds from one, through ``numpy.random.SeedSequence.spawn``.

    Each is a plain integer: the item with seed ``s`` is recreated alone by
    the same command with ``--seed s`` (and no ``--count``).

    Examples
    --------
    >>> derive_seeds(7, 3) == derive_seeds(7, 3)
    True
    >>> len(set(derive_seeds(7, 100)))
    100
    """
    import numpy as np

    return [int(child.generate_state(1, dtype=np.uint32)[0] >> 1)
            for child in np.random.SeedSequence(seed).spawn(count)]


def default_jobs(devices=None):
    """Worker processes when ``jobs`` is not given: one per listed device, else one per core.

    On the 2-core development VM two workers (one PoCL thread each) stippled
    24.4 images a minute at n = 20000, one process with two threads 12.7
    (README, "Performance").

    Examples
    --------
    >>> default_jobs(["0:0", "0:1", "1:0"])
    3
    """
    if devices:
        return len(devices)
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else os.cpu_count() or 1)


def dots_for_image(width, height, *, n=None, density=None, dots_per_cm2=None, **layout):
    """The number of dots: ``n``, or ``density`` per megapixel, or per cm^2 of the print.

    ``dots_per_cm2`` needs the physical size: ``layout`` as for the SVG
    (:func:`diskpack_cl.export.svg_layout`), with ``width_mm``,
    ``height_mm``, ``dpi`` or ``page``.

    Examples
    --------
    >>> dots_for_image(1000, 500, density=20000)
    10000
    >>> dots_for_image(1000, 500, dots_per_cm2=100, width_mm=100)
    5000
    """
    if n is not None:
        return int(n)
    if density is not None:
        count = density * width * height / 1e6
    else:
        from diskpack_cl.export import svg_layout

        if all(layout.get(k) is None for k in ("width_mm", "height_mm", "dpi", "page")):
            raise ValueError("--dots-per-cm2 needs the print size: --width-mm, --height-mm, "
                             "--dpi or --page")
        cm = svg_layout(width, height, **layout)["scale"] / 10.0
        count = dots_per_cm2 * (width * cm) * (height * cm)
    return max(1, int(round(count)))


# ----------------------------------------------------------------- manifest

class Manifest:
    """An append-only JSON-lines record of finished items.

    Each line is written with one ``os.write`` on an ``O_APPEND`` descriptor
    and synced, so a killed run leaves only whole lines (a line torn by a
    power cut is ignored when read).

    Examples
    --------
    >>> import tempfile, os
    >>> m = Manifest(os.path.join(tempfile.mkdtemp(), "manifest.jsonl"))
    >>> m.append({"outputs": ["a.npz"], "status": "ok"})
    >>> m.records()
    [{'outputs': ['a.npz'], 'status': 'ok'}]
    """

    def __init__(self, path):
        self.path = os.fspath(path)

    def records(self):
        """Every whole line of the manifest, oldest first."""
        try:
            with open(self.path, "rb") as fh:
                lines = fh.read().split(b"\n")
        except FileNotFoundError:
            return []
        out = []
        for line in lines:
            with contextlib.suppress(ValueError):
                record = json.loads(line)
                if isinstance(record, dict):
                    out.append(record)
        return out

    def finished(self):
        """The latest record per output set: ``{tuple(outputs): record}``."""
        return {tuple(r.get("outputs") or ()): r for r in self.records()}

    def append(self, record):
        """Append one record as one line, atomically with respect to other lines."""
        data = (json.dumps(record, default=json_default) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)


def json_default(obj):
    """``json.dumps(..., default=json_default)``: numpy scalars and arrays as numbers and lists.

    Examples
    --------
    >>> import numpy as np
    >>> json.dumps({"k": np.float32(0.5), "a": np.arange(2)}, default=json_default)
    '{"k": 0.5, "a": [0, 1]}'
    """
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def _is_done(item, record):
    if record is None or record.get("status") != "ok":
        return False
    ident = item.identity()
    if any(record.get(k) != v for k, v in ident.items()):
        return False
    return all(os.path.exists(p) for p in item.outputs)


# ----------------------------------------------------------------- one item

def write_stipple_outputs(result, gray, outputs, options=None, *, progress=None, **overrides):
    """Write a stippling to every path of ``outputs``, as ``diskpack stipple`` does.

    With ``dots="tone"`` (and no ``dot_mm``) every dot gets one size, chosen
    so that the total ink equals the image's darkness; ``dots="packing"``
    draws the certified disks. The outputs replace their files together
    (:func:`diskpack_cl.io.atomic_writes`): if a write fails or the run is
    interrupted, every file that existed before is left as it was.

    Parameters
    ----------
    result : StippleResult
        Or a stippling :func:`diskpack_cl.read_stipple` read.
    gray : (H, W) array or None
        The gray image that was stippled (before ``invert``); None: the
        tone dot size is ``result.tone_radius``.
    outputs : list of str
        ``.svg``, ``.png``, ``.npz`` or ``.csv`` paths.
    options : WriteOptions, optional
        How the dots are drawn (:class:`diskpack_cl.export.WriteOptions`;
        ``pen_mm``: the PNG preview shows what the pen draws).
    progress : callable, optional
        ``progress(k)`` after each ``k`` dots a PNG preview stamped.
    **overrides
        Fields of :class:`~diskpack_cl.export.WriteOptions` replacing those of `options`.

    Returns
    -------
    dot_mm : float or None
        The drawn dot diameter (None: the packing radii).
    written : list of dict
        ``path``, ``format`` and the writer's info, per output.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> from diskpack_cl import stipple
    >>> gray = np.linspace(0, 1, 32 * 32).reshape(32, 32)
    >>> res = stipple(gray, 30, schedule=[("pack", 2)])
    >>> out = os.path.join(tempfile.mkdtemp(), "s.svg")
    >>> dot_mm, written = write_stipple_outputs(res, gray, [out])
    >>> written[0]["format"], round(dot_mm, 3) > 0
    ('svg', True)
    """
    from diskpack_cl.export import (WriteOptions, check_output_path, preview_scale, tone_dot_size,
                                    write_stipple)
    from diskpack_cl.io import atomic_writes

    o = (options or WriteOptions()).replace(**overrides)
    dots = o.dots or "tone"
    scale = o.scale(result.width, result.height)
    png_scale = preview_scale(result.width, result.height, o.png_scale)
    dot_mm = o.dot_mm
    color = getattr(result, "pen", None) is not None   # one tone dot size per pen
    if dot_mm is None and dots == "tone" and not color:
        dot_mm = tone_dot_size(result, scale, o.radius_scale, gray=gray, invert=o.invert)
    svg_opts = dict(dot_mm=dot_mm, radius_scale=o.radius_scale, pen_path=o.pen_path,
                    invert=o.invert, pen_mm=o.pen_mm, dots=dots,
                    plot_speed_mm_s=o.plot_speed_mm_s, **o.layout(),
                    **({"pen_order": o.pen_order} if color else {}))
    png_opts = dict(scale=png_scale, radius_scale=o.radius_scale, invert=o.invert, dots=dots,
                    progress=progress)
    if dot_mm is not None:  # preview the pen's dots
        png_opts["dot_px"] = 0.5 * dot_mm / scale * png_scale
    if o.pen_mm is not None:  # and what the pen draws: touches a pen wide, filled dots
        png_opts["pen_px"] = o.pen_mm / scale * png_scale
    written = []
    with atomic_writes():
        for out in outputs:
            ext = check_output_path(out)
            opts = svg_opts if ext == ".svg" else png_opts if ext == ".png" else {}
            info = write_stipple(out, result, **opts)
            written.append({"path": out, "format": ext[1:], **info})
    return dot_mm, written


def _item_image(path, params):
    """``(gray, image, run)`` of an item: the toned gray image and :func:`diskpack_cl.stipple`,
    or (with ``params["color"]``) the colour image and :func:`diskpack_cl.stipple_colors`;
    ``run(image, n, options, **keywords)``."""
    color = params.get("color")
    if color is None:
        from diskpack_cl import load_gray
        from diskpack_cl.image import ToneOptions
        from diskpack_cl.stipple import stipple

        gray = ToneOptions(**params.get("tone", {})).adjust(
            load_gray(path, allow_large=params.get("allow_large", False)))
        return gray, gray, stipple
    from diskpack_cl.color import load_rgb
    from diskpack_cl.multipen import stipple_colors
    from diskpack_cl.options import changed

    def run(image, n, options, **keywords):
        return stipple_colors(image, n, **color, **keywords, **changed(options))

    return None, load_rgb(path), run


def _item_dots(params, write, gray, width, height, note):
    """``(n, tone_n)`` of an item: its dot count, and with a dot or pen size (one pen) the
    count whose ink is the image's on paper (``-n tone``), a note when n is far from it."""
    n, tone_n = params.get("n"), None
    dot = write.dot_mm or write.pen_mm
    if gray is not None and dot is not None:
        from diskpack_cl.export import tone_dot_count

        tone = tone_dot_count(gray if write.invert else 1.0 - gray, write.scale(width, height), dot)
        if isinstance(n, int) and not 2 / 3 <= n / tone <= 3 / 2 and note is not None:
            note(f"{tone} dots of {dot:g} mm give the image's ink on this paper; -n {n} will "
                 f"look {'darker' if n > tone else 'lighter'} (-n tone uses {tone})")
        n, tone_n = (tone if n == "tone" else n), {"n": tone, "dot_mm": dot}
    elif n == "tone":
        raise ValueError("n='tone' needs the dot size: give dot_mm or pen_mm")
    n = dots_for_image(width, height, n=n, density=params.get("density"),
                       dots_per_cm2=params.get("dots_per_cm2"), **write.layout())
    return n, tone_n


def stipple_item(item, *, device=None, callback=None, verify=False, profile=False, note=None):
    """Stipple the image of one item: what a single input and every item of a batch run.

    Loads the image (tone controls applied, or the colour image with
    ``params["color"]``), counts its dots, checks that the machine and the
    device can hold the work (:func:`diskpack_cl.memory.check_stipple_memory`),
    and stipples. Writing the outputs is :func:`write_stipple_outputs`.

    Parameters
    ----------
    item : Item
        A ``stipple`` item (:func:`plan_stipple`).
    device : str, optional
        OpenCL device.
    callback : callable, optional
        ``callback(entry, total)`` after each iteration: the history entry and
        the number of iterations of the schedule.
    verify, profile : bool
        As for :func:`diskpack_cl.stipple` (one pen).
    note : callable, optional
        ``note(text)`` for advice that is no error (a dot count far from the
        one whose ink is the image's).

    Returns
    -------
    result : StippleResult or ColorStippleResult
        With ``params["tone"]`` (one pen): the tone controls applied.
    gray : (H, W) array or None
        The toned gray image (None for colour).
    summary : dict
        ``result.summary()`` with ``image`` and ``tone_n`` (the count whose
        ink is the image's with a dot size, else None).

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl import sample_image_path
    >>> item, = plan_stipple([sample_image_path()], [os.path.join(tempfile.mkdtemp(), "a.svg")],
    ...                      n=300, method="lloyd")
    >>> result, gray, summary = stipple_item(item)
    >>> result.n, result.certificate.valid, summary["image"].endswith("astronaut.png")
    (300, True, True)
    """
    from diskpack_cl.export import WriteOptions, preview_scale
    from diskpack_cl.memory import check_stipple_memory
    from diskpack_cl.schedule import StippleOptions

    params = item.params
    write = WriteOptions(**item.write)
    options = StippleOptions(**params.get("options", {}))
    gray, image, run = _item_image(item.input, params)
    H, W = image.shape[:2]
    n, tone_n = _item_dots(params, write, gray, W, H, note)
    # the ink without the paper tone: no more than the stippling's, so no smaller a raster
    ink = None if gray is None else float((gray if options.invert else 1.0 - gray).sum())
    check_stipple_memory(W, H, n, supersample=options.supersample, ink=ink,
                         png_scale=preview_scale(W, H, write.png_scale), device=device,
                         outputs=item.outputs)
    each = None
    if callback is not None:
        total = sum(ph[1] for ph in options.plan(n, W, H).phases)

        def each(entry):
            callback(entry, total)

    extra = {} if gray is None else {"verify": verify, "profile": profile}
    res = run(image, n, options, device=device, callback=each,
              backend=params.get("backend", "auto"), **extra)
    if gray is not None:   # recorded in the .npz and the --json params
        from diskpack_cl.image import ToneOptions

        res.params["tone"] = ToneOptions(**params.get("tone", {})).params()
    return res, gray, dict(res.summary(), image=item.input, tone_n=tone_n)


def _stipple_item(item, device, progress):
    """A batch's stipple item: :func:`stipple_item`, its outputs written; its summary."""
    callback = None
    if progress is not None:
        def callback(entry, total):
            progress(int(entry.get("iteration", 0)) + 1,
                     f"{entry.get('kind', '?')} k={entry.get('k', float('nan')):.4g}")
    res, gray, summary = stipple_item(item, device=device, callback=callback)
    t = time.perf_counter()
    dot_mm, written = write_stipple_outputs(res, gray, list(item.outputs), **item.write)
    summary.pop("params", None)
    summary.update(dot_mm=dot_mm, files=written, write_seconds=time.perf_counter() - t)
    return summary


def relax_item(item, points=None, *, device=None, callback=None, verify=False, profile=False):
    """Relax the points of one item and write its outputs: what a single input and every
    item of a batch run (``relax``, and ``poisson`` after :func:`poisson_start`).

    The relaxation is :func:`diskpack_cl.relax.relax_poisson` with the item's
    options, on the unit torus or in the item's ``box``. Each ``.npz``
    output also holds ``rho``, ``eps`` and (in a box) ``box``.

    Parameters
    ----------
    item : Item
        A ``relax`` item (:func:`plan_relax`) or a ``poisson`` item.
    points : (n, 2) array, optional
        The start set; None: read from the item's input (its ``columns``).
    device : str, optional
        OpenCL device.
    callback : callable, optional
        ``callback(iteration, rho)`` after each iteration.
    verify, profile : bool
        As for :func:`~diskpack_cl.relax.relax_poisson`.

    Returns
    -------
    RelaxResult

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> folder = tempfile.mkdtemp()
    >>> np.save(os.path.join(folder, "a.npy"), np.random.default_rng(0).random((64, 2)))
    >>> item, = plan_relax([os.path.join(folder, "a.npy")], [os.path.join(folder, "b.npz")],
    ...                    eps=0.7, box="1x1")
    >>> res = relax_item(item)
    >>> res.stop_reason, sorted(np.load(os.path.join(folder, "b.npz")))
    ('eps', ['box', 'eps', 'points', 'rho'])
    """
    from diskpack_cl.io import box_record, read_points, write_points
    from diskpack_cl.poisson import as_box
    from diskpack_cl.relax import relax_poisson

    p = item.params
    if points is None:
        points = read_points(item.input, min_points=2, columns=p.get("columns"))
    domain = as_box(p.get("box"))
    res = relax_poisson(points, eps=p["eps"], max_iter=p["max_iter"], backend=p["backend"],
                        grid=p["grid"], device=device, callback=callback, verify=verify,
                        profile=profile, domain=domain)
    for out in item.outputs:
        extra = {}
        if out.lower().endswith(".npz"):
            extra = {"rho": res.rho, "eps": p["eps"], **box_record(out, domain)}
        write_points(out, res.points, **extra)
    return res


def poisson_start(item, *, warn=None):
    """The start set of a ``poisson`` item: dart throwing or uniform random with the
    item's seed, or the points of a file (a single run's ``init``).

    Parameters
    ----------
    item : Item
        A ``poisson`` item (:func:`plan_poisson`).
    warn : callable, optional
        ``warn(text)`` for each warning of the dart throwing, as it comes.

    Returns
    -------
    points : (n, 2) array
    info : dict
        ``dart_rel_radius`` of a dart-throwing start, else empty.

    Raises
    ------
    ValueError
        Fewer than two points, or a file whose count is not the item's ``n``.

    Examples
    --------
    >>> import os, tempfile
    >>> item, = plan_poisson(1, 64, [os.path.join(tempfile.mkdtemp(), "a.npz")], seed=3)
    >>> points, info = poisson_start(item)
    >>> points.shape, sorted(info)
    ((64, 2), ['dart_rel_radius'])
    """
    from diskpack_cl.io import read_points
    from diskpack_cl.sampling import dart_throwing, random_points

    p = item.params
    info = {}
    if p["init"] == "dart":
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.showwarning = lambda message, *_a, **_k: (
                None if warn is None else warn(str(message)))
            points, dart = dart_throwing(p["n"], rel_radius=p["dart_radius"], seed=item.seed,
                                         full_output=True)
        info["dart_rel_radius"] = dart["rel_radius"]
    elif p["init"] == "random":
        points = random_points(p["n"], seed=item.seed)
    else:
        points = read_points(p["init"])
        if p["n"] is not None and p["n"] != len(points):
            raise ValueError(f"-n {p['n']} does not match the {len(points)} points "
                             f"of {p['init']}; leave -n out")
    if len(points) < 2:
        raise ValueError(f"need at least 2 points, got {len(points)}")
    return points, info


def _relax_summary(res):
    """A batch record's summary of a relaxation."""
    return {"n": int(len(res.points)), "iterations": int(res.iterations),
            "rho_start": float(res.rho[0]), "rho_final": float(res.rho[-1]),
            "stop_reason": res.stop_reason, "backend": res.backend, "device": res.device,
            "relax_seconds": float(res.seconds),
            "stage_seconds": {k: float(v) for k, v in res.timings.items()}}


def _rho_progress(progress):
    return None if progress is None else (lambda it, rho: progress(it, f"rho={rho:.4f}"))


def _poisson_item(item, device, progress):
    """A batch's poisson item: :func:`poisson_start`, then :func:`relax_item`; its summary."""
    caught = []
    points, info = poisson_start(item, warn=caught.append)
    if caught:
        info["warnings"] = caught
    res = relax_item(item, points, device=device, callback=_rho_progress(progress))
    return {**_relax_summary(res), **info}


def _relax_item(item, device, progress):
    """A batch's relax item: :func:`relax_item`; its summary."""
    return _relax_summary(relax_item(item, device=device, callback=_rho_progress(progress)))


_KINDS = {"stipple": _stipple_item, "poisson": _poisson_item, "relax": _relax_item}


def _peak_rss_mib():
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return None
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(rss / (1 << 20 if sys.platform == "darwin" else 1 << 10), 1)


def run_item(item, *, device=None, collect=False, progress=None):
    """Run one item and return its record; a failure is recorded, not raised.

    Parameters
    ----------
    item : Item
    device : str, optional
        OpenCL device (default: ``DISKPACK_DEVICE``, then the usual choice).
    collect : bool
        Write the outputs in a temporary folder and return their bytes under
        ``"data"`` (``{path: bytes}``) for the caller to write (Dask
        ``--collect``), instead of writing them in place.
    progress : callable, optional
        ``progress(iteration, text)`` after each iteration.

    Returns
    -------
    dict
        The item's identity plus ``status`` (``"ok"`` or ``"failed"``),
        ``error``, ``summary``, ``certificate``, ``seconds``, ``worker``
        (host and process id), ``peak_rss_mib`` of the process so far and
        ``worker_env`` (the PoCL thread cap and ``DISKPACK_DEVICE``, if set).

    Examples
    --------
    >>> rec = run_item(Item("relax", 0, "missing.npz", None, {}, ("out.npz",)))
    >>> rec["status"], rec["error"]
    ('failed', 'missing.npz: no such file')
    """
    import platform

    t0 = time.perf_counter()
    record = {"i": item.i, **item.identity(), "status": "failed", "error": item.error}
    if item.error is None:
        try:
            with tempfile.TemporaryDirectory(prefix="diskpack-collect-") if collect \
                    else contextlib.nullcontext() as tmp:
                run = item
                if collect:
                    run = replace(item, outputs=tuple(
                        os.path.join(tmp, f"{k}-{os.path.basename(p)}")
                        for k, p in enumerate(item.outputs)))
                summary = _KINDS[item.kind](run, device, progress)
                if collect:
                    record["data"] = {}
                    for out, tmp_out in zip(item.outputs, run.outputs):
                        with open(tmp_out, "rb") as fh:
                            record["data"][out] = fh.read()
                    for f in summary.get("files", ()):
                        f["path"] = item.outputs[run.outputs.index(f["path"])]
            record.update(status="ok", summary=summary,
                          certificate=summary.pop("certificate", None))
        except Exception as exc:  # recorded, the batch goes on
            record["error"] = _error_text(item, exc)
    record.update(seconds=time.perf_counter() - t0, finished=time.time(),
                  worker=f"{platform.node()}:{os.getpid()}", peak_rss_mib=_peak_rss_mib(),
                  worker_env={k: os.environ[k] for k in (*POCL_THREAD_VARS, "DISKPACK_DEVICE")
                              if k in os.environ})
    return record


def _error_text(item, exc):
    text = str(exc) or type(exc).__name__
    if not isinstance(exc, (ValueError, FileNotFoundError, OSError)):
        text = f"{type(exc).__name__}: {text}"
    if item.input is not None and item.input not in text:
        text = f"{item.input}: {text}"
    return text


# ---------------------------------------------------------------- executors

def _ignore_interrupts_and_exit_on_term():
    """Worker signals: Ctrl-C is the coordinator's; SIGTERM ends cleanly (no .part files)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_first_term)


def _exit_on_first_term(*_):
    """SystemExit(143), once: a second SIGTERM (the pool terminates its other workers
    when one exits) must not interrupt the removal of the partial files."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.exit(143)


def _init_worker(slots, devices, threads):
    slot = slots.get()
    if threads:
        for var in POCL_THREAD_VARS:
            os.environ.setdefault(var, str(threads))
    if devices:
        os.environ["DISKPACK_DEVICE"] = devices[slot % len(devices)]
    _ignore_interrupts_and_exit_on_term()


def _run_in_worker(item, collect):
    try:
        return run_item(item, collect=collect)
    except SystemExit:  # SIGTERM: the partial files are removed on the way here
        os._exit(143)


def _failed(item, error):
    return {"i": item.i, **item.identity(), "status": "failed", "error": error,
            "finished": time.time()}


def _local_pool(todo, jobs, devices, collect):
    """Yield records from ``jobs`` spawned worker processes (spawn: OpenCL does not survive fork)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")
    slots = ctx.Queue()
    for k in range(jobs):
        slots.put(k)
    threads = max(1, default_jobs() // jobs)
    pool = ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_init_worker,
                               initargs=(slots, devices, threads))
    try:
        futures = {pool.submit(_run_in_worker, item, collect): item for item in todo}
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except BrokenProcessPool as exc:
                yield _failed(futures[fut], f"worker process died: {exc}")
    finally:  # stop the workers first: shutdown() forgets them
        _stop_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def _stop_workers(pool):
    """Send SIGTERM to the pool's workers (they remove their partial files and exit)."""
    stop = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if stop is not None:
        stop()
        return
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(Exception):
            proc.terminate()


def _dask_client(client):
    try:
        import distributed
    except ImportError:
        raise ImportError(DASK_HINT) from None
    if isinstance(client, distributed.Client):
        return client, False
    return distributed.Client(client), True


def _dask(todo, client, device, collect):
    """Yield records from the items sent to a ``dask.distributed`` cluster."""
    from distributed import as_completed

    client, own = _dask_client(client)
    futures = {}
    try:
        for item in todo:
            fut = client.submit(run_item, item, device=device, collect=collect, pure=False,
                                key=f"diskpack-{item.kind}-{item.i}-{os.getpid()}-{time.time_ns()}")
            futures[fut] = item
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except Exception as exc:  # the worker died or the cluster lost the task
                yield _failed(futures[fut], f"Dask task failed: {type(exc).__name__}: {exc}")
    finally:
        client.cancel(list(futures))
        if own:
            client.close()


def _write_collected(record):
    """Write the bytes a worker returned (``collect``), atomically; the record updated."""
    from diskpack_cl.io import atomic_write, atomic_writes

    data = record.pop("data", None)
    if not data:
        return record
    try:
        with atomic_writes():
            for path, blob in data.items():
                with atomic_write(path, "wb") as fh:
                    fh.write(blob)
    except OSError as exc:
        record.update(status="failed", error=f"writing {path}: {exc}")
    return record


def run_batch(items, *, manifest=None, overwrite=False, jobs=1, devices=None, client=None,
              collect=False, progress=None):
    """Run items and yield one record per item, as each finishes.

    Items whose manifest line matches (same input size and time, parameters,
    seed and outputs, status ok) and whose outputs exist are yielded with
    status ``"skipped"`` and get no new line. Every other item runs and its
    record is appended to the manifest, by this process only.

    Parameters
    ----------
    items : list of Item
    manifest : str, optional
        Manifest path; None: no manifest (nothing is skipped).
    overwrite : bool
        Redo every item.
    jobs : int
        1: run in this process; more: that many spawned worker processes,
        each with its own OpenCL context, PoCL capped at ``cores // jobs``
        threads (:data:`POCL_THREAD_VARS`), and with ``devices`` one device
        per worker (through ``DISKPACK_DEVICE``).
    devices : list of str, optional
        OpenCL devices (``jobs == 1`` or Dask: the first is used).
    client : distributed.Client or str, optional
        Send the items to this Dask cluster (a client or a scheduler
        address) instead; ``jobs`` is then not used.
    collect : bool
        With Dask: workers return the outputs' bytes and this process writes
        them (for workers without the shared output folder).
    progress : callable, optional
        ``progress(item, iteration, text)`` during an item, in this process
        only (``jobs == 1`` without Dask).

    Yields
    ------
    dict
        The record (see :func:`run_item`); ``"skipped"`` ones hold the
        identity and the earlier record's ``summary``.

    Examples
    --------
    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> items = plan_poisson(2, 64, [os.path.join(out, "{i}.npz")], seed=1)
    >>> manifest = os.path.join(out, "manifest.jsonl")
    >>> [r["status"] for r in run_batch(items, manifest=manifest)]
    ['ok', 'ok']
    >>> [r["status"] for r in run_batch(items, manifest=manifest)]   # done already
    ['skipped', 'skipped']
    """
    man = Manifest(manifest) if manifest is not None else None
    folder = os.path.dirname(manifest or "")
    if folder and not os.path.isdir(folder):
        raise FileNotFoundError(f"the manifest's folder does not exist: {folder}")
    finished = {} if (man is None or overwrite) else man.finished()
    todo = []
    for item in items:
        old = finished.get(tuple(item.outputs))
        if _is_done(item, old):
            yield {**old, "status": "skipped"}
        else:
            todo.append(item)
    if client is not None:
        source = _dask(todo, client, devices[0] if devices else None, collect)
    elif jobs > 1 and len(todo) > 1:
        source = _local_pool(todo, min(jobs, len(todo)), devices, collect)
    else:
        source = (run_item(item, device=devices[0] if devices else None, collect=collect,
                           progress=None if progress is None
                           else (lambda it, text, item=item: progress(item, it, text)))
                  for item in todo)
    with contextlib.closing(source):
        for record in source:
            record = _write_collected(record)
            if man is not None:
                man.append(record)
            yield record


# -------------------------------------------------------------------- plans

def _paths_check(kind):
    if kind == "stipple":
        from diskpack_cl.export import check_output_path

        return check_output_path
    from diskpack_cl.io import check_points_path

    return lambda path: check_points_path(path, for_writing=True)


def _image_dots(path, count, write):
    """The dot count of an image for the ``{n}`` field: read from its header."""
    if count.get("n") is not None:
        return count["n"]
    from PIL import Image

    with Image.open(path) as im:
        width, height = im.size
    return dots_for_image(width, height, **count, **write.layout())


def plan_stipple(inputs, outputs, options=None, *, n=None, density=None, dots_per_cm2=None,
                 recursive=False, allow_large=False, write=None, tone=None, color=None,
                 backend="auto", make_folders=True, **overrides):
    """Items for stippling every image of ``inputs`` (files or folders).

    Parameters
    ----------
    inputs : list of str
        Image files and folders (their images, see :func:`expand_inputs`).
    outputs : list of str
        Output templates (:data:`TEMPLATE_FIELDS`).
    n, density, dots_per_cm2 : optional
        Exactly one: dots per image (or ``"tone"``: as many as give the
        image's ink with ``dot_mm`` or ``pen_mm`` in ``write``), per
        megapixel, or per cm^2 of the print (with ``width_mm``/``height_mm``/``dpi``
        in ``write``).
    options : StippleOptions, optional
        The options of :func:`diskpack_cl.stipple` for every image (its
        ``seed`` is the items' seed).
    write : WriteOptions, optional
        Options of :func:`write_stipple_outputs`.
    tone : ToneOptions, optional
        Tone controls applied to every image before stippling.
    **overrides
        Fields of :class:`~diskpack_cl.schedule.StippleOptions` (``gamma``,
        ``schedule``, ``seed``, ...) replacing those of `options`.
    backend : {"auto", "opencl", "exact"}
        The engine of every item (:func:`diskpack_cl.stipple`).
    color : ColorOptions or dict, optional
        Several pens: the separation of :func:`diskpack_cl.stipple_colors`
        (:class:`diskpack_cl.color.ColorOptions`, or a dict of ``colors``,
        ``black_generation``, ``clean_black``, ``clean_white``) makes every
        item a colour stippling.
    make_folders : bool
        Create the missing folders of the outputs (see :func:`check_outputs`).

    Raises
    ------
    ValueError
        No or several dot counts, a bad template, or two items sharing an output.

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl import sample_image_path
    >>> items = plan_stipple([sample_image_path()], [os.path.join(tempfile.mkdtemp(), "{stem}_{n}.svg")],
    ...                      density=400)
    >>> [(it.kind, os.path.basename(it.outputs[0])) for it in items]
    [('stipple', 'astronaut_105.svg')]
    """
    if sum(v is not None for v in (n, density, dots_per_cm2)) != 1:
        raise ValueError("give exactly one of n, density (dots per megapixel) and dots_per_cm2")
    from diskpack_cl.export import WriteOptions
    from diskpack_cl.image import ToneOptions
    from diskpack_cl.options import changed
    from diskpack_cl.schedule import StippleOptions

    options = (options or StippleOptions()).replace(**overrides)
    write = write or WriteOptions()
    seed = options.seed
    count = {"n": n, "density": density, "dots_per_cm2": dots_per_cm2}
    if dots_per_cm2 is not None:  # refused now, not once per image
        dots_for_image(1, 1, dots_per_cm2=dots_per_cm2, **write.layout())
    params = {**{k: v for k, v in count.items() if v is not None},
              "options": changed(options), "tone": changed(tone or ToneOptions())}
    if allow_large:
        params["allow_large"] = True
    if color is not None:
        params["color"] = color if isinstance(color, dict) else color.separation()
    if backend != "auto":
        params["backend"] = backend
    uses_n = any("{n" in t for t in outputs)
    items = []
    for i, path in enumerate(expand_inputs(inputs, recursive=recursive)):
        error = None
        dots = n
        if uses_n and n is None:
            try:
                dots = _image_dots(path, count, write)
            except Exception as exc:  # the item fails, the batch goes on
                error = f"{path}: cannot read the image size for {{n}}: {exc}"
        rendered = [render_template(t, input=path, n=dots if dots is not None else 0,
                                    seed=seed, i=i) for t in outputs]
        items.append(Item("stipple", i, path, seed, json.loads(json.dumps(params)),
                          tuple(rendered), changed(write), error))
    check_outputs(items, _paths_check("stipple"), make_folders=make_folders)
    return items


def _relax_params(relax, overrides):
    """The relaxation of every item: :class:`~diskpack_cl.relax.RelaxOptions` as JSON."""
    from diskpack_cl.relax import RelaxOptions

    return replace(relax or RelaxOptions(), **overrides).kwargs()


def plan_poisson(count, n, outputs, relax=None, *, seed=None, init="dart", dart_radius=0.74,
                 derive=True, box=None, make_folders=True, **overrides):
    """Items for ``count`` Poisson disk sets with seeds derived from ``seed``.

    Set ``i`` has seed ``derive_seeds(seed, count)[i]``; ``seed=None`` takes
    a fresh one. ``init`` is ``"dart"`` or ``"random"``. ``relax`` (a
    :class:`~diskpack_cl.relax.RelaxOptions`) with ``overrides`` (its
    fields: ``eps``, ``max_iter``, ...) relaxes every set. With
    ``derive=False`` (a single run: ``count`` 1) the set has ``seed``
    itself, ``init`` may also be a point file (``n`` None: its count), and
    ``box`` relaxes that file in a box. ``make_folders`` as for
    :func:`check_outputs`.

    Examples
    --------
    >>> import os, tempfile
    >>> items = plan_poisson(3, 64, [os.path.join(tempfile.mkdtemp(), "{i}.npz")], seed=7)
    >>> [it.seed for it in items] == derive_seeds(7, 3)
    True
    >>> plan_poisson(1, 64, [os.path.join(tempfile.mkdtemp(), "a.npz")], seed=7,
    ...              derive=False)[0].seed
    7
    """
    if derive and init not in ("dart", "random"):
        raise ValueError(f"init must be 'dart' or 'random' for many sets, got {init!r}")
    if not derive and count != 1:
        raise ValueError(f"derive=False makes one set, not {count}")
    if seed is None:
        import numpy as np

        seed = int(np.random.SeedSequence().entropy % 2**31)
    params = {"n": n, "init": init, **_relax_params(relax, overrides)}
    if init == "dart":
        params["dart_radius"] = dart_radius
    if box is not None:
        params["box"] = box
    seeds = derive_seeds(seed, count) if derive else [seed]
    items = [Item("poisson", i, None, s, {**params, "base_seed": seed},
                  tuple(render_template(t, n=n, seed=s, i=i) for t in outputs))
             for i, s in enumerate(seeds)]
    check_outputs(items, _paths_check("poisson"), make_folders=make_folders)
    return items


def plan_relax(inputs, outputs, relax=None, *, box=None, columns=None, make_folders=True,
               **overrides):
    """Items for relaxing every point file of ``inputs`` (see :func:`plan_poisson` for
    ``relax``, ``overrides`` and ``make_folders``), on the unit torus or in
    ``box`` (``"WxH"`` or ``(W, H)``), reading ``columns`` (two names or
    indices, see :func:`diskpack_cl.io.read_points`).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from diskpack_cl.io import write_points
    >>> folder = tempfile.mkdtemp()
    >>> write_points(os.path.join(folder, "a.npy"), np.random.default_rng(0).random((64, 2)))
    >>> items = plan_relax([os.path.join(folder, "a.npy")], [os.path.join(folder, "{stem}_relaxed.npz")])
    >>> [(it.kind, os.path.basename(it.outputs[0])) for it in items]
    [('relax', 'a_relaxed.npz')]
    """
    params = _relax_params(relax, overrides)
    if box is not None:
        params["box"] = box
    if columns is not None:
        params["columns"] = list(columns)
    items = [Item("relax", i, os.fspath(path), None, params,
                  tuple(render_template(t, input=path, i=i) for t in outputs))
             for i, path in enumerate(inputs)]
    check_outputs(items, _paths_check("relax"), make_folders=make_folders)
    return items


class Batch:
    """Planned items; iterating runs them and yields their records as they finish.

    Attributes
    ----------
    items : list of Item
    manifest : str or None
    progress : callable or None
        ``progress(item, iteration, text)``, see :func:`run_batch`.

    Examples
    --------
    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> batch = poisson_many(2, 64, [os.path.join(out, "{i}.npz")], seed=1)
    >>> len(batch.items), [r["status"] for r in batch]
    (2, ['ok', 'ok'])
    """

    def __init__(self, items, outputs, manifest, **run):
        self.items = items
        self.manifest = (default_manifest(list(outputs)) if manifest is None
                         else manifest or None)
        self.progress = run.pop("progress", None)
        self._run = run

    def __len__(self):
        return len(self.items)

    def __iter__(self):
        return run_batch(self.items, manifest=self.manifest, progress=self.progress,
                         **self._run)


def stipple_many(inputs, outputs, options=None, *, n=None, density=None, dots_per_cm2=None,
                 recursive=False, allow_large=False, write=None, tone=None, color=None,
                 backend="auto", manifest=None,
                 overwrite=False, jobs=1, devices=None, client=None, collect=False,
                 progress=None, **overrides):
    """Stipple many images: a :class:`Batch` that yields one record per image as it finishes.

    Plans with :func:`plan_stipple` now (every template and output is
    checked before any work) and runs with :func:`run_batch` when iterated.
    ``manifest`` defaults to ``manifest.jsonl`` in the folder of the first
    output template (``False``: none). ``jobs``, ``devices``, ``client``
    (a ``distributed.Client`` or a scheduler address), ``collect`` and
    ``progress`` are those of :func:`run_batch`.

    Examples
    --------
    >>> import tempfile, os
    >>> from diskpack_cl import sample_image_path
    >>> out = tempfile.mkdtemp()
    >>> recs = stipple_many([sample_image_path()], [os.path.join(out, "{stem}_{n}.npz")],
    ...                     density=400, schedule=[("pack", 1)])
    >>> [(r["status"], os.path.basename(r["outputs"][0])) for r in recs]
    [('ok', 'astronaut_105.npz')]
    """
    items = plan_stipple(inputs, outputs, options, n=n, density=density,
                         dots_per_cm2=dots_per_cm2, recursive=recursive,
                         allow_large=allow_large, write=write, tone=tone, color=color,
                         backend=backend, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)


def poisson_many(count, n, outputs, relax=None, *, seed=None, init="dart", dart_radius=0.74,
                 manifest=None, overwrite=False, jobs=1, devices=None, client=None,
                 collect=False, progress=None, **overrides):
    """Make ``count`` independent Poisson disk sets; yield records as they finish.

    Seeds come from ``numpy.random.SeedSequence(seed).spawn(count)``; each
    record's ``seed`` recreates its set alone. Without ``seed``, a rerun
    takes the seed of the run recorded in the manifest (else a fresh one). See :func:`plan_poisson` and
    :func:`run_batch`; the module's example shows a run and its resume.

    Examples
    --------
    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> recs = list(poisson_many(2, 64, [os.path.join(out, "{i}.npz")], seed=1))
    >>> sorted(os.path.basename(r["outputs"][0]) for r in recs)
    ['0.npz', '1.npz']
    """
    if manifest is None:
        manifest = default_manifest(list(outputs))
    if seed is None and manifest and not overwrite:  # resume: the earlier run's seed
        seed = next((r["params"]["base_seed"] for r in reversed(Manifest(manifest).records())
                     if r.get("kind") == "poisson" and "base_seed" in r.get("params", {})),
                    None)
    items = plan_poisson(count, n, outputs, relax, seed=seed, init=init,
                         dart_radius=dart_radius, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)


def relax_many(inputs, outputs, relax=None, *, box=None, columns=None, manifest=None,
               overwrite=False, jobs=1, devices=None, client=None, collect=False, progress=None,
               **overrides):
    """Relax many point files; yield records as they finish (see :func:`plan_relax`
    for ``box`` and ``columns``).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> folder = tempfile.mkdtemp(); np.save(os.path.join(folder, "a.npy"), np.random.default_rng(0).random((64, 2)))
    >>> recs = list(relax_many([os.path.join(folder, "a.npy")], [os.path.join(folder, "{stem}.npz")], eps=0.7))
    >>> [(r["status"], r["summary"]["rho_final"] >= 0.7) for r in recs]
    [('ok', True)]
    """
    items = plan_relax(inputs, outputs, relax, box=box, columns=columns, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)
