"""Image input: formats, bit depths, colour, EXIF, alpha, errors."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from diskpack_cl.image import adjust_tone, load_gray, sample_image_path, to_gray

DATA = Path(__file__).parent / "data"


def test_sample_image():
    p = sample_image_path()
    assert p.is_file()
    g = load_gray(p)
    assert g.shape == (512, 512) and g.dtype == np.float64
    assert 0.0 <= g.min() < 0.1 and 0.9 < g.max() <= 1.0


@pytest.mark.parametrize("name", ["astronaut.png", "coffee.png", "camera.png"])
def test_test_photographs(name):
    g = load_gray(DATA / name)
    assert g.shape == (512, 512)
    assert g.std() > 0.1


def test_8_and_16_bit(tmp_path):
    a8 = np.arange(256, dtype=np.uint8).reshape(16, 16)
    Image.fromarray(a8).save(tmp_path / "g8.png")
    # exactly the quotients (a product with 1/255 differs in the last bit for 24 of the 256 levels)
    np.testing.assert_array_equal(load_gray(tmp_path / "g8.png"), a8 / 255.0)
    a16 = (np.arange(256, dtype=np.uint16) * 257 + 3).reshape(16, 16)
    for ext in ("png", "tif"):
        Image.fromarray(a16).save(tmp_path / f"g16.{ext}")
        np.testing.assert_allclose(load_gray(tmp_path / f"g16.{ext}"), a16 / 65535.0)


def test_rgb_luma_bt601_and_jpeg(tmp_path):
    rgb = np.zeros((4, 6, 3), np.uint8)
    rgb[..., 0], rgb[..., 1], rgb[..., 2] = 200, 100, 50
    Image.fromarray(rgb).save(tmp_path / "c.png")
    expected = (0.299 * 200 + 0.587 * 100 + 0.114 * 50) / 255
    np.testing.assert_allclose(load_gray(tmp_path / "c.png"), expected)
    Image.fromarray(rgb).save(tmp_path / "c.jpg", quality=95)
    np.testing.assert_allclose(load_gray(tmp_path / "c.jpg"), expected, atol=0.02)


def test_alpha_over_white(tmp_path):
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[0, 0] = (0, 0, 0, 255)
    rgba[0, 1] = (0, 0, 0, 0)
    rgba[1, :] = (0, 0, 0, 51)
    Image.fromarray(rgba).save(tmp_path / "a.png")
    np.testing.assert_allclose(load_gray(tmp_path / "a.png"), [[0.0, 1.0], [0.8, 0.8]])


def test_palette_and_bilevel(tmp_path):
    a = np.zeros((8, 8), np.uint8)
    a[:, 4:] = 255
    Image.fromarray(a).convert("1").save(tmp_path / "b.png")
    Image.fromarray(a).convert("P").save(tmp_path / "p.gif")
    for f in ("b.png", "p.gif"):
        np.testing.assert_array_equal(load_gray(tmp_path / f), a / 255.0)


def test_exif_orientation(tmp_path):
    a = np.zeros((10, 20), np.uint8)
    a[:, :5] = 255  # white band on the left
    im = Image.fromarray(a)
    exif = im.getexif()
    exif[0x0112] = 6  # rotate 90 degrees clockwise to display
    im.save(tmp_path / "o.jpg", exif=exif, quality=100)
    g = load_gray(tmp_path / "o.jpg")
    assert g.shape == (20, 10)
    assert g[:5].mean() > 0.9 and g[10:].mean() < 0.1  # the band is now on top


def test_invert(tmp_path):
    a = np.array([[0, 255]], np.uint8)
    Image.fromarray(a).save(tmp_path / "i.png")
    np.testing.assert_array_equal(load_gray(tmp_path / "i.png", invert=True), [[1.0, 0.0]])


def test_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="image file not found"):
        load_gray(tmp_path / "nope.png")
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(ValueError, match="empty"):
        load_gray(tmp_path / "empty.png")
    (tmp_path / "text.png").write_text("hello, not an image")
    with pytest.raises(ValueError, match="not an image Pillow can read"):
        load_gray(tmp_path / "text.png")
    data = sample_image_path().read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 3])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        load_gray(tmp_path / "cut.png")
    with pytest.raises(ValueError, match="directory"):
        load_gray(tmp_path)


def test_decompression_bomb_limit(tmp_path, monkeypatch):
    Image.fromarray(np.zeros((40, 40), np.uint8)).save(tmp_path / "big.png")
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 1000)  # 1600 px: warning zone
    with pytest.raises(ValueError, match="decompression-bomb limit"):
        load_gray(tmp_path / "big.png")
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 500)  # > 2x: Pillow's error
    with pytest.raises(ValueError, match="allow_large"):
        load_gray(tmp_path / "big.png")
    assert load_gray(tmp_path / "big.png", allow_large=True).shape == (40, 40)
    assert Image.MAX_IMAGE_PIXELS == 500  # restored


def test_to_gray_arrays():
    np.testing.assert_array_equal(to_gray(np.array([[0, 65535]], np.uint16)), [[0.0, 1.0]])
    np.testing.assert_array_equal(to_gray(np.array([[True, False]])), [[1.0, 0.0]])
    a = np.array([[0.25, 0.5]])
    g = to_gray(a)
    np.testing.assert_array_equal(g, a)
    assert not np.may_share_memory(g, a)
    with pytest.raises(ValueError, match="zero size"):
        to_gray(np.zeros((0, 5)))
    with pytest.raises(ValueError, match="finite"):
        to_gray(np.array([[np.nan]]))
    with pytest.raises(ValueError, match="shape"):
        to_gray(np.zeros((2, 2, 5)))
    assert to_gray(Image.new("RGB", (3, 2), (255, 255, 255))).shape == (2, 3)


@pytest.mark.parametrize("controls", [{}, {"black": 0.2}, {"white": 0.5}, {"gamma": 2.0},
                                      {"black": 0.1, "white": 0.9, "gamma": 0.5}])
def test_adjust_tone_in_place_equals_the_copy(controls):
    g = np.random.default_rng(0).random((20, 30))
    g[0, :3] = 0.0, 1.0, 0.5
    kept = g.copy()
    new = adjust_tone(g, **controls)
    np.testing.assert_array_equal(g, kept)              # the input is left as it was
    same = adjust_tone(g, **controls, copy=False)
    assert same is g                                     # in place, no second image
    np.testing.assert_array_equal(same, new)
    if not controls:
        np.testing.assert_array_equal(same, kept)        # the identity controls change nothing


@settings(max_examples=40)
@given(h=st.integers(1, 40), w=st.integers(1, 30), bands=st.sampled_from([0, 2, 3, 4]),
       part=st.integers(1, 2000), seed=st.integers(0, 2**16))
def test_uint8_gray_in_bands_is_the_whole_arrays(h, w, bands, part, seed):
    """The uint8 pixels made float64 in row bands on the cores: the values of the whole array
    cast and divided at once, whatever the bands."""
    from diskpack_cl.image import _uint8_gray

    shape = (h, w) if bands == 0 else (h, w, bands)
    a = np.random.default_rng(seed).integers(0, 256, shape, dtype=np.uint8)
    got = _uint8_gray(a, part=part)
    assert got.dtype == np.float64 and got.shape == a.shape
    np.testing.assert_array_equal(got, a.astype(np.float64) / 255.0)


# -- the smallest array of a picture ---------------------------------------------

def _picture_file(tmp_path, mode, seed):
    """A small image file of `mode`, with random pixels (and a few pure black and white ones)."""
    rng = np.random.default_rng(seed)
    h, w = 7 + seed % 5, 9 + seed % 3
    if mode == "I;16":
        im = Image.fromarray(rng.integers(0, 65536, (h, w), dtype=np.uint16))
    else:
        bands = {"L": 1, "LA": 2, "RGB": 3, "RGBA": 4, "P": 3, "1": 1}[mode]
        a = rng.integers(0, 256, (h, w, bands), dtype=np.uint8)
        a[0, 0], a[-1, -1] = 0, 255
        im = Image.fromarray(a[..., 0] if bands == 1 else a,
                             "L" if bands == 1 else {2: "LA", 3: "RGB", 4: "RGBA"}[bands])
        if mode in ("P", "1"):
            im = im.convert(mode)
    path = tmp_path / f"{mode.replace(';', '_')}_{seed}.png"
    im.save(path)
    return path


@pytest.mark.parametrize("mode", ["L", "LA", "RGB", "RGBA", "P", "1", "I;16"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_load_picture_gives_load_grays_gray_bit_for_bit(tmp_path, mode, seed):
    """load_picture keeps 8-bit gray and RGB(A) files as uint8 (the float gray left to the
    stippling); to_gray of it is load_gray's gray to the bit, and so is every strip of
    gray_strips."""
    from diskpack_cl.image import gray_strips, load_picture

    path = _picture_file(tmp_path, mode, seed)
    pic, gray = load_picture(path), load_gray(path)
    assert pic.dtype == (np.uint8 if mode in ("L", "LA", "RGB", "RGBA") else np.float64)
    assert np.array_equal(to_gray(pic, copy=False), gray)
    shape, strips = gray_strips(pic, rows=3)
    assert shape == gray.shape
    assert np.array_equal(np.concatenate([s for _, s in strips]), gray)
