"""``diskpack analyze``'s checks of what it is given (:mod:`diskpack_cl.reports`)."""

import numpy as np
import pytest
from PIL import Image

from diskpack_cl import read_stipple, stipple, write_stipple
from diskpack_cl.io import write_points
from diskpack_cl.reports import analyze, analyze_point_sets, analyze_stippling, point_file_box

RNG = np.random.default_rng(3)


def _set(tmp_path, points, name="p.npy", box=None):
    path = tmp_path / name
    if box is None:
        write_points(path, np.asarray(points, np.float64))
    else:
        np.savez(path, points=np.asarray(points, np.float64), box=np.asarray(box, np.float64))
    return path


def _inside(size, n=30):
    return RNG.random((n, 2)) * 0.9 * np.asarray(size) + 0.05 * np.asarray(size)


def test_points_on_the_box_edges_are_in_it_one_ulp_off_is_not(tmp_path):
    """The box is 2 x 1 (not square: its sides are not swapped); its edges belong to it."""
    edges = [[0.0, 0.0], [2.0, 1.0], [0.0, 1.0], [2.0, 0.0], [1.9, 0.5]]
    path = _set(tmp_path, np.vstack([_inside((2, 1)), edges]))
    assert analyze_point_sets([path], kmax=4, box=(2, 1))["n"] == 35
    for off in ([np.nextafter(2.0, 3.0), 0.5], [1.0, np.nextafter(1.0, 2.0)],
                [-5e-324, 0.5], [1.0, -5e-324], [0.5, 1.5]):
        bad = _set(tmp_path, np.vstack([_inside((2, 1)), [off]]), name="bad.npy")
        with pytest.raises(ValueError, match=r"bad.npy: points must lie in the box \[0, 2\] x "
                                             r"\[0, 1\]"):
            analyze_point_sets([bad], kmax=4, box=(2, 1))


def test_points_off_the_unit_torus_are_refused(tmp_path):
    for off in ([np.nextafter(1.0, 2.0), 0.5], [0.5, -5e-324]):
        bad = _set(tmp_path, np.vstack([_inside((1, 1)), [off]]))
        with pytest.raises(ValueError, match="points must lie on the unit torus"):
            analyze_point_sets([bad], kmax=4)


def test_points_that_coincide_across_the_torus_seam_are_refused_not_in_a_box(tmp_path):
    """x = 0 and x = 1 are one place on the unit torus, two in the box 1 x 1."""
    pts = np.vstack([_inside((1, 1)), [[0.0, 0.5], [1.0, 0.5]]])
    path = _set(tmp_path, pts)
    with pytest.raises(ValueError, match=r"p.npy: 2 of 32 points coincide with another "
                                         r"\(first: row 30\)"):
        analyze_point_sets([path], kmax=4)
    assert analyze_point_sets([path], kmax=4, box=(1, 1))["n"] == 32


def test_the_box_a_file_records_is_read_in_its_order_and_checked(tmp_path):
    assert point_file_box(_set(tmp_path, _inside((2, 1)), "a.npz", box=[2, 1])) == (2.0, 1.0)
    for box in ([2, 0], [0, 1], [2, -1], [2, np.inf], [1, 2, 3]):
        with pytest.raises(ValueError, match=r"b.npz: 'box' must be two positive sizes"):
            point_file_box(_set(tmp_path, _inside((2, 1)), "b.npz", box=box))
    assert point_file_box(_set(tmp_path, _inside((1, 1)), "c.npy")) is None


def test_point_sets_take_the_box_their_files_record_all_alike(tmp_path):
    a = _set(tmp_path, _inside((2, 1)), "a.npz", box=[2, 1])
    b = _set(tmp_path, _inside((2, 1)), "b.npz", box=[2, 1])
    assert analyze([a, b], kmax=4)["realizations"] == 2
    c = _set(tmp_path, _inside((1, 1)), "c.npz", box=[1, 1])
    with pytest.raises(ValueError, match=r"the files record different boxes: "
                                         r"\[\(1.0, 1.0\), \(2.0, 1.0\)\]"):
        analyze([a, c], kmax=4)


@pytest.fixture(scope="module")
def ramp(tmp_path_factory):
    """A 48 x 32 px ramp and its stippling (not square: width and height tell apart)."""
    folder = tmp_path_factory.mktemp("ramp")
    g = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
    image, path = folder / "ramp.png", folder / "s.npz"
    Image.fromarray((g * 255).astype(np.uint8)).save(image)
    write_stipple(path, stipple(str(image), 60, schedule=[("mix", 3, 0.5)], backend="exact"))
    return folder, image, path


def test_a_stippling_is_analyzed_with_its_image_not_a_transposed_one(ramp):
    folder, image, path = ramp
    assert analyze_stippling(path, read_stipple(path), image)["n"] == 60
    turned = folder / "turned.png"
    Image.open(image).transpose(Image.Transpose.TRANSPOSE).save(turned)
    with pytest.raises(ValueError, match=r"the image is 32x48 px but .*s.npz is a stippling of "
                                         r"a 48x32 px image"):
        analyze_stippling(path, read_stipple(path), turned)
