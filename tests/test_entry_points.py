"""Every public entry point takes its options object the way ``stipple()`` does: keyword
arguments remain, turned into the object in one place, and no default is restated in the
signature; and every one (each callable of ``diskpack_cl.__all__``, every format of the
writers) runs through the public API on a tiny input and gives what it promises."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist

import diskpack_cl
from diskpack_cl import stipple, stipple_colors
from diskpack_cl.pens import ColorOptions
from diskpack_cl.relax import (TRIAL_RELAX, RelaxOptions, max_points_for_radius,
                               relax_poisson)
from diskpack_cl.schedule import StippleOptions

#: Each entry point, an options class it takes, the parameter that takes the object, and
#: the parameters that stand for a field without restating its default (None: the
#: object's value).
ENTRY_POINTS = [
    (stipple, StippleOptions, "options", ()),
    (stipple_colors, StippleOptions, "options", ()),
    (stipple_colors, ColorOptions, "colors", ()),
    (relax_poisson, RelaxOptions, "options", ("eps",)),
    (max_points_for_radius, RelaxOptions, "options", ()),
]


@pytest.mark.parametrize("func, cls, name, standing", ENTRY_POINTS,
                         ids=[f"{f.__name__}-{c.__name__}" for f, c, _, _ in ENTRY_POINTS])
def test_an_entry_point_takes_its_object_and_restates_no_default(func, cls, name, standing):
    params = inspect.signature(func).parameters
    assert params[name].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    assert params[name].default is None
    assert any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    for f in dataclasses.fields(cls):
        if f.name in params and f.name != name:
            assert f.name in standing and params[f.name].default is None, f.name


def test_relax_poisson_takes_its_options_object():
    pts = np.random.default_rng(1).random((128, 2))
    by_keywords = relax_poisson(pts, 0.78, backend="exact", max_iter=40, patience=5)
    opt = RelaxOptions(eps=0.78, backend="exact", max_iter=40, patience=5)
    for res in (relax_poisson(pts, options=opt), relax_poisson(pts, None, opt),
                relax_poisson(pts, 0.78, RelaxOptions(backend="exact"), max_iter=40,
                              patience=5)):
        np.testing.assert_array_equal(res.points, by_keywords.points)
        np.testing.assert_array_equal(res.rho, by_keywords.rho)


def test_relax_poisson_checks_the_options_as_before():
    pts = np.random.default_rng(0).random((10, 2))
    with pytest.raises(ValueError, match="eps must be in"):
        relax_poisson(pts, options=RelaxOptions(backend="exact"), eps=1.5)
    with pytest.raises(ValueError, match="backend must be one of"):
        relax_poisson(pts, options=RelaxOptions(), backend="cuda")


def test_max_points_for_radius_takes_the_trials_options():
    by_keywords = max_points_for_radius(0.06, seed=2, backend="exact", max_iter=100)
    by_object = max_points_for_radius(0.06, TRIAL_RELAX.replace(backend="exact", max_iter=100),
                                      seed=2)
    def trials(res):
        return [(t["n"], t["reached"], t["rho"], t["iterations"]) for t in res.trials]

    assert by_object.n == by_keywords.n and trials(by_object) == trials(by_keywords)
    np.testing.assert_array_equal(by_object.points, by_keywords.points)


def test_the_search_relaxes_each_trial_with_its_own_defaults(monkeypatch):
    """300 iterations and a patience of 60 unless told otherwise (TRIAL_RELAX), one object."""
    import diskpack_cl.relax as relax

    seen = []
    real = relax.relax_poisson

    def spy(points, eps, options, **kwargs):
        seen.append(options)
        return real(points, eps, options, **kwargs)

    monkeypatch.setattr(relax, "relax_poisson", spy)
    max_points_for_radius(0.1, backend="exact", patience=7)
    assert seen and all(o == RelaxOptions(backend="exact", max_iter=300, patience=7)
                        for o in seen)


def _colour_image():
    img = np.zeros((32, 48, 3))
    img[..., 0] = np.linspace(0, 1, 48)
    img[..., 2] = 0.6
    return img


def test_stipple_colors_takes_its_options_objects():
    img, sched = _colour_image(), [("mix", 4, 0.5)]
    by_keywords = stipple_colors(img, 120, "cmyk", schedule=sched, seed=3, black_generation=0.5,
                                 clean_white=0.05, backend="exact")
    color = ColorOptions(colors="cmyk", black_generation=0.5, clean_white=0.05)
    options = StippleOptions(schedule=sched, seed=3)
    for res in (stipple_colors(img, 120, color, options, backend="exact"),
                stipple_colors(img, 120, ColorOptions(colors="cmyk"), options, backend="exact",
                               black_generation=0.5, clean_white=0.05)):
        np.testing.assert_array_equal(res.points, by_keywords.points)
        np.testing.assert_array_equal(res.pen, by_keywords.pen)
        assert res.params == by_keywords.params


def test_stipple_colors_takes_the_dots_per_pen_of_its_object():
    img, sched = _colour_image(), [("mix", 3, 0.5)]
    by_counts = stipple_colors(img, 90, "cmy", schedule=sched, counts={"cyan": 50},
                               backend="exact")
    by_object = stipple_colors(img, 90, ColorOptions(colors="cmy", pen_dots="cyan=50"),
                               schedule=sched, backend="exact")
    np.testing.assert_array_equal(by_object.counts, by_counts.counts)
    np.testing.assert_array_equal(by_object.points, by_counts.points)
    with pytest.raises(ValueError, match="counts or pen_dots"):
        stipple_colors(img, 90, ColorOptions(colors="cmy", pen_dots="cyan=50"),
                       counts={"cyan": 40})


# ----------------------------------------------- each public entry point, once, on a tiny input

#: Four sites on a square lattice of the unit torus: every cell a square of side 1/2.
LATTICE = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])


def _gray_ramp():
    return np.linspace(0.1, 0.9, 30 * 40).reshape(30, 40)


def _torus_min_distance(points):
    return cKDTree(points, boxsize=1.0).query(points, k=2)[0][:, 1].min()


def _check_certify_disks(request):
    torus = diskpack_cl.Domain.torus()
    assert diskpack_cl.certify_disks(LATTICE, np.full(4, 0.2), torus).valid
    assert not diskpack_cl.certify_disks(LATTICE, np.full(4, 0.3), torus).valid


def _check_exact_mic(request):
    mic = diskpack_cl.exact_mic(LATTICE)
    np.testing.assert_allclose(mic.radii, 0.25, atol=1e-12)
    np.testing.assert_allclose(mic.centers, LATTICE, atol=1e-12)


def _check_normalized_radius(request):
    # half the square lattice's spacing over the hexagonal packing's radius
    assert diskpack_cl.normalized_radius(LATTICE) == pytest.approx(np.sqrt(np.sqrt(3) / 2))


def _check_device_queries(request):
    ctx = request.getfixturevalue("ctx")
    assert diskpack_cl.get_context() is ctx
    assert isinstance(diskpack_cl.describe(ctx), str) and diskpack_cl.describe(ctx)
    assert diskpack_cl.list_platforms()
    assert all(len(row) == 4 for row in diskpack_cl.list_devices())


def _check_relax_poisson(request):
    start = np.random.default_rng(1).random((64, 2))
    res = diskpack_cl.relax_poisson(start, 0.78, backend="exact", max_iter=40)
    assert res.points.shape == (64, 2) and res.rho[-1] >= 0.78 > res.rho[0]


def _check_max_points_for_radius(request):
    res = diskpack_cl.max_points_for_radius(0.1, backend="exact", max_iter=60)
    assert res.points.shape == (res.n, 2) and res.n > 1
    assert res.achieved_radius >= 0.1
    assert _torus_min_distance(res.points) == pytest.approx(2 * res.achieved_radius)


def _check_dart_throwing(request):
    points = diskpack_cl.dart_throwing(50, rel_radius=0.7, seed=0)
    assert points.shape == (50, 2) and diskpack_cl.normalized_radius(points) >= 0.7


def _check_random_points(request):
    points = diskpack_cl.random_points(10, seed=0)
    assert points.shape == (10, 2) and np.all((points >= 0) & (points < 1))
    np.testing.assert_array_equal(points, diskpack_cl.random_points(10, seed=0))


def _check_poisson_disk(request):
    res = diskpack_cl.poisson_disk(60, seed=0, backend="exact")
    assert res.points.shape == (60, 2) and res.reached and res.rho >= res.eps
    assert res.min_distance == pytest.approx(_torus_min_distance(res.points))


def _check_qmc_poisson_disk(request):
    points = diskpack_cl.PoissonDisk(d=2, radius=0.1, seed=0).random(10)
    assert points.shape == (10, 2) and np.all((points >= 0) & (points <= 1))
    assert pdist(points).min() >= 0.1


def _check_stipple(request):
    res = diskpack_cl.stipple(_gray_ramp(), 60, seed=0, backend="exact")
    assert res.points.shape == (60, 2) and res.radii.shape == (60,)
    assert np.all((res.points >= 0) & (res.points <= [40, 30]))


def _check_error_diffusion(request):
    points = diskpack_cl.error_diffusion(_gray_ramp(), 50, seed=0)
    assert points.shape == (50, 2) and np.all((points >= 0) & (points <= [40, 30]))


def _check_load_gray(request):
    path = request.getfixturevalue("tmp_path") / "ramp.png"
    Image.fromarray(np.round(255 * _gray_ramp()).astype(np.uint8)).save(path)
    np.testing.assert_allclose(diskpack_cl.load_gray(path), _gray_ramp(), atol=0.5 / 255)
    np.testing.assert_allclose(diskpack_cl.load_gray(path, invert=True), 1 - _gray_ramp(),
                               atol=0.5 / 255)


def _check_sample_image_path(request):
    gray = diskpack_cl.load_gray(diskpack_cl.sample_image_path())
    assert gray.ndim == 2 and 0 <= gray.min() < gray.max() <= 1


def _colour_stippling():
    return stipple_colors(_colour_image(), 60, "cmy", seed=0, backend="exact")


def _check_stipple_colors(request):
    res = _colour_stippling()
    assert res.points.shape == (60, 2) and res.pen.shape == (60,)
    assert sorted(res.names) == ["cyan", "magenta", "yellow"]
    np.testing.assert_array_equal(res.counts, np.bincount(res.pen, minlength=3))


def _check_preview(request):
    mono = diskpack_cl.preview(diskpack_cl.stipple(_gray_ramp(), 60, seed=0, backend="exact"),
                               size=64)
    assert mono.mode == "L" and max(mono.size) == 64
    assert np.asarray(mono).min() < 255   # dots drawn on white
    assert diskpack_cl.preview(_colour_stippling(), size=64).mode == "RGB"


def _written_and_read(path, result, **opts):
    diskpack_cl.write_stipple(path, result, **opts)
    return diskpack_cl.read_stipple(path)


def _check_writers(request):
    tmp_path = request.getfixturevalue("tmp_path")
    mono = diskpack_cl.stipple(_gray_ramp(), 60, seed=0, backend="exact")
    for ext in (".npz", ".csv"):
        back = _written_and_read(tmp_path / f"mono{ext}", mono)
        np.testing.assert_array_equal(back.points, mono.points)
        np.testing.assert_array_equal(back.radii, mono.radii)
    # an SVG holds the drawing: its dots in pen-path order, the page's size
    back = _written_and_read(tmp_path / "mono.svg", mono, width_mm=80)
    assert back.points.shape == mono.points.shape
    assert (back.width, back.height) == (mono.width, mono.height)
    diskpack_cl.write_stipple(tmp_path / "mono.png", mono, png_scale=2)
    with Image.open(tmp_path / "mono.png") as png:
        assert png.size == (80, 60) and np.asarray(png.convert("L")).min() < 255
    colour = _colour_stippling()
    back = _written_and_read(tmp_path / "colour.svg", colour, width_mm=80)
    assert back.names == colour.names
    np.testing.assert_array_equal(np.bincount(back.pen), colour.counts)
    diskpack_cl.write_stipple(tmp_path / "colour.png", colour)   # 2 px a pixel, as the CLI
    with Image.open(tmp_path / "colour.png") as png:
        assert png.mode == "RGB" and png.size == (96, 64)


#: The check of each public callable (the writers' check covers ``write_stipple`` and
#: ``read_stipple``; the device queries' check the four device names).
PUBLIC_CALLS = {
    "certify_disks": _check_certify_disks,
    "exact_mic": _check_exact_mic,
    "normalized_radius": _check_normalized_radius,
    "describe": _check_device_queries,
    "get_context": _check_device_queries,
    "list_devices": _check_device_queries,
    "list_platforms": _check_device_queries,
    "relax_poisson": _check_relax_poisson,
    "max_points_for_radius": _check_max_points_for_radius,
    "dart_throwing": _check_dart_throwing,
    "random_points": _check_random_points,
    "poisson_disk": _check_poisson_disk,
    "PoissonDisk": _check_qmc_poisson_disk,
    "stipple": _check_stipple,
    "error_diffusion": _check_error_diffusion,
    "write_stipple": _check_writers,
    "read_stipple": _check_writers,
    "load_gray": _check_load_gray,
    "sample_image_path": _check_sample_image_path,
    "stipple_colors": _check_stipple_colors,
    "preview": _check_preview,
}

#: Public classes that hold options, results or errors: made by the calls above, not
#: entry points of their own.
DATA_CLASSES = {"Domain", "CertificateError", "NoOpenCLError", "RelaxOptions", "RelaxResult",
                "RadiusResult", "PoissonOptions", "PoissonDiskResult", "StippleOptions",
                "StippleResult", "WriteOptions", "ToneOptions", "ColorStippleResult"}


def test_every_public_name_is_called_here_or_is_data():
    """A name added to ``__all__`` fails here until it has a check above."""
    assert set(PUBLIC_CALLS) | DATA_CLASSES == set(diskpack_cl.__all__)
    assert not set(PUBLIC_CALLS) & DATA_CLASSES


@pytest.mark.parametrize("check", sorted(set(PUBLIC_CALLS.values()), key=lambda f: f.__name__),
                         ids=lambda f: f.__name__.removeprefix("_check_"))
def test_each_public_entry_point_gives_what_it_promises(request, check):
    check(request)
