"""The jobs of a batch, one item at a time: items, their planning, and the work of each.

An :class:`Item` is one input image, point file or seed, its parameters and
its output paths, rendered from templates (:data:`TEMPLATE_FIELDS`).
:func:`plan_stipple`, :func:`plan_poisson` and :func:`plan_relax` make the
items. :func:`stipple_item`, :func:`relax_item` and :func:`poisson_start`
are the one implementation of each job, run by a single input (a one-item
plan) and by every item of a batch; :func:`run_job` runs an item and writes
its outputs. Running many items (worker processes, Dask, the manifest) is
:mod:`diskpack_cl.jobs.executors`. This module uses only the public API of the
package, so it follows the engine as it changes.

Examples
--------
>>> import os, tempfile
>>> item, = plan_poisson(1, 64, [os.path.join(tempfile.mkdtemp(), "a.npz")], seed=3)
>>> summary = run_job(item)
>>> summary["n"], os.path.exists(item.outputs[0])
(64, True)
"""

from __future__ import annotations

import json
import os
import string
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..drawing.page import svg_layout
from ..drawing.write_options import (WriteOptions, check_preview_memory, preview_scale,
                                     write_options)
from ..drawing.writers import check_output_path, tone_dot_count, tone_dot_size, write_stipple
from ..image import ToneOptions, gray_strips, load_picture, load_rgb, to_gray
from ..io import (atomic_writes, box_record, check_not_inputs, check_points_path, read_points,
                 write_points)
from ..memory import check_stipple_memory
from ..multipen import stipple_colors
from ..options import changed
from ..palette import grey_note
from ..picture_measures import tone_radius
from ..poisson import PoissonOptions, as_box, poisson_job
from ..progress import RunProgress, running, stage
from ..relax import RELAX_FIELDS, RelaxOptions, relax_poisson, relax_summary
from ..schedule import StippleOptions
from ..stipple import stipple

__all__ = [
    "TEMPLATE_FIELDS", "IMAGE_SUFFIXES", "Item", "expand_inputs", "render_template",
    "check_outputs", "derive_seeds", "dots_for_image",
    "write_stipple_outputs", "stipple_item", "relax_item", "run_job",
    "plan_stipple", "plan_poisson", "plan_relax",
]


TEMPLATE_FIELDS = ("stem", "name", "parent", "n", "seed", "i")
"""Fields of an output template: ``{stem}`` (input file name without its
extension), ``{name}`` (with it), ``{parent}`` (the input's folder name),
``{n}`` (points or dots), ``{seed}`` and ``{i}`` (the item's index, from 0).
Format specs work as in :meth:`str.format`: ``{i:04d}``."""


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".gif")
"""Extensions that a folder given as input contributes (case-insensitive)."""


# ---------------------------------------------------------------- items


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
              "parent": (_parent_name(p) if p else None), "n": n, "seed": seed, "i": i}
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


def absolute_path(path):
    """``path`` made absolute against this process's working folder.

    An item may run where the working folder is another one (a Dask worker
    on another machine, or started elsewhere), so the plans resolve every
    input and output before the items leave this process. ``"-"`` (standard
    input, :func:`diskpack_cl.image.load_gray`) stays as it is.

    Examples
    --------
    >>> os.path.isabs(absolute_path("photos/face.png")), absolute_path("-")
    (True, '-')
    """
    path = os.fspath(path)
    return path if path == "-" else os.path.abspath(path)


def _item_inputs(item):
    """The files an item reads: its input and a start set's file (``init``)."""
    init = item.params.get("init")
    return [item.input] + ([init] if init not in (None, "dart", "random") else [])


def _parent_name(path):
    """The name of the folder `path` lies in, symlinks resolved; a symlink loop (which
    ``Path.resolve`` refuses with a RuntimeError) is resolved as far as it goes, and the
    item fails later on reading it, with the batch going on."""
    return Path(os.path.realpath(path)).parent.name


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
        if _parent_name(pa) != _parent_name(pb):
            fields.append("{parent}")
    return " or ".join(fields + ["{i}"])


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
    return [int(child.generate_state(1, dtype=np.uint32)[0] >> 1)
            for child in np.random.SeedSequence(seed).spawn(count)]


