"""Image input for stippling: grayscale float images in [0, 1], 1 = white.

Every image Pillow reads is accepted (PNG, JPEG, TIFF, BMP, WebP, ...), 8- and
16-bit. Colour is converted to luma with the ITU-R BT.601 weights applied to
the gamma-encoded values, ``Y' = 0.299 R' + 0.587 G' + 0.114 B'`` (the same
weights as Pillow's ``convert("L")``), computed in float64 so that 16-bit
precision survives. Transparent pixels are composited on white (paper), the
EXIF orientation tag is honoured, and Pillow's decompression-bomb limit
(``PIL.Image.MAX_IMAGE_PIXELS``) is kept unless ``allow_large=True``.

A uniform image is accepted here; :func:`diskpack_cl.stipple.stipple` refuses
a white one ("nothing to stipple") and stipples any other uniform tone as a
uniform point set.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
import os
import warnings
from importlib import resources
from pathlib import Path
import io
import stat
import sys

import numpy as np

from ._cores import on_cores
from .memory import PageReserve, freed_memory_kept
from .options import OptionConflict, check_fields, option

__all__ = ["adjust_tone", "ToneOptions", "load_gray", "load_picture", "load_rgb", "to_gray", "gray_strips",
           "image_size", "sample_image_path", "LUMA_601"]

#: ITU-R BT.601 luma weights for R', G', B' (Pillow's ``convert("L")``).
LUMA_601 = (0.299, 0.587, 0.114)


def sample_image_path():
    """Path of the bundled sample photograph (512x512 8-bit grayscale PNG).

    It is a portrait of astronaut Eileen Collins (NASA, public domain); see
    ``diskpack_cl/data/README.md``.

    Examples
    --------
    >>> from diskpack_cl.image import sample_image_path, load_gray
    >>> load_gray(sample_image_path()).shape
    (512, 512)
    """
    ref = resources.files("diskpack_cl") / "data" / "astronaut.png"
    with resources.as_file(ref) as p:
        return Path(p)


@contextlib.contextmanager
def _bomb_limit(allow_large):
    """Keep Pillow's decompression-bomb check, or lift it for this block."""
    from PIL import Image  # not loaded at start-up

    if not allow_large:
        with warnings.catch_warnings():
            # Pillow only warns between 1x and 2x the limit; make it an error.
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            yield
        return
    old = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        yield
    finally:
        Image.MAX_IMAGE_PIXELS = old


def _image_source(path):
    """``(name, source)`` for Pillow: a regular file's path, or the bytes of
    standard input (``"-"``) or of a pipe (``/dev/stdin``, a FIFO) in memory
    (Pillow needs to seek, and a pipe reports size 0)."""
    if os.fspath(path) == "-":
        name, data = "standard input", sys.stdin.buffer.read()
    else:
        p = Path(os.fspath(path))
        if not p.exists():
            raise FileNotFoundError(f"image file not found: {p}")
        if p.is_dir():
            raise ValueError(f"not an image file (it is a directory): {p}")
        if stat.S_ISREG(p.stat().st_mode):
            if p.stat().st_size == 0:
                raise ValueError(f"image file is empty (0 bytes): {p}")
            return str(p), p
        name, data = str(p), p.read_bytes()
    if not data:
        raise ValueError(f"no image data (0 bytes) on {name}")
    return name, io.BytesIO(data)


def load_gray(path, *, invert=False, allow_large=False):
    """Read an image file as a float64 gray image in [0, 1], 1 = white.

    Parameters
    ----------
    path : str or os.PathLike
        Any file Pillow can read; ``"-"`` reads the image from standard input
        (``./-`` names a file of that name), and a pipe such as ``/dev/stdin``
        is read to its end.
    invert : bool, optional
        Return ``1 - gray`` (for light-on-dark stippling).
    allow_large : bool, optional
        Lift Pillow's decompression-bomb limit (``PIL.Image.MAX_IMAGE_PIXELS``,
        about 89 Mpixel). By default an image larger than the limit is refused.

    Returns
    -------
    gray : (H, W) float64 ndarray
        Row 0 is the top of the image (after EXIF orientation).

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        The file is empty, not an image, truncated or corrupt, has zero
        size, or exceeds the decompression-bomb limit.

    Examples
    --------
    >>> from diskpack_cl.image import load_gray, sample_image_path
    >>> g = load_gray(sample_image_path())
    >>> g.dtype, float(g.min()) >= 0.0, float(g.max()) <= 1.0
    (dtype('float64'), True, True)
    """
    # the float64 picture's pages (and those of the decoded bytes) are touched on another
    # core while this one decodes: a fresh page costs far more on a virtual machine
    with freed_memory_kept():
        im, name = _open_image(path, allow_large, reserve=GRAY_BYTES_PER_PIXEL)
        return _pil_to_gray(im, invert=invert, name=name)


