import os

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from diskpack_cl.domain import Domain
from diskpack_cl.io import (POINT_FORMATS, OutputIsInputError, atomic_write, check_not_inputs,
                            check_points_path, read_points,
                            validate_points, write_points)

FORMATS = [".npz", ".npy", ".csv", ".txt", ".xy"]

finite = st.floats(allow_nan=False, allow_infinity=False, width=64,
                   min_value=-1e300, max_value=1e300)
point_arrays = st.integers(2, 40).flatmap(
    lambda n: arrays(np.float64, (n, 2), elements=finite))


def _leftovers(directory):
    return sorted(os.listdir(directory))


def test_formats_listed():
    assert set(POINT_FORMATS) == set(FORMATS)


@pytest.mark.parametrize("suffix", FORMATS)
@given(points=point_arrays)
def test_round_trip_exact(tmp_path_factory, suffix, points):
    path = tmp_path_factory.mktemp("rt") / f"pts{suffix}"
    write_points(path, points)
    back = read_points(path)
    assert back.dtype == np.float64 and back.shape == points.shape
    np.testing.assert_array_equal(back, points)
    assert _leftovers(path.parent) == [path.name]


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_upper_case_suffix_and_str_path(tmp_path, suffix):
    p = np.random.default_rng(0).random((5, 2))
    path = str(tmp_path / f"pts{suffix.upper()}")
    write_points(path, p)
    np.testing.assert_array_equal(read_points(path), p)


def test_npz_extra_arrays(tmp_path):
    p = np.random.default_rng(1).random((4, 2))
    path = tmp_path / "a.npz"
    write_points(path, p, rho=np.array([0.7, 0.8]), eps=0.8)
    with np.load(path) as z:
        assert sorted(z.files) == ["eps", "points", "rho"]
        np.testing.assert_array_equal(z["rho"], [0.7, 0.8])
    np.testing.assert_array_equal(read_points(path), p)


def test_csv_extra_columns_and_header(tmp_path):
    p = np.random.default_rng(2).random((3, 2))
    path = tmp_path / "a.csv"
    write_points(path, p, r=np.array([1.0, 2.0, 3.0]))
    assert path.read_text().splitlines()[0] == "x,y,r"
    np.testing.assert_array_equal(read_points(path), p)