def dots_for_image(width, height, *, n=None, density=None, dots_per_cm2=None, **layout):
    """The number of dots: ``n``, or ``density`` per megapixel, or per cm^2 of the print.

    ``dots_per_cm2`` needs the physical size: ``layout`` as for the SVG
    (:func:`diskpack_cl.drawing.writers.svg_layout`), with ``width_mm``,
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
        if all(layout.get(k) is None for k in ("width_mm", "height_mm", "dpi", "page")):
            raise ValueError("--dots-per-cm2 needs the print size: --width-mm, --height-mm, "
                             "--dpi or --page")
        cm = svg_layout(width, height, **layout)["scale"] / 10.0
        count = dots_per_cm2 * (width * cm) * (height * cm)
    return max(1, int(round(count)))


# ------------------------------------------------------------- one item


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
        tone dot size is ``result.tone_radius`` (a :class:`~diskpack_cl.StippleResult`'s is
        its picture's darkness without the paper tone, as from its gray).
    outputs : list of str
        ``.svg``, ``.png``, ``.npz`` or ``.csv`` paths.
    options : WriteOptions, optional
        How the dots are drawn (:class:`diskpack_cl.drawing.write_options.WriteOptions`;
        ``pen_mm``: the PNG preview shows what the pen draws).
    progress : callable or RunProgress, optional
        ``progress(stage, done, total)`` (:mod:`diskpack_cl.progress`): the
        stage ``writing``, counted in files and, in a PNG preview, in the
        dots it stamped, and within it an SVG's ``pen path`` (its 2-opt
        rounds); None: the run going on, if any.
    **overrides
        Fields of :class:`~diskpack_cl.drawing.write_options.WriteOptions` replacing those of `options`.

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
    o = write_options(options, **overrides)
    check_preview_memory(o, result.width, result.height, outputs)   # before any file
    if o.dot_mm is None and o.dot_kind == "tone" and getattr(result, "pen", None) is None:
        # one tone dot size, from the image (a colour stippling has one per pen)
        o = o.replace(dots=None, dot_mm=tone_dot_size(result, o.scale(result.width, result.height),
                                                      o.radius_scale, gray=gray, invert=o.invert))
    written = []
    units = [len(result.points) if out.lower().endswith(".png") else 1 for out in outputs]
    with running(progress), stage("writing", sum(units)) as advance, atomic_writes():
        for out, done in zip(outputs, np.cumsum([0, *units[:-1]]).tolist()):
            ext = check_output_path(out)
            info = write_stipple(out, result, o, progress=_stamped(advance, done))
            advance(done + units[len(written)])
            written.append({"path": out, "format": ext[1:], **info})
    return o.dot_mm, written


def _stamped(advance, done):
    """``progress(k)`` of a PNG writer (`k` more dots stamped): the writing stage's
    ``advance``, from the `done` units of the outputs before."""
    count = [done]

    def progress(k):
        count[0] += k
        advance(count[0])

    return progress


def _item_image(path, params):
    """``(gray_sum, image, run)`` of an item: the sum of its toned gray image's levels, the
    picture :func:`diskpack_cl.stipple` takes (its 8-bit pixels where the tone controls
    leave them as they are: the run then holds the only float copy, and frees it when its
    fields are made), or (with ``params["color"]``) None, the colour image and
    :func:`diskpack_cl.stipple_colors`; ``run(image, n, options, **keywords)``."""
    color = params.get("color")
    if color is None:
        tone = ToneOptions(**params.get("tone", {}))
        picture = load_picture(path, allow_large=params.get("allow_large", False))
        if tone != ToneOptions():
            picture = tone.adjust(to_gray(picture, copy=False), copy=False)
        return sum(float(strip.sum()) for _, strip in gray_strips(picture)[1]), picture, stipple

    def run(image, n, options, **keywords):
        return stipple_colors(image, n, options=options, **color, **keywords)

    return None, load_rgb(path), run


def _drawn_dot_mm(write, n, darkness, scale):
    """Diameter (mm) of the ink of each of `n` dots as `write` draws them: its dot size, or
    the tone size of n dots times its radius scale, and at least the pen's width (a
    narrower dot is one pen touch); None for the packing disks, which have no one size."""
    if write.dot_mm is not None:
        dot = write.dot_mm
    elif (write.dots or "tone") == "tone":
        dot = 2.0 * tone_radius(n, darkness) * write.radius_scale * scale
    else:
        return None
    return max(dot, write.pen_mm or 0.0)


def _ink_note(n, drawn_mm, darkness, scale, tone):
    """What to say when `n` dots `drawn_mm` wide hold far more or less ink than the image
    on paper (`tone`: the count of ``-n tone``), else None.

    Examples
    --------
    >>> _ink_note(100, 2.0, np.full((10, 10), 0.5), 6.0, 573)
    "573 dots of 2 mm give the image's ink on this paper; -n 100 will look lighter (-n tone uses 573)"
    >>> _ink_note(573, 2.0, np.full((10, 10), 0.5), 6.0, 573) is None
    True
    """
    if drawn_mm is None:
        return None
    ink_mm2 = float(np.sum(darkness)) * scale * scale
    like = int(round(ink_mm2 / (0.25 * np.pi * drawn_mm * drawn_mm)))
    if 2 / 3 <= n / max(like, 1) <= 3 / 2:
        return None
    return (f"{like} dots of {drawn_mm:.3g} mm give the image's ink on this paper; -n {n} will "
            f"look {'darker' if n > like else 'lighter'}"
            + (f" (-n tone uses {tone})" if like == tone else ""))


def _item_dots(params, write, gray_sum, width, height, note):
    """``(n, tone_n)`` of an item: its dot count, and with a dot or pen size (one pen) the
    count whose ink is the image's on paper (``-n tone``; `gray_sum`: the sum of its gray
    levels), a note when n is far from it."""
    n, tone_n = params.get("n"), None
    dot = write.dot_mm or write.pen_mm
    if gray_sum is not None and dot is not None:
        # the summed darkness: what the dot counts and sizes below sum
        darkness = gray_sum if write.invert else width * height - gray_sum
        scale = write.scale(width, height)
        tone = tone_dot_count(darkness, scale, dot)
        text = isinstance(n, int) and _ink_note(n, _drawn_dot_mm(write, n, darkness, scale),
                                                darkness, scale, tone)
        if text and note is not None:
            note(text)
        n, tone_n = (tone if n == "tone" else n), {"n": tone, "dot_mm": dot}
    elif n == "tone":
        raise ValueError("n='tone' needs the dot size: give dot_mm or pen_mm")
    n = dots_for_image(width, height, n=n, density=params.get("density"),
                       dots_per_cm2=params.get("dots_per_cm2"), **write.layout())
    return n, tone_n


def stipple_item(item, *, device=None, callback=None, progress=None, verify=False, profile=False,
                 note=None):
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
    progress : callable or RunProgress, optional
        ``progress(stage, done, total)`` as each stage starts, advances and
        ends (:mod:`diskpack_cl.progress`): ``load`` (the image read, the dot
        count) and within it ``device`` (the memory check: the OpenCL device
        found, and checked on its first run), then those of
        :func:`diskpack_cl.stipple`;
        with a :class:`~diskpack_cl.progress.RunProgress` the caller reads
        each stage's seconds (:attr:`~diskpack_cl.progress.RunProgress.seconds`)
        and goes on with the writers (:func:`write_stipple_outputs`).
    verify, profile : bool
        As for :func:`diskpack_cl.stipple` (one pen).
    note : callable, optional
        ``note(text)`` for advice that is no error (a dot count far from the
        one whose ink is the image's, pens for an image without hue).

    Returns
    -------
    result : StippleResult or ColorStippleResult
        With ``params["tone"]`` (one pen): the tone controls applied, and a
        ``tone_radius`` from the toned picture's darkness (what the writers draw).
    summary : dict
        ``result.summary()`` with ``image`` and ``tone_n`` (the count whose
        ink is the image's with a dot size, else None).

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl import sample_image_path
    >>> item, = plan_stipple([sample_image_path()], [os.path.join(tempfile.mkdtemp(), "a.svg")],
    ...                      n=300, method="lloyd")
    >>> result, summary = stipple_item(item)
    >>> result.n, result.certificate.valid, summary["image"].endswith("astronaut.png")
    (300, True, True)
    """
    with running(progress):
        return _stipple_item_run(item, device, callback, verify, profile, note)