def load_picture(path, *, allow_large=False):
    """Read an image file as the smallest array whose gray is :func:`load_gray`'s.

    An 8-bit gray or RGB(A) file comes back as its pixels, a uint8 array
    (an eighth or, in colour, three eighths of the float64 gray image);
    :func:`to_gray` then makes the gray of :func:`load_gray` from it, bit
    for bit.  Other files come back as :func:`load_gray`'s gray image.  A
    stippling that is handed the small array makes its own gray image, and
    frees it when its fields are made.

    Parameters
    ----------
    path : str or os.PathLike
        As :func:`load_gray` reads it (``"-"``: standard input).
    allow_large : bool, optional
        As for :func:`load_gray`.

    Returns
    -------
    picture : (H, W), (H, W, 2|3|4) uint8 or (H, W) float64 ndarray

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`load_gray`.

    Examples
    --------
    >>> from diskpack_cl.image import load_gray, load_picture, sample_image_path
    >>> pic = load_picture(sample_image_path())
    >>> pic.dtype, bool((to_gray(pic) == load_gray(sample_image_path())).all())
    (dtype('uint8'), True)
    """
    im, name = _open_image(path, allow_large)
    if im.mode in ("L", "LA", "RGB", "RGBA") and im.width and im.height:
        return np.asarray(im)
    return _pil_to_gray(im, name=name)


def load_rgb(image):
    """Anything image-like to float64 sRGB (H, W, 3) in [0, 1] (a new array).

    Paths and Pillow images are read with their EXIF orientation, transparency
    composited on white; gray images give three equal channels. Arrays:
    ``(H, W)`` or ``(H, W, 3|4)``, integers scaled by their bit depth (uint8
    by 255, uint16 by 65535), floats in [0, 1].

    Examples
    --------
    >>> load_rgb(np.array([[[255, 0, 0, 0]]], dtype=np.uint8)).tolist()
    [[[1.0, 1.0, 1.0]]]
    """
    from PIL import Image, ImageOps  # not loaded at start-up

    if isinstance(image, (str, os.PathLike)):
        load_gray(image)   # the same checks and messages as for gray input
        with Image.open(image) as im:
            image = ImageOps.exif_transpose(im).convert("RGBA")
    elif isinstance(image, Image.Image):
        image = ImageOps.exif_transpose(image).convert("RGBA")
    a = np.asarray(image)
    if np.issubdtype(a.dtype, np.integer):
        f = a.astype(np.float64) / (255.0 if a.max(initial=0) <= 255 else 65535.0)
    else:
        f = np.asarray(a, dtype=np.float64)
    if f.ndim == 2:
        f = np.repeat(f[..., None], 3, axis=2)
    if f.ndim != 3 or f.shape[2] not in (3, 4) or not np.all(np.isfinite(f)) \
            or f.min(initial=0) < 0 or f.max(initial=0) > 1:
        raise ValueError(f"a colour image must be (H, W) or (H, W, 3|4) with values in [0, 1], "
                         f"got shape {a.shape}")
    if f.shape[2] == 4:
        f = f[..., :3] * f[..., 3:] + (1.0 - f[..., 3:])
    return np.ascontiguousarray(f)


def gray_strips(image, *, rows=256, allow_large=False):
    """The gray image of `image` (as :func:`to_gray` makes it), a strip of rows at a time.

    Returns ``(shape, strips)``: the gray image's ``(H, W)`` and an iterator
    of ``(y0, strip)``, float64 rows ``y0 ..`` of it. A file is decoded
    once and converted strip by strip, so that no float copy of the whole
    picture is made (a tiled stippling, :func:`diskpack_cl.jobs.tiles.stipple_tiled`).

    Examples
    --------
    >>> shape, strips = gray_strips(np.zeros((5, 3)), rows=2)
    >>> shape, [(y0, s.shape) for y0, s in strips]
    ((5, 3), [(0, (2, 3)), (2, (2, 3)), (4, (1, 3))])
    """
    if isinstance(image, (str, os.PathLike)):
        im, name = _open_image(image, allow_large)
        if im.mode != "I":   # 32-bit integer images are scaled by their maximum: whole
            def strips():
                for y0 in range(0, im.height, rows):
                    box = (0, y0, im.width, min(y0 + rows, im.height))
                    yield y0, _pil_to_gray(im.crop(box), name=name)
            return (im.height, im.width), strips()
        image = _pil_to_gray(im, name=name)
    if not isinstance(image, np.ndarray):
        image = to_gray(image)
    # an array's rows convert on their own: to_gray's values, without a whole float copy
    return image.shape[:2], ((y0, to_gray(image[y0:y0 + rows], copy=False))
                             for y0 in range(0, image.shape[0], rows))