def test_csv_header_in_other_column_order(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text("# comment\nr, Y, X\n9,0.2,0.1\n9,0.4,0.3\n")
    np.testing.assert_array_equal(read_points(path), [[0.1, 0.2], [0.3, 0.4]])


def test_headerless_csv_and_commented_txt(tmp_path):
    (tmp_path / "a.csv").write_text("0.1,0.2\n0.3,0.4\n")
    (tmp_path / "a.xy").write_text("# made by hand\n0.1 0.2  # first\n\n0.3\t0.4\n")
    for name in ("a.csv", "a.xy"):
        np.testing.assert_array_equal(read_points(tmp_path / name), [[0.1, 0.2], [0.3, 0.4]])


def test_read_returns_float64_from_integer_npy(tmp_path):
    np.save(tmp_path / "a.npy", np.array([[0, 1], [1, 0]], dtype=np.int32))
    got = read_points(tmp_path / "a.npy")
    assert got.dtype == np.float64


def test_write_does_not_mutate_input(tmp_path):
    p = np.random.default_rng(3).random((6, 2))
    before = p.copy()
    write_points(tmp_path / "a.txt", p)
    np.testing.assert_array_equal(p, before)


# ------------------------------------------------------------------ bad input

@pytest.mark.parametrize("name", ["pts.dat", "pts", "pts.npz.bak"])
def test_unknown_extension(tmp_path, name):
    path = tmp_path / name
    with pytest.raises(ValueError, match=r"unknown point file extension"):
        write_points(path, np.zeros((2, 2)))
    path.write_text("0 0\n1 1\n")
    with pytest.raises(ValueError, match=rf"{name}: unknown point file extension"):
        read_points(path)
    assert _leftovers(tmp_path) == [name]


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.npz: no such file"):
        read_points(tmp_path / "nope.npz")


def test_directory_is_not_a_point_file(tmp_path):
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(ValueError, match=r"d\.npz: not a regular file"):
        read_points(tmp_path / "d.npz")


@pytest.mark.parametrize("name, content, message", [
    ("a.npz", b"PK\x03\x04 broken zip", r"a\.npz: unreadable \.npz file"),
    ("b.npz", b"plain text", r"b\.npz: unreadable \.npz file"),
    ("c.npy", b"garbage", r"c\.npy: unreadable \.npy file: not a numpy array file"),
    ("d.txt", b"\xff\xfe\x00binary", r"d\.txt: unreadable \.txt file"),
    ("e.txt", b"x y\n1 2\n", r"e\.txt: malformed \.txt file: line 1 is not two numbers"),
    ("f.txt", b"1 2\n3 4 5\n", r"f\.txt: malformed \.txt file: the number of columns changed"),
    ("g.xy", b"1 2\n3 abc\n", r"g\.xy: malformed \.xy file"),
    ("h.csv", b"a,b\n1,2\n", r"h\.csv: malformed \.csv file: header must name columns x,y"),
    ("i.csv", b"x,y\n1,2\n3\n", r"i\.csv: malformed \.csv file"),
    ("j.txt", b"1 2 3\n4 5 6\n", r"j\.txt: points must have shape \(n, 2\), got \(2, 3\)"),
])
def test_malformed_files(tmp_path, name, content, message):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(ValueError, match=message):
        read_points(tmp_path / name)


def test_npz_without_points_key(tmp_path):
    np.savez(tmp_path / "a.npz", pts=np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"a\.npz: \.npz file has no array 'points' \(keys: pts\)"):
        read_points(tmp_path / "a.npz")


def test_npy_of_wrong_shape_and_object_dtype(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros(6))
    with pytest.raises(ValueError, match=r"a\.npy: points must have shape \(n, 2\), got \(6,\)"):
        read_points(tmp_path / "a.npy")
    np.save(tmp_path / "b.npy", np.array([[None, 1]], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"b\.npy: unreadable \.npy file"):
        read_points(tmp_path / "b.npy")


@pytest.mark.parametrize("suffix", [".csv", ".txt", ".npy"])
def test_too_few_points(tmp_path, suffix):
    path = tmp_path / f"one{suffix}"
    write_points(path, [[0.5, 0.5]])
    with pytest.raises(ValueError, match=r"one\.\w+: has 1 point, need at least 2"):
        read_points(path)
    assert read_points(path, min_points=1).shape == (1, 2)
    (tmp_path / "empty.txt").write_text("# nothing\n")
    with pytest.raises(ValueError, match=r"empty\.txt: has 0 points, need at least 2"):
        read_points(tmp_path / "empty.txt")


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_in_file(tmp_path, bad):
    path = tmp_path / "a.txt"
    path.write_text(f"0.1 0.2\n0.3 {bad}\n0.5 0.5\n")
    with pytest.raises(ValueError, match=r"a\.txt: 1 point has NaN or infinite coordinates \(first: row 1\)"):
        read_points(path)


def test_validate_points_errors():
    with pytest.raises(ValueError, match=r"points: 2 points have NaN or infinite coordinates \(first: row 0\)"):
        validate_points([[np.nan, 0], [0, np.inf], [0, 0]])
    with pytest.raises(ValueError, match=r"points must have shape \(n, 2\), got \(2, 3\)"):
        validate_points(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"has 3 points, need at least 4"):
        validate_points(np.zeros((3, 2)), min_points=4)
    with pytest.raises(ValueError, match=r"mine: points must be numeric"):
        validate_points([["a", "b"]], source="mine")
    with pytest.raises(ValueError, match=r"points must be numeric"):
        validate_points(np.zeros((2, 2), dtype=complex))


def test_validate_points_domain():
    p = np.array([[-0.5, 0.2], [3.0, 0.4], [0.5, 0.5]])
    assert validate_points(p, domain=Domain.torus()).shape == (3, 2)  # wrapped later
    with pytest.raises(ValueError, match=r"2 points lie outside the domain \[0, 2\] x \[0, 1\] \(first: row 0\)"):
        validate_points(p, domain=Domain.rect(2, 1))
    ok = validate_points([[0, 0], [2, 1]], domain=Domain.rect(2, 1))
    assert ok.dtype == np.float64 and ok.flags.c_contiguous
    # each bound alone: the height is not the width (a 2 x 1 box), and -0.0 is inside
    for row, msg in (([0.5, 1.5], "row 1"), ([1.5, -1e-300], "row 1"), ([2.5, 0.5], "row 1")):
        with pytest.raises(ValueError, match=rf"1 point lies outside the domain .*\(first: {msg}\)"):
            validate_points([[0.0, -0.0], row], domain=Domain.rect(2, 1))


@pytest.mark.parametrize("suffix", FORMATS)
def test_write_rejects_bad_points_and_leaves_nothing(tmp_path, suffix):
    path = tmp_path / f"a{suffix}"
    with pytest.raises(ValueError, match=r"NaN or infinite"):
        write_points(path, [[0.0, np.nan], [0.1, 0.2]])
    with pytest.raises(ValueError, match=r"shape \(n, 2\) or \(n, 3\)"):
        write_points(path, np.zeros((3, 4)))
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("suffix", [".npy", ".txt", ".xy"])
def test_extras_need_npz_or_csv(tmp_path, suffix):
    with pytest.raises(ValueError, match=r"hold points only; use \.npz or \.csv to also store rho"):
        write_points(tmp_path / f"a{suffix}", np.zeros((2, 2)), rho=[1.0])
    assert _leftovers(tmp_path) == []


def test_bad_extras(tmp_path):
    with pytest.raises(ValueError, match=r"extra column 'r' must have shape \(2,\), got \(3,\)"):
        write_points(tmp_path / "a.csv", np.zeros((2, 2)), r=[1, 2, 3])
    with pytest.raises(ValueError, match=r"'points' is reserved"):
        write_points(tmp_path / "a.npz", np.zeros((2, 2)), points=np.zeros((2, 2)))
    assert _leftovers(tmp_path) == []


def test_check_points_path(tmp_path):
    assert check_points_path("x.CSV") == ".csv"
    with pytest.raises(FileNotFoundError, match=r"output directory does not exist"):
        check_points_path(tmp_path / "missing" / "a.npz", for_writing=True)
    with pytest.raises(FileNotFoundError, match=r"output directory does not exist"):
        write_points(tmp_path / "missing" / "a.npz", np.zeros((2, 2)))


# -------------------------------------------------------------- atomic writes

def test_atomic_write_failure_keeps_old_file_and_leaves_no_part(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_write(path, "w") as fh:
            fh.write("partial new content")
            fh.flush()
            assert any(f.endswith(".part") for f in os.listdir(tmp_path))
            raise RuntimeError("boom")
    assert path.read_text() == "old"
    assert _leftovers(tmp_path) == ["a.txt"]


def test_atomic_write_interrupt_mid_write_leaves_nothing(tmp_path):
    path = tmp_path / "new.txt"
    with pytest.raises(KeyboardInterrupt):
        with atomic_write(path, "w") as fh:
            fh.write("half")
            raise KeyboardInterrupt
    assert _leftovers(tmp_path) == []


def test_write_points_failure_mid_write(tmp_path, monkeypatch):
    """A writer that dies halfway (disk full, Ctrl-C) leaves no file and no .part."""
    path = tmp_path / "a.npz"
    real = np.savez

    def dying_savez(fh, **arrays):
        fh.write(b"PK\x03\x04 half an archive")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez", dying_savez)
    with pytest.raises(OSError, match="No space left"):
        write_points(path, np.zeros((4, 2)))
    assert _leftovers(tmp_path) == []
    # an existing file survives a failed overwrite
    monkeypatch.setattr(np, "savez", real)
    write_points(path, np.ones((4, 2)))
    monkeypatch.setattr(np, "savez", dying_savez)
    with pytest.raises(OSError):
        write_points(path, np.zeros((4, 2)))
    np.testing.assert_array_equal(read_points(path), np.ones((4, 2)))
    assert _leftovers(tmp_path) == ["a.npz"]


def test_atomic_write_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        path = tmp_path / "a.txt"
        write_points(path, np.zeros((2, 2)))
        assert path.stat().st_mode & 0o777 == 0o644
        os.chmod(path, 0o600)
        write_points(path, np.ones((2, 2)))
        assert path.stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(old)


def test_atomic_writes_replace_all_files_together_or_none(tmp_path):
    from diskpack_cl.io import atomic_writes

    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a")
    with pytest.raises(RuntimeError, match="disk full"):
        with atomic_writes():
            with atomic_write(a, "w") as fh:
                fh.write("new a")
            with atomic_write(b, "w") as fh:
                raise RuntimeError("disk full")
    assert sorted(os.listdir(tmp_path)) == ["a.txt"] and a.read_text() == "old a"
    with atomic_writes():
        for path in (a, b):
            with atomic_write(path, "w") as fh:
                fh.write("new")
        assert a.read_text() == "old a" and not b.exists()   # renamed at the end, together
    assert a.read_text() == b.read_text() == "new" and len(os.listdir(tmp_path)) == 2


def _ways_to_the_file(folder):
    """Paths that all reach one file, ``folder/target.png``: itself, a symlink, a symlink
    to the symlink, a hard link, a path through ``..``."""
    target = folder / "target.png"
    target.write_bytes(b"photo")
    (folder / "sub").mkdir()
    (folder / "link.png").symlink_to(target)
    (folder / "link2.png").symlink_to(folder / "link.png")
    os.link(target, folder / "hard.png")
    return {"target": target, "link": folder / "link.png", "link2": folder / "link2.png",
            "hard": folder / "hard.png", "dotted": folder / "sub" / ".." / "target.png"}


WAYS = ["target", "link", "link2", "hard", "dotted"]


@pytest.mark.parametrize("output", WAYS)
@pytest.mark.parametrize("given", WAYS)
def test_an_output_reaching_an_input_by_any_way_is_refused(tmp_path, given, output):
    """An input given as a symlink with an output hard-linked to its target too: the
    guard compares the files the paths reach (device and inode), not the paths."""
    ways = _ways_to_the_file(tmp_path)
    with pytest.raises(OutputIsInputError, match=f"output {ways[output]} would replace the "
                                                 f"input {ways[given]}"):
        check_not_inputs([tmp_path / "other.svg", ways[output]], [ways[given]])
    assert ways["target"].read_bytes() == b"photo"


def test_a_copy_of_an_input_or_a_new_file_is_no_input(tmp_path):
    ways = _ways_to_the_file(tmp_path)
    (tmp_path / "copy.png").write_bytes(b"photo")   # same bytes, another file
    check_not_inputs([tmp_path / "copy.png", tmp_path / "new.svg", None], [ways["link"], None])


def test_an_output_reaching_a_missing_input_through_a_symlinked_folder_is_refused(tmp_path):
    """No file to compare yet: the paths are compared with their symlinks resolved."""
    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    with pytest.raises(OutputIsInputError, match="alias/x.png"):
        check_not_inputs([tmp_path / "alias" / "x.png"], [tmp_path / "real" / "x.png"])
    with pytest.raises(OutputIsInputError, match="real/x.png"):
        check_not_inputs([tmp_path / "real" / "x.png"], [tmp_path / "alias" / "x.png"])


@pytest.mark.parametrize("suffix", FORMATS)
def test_columns_pick_two_of_three_in_the_order_given(tmp_path, suffix):
    """By index in every format (and by name in a .csv with a header): (2, 0) is z, x."""
    xyz = np.random.default_rng(9).random((5, 3))
    path = tmp_path / f"a{suffix}"
    write_points(path, xyz)
    np.testing.assert_array_equal(read_points(path, columns=(2, 0)), xyz[:, [2, 0]])
    np.testing.assert_array_equal(read_points(path, columns=(0, 1)), xyz[:, :2])
    if suffix == ".csv":
        np.testing.assert_array_equal(read_points(path, columns=("Z", "x")), xyz[:, [2, 0]])
        with pytest.raises(ValueError, match=r"a\.csv: has a z column"):
            read_points(path)


def test_a_csv_header_under_comment_and_blank_lines_is_skipped_with_them(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text("# one\n\n# two\ny,x\n0.2,0.1\n0.4,0.3\n")
    np.testing.assert_array_equal(read_points(path), [[0.1, 0.2], [0.3, 0.4]])