def _stipple_item_run(item, device, callback, verify, profile, note):
    """The body of :func:`stipple_item`, in its run."""
    with stage("load"):
        loaded = _stipple_item_load(item, device, note)
    res = _stipple_item_stipple(item, loaded, device, callback, verify, profile)
    grey = loaded.gray_sum is None and note is not None and grey_note(loaded.image, res.names, res.pen)
    if grey:
        note(grey)
    return res, dict(res.summary(), image=item.input, tone_n=loaded.tone_n)


class _Loaded(NamedTuple):
    """A stipple item read: see :func:`_item_image` and :func:`_item_dots`."""

    gray_sum: object
    image: object
    run: object
    tone_n: object
    n: int
    options: StippleOptions


def _stipple_item_load(item, device, note):
    """The :class:`_Loaded` of a stipple item: its image read, its dot count, the memory it
    needs checked."""
    params = item.params
    write = WriteOptions(**item.write)
    options = StippleOptions(**params.get("options", {}))
    gray_sum, image, run = _item_image(item.input, params)
    H, W = image.shape[:2]
    n, tone_n = _item_dots(params, write, gray_sum, W, H, note)
    # the ink without the paper tone: no more than the stippling's, so no smaller a raster
    ink = None if gray_sum is None else gray_sum if options.invert else W * H - gray_sum
    area = write.preview_area(W, H)
    # the device's first use in the job: found, and on its first run checked (known answers)
    with stage("device"):
        check_stipple_memory(W, H, n, supersample=options.supersample, ink=ink,
                             png_scale=preview_scale(*area, write.png_scale), png_area=area,
                             device=device, outputs=item.outputs)
    return _Loaded(gray_sum, image, run, tone_n, n, options)