def image_size(path, *, allow_large=False):
    """``(width, height)`` of an image file upright (EXIF), read from its header; None for
    standard input (``"-"``, which it would consume) and where Pillow cannot read it
    (:func:`load_gray` then says why).

    Examples
    --------
    >>> image_size(sample_image_path())
    (512, 512)
    """
    from PIL import Image  # not loaded at start-up

    if os.fspath(path) == "-":
        return None
    try:
        with _bomb_limit(allow_large), Image.open(_image_source(path)[1]) as im:
            width, height = im.size
            turned = im.getexif().get(_ORIENTATION) in (5, 6, 7, 8)   # a quarter turn
    except (ValueError, OSError, SyntaxError, Image.DecompressionBombError,
            Image.DecompressionBombWarning):
        return None
    return (height, width) if turned else (width, height)


#: The EXIF tag of the image's orientation.
_ORIENTATION = 0x0112


#: Bytes a pixel of an 8-bit picture takes as :func:`load_gray` reads it: its bytes as
#: numpy reads them from Pillow and the float64 gray image.
GRAY_BYTES_PER_PIXEL = 9


def _open_image(path, allow_large, reserve=0):
    """``(image, name)``: the Pillow image of a file, decoded and turned upright (EXIF).

    `reserve`: bytes a pixel whose pages another thread touches while the
    file decodes, handed to the heap once it is decoded (a
    :class:`~diskpack_cl.memory.PageReserve`: only inside
    :func:`~diskpack_cl.memory.freed_memory_kept`)."""
    from PIL import Image, ImageOps, UnidentifiedImageError  # not loaded at start-up

    name, source = _image_source(path)
    try:
        with _bomb_limit(allow_large):
            with Image.open(source) as im:
                pages = PageReserve(reserve * im.width * im.height)
                try:
                    im.load()
                finally:
                    pages.release()
                im = ImageOps.exif_transpose(im)
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise ValueError(
            f"image is larger than Pillow's decompression-bomb limit "
            f"({Image.MAX_IMAGE_PIXELS} pixels): {name}; pass allow_large=True "
            f"(CLI: --allow-large) if you trust the file"
        ) from exc
    except UnidentifiedImageError as exc:
        raise ValueError(f"not an image Pillow can read: {name}") from exc
    except (OSError, SyntaxError, EOFError) as exc:
        raise ValueError(f"image file is truncated or corrupt: {name} ({exc})") from exc
    return im, name


def _pil_to_gray(im, *, invert=False, name="image"):
    if im.width == 0 or im.height == 0:
        raise ValueError(f"image has zero size ({im.width}x{im.height}): {name}")
    mode = im.mode
    if mode == "P":
        im = im.convert("RGBA" if "transparency" in im.info else "RGB")
    elif mode == "PA":
        im = im.convert("RGBA")
    elif mode in ("CMYK", "YCbCr", "LAB", "HSV"):
        im = im.convert("RGB")
    elif mode == "1":
        im = im.convert("L")
    elif mode in ("RGBa", "La"):  # premultiplied alpha
        im = im.convert("RGBA" if mode == "RGBa" else "LA")
    mode = im.mode
    if mode.startswith("I;16"):
        g = np.asarray(im, dtype=np.float64) / 65535.0
    elif mode == "I":
        a = np.asarray(im, dtype=np.float64)
        # 32-bit integer images: 16-bit data (PNG, TIFF) stored as "I".
        scale = 65535.0 if a.max(initial=0) > 255 else 255.0
        g = a / scale
    elif mode == "F":
        g = np.asarray(im, dtype=np.float64)
        if not np.all(np.isfinite(g)) or g.min() < 0.0 or g.max() > 1.0:
            raise ValueError(f"float image values must be finite and in [0, 1]: {name}")
    else:
        if mode not in ("L", "LA", "RGB", "RGBA"):
            im = im.convert("RGBA" if "A" in mode else "RGB")
        g = _array_to_gray(np.asarray(im), name=name)
        return 1.0 - g if invert else g
    g = np.clip(g, 0.0, 1.0)
    return 1.0 - g if invert else np.ascontiguousarray(g)


