"""Every door: no output replaces an input, every reader checks what it reads, names are
escaped in every SVG, messages are one line."""

import functools
import importlib
import os
import re
import shutil
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from diskpack_cl import cli
from diskpack_cl.domain import Domain
from diskpack_cl.drawing.writers import write_stipple, write_svg
from diskpack_cl.geometry import certify_disks
from diskpack_cl.image import sample_image_path
from diskpack_cl.io import read_points, write_points
from diskpack_cl.drawing.readers import read_stipple


def _run(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a computation or a reader starts."""
    def not_called(*args, **kwargs):
        raise AssertionError("the work started although an output is an input")

    # the subcommand's own name first (imported here with the real one: imported under the
    # patch of reports.analyze, it kept the stub for the later tests)
    for module, name in [("diskpack_cl.cli.analyze", "analyze"),
                         ("diskpack_cl.jobs.items", "stipple"), ("diskpack_cl.jobs.items", "relax_poisson"),
                         ("diskpack_cl.poisson", "poisson_disk"), ("diskpack_cl.jobs.batch", "run_batch"),
                         ("diskpack_cl.drawing.writers", "read_stipple"), ("diskpack_cl.reports", "analyze")]:
        monkeypatch.setattr(importlib.import_module(module), name, not_called)


def _stippling(n=16, w=40, h=30):
    """A small certified stippling: a grid of disjoint disks inside the picture."""
    gx, gy = np.meshgrid(np.linspace(4, w - 4, 4), np.linspace(4, h - 4, n // 4))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    radii = np.full(len(pts), 1.5)
    return SimpleNamespace(points=pts, radii=radii, width=w, height=h, k=0.5, tone_radius=1.0,
                           certificate=certify_disks(pts, radii, Domain.rect(w, h)),
                           params={"n": n})


# ------------------------------------------------------------ outputs never replace inputs

@pytest.fixture
def photo(tmp_path):
    path = tmp_path / "photo.png"
    shutil.copy(sample_image_path(), path)
    return path


def _unchanged(path, before):
    assert path.read_bytes() == before


def _refused(rc, err, *names):
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "would replace the input" in lines[0], err
    assert all(name in lines[0] for name in names), err
    assert "Traceback" not in err


def test_stipple_output_is_its_input(photo, no_work, capsys):
    before = photo.read_bytes()
    rc, _, err = _run(["stipple", str(photo), "-n", "500", "-o", str(photo)], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)


def test_stipple_output_reaches_its_input_through_a_symlink_and_a_hard_link(photo, no_work,
                                                                           capsys):
    before = photo.read_bytes()
    (photo.parent / "link.png").symlink_to(photo)
    os.link(photo, photo.parent / "hard.png")
    for out in ("link.png", "hard.png", "./sub/../photo.png"):
        (photo.parent / "sub").mkdir(exist_ok=True)
        rc, _, err = _run(["stipple", str(photo), "-n", "500", "-o",
                           str(photo.parent / "a.svg"), "-o", f"{photo.parent}/{out}"], capsys)
        _refused(rc, err, out.split("/")[-1])
    _unchanged(photo, before)
    assert not (photo.parent / "a.svg").exists()


def test_stipple_batch_template_over_its_inputs(photo, no_work, capsys):
    shutil.copy(photo, photo.parent / "second.png")
    before = photo.read_bytes()
    rc, _, err = _run(["stipple", str(photo.parent), "-n", "500", "-o",
                       str(photo.parent / "{stem}.png")], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)
    assert not (photo.parent / "manifest.jsonl").exists()


def test_relax_output_is_a_hard_link_of_its_input(tmp_path, no_work, capsys):
    src = tmp_path / "a.npz"
    write_points(src, np.random.default_rng(0).random((64, 2)))
    os.link(src, tmp_path / "b.npz")
    before = src.read_bytes()
    for out in (src, tmp_path / "b.npz"):
        rc, _, err = _run(["relax", str(src), "-o", str(out), "-q"], capsys)
        _refused(rc, err, str(out))
    rc, _, err = _run(["relax", str(src), str(tmp_path / "b.npz"), "-o",
                       str(tmp_path / "{stem}.npz"), "-q"], capsys)
    _refused(rc, err)
    _unchanged(src, before)


@pytest.mark.parametrize("ext", [".npz", ".csv"])
def test_export_output_is_its_input(tmp_path, no_work, capsys, ext):
    src = tmp_path / f"dots{ext}"
    write_stipple(src, _stippling())
    before = src.read_bytes()
    rc, _, err = _run(["export", str(src), "-o", str(tmp_path / "a.svg"), "-o", str(src)],
                      capsys)
    _refused(rc, err, src.name)
    _unchanged(src, before)


def test_analyze_report_over_its_image(tmp_path, photo, no_work, capsys):
    src = tmp_path / "dots.npz"
    write_stipple(src, _stippling())
    before = photo.read_bytes()
    rc, _, err = _run(["analyze", str(src), "--image", str(photo), "-o", str(photo)], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)


@pytest.mark.parametrize("flag", ["--init", "--mask", "--density"])
def test_poisson_output_is_its_start_or_field_file(tmp_path, no_work, capsys, flag):
    src = tmp_path / "start.npz"
    write_points(src, np.random.default_rng(0).random((64, 2)))
    before = src.read_bytes()
    rc, _, err = _run(["poisson", flag, str(src), "-o", str(src), "-q"], capsys)
    _refused(rc, err, "start.npz")
    _unchanged(src, before)


# ------------------------------------------------------------ readers check what they read

def _color_stippling():
    res = _stippling()
    res.pen = np.arange(len(res.points)) % 2
    res.names = ("a b", "c<d>&\"e\":;=%")
    res.colors = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    res.pen_radius = np.array([1.0, 1.2])
    return res


def _refuses(path, *words):
    with pytest.raises(ValueError) as info:
        read_stipple(path)
    text = str(info.value)
    assert str(path) in text and "\n" not in text and "allow_pickle" not in text, text
    assert all(word in text for word in words), text


CSV_HEAD = "# diskpack_cl stippling width=40 height=30\n"


@pytest.mark.parametrize("body, words", [
    ("x,y,r\n5,5,1\n10,5,-0.79\n", ["row 1", "radius", "> 0"]),
    ("x,y,r\n5,5,1\n10,5,inf\n", ["row 1", "finite"]),
    ("x,y,r\n5,5,1\nnan,5,1\n", ["row 1", "finite"]),
    ("x,y,r\n5,5,1\n45,5,1\n", ["row 1", "outside"]),
    ("x,y,r\n5,5,1\n1e308,1e308,1\n", ["row 1", "outside"]),
    ("x,y,r\n5,5,1\n0.5,9,1\n", ["row 1", "sticks out"]),
    ("x,y,r\n5,5,1\n6,5,1\n", ["rows 0 and 1", "overlap"]),
    ("x,y,r\n5,5,1,4\n10,5,1,4\n", ["header", "3 columns", "4 values"]),
    ("x,y\n5,5\n", ["header", "x,y,r"]),
])
def test_csv_reader_names_the_row_and_the_rule(tmp_path, body, words):
    path = tmp_path / "dots.csv"
    path.write_text(CSV_HEAD + body)
    _refuses(path, *words)


@pytest.mark.parametrize("tag", ["width=0 height=30", "width=-4 height=30", "width=40 height=nan",
                                 "width=40.5 height=30", "width=40 height"])
def test_csv_reader_refuses_a_picture_without_a_size(tmp_path, tag):
    path = tmp_path / "dots.csv"
    path.write_text(f"# diskpack_cl stippling {tag}\nx,y,r\n5,5,1\n")
    _refuses(path)


def test_csv_with_a_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "dots.csv"
    write_stipple(path, _stippling())
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert read_stipple(path).width == 40
    points = tmp_path / "points.csv"
    points.write_bytes(b"\xef\xbb\xbfx,y\n0.25,0.5\n0.75,0.5\n")
    assert read_points(points).tolist() == [[0.25, 0.5], [0.75, 0.5]]


def test_point_csv_rows_must_match_the_header(tmp_path):
    path = tmp_path / "points.csv"
    path.write_text("x,y,r\n0.1,0.2,0.01,7\n0.3,0.4,0.01,7\n")
    with pytest.raises(ValueError, match=r"points\.csv: .*header names 3 columns"):
        read_points(path)


def test_npz_reader_refuses_what_the_certificate_refuses(tmp_path):
    res = _stippling()
    res.points[1] = res.points[0] + 0.5        # two dots on each other
    path = tmp_path / "dots.npz"
    from diskpack_cl.drawing.writers import write_npz
    write_npz(path, res)
    _refuses(path, "rows 0 and 1", "overlap", "certificate")


@pytest.mark.parametrize("field, value, words", [
    ("pen", np.array([0, 5] * 8), ["row 1", "pen index"]),
    ("width", np.array(0), ["width"]),
    ("radii", np.full(16, -1.0), ["row 0", "radius"]),
    ("points", np.zeros((16, 3)), ["points", "(n, 2)"]),
    ("radii", np.array(["a"] * 16), ["radii", "numbers"]),
])
def test_npz_reader_checks_every_field(tmp_path, field, value, words):
    from diskpack_cl.drawing.writers import write_npz
    path = tmp_path / "dots.npz"
    write_npz(path, _color_stippling())
    arrays = dict(np.load(path))
    arrays[field] = value
    np.savez(path, **arrays)
    _refuses(path, *words)


@pytest.mark.parametrize("content, words", [
    (b"PK\x03\x04", ["truncated"]), (b"\x93NUMPY not a zip", ["not a numpy .npz"]),
    (b"", ["not a numpy .npz"])])
def test_npz_that_is_no_zip_or_truncated(tmp_path, content, words):
    path = tmp_path / "dots.npz"
    path.write_bytes(content)
    _refuses(path, *words)
    with pytest.raises(ValueError, match="dots.npz") as info:
        read_points(path)
    assert "allow_pickle" not in str(info.value)


def _svg_text(tmp_path):
    path = tmp_path / "dots.svg"
    write_stipple(path, _stippling(), width_mm=80, dots="packing")
    return path, path.read_text()


@pytest.mark.parametrize("edit, words", [
    (lambda t: t.replace('<metadata id="diskpack_cl">{', '<metadata id="diskpack_cl">{{'),
     ["<metadata>", "JSON"]),
    (lambda t: t.replace('<metadata id="diskpack_cl">{', '<metadata id="diskpack_cl">[{')
              .replace("}</metadata>", "}]</metadata>"), ["JSON object", "list"]),
    (lambda t: t.replace('"mm_per_px": ', '"mm_per_px": -'), ["mm_per_px", "> 0"]),
    (lambda t: t.replace('"width": 40', '"width": "40"'), ["width"]),
    (lambda t: t.replace('<circle cx=', '<circle x=', 1), ["element 0", "cx"]),
    (lambda t: t.replace('<circle cx="', '<circle cx="-', 1), ["row 0", "outside"]),
])
def test_svg_reader_checks_its_metadata_and_dots(tmp_path, edit, words):
    path, text = _svg_text(tmp_path)
    path.write_text(edit(text))
    _refuses(path, *words)


def test_svg_with_an_unknown_encoding_is_refused(tmp_path):
    path, text = _svg_text(tmp_path)
    path.write_text(text.replace('encoding="UTF-8"', 'encoding="UTFnan"'))
    _refuses(path, "unreadable .svg file")


def test_export_refuses_overlapping_dots_in_one_line(tmp_path, capsys):
    path = tmp_path / "dots.csv"
    path.write_text(CSV_HEAD + "x,y,r\n5,5,1\n6,5,1\n")
    rc, _, err = _run(["export", str(path), "-o", str(tmp_path / "a.svg")], capsys)
    assert rc == 1 and len(err.strip().splitlines()) == 1 and "overlap" in err, err
    assert not (tmp_path / "a.svg").exists()


def test_analyze_refuses_a_point_archive_that_is_no_zip(tmp_path, capsys):
    path = tmp_path / "points.npz"
    path.write_bytes(b"\x93NUMPY not a zip")
    rc, _, err = _run(["analyze", str(path), "--json"], capsys)
    assert rc == 1 and "points.npz" in err and "allow_pickle" not in err, err
    assert len(err.strip().splitlines()) == 1, err


def test_relax_init_file_is_checked(tmp_path, capsys):
    path = tmp_path / "start.csv"
    path.write_text("x,y\n0.1,0.2\nnan,0.4\n0.5,0.5\n")
    rc, _, err = _run(["poisson", "--init", str(path), "-o", str(tmp_path / "o.npz"), "-q"],
                      capsys)
    assert rc == 1 and "start.csv" in err and "row 1" in err and "Traceback" not in err, err


# -------------------------------------------------- every reader, corrupted and random files

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

#: What the files are made of: the readers, the formats and a valid file of each.
STIPPLE_FILES = ["dots.npz", "dots.csv", "dots.svg", "pens.npz", "pens.csv", "pens.svg"]
POINT_FILES = ["points.npz", "points.npy", "points.csv", "points.txt"]
TOKENS = ["nan", "inf", "-inf", "-1", "0", "1e308", "-1e308", "1e999", "abc", "", "7,7",
          "\ufeff", "\x00", "[]", "{}", "null", "true", "\"x\"", "<", "&", "4.5e-320"]


@functools.lru_cache(maxsize=None)
def _valid_files():
    """The bytes of a valid file of each kind (not a fixture: hypothesis would print it)."""
    folder = Path(tempfile.mkdtemp())
    for name in STIPPLE_FILES:
        res = _color_stippling() if name.startswith("pens") else _stippling()
        write_stipple(folder / name, res, **({"width_mm": 80} if name.endswith(".svg") else {}))
    for name in POINT_FILES:
        write_points(folder / name, np.random.default_rng(1).random((12, 2)))
    files = {name: (folder / name).read_bytes() for name in STIPPLE_FILES + POINT_FILES}
    shutil.rmtree(folder)
    return files


@st.composite
def corrupted(draw, data):
    """`data` with one to three corruptions: cut, bytes overwritten, a number or field
    replaced, a column added, a byte-order mark, lines dropped or repeated."""
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["cut", "bytes", "token", "column", "bom", "lines"]))
        if kind == "cut":
            data = data[:draw(st.integers(0, max(len(data) - 1, 0)))]
        elif kind == "bytes":
            at = draw(st.integers(0, len(data)))
            data = data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at + 8:]
        elif kind == "bom":
            data = b"\xef\xbb\xbf" + data
        else:
            text = data.decode("utf-8", "replace")
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            if kind == "column":
                lines[i] += "," + draw(st.sampled_from(TOKENS))
            elif kind == "lines":
                lines = lines[:i] + lines[i:i + 1] * draw(st.integers(0, 3)) + lines[i + 1:]
            else:
                numbers = list(re.finditer(r"-?[0-9.]+(?:e-?[0-9]+)?|true|false|null|\"[a-z_]+\"",
                                           lines[i]))
                if numbers:
                    m = numbers[draw(st.integers(0, len(numbers) - 1))]
                    lines[i] = lines[i][:m.start()] + draw(st.sampled_from(TOKENS)) + lines[i][m.end():]
            data = "\n".join(lines).encode("utf-8", "replace")
    return data


def _read_or_refuse(read, path):
    """A result, or a ValueError of one line naming the file: nothing else may come out."""
    try:
        return read(path)
    except ValueError as exc:
        assert path.name in str(exc) and "\n" not in str(exc), str(exc)
        return None


@settings(max_examples=300)
@given(st.data())
def test_every_reader_gives_a_result_or_a_value_error_naming_the_file(tmp_path, data):
    name = data.draw(st.sampled_from(STIPPLE_FILES + POINT_FILES))
    path = tmp_path / f"case-{name}"
    path.write_bytes(data.draw(corrupted(_valid_files()[name])))
    if name in STIPPLE_FILES:
        res = _read_or_refuse(read_stipple, path)
        if res is not None and not name.endswith(".svg"):   # what comes out is a packing
            assert certify_disks(res.points, res.radii, Domain.rect(res.width, res.height)).valid
    else:
        res = _read_or_refuse(read_points, path)
        if res is not None:
            assert np.isfinite(res).all() and res.shape[1] == 2


ARRAYS = st.one_of(
    st.sampled_from([np.array(np.nan), np.array(np.inf), np.array(-1.0), np.array(1e308),
                     np.array(0), np.array("x"), np.array([1.0, 2.0]), np.zeros((16, 3)),
                     np.full(16, np.nan), np.full(16, 1e308), np.full((16, 2), -5.0),
                     np.array([1 + 2j]), np.zeros(0), np.arange(16) - 3, np.array(True)]),
    st.builds(lambda n, v: np.full(n, v), st.integers(0, 20),
              st.floats(allow_nan=True, allow_infinity=True)))


@settings(max_examples=200)
@given(st.data())
def test_npz_readers_take_wrong_arrays_in_every_field(tmp_path, data):
    name = data.draw(st.sampled_from(["dots.npz", "pens.npz", "points.npz"]))
    path = tmp_path / f"case-{name}"
    path.write_bytes(_valid_files()[name])
    arrays = dict(np.load(path))
    for _ in range(data.draw(st.integers(1, 3))):
        arrays[data.draw(st.sampled_from(sorted(arrays)))] = data.draw(ARRAYS)
    np.savez(path, **arrays)
    res = _read_or_refuse(read_stipple if name != "points.npz" else read_points, path)
    if res is not None and name != "points.npz":
        assert certify_disks(res.points, res.radii, Domain.rect(res.width, res.height)).valid


# ------------------------------------------------------------------- names escaped in SVGs

NAMES = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
                min_size=1, max_size=12)


def _dot_pens(res):
    """The pen name of every dot, in any order (an SVG draws them pen by pen)."""
    return sorted(res.names[i] for i in res.pen)


def _pens_of(path):
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()   # well-formed XML, or this raises
    return [g.get("{http://www.inkscape.org/namespaces/inkscape}label")
            for g in root.iter("{http://www.w3.org/2000/svg}g")]


def test_pens_with_markup_in_their_names_give_well_formed_svg(tmp_path, capsys):
    from diskpack_cl.pens import parse_pens

    res = _color_stippling()
    res.names, res.colors = parse_pens("a b=#000,c<d>=#f00")
    for ext in (".svg", ".csv", ".npz"):
        write_stipple(tmp_path / f"dots{ext}", res, **({"width_mm": 80} if ext == ".svg" else {}))
        assert _dot_pens(read_stipple(tmp_path / f"dots{ext}")) == _dot_pens(res)
    assert sorted(_pens_of(tmp_path / "dots.svg")) == ["a b", "c<d>"]
    rc, _, err = _run(["export", str(tmp_path / "dots.npz"), "-o", str(tmp_path / "again.svg")],
                      capsys)
    assert rc == 0, err
    assert sorted(_pens_of(tmp_path / "again.svg")) == ["a b", "c<d>"]


@settings(max_examples=60)
@given(names=st.lists(NAMES, min_size=2, max_size=2, unique=True), layer=NAMES)
def test_every_name_that_can_be_written_reads_back(tmp_path, names, layer):
    res = _color_stippling()
    res.names = tuple(names)
    for ext in (".svg", ".csv", ".npz"):
        path = tmp_path / f"dots{ext}"
        try:
            write_stipple(path, res, **({"width_mm": 80} if ext == ".svg" else {}))
        except ValueError as exc:   # a name XML cannot carry is refused before writing
            assert ext == ".svg" and "cannot carry" in str(exc)
            continue
        assert _dot_pens(read_stipple(path)) == _dot_pens(res)
    mono = tmp_path / "mono.svg"
    try:
        write_svg(mono, _stippling(), width_mm=80, layer=layer)
    except ValueError as exc:
        assert "cannot carry" in str(exc)
    else:
        assert _pens_of(mono) == [layer]
        assert read_stipple(mono).points.shape == (16, 2)


@pytest.mark.parametrize("argv", [["relax", "loop.npz", "-o", "r.npz"],
                                  ["stipple", "loop.png", "-n", "100", "-o", "s.svg"],
                                  ["export", "loop.npz", "-o", "e.svg"]])
def test_a_symlink_loop_as_input_is_one_line(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    os.symlink(argv[1], tmp_path / argv[1])
    rc, _, err = _run(argv, capsys)
    assert rc == 1 and len(err.strip().splitlines()) == 1 and argv[1] in err, err


# ---------------------------------------------------------------------------- messages

@pytest.mark.parametrize("argv, words", [
    (["stipple", "sample", "-n", "200", "--pen-width", "3", "-o", "a.svg"], ["--pen-mm"]),
    (["poisson", "-n", "64", "--pens", "a", "-o", "a.npz"], ["unrecognized arguments: --pens"]),
    (["relax"], ["required"]),
    (["poisson", "-n", "1", "-o", "a.npz"], ["-n"]),
])
def test_usage_errors_are_one_line_without_the_usage(tmp_path, capsys, monkeypatch, argv, words):
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(argv, capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert "usage:" not in err and f"(see 'diskpack {argv[0]} --help')" in err, err
    assert all(word in err for word in words), err
    assert "did you mean --pens" not in err and "one of --pens," not in err


def test_a_report_given_twice_is_a_usage_error(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(["analyze", "a.npz", "-o", "a.pdf", "-o", "b.png"], capsys)
    assert rc == 2 and "-o given twice (a.pdf and b.png)" in err, err


def test_an_option_of_another_command_gets_no_wrong_neighbour(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(["stipple", "sample", "-n", "200", "--max-iter", "3", "-o", "a.svg"], capsys)
    assert rc == 2 and "did you mean" not in err, err


@pytest.mark.parametrize("text, n", [("20k", 20000), ("1.5M", 1500000), ("2G", 2 * 10**9),
                                     ("300", 300)])
def test_counts_take_k_and_m_suffixes(text, n):
    parser = cli.build_parser()
    assert parser.parse_args(["poisson", "-n", text, "-o", "a.npz"]).n == n
    assert parser.parse_args(["stipple", "x.png", "-n", text, "-o", "a.svg"]).n == n


@pytest.mark.parametrize("text", ["1.5x", "0.0005k", "k", "nank", "infM"])
def test_counts_that_are_no_whole_number_are_usage_errors(capsys, text):
    rc, _, err = _run(["poisson", "-n", text, "-o", "a.npz"], capsys)
    assert rc == 2 and "-n" in err and len(err.strip().splitlines()) == 1, err


def test_an_unknown_device_in_the_environment_is_an_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("DISKPACK_DEVICE", "nosuch")
    rc, _, err = _run(["poisson", "-n", "64", "-o", str(tmp_path / "a.npz"), "-q"], capsys)
    assert rc == 1 and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "a.npz").exists()


def test_ctrl_c_while_the_parser_is_built(monkeypatch, capsys):
    def interrupted(*_):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    rc, _, err = _run(["devices"], capsys)
    assert rc == 130 and err == "diskpack: error: interrupted, nothing written\n"


def test_ctrl_c_while_the_package_loads(tmp_path):
    import subprocess
    import sys
    import tomllib

    root = Path(__file__).parents[1]
    scripts = tomllib.loads((root / "pyproject.toml").read_text())["project"]["scripts"]
    module, func = scripts["diskpack"].split(":")
    code = (f"import sys\n"
            f"class Slow:\n"     # Ctrl-C arrives while diskpack_cl.cli is imported
            f"    def find_spec(self, name, path, target=None):\n"
            f"        if name == 'diskpack_cl.cli':\n"
            f"            raise KeyboardInterrupt\n"
            f"sys.meta_path.insert(0, Slow())\n"
            f"import {module}\n"
            f"sys.exit({module}.{func}())\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=root, timeout=300)
    assert run.returncode == 130, run.stderr
    assert run.stderr == "diskpack: error: interrupted, nothing written\n"


def test_help_paragraphs_are_wrapped(monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    parser = cli.build_parser()
    subcommands = next(a for a in parser._actions if a.choices and "stipple" in a.choices)
    for name, sub in subcommands.choices.items():
        long = [line for line in sub.format_help().splitlines()
                if len(line) > 80 and not line.lstrip().startswith("diskpack ")]
        assert not long, (name, long[0])


# ---------------------------------------------------------------------- sizes bounded

@pytest.mark.parametrize("flags, words", [
    (["--pen-mm", "1000"], ["pen", "1000 mm"]),
    (["--pen-mm", "300", "--width-mm", "200"], ["pen", "300 mm"]),
    (["--dot-mm", "500"], ["dots 500 mm wide"]),
    (["--dots", "packing", "--radius-scale", "1e6"], ["do not fit"]),
    (["--dots", "packing", "--radius-scale", "1e6"], ["do not fit", "px"]),
])
def test_drawn_sizes_that_leave_the_picture_are_refused(tmp_path, capsys, monkeypatch, flags,
                                                        words):
    monkeypatch.chdir(tmp_path)
    write_stipple("dots.npz", _stippling())
    out = "b.png" if "px" in words else "a.svg"
    rc, _, err = _run(["export", "dots.npz", "-o", out, *flags], capsys)
    assert rc == 1 and all(word in err for word in words), err
    assert sorted(os.listdir(tmp_path)) == ["dots.npz"]


def test_tone_dots_too_large_for_the_ink_are_refused_before_the_work(tmp_path, capsys,
                                                                      no_work):
    rc, _, err = _run(["stipple", "sample", "-n", "tone", "--dot-mm", "500", "-o",
                       str(tmp_path / "a.svg")], capsys)
    assert rc == 1 and "fewer than 2" in err, err


def test_a_plot_of_many_hours_is_announced_before_the_work(tmp_path, capsys, no_work):
    with pytest.raises(AssertionError, match="the work started"):
        cli.main(["stipple", "sample", "-n", "1000000", "-o", str(tmp_path / "a.svg")])
    assert "warning: 1000000 dots take at least 83 h to plot" in capsys.readouterr().err


# ------------------------------------------------------------------------ tests that end

def test_every_test_has_a_time_limit(request):
    assert float(request.config.getini("timeout")) > 0


def test_an_interrupted_batch_with_nothing_done_names_no_manifest(tmp_path, capsys, monkeypatch):
    """Interrupted before any item finished, a batch does not point to a manifest that does
    not exist."""
    import diskpack_cl.jobs.batch

    def interrupted(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(diskpack_cl.jobs.batch.Batch, "__iter__", interrupted)
    rc, _, err = _run(["poisson", "--count", "2", "-n", "50", "-o",
                       str(tmp_path / "sets" / "{i}.npz")], capsys)
    assert rc == 130 and "none had finished" in err and "manifest.jsonl" not in err