def _stipple_item_stipple(item, loaded, device, callback, verify, profile):
    """The stippling of a :class:`_Loaded` item."""
    params, (gray_sum, image, run, _, n, options) = item.params, loaded
    H, W = image.shape[:2]
    each = None
    if callback is not None:
        total = sum(ph[1] for ph in options.plan(n, W, H).phases)

        def with_total(entry):
            callback(entry, total)

        each = with_total
    extra = {} if gray_sum is None else {"verify": verify, "profile": profile}
    res = run(image, n, options, device=device, callback=each,
              backend=params.get("backend", "auto"), **extra)
    if gray_sum is not None:   # recorded in the .npz and the --json params
        res.params["tone"] = ToneOptions(**params.get("tone", {})).params()
    return res


def _stipple_item(item, device, progress):
    """A batch's stipple item: :func:`stipple_item`, its outputs written; its summary."""
    callback = None
    if progress is not None:
        def show(entry, total):
            progress(int(entry.get("iteration", 0)) + 1,
                     f"{entry.get('kind', '?')} k={entry.get('k', float('nan')):.4g}")

        callback = show
    with running(RunProgress()) as run:   # the item's own run: its seconds per stage
        res, summary = stipple_item(item, device=device, callback=callback)
        t = time.perf_counter()
        dot_mm, written = write_stipple_outputs(res, None, list(item.outputs), **item.write)
    summary.pop("params", None)
    summary.update(dot_mm=dot_mm, files=written, write_seconds=time.perf_counter() - t,
                   stage_seconds=run.by_stage())
    return summary


def relax_item(item, points=None, *, device=None, callback=None, verify=False, profile=False):
    """Relax the points of one item and write its outputs: what a single input and every
    item of a batch run (``relax``, and ``poisson --init FILE``).

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
    p = item.params
    if points is None:
        points = read_points(item.input, min_points=2, columns=p.get("columns"))
    domain = as_box(p.get("box"))
    relax = RelaxOptions(**{k: v for k, v in p.items() if k in RELAX_FIELDS})
    res = relax_poisson(points, options=relax, device=device, callback=callback, verify=verify,
                        profile=profile, domain=domain)
    for out in item.outputs:
        extra = {}
        if out.lower().endswith(".npz"):
            extra = {"rho": res.rho, "eps": p["eps"], **box_record(out, domain)}
        write_points(out, res.points, **extra)
    return res


def _rho_progress(progress):
    return None if progress is None else (lambda it, rho: progress(it, f"rho={rho:.4f}"))


def _poisson_item(item, device, progress):
    """A poisson item: :func:`~diskpack_cl.poisson.poisson_job` with the item's options and
    seed (what ``diskpack poisson`` and :func:`~diskpack_cl.poisson.poisson_disk` run); its
    summary."""
    p = item.params
    _, summary = poisson_job(p["n"], item.outputs, PoissonOptions(**p["options"]), seed=item.seed,
                             device=device, callback=_rho_progress(progress))
    return summary


def _relax_item(item, device, progress):
    """A batch's relax item: :func:`relax_item`; its summary."""
    res = relax_item(item, device=device, callback=_rho_progress(progress))
    return relax_summary(res, item.params["eps"])