def _uint8_gray(a, *, part=1 << 22):
    """``a / 255`` of a uint8 array as float64, the same values, in row bands of at least
    `part` values on every core (most of its time is the first touch of the new array's
    pages, which the cores share).

    Each band is cast, then divided in place: half the time of np.divide with
    dtype=float64 (a casting loop); a table of the 256 quotients indexed by
    the image gives the same values at about twenty times the time.

    Examples
    --------
    >>> _uint8_gray(np.array([[0, 51, 255]], np.uint8), part=1)
    array([[0. , 0.2, 1. ]])
    """
    f = np.empty(a.shape, np.float64)

    def run(rows):
        np.copyto(f[rows], a[rows])
        f[rows] /= 255.0

    on_cores(run, len(a), a.size, part)
    return f


def _array_to_gray(a, *, name="array", copy=True):
    """(H,W), (H,W,1..4) array -> float64 gray in [0, 1]; alpha over white."""
    a = np.asarray(a)
    if a.dtype == np.bool_:
        f = a.astype(np.float64)
    elif np.issubdtype(a.dtype, np.integer):
        info = np.iinfo(a.dtype)
        if info.min < 0 and a.min(initial=0) < 0:
            raise ValueError(f"integer image values must be non-negative: {name}")
        bits = 8 if info.max <= 255 else 16 if info.max <= 65535 else None
        if bits is None:
            top = float(a.max(initial=0))
            bits = 8 if top <= 255 else 16
        if a.dtype == np.uint8:
            f = _uint8_gray(a)
        else:
            f = a.astype(np.float64) / (2.0**bits - 1.0)
    elif np.issubdtype(a.dtype, np.floating):
        f = a.astype(np.float64, copy=copy)
        if not np.all(np.isfinite(f)):
            raise ValueError(f"image values must be finite: {name}")
        if f.size and (f.min() < 0.0 or f.max() > 1.0):
            raise ValueError(
                f"float image values must be in [0, 1] (1 = white), got "
                f"[{f.min():.4g}, {f.max():.4g}]: {name}"
            )
    else:
        raise ValueError(f"unsupported image dtype {a.dtype}: {name}")
    if f.ndim == 3 and f.shape[2] == 1:
        f = f[:, :, 0]
    if f.ndim == 2:
        g = f
    elif f.ndim == 3 and f.shape[2] in (2, 3, 4):
        c = f.shape[2]
        if c in (2, 4):
            alpha, f = f[:, :, -1], f[:, :, :-1]
        else:
            alpha = None
        if f.shape[2] == 3:
            # written around G so that neutral colours (R = G = B) stay exact
            R, G, B = f[:, :, 0], f[:, :, 1], f[:, :, 2]
            g = G + LUMA_601[0] * (R - G) + LUMA_601[2] * (B - G)
        else:
            g = f[:, :, 0]
        if alpha is not None:
            g = alpha * g + (1.0 - alpha)
    else:
        raise ValueError(f"image must be (H, W) or (H, W, 1..4), got shape {a.shape}: {name}")
    if g.shape[0] == 0 or g.shape[1] == 0:
        raise ValueError(f"image has zero size ({g.shape[1]}x{g.shape[0]}): {name}")
    if not np.may_share_memory(g, a):   # a float array kept (copy=False) is in [0, 1] already
        np.clip(g, 0.0, 1.0, out=g)      # this function's own array: clipped in place
    return np.ascontiguousarray(g)


