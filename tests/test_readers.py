"""read_stipple's rules, each refused with a message that names the value, and the writers'
check (check_stippling): what a reader refuses is not written."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from diskpack_cl.drawing.writers import read_stipple, write_npz, write_stipple

W, H = 40, 30


def _stippling(color=True):
    gx, gy = np.meshgrid(5.0 + 10 * np.arange(4), 5.0 + 10 * np.arange(3))
    points = np.column_stack([gx.ravel(), gy.ravel()])
    res = SimpleNamespace(points=points, radii=np.full(len(points), 2.0), width=W, height=H,
                          k=0.5, tone_radius=1.5, params={"invert": False})
    if color:
        res.pen = np.arange(len(points)) % 2
        res.names, res.colors = ("red", "blue"), np.array([[1.0, 0, 0], [0, 0, 1.0]])
        res.pen_radius = np.array([1.0, 1.2])
    return res


def _refused(path, *words):
    with pytest.raises(ValueError) as info:
        read_stipple(path)
    text = str(info.value)
    assert str(path) in text and "\n" not in text, text
    assert all(word in text for word in words), text


def _npz_with(tmp_path, **fields):
    path = tmp_path / "dots.npz"
    write_npz(path, _stippling())
    arrays = {k: v for k, v in np.load(path).items() if k not in fields or fields[k] is not None}
    arrays.update({k: v for k, v in fields.items() if v is not None})
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("fields, words", [
    ({"pen": np.array([0, 2] * 6)}, ["row 1", "pen index must be in [0, 2)", "got"]),
    ({"pen_names": np.array(["red", "red"])}, ["pen names must differ", "red, red"]),
    ({"pen_colors": np.array([[1.0, 0, 0], [0, 0, 1.5]])}, ["row 1", "[0, 1]", "1.5"]),
    ({"pen_colors": np.array([[1.0, 0, 0], [0, -0.2, 1.0]])}, ["row 1", "[0, 1]", "-0.2"]),
    ({"base_radii": np.ones(11)}, ["base_radii must have shape (12,)", "(11,)"]),
    ({"radii": np.array([2.0] * 11 + [0.0])}, ["row 11", "radius must be > 0", "got 0"]),
    ({"pen_names": None}, ["without pen_names"]),
    ({"pen_colors": None}, ["without pen_colors"]),
])
def test_npz_rules(tmp_path, fields, words):
    """Each rule named with its value: a pen index one past the last, repeated names, a
    colour outside [0, 1], base_radii of another length, a zero radius, a missing field
    named as itself (not as the next one checked)."""
    _refused(_npz_with(tmp_path, **fields), *words)


def _csv(tmp_path, edit):
    path = tmp_path / "dots.csv"
    write_stipple(path, _stippling())
    text = path.read_text()
    assert edit(text) != text   # the edit applies
    path.write_text(edit(text))
    return path


@pytest.mark.parametrize("edit, words", [
    (lambda t: t.replace("invert=0", "invert=0.5"), ["invert must be 0 or 1, got 0.5"]),
    (lambda t: t.replace(",blue\n", ",purple\n", 1), ["row 1", "red, blue", "'purple'"]),
    (lambda t: t.replace("5,5,2,red", "5,5,0,red"), ["row 0", "radius must be > 0, got 0"]),
    (lambda t: t.replace("pen_radius=1;", "pen_radius=-1;"), ["pen_radius", "-1"]),
])
def test_colour_csv_rules(tmp_path, edit, words):
    """A bad pen is reported by its name (not by the row's radius)."""
    _refused(_csv(tmp_path, edit), *words)


def test_bad_pen_message_shows_the_pen_not_the_radius(tmp_path):
    path = _csv(tmp_path, lambda t: t.replace(",blue\n", ",purple\n", 1))
    with pytest.raises(ValueError) as info:
        read_stipple(path)
    assert "got 2" not in str(info.value)   # the row's radius


def test_a_colour_csv_says_its_paper_and_pen_radii(tmp_path):
    path = tmp_path / "dots.csv"
    write_stipple(path, _stippling())
    head = path.read_text().splitlines()[0]
    assert " invert=0 " in head and head.endswith(" pen_radius=1;1.2")
    back = read_stipple(path)
    assert back.params == {"invert": False} and back.pen_radius.tolist() == [1.0, 1.2]


def _cmyk(res):
    res.pen = np.arange(len(res.points)) % 4
    res.names = ("yellow", "cyan", "magenta", "black")
    res.colors = np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1], [0, 0, 0.0]])
    res.pen_radius = np.ones(4)
    return res


def test_white_paper_pens_said_to_be_for_black_paper_are_refused(tmp_path):
    """A hand-edited invert=1 on a CMYK stippling: refused by every reader, as the writers
    refuse to draw CMYK pens on black."""
    csv = tmp_path / "cmyk.csv"
    write_stipple(csv, _cmyk(_stippling()))
    csv.write_text(csv.read_text().replace("invert=0", "invert=1"))
    _refused(csv, "black paper", "cmyk is for white paper")
    npz = tmp_path / "cmyk.npz"
    write_npz(npz, _cmyk(_stippling()))
    arrays = dict(np.load(npz))
    arrays["params"] = np.asarray(json.dumps({"invert": True}))
    np.savez(npz, **arrays)
    _refused(npz, "black paper", "cmyk is for white paper")


@pytest.mark.parametrize("ext", [".svg", ".png", ".npz", ".csv"])
@pytest.mark.parametrize("field, value, words", [
    ("radii", -1.0, ["row 3", "radius must be > 0", "got -1"]),
    ("radii", 0.0, ["row 3", "radius must be > 0", "got 0"]),
    ("radii", np.nan, ["row 3", "finite", "nan"]),
    ("points", np.nan, ["row 3", "finite", "nan"]),
])
def test_writers_refuse_what_readers_refuse(tmp_path, ext, field, value, words):
    """A negative, zero or NaN size is not written (dots='packing' drew a negative radius)."""
    res = _stippling(color=False)
    getattr(res, field)[3] = value
    path = tmp_path / f"dots{ext}"
    with pytest.raises(ValueError) as info:
        write_stipple(path, res, **({} if ext in (".npz", ".csv") else {"dots": "packing"}))
    text = str(info.value)
    assert str(path) in text and "not written" in text and all(w in text for w in words), text
    assert not path.exists()


def test_writers_of_the_packing_certify_it(tmp_path):
    """Overlapping disks without a certificate (a stippling read from an .svg) are not
    written to the formats that hold the packing."""
    res = _stippling(color=False)
    res.points[1] = res.points[0] + 1.0
    for ext in (".npz", ".csv"):
        with pytest.raises(ValueError, match=r"not written .*rows 0 and 1: the dots overlap.*"
                                             r"not packing disks \(an \.svg holds the dots"):
            write_stipple(tmp_path / f"dots{ext}", res)
    write_stipple(tmp_path / "dots.svg", res, dots="packing")   # a drawing may overlap