_KINDS = {"stipple": _stipple_item, "poisson": _poisson_item, "relax": _relax_item}


def run_job(item, *, device=None, progress=None):
    """Run one item here and write its outputs; its summary (what a batch record holds).

    Parameters
    ----------
    item : Item
    device : str, optional
        OpenCL device.
    progress : callable, optional
        ``progress(iteration, text)`` after each iteration.

    Returns
    -------
    dict
        The job's summary: ``n``, ``iterations``, ``rho_start``,
        ``rho_final``, ... for point sets; ``result.summary()`` with
        ``image``, ``dot_mm`` and the written ``files`` for a stippling.

    Examples
    --------
    >>> import os, tempfile
    >>> item, = plan_poisson(1, 64, [os.path.join(tempfile.mkdtemp(), "a.npz")], seed=3)
    >>> run_job(item)["stop_reason"] in ("eps", "max_iter", "stalled")
    True
    """
    return _KINDS[item.kind](item, device, progress)


# ---------------------------------------------------------------- plans


def _paths_check(kind):
    if kind == "stipple":
        return check_output_path

    return lambda path: check_points_path(path, for_writing=True)


def _image_dots(path, count, write):
    """The dot count of an image for the ``{n}`` field: read from its header."""
    if count.get("n") is not None:
        return count["n"]
    from PIL import Image  # Pillow is not loaded at start-up; only {n} reads a header

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
        (:class:`diskpack_cl.pens.ColorOptions`, or a dict of ``colors``,
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
    for i, path in enumerate(map(absolute_path, expand_inputs(inputs, recursive=recursive))):
        error = None
        dots = n
        if uses_n and n is None:
            try:
                dots = _image_dots(path, count, write)
            except Exception as exc:  # the item fails, the batch goes on
                error = f"{path}: cannot read the image size for {{n}}: {exc}"
        rendered = [absolute_path(render_template(t, input=path, n=dots if dots is not None else 0,
                                                  seed=seed, i=i)) for t in outputs]
        items.append(Item("stipple", i, path, seed, json.loads(json.dumps(params)),
                          tuple(rendered), changed(write), error))
    check_outputs(items, _paths_check("stipple"), make_folders=make_folders)
    return items


def _relax_params(relax, overrides):
    """The relaxation of every item: :class:`~diskpack_cl.relax.RelaxOptions` as JSON."""
    return replace(relax or RelaxOptions(), **overrides).kwargs()


def plan_poisson(count, n, outputs, options=None, *, seed=None, make_folders=True, **overrides):
    """Items for ``count`` Poisson disk sets with seeds derived from ``seed``.

    Set ``i`` has seed ``derive_seeds(seed, count)[i]``; ``seed=None`` takes
    a fresh one. ``options`` (a :class:`~diskpack_cl.poisson.PoissonOptions`)
    with ``overrides`` (its fields: ``eps``, ``init``, ``dim``, ...) makes
    every set; an item carries the fields that differ from their defaults
    (:func:`~diskpack_cl.options.changed`, JSON for the manifest).
    ``make_folders`` as for :func:`check_outputs`.

    Examples
    --------
    >>> import os, tempfile
    >>> items = plan_poisson(3, 64, [os.path.join(tempfile.mkdtemp(), "{i}.npz")], seed=7,
    ...                      eps=0.75)
    >>> [it.seed for it in items] == derive_seeds(7, 3), items[0].params["options"]
    (True, {'eps': 0.75})
    """
    options = (options or PoissonOptions()).replace(**overrides)
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % 2**31)
    params = {"n": n, "options": changed(options), "base_seed": seed}
    items = [Item("poisson", i, None, s, params,
                  tuple(absolute_path(render_template(t, n=n, seed=s, i=i)) for t in outputs))
             for i, s in enumerate(derive_seeds(seed, count))]
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
    items = [Item("relax", i, path, None, params,
                  tuple(absolute_path(render_template(t, input=path, i=i)) for t in outputs))
             for i, path in enumerate(map(absolute_path, inputs))]
    check_outputs(items, _paths_check("relax"), make_folders=make_folders)
    return items