def to_gray(image, *, invert=False, allow_large=False, copy=True):
    """Anything image-like -> float64 gray in [0, 1], 1 = white (a new array, unless `copy` is False).

    Parameters
    ----------
    image : str, os.PathLike, PIL.Image.Image or array_like
        A file path (read with :func:`load_gray`), a Pillow image, or an array:
        ``(H, W)`` gray or ``(H, W, 3|4)`` RGB(A). Integer arrays are scaled
        by their bit depth (uint8 by 255, uint16 by 65535); float arrays must
        already lie in [0, 1] with 1 = white; bool arrays are 0/1.
    invert : bool, optional
        Return ``1 - gray``.
    allow_large : bool, optional
        Passed to :func:`load_gray` for paths.
    copy : bool, optional
        False: a C-ordered float64 gray array in [0, 1] comes back as it is,
        not copied (the caller then must not change it while the result is
        in use); every other input still makes a new array.

    Examples
    --------
    >>> import numpy as np
    >>> to_gray(np.array([[0, 255]], dtype=np.uint8))
    array([[0., 1.]])
    >>> g = np.array([[0.25, 1.0]])
    >>> to_gray(g) is g, to_gray(g, copy=False) is g
    (False, True)
    """
    if isinstance(image, (str, os.PathLike)):
        return load_gray(image, invert=invert, allow_large=allow_large)
    try:
        from PIL import Image, ImageOps  # not loaded at start-up

        if isinstance(image, Image.Image):
            return _pil_to_gray(ImageOps.exif_transpose(image), invert=invert)
    except ImportError:  # pragma: no cover - Pillow is a dependency
        pass
    g = _array_to_gray(image, copy=copy)
    return 1.0 - g if invert else g


def adjust_tone(gray, *, black=0.0, white=1.0, gamma=1.0, copy=True):
    """Tone controls before stippling, for every schedule: black and white point, gamma.

    Gray levels at or below ``black`` become 0 (full ink), at or above
    ``white`` 1 (blank paper: no dots there), linear in between, then raised
    to ``gamma`` (above 1: darker mid-tones, more dots; below 1: lighter).
    The input is not modified, unless `copy` is False and it is a float64
    array: then it is adjusted in place and returned (with the identity
    controls 0, 1, 1 that only clips it to [0, 1]).

    Examples
    --------
    >>> adjust_tone(np.array([0.1, 0.5, 0.95]), black=0.1, white=0.9)
    array([0. , 0.5, 1. ])
    >>> adjust_tone(np.array([0.25, 1.0]), gamma=0.5)
    array([0.5, 1. ])
    """
    if not 0.0 <= black < white <= 1.0:
        raise ValueError(f"the tone needs 0 <= black point < white point <= 1, got black "
                         f"{black:g} and white {white:g}")
    if not 0.0 < gamma < float("inf"):
        raise ValueError(f"the tone gamma must be a finite number > 0, got {gamma:g}")
    g = np.array(gray, dtype=np.float64) if copy else np.asarray(gray, dtype=np.float64)
    if black != 0.0:
        g -= black
    if white - black != 1.0:
        g /= white - black
    np.clip(g, 0.0, 1.0, out=g)
    if gamma != 1.0:
        g **= gamma   # numpy's operator, as g**gamma (square and square root by their own ufuncs)
    return g


_TONE = "tone (before stippling, on every schedule; in --json params.tone)"


@dataclass(frozen=True)
class ToneOptions:
    """The tone controls of :func:`adjust_tone`, as options.

    Examples
    --------
    >>> ToneOptions(black_point=0.1, white_point=0.9).adjust(np.array([0.1, 0.5, 0.95]))
    array([0. , 0.5, 1. ])
    >>> ToneOptions(black_point=0.6, white_point=0.5)
    Traceback (most recent call last):
    ...
    diskpack_cl.options.OptionConflict: black_point 0.6 must be below white_point 0.5
    """

    black_point: float = option(0.0, "gray levels at or below B (0 black .. 1 white) get full "
                                "ink (default 0)", lo=0, hi=1, metavar="B", group=_TONE)
    white_point: float = option(1.0, "gray levels at or above W are blank paper, no dots "
                                "(default 1)", lo=0, hi=1, metavar="W", group=_TONE)
    tone_gamma: float = option(1.0, "contrast: the levels between the points are raised to G "
                               "(above 1: darker mid-tones, below 1: lighter; default 1)",
                               lo=0, lo_open=True, metavar="G", group=_TONE)

    def __post_init__(self):
        check_fields(self)
        if not self.black_point < self.white_point:
            raise OptionConflict(f"{{}} {self.black_point:g} must be below {{}} "
                                 f"{self.white_point:g}", "black_point", "white_point")

    def params(self):
        """The keyword arguments of :func:`adjust_tone` (recorded as ``params["tone"]``)."""
        return {"black": self.black_point, "white": self.white_point, "gamma": self.tone_gamma}

    def adjust(self, gray, copy=True):
        """``gray`` with these tone controls (:func:`adjust_tone`; `copy` False: in place)."""
        return adjust_tone(gray, **self.params(), copy=copy)
