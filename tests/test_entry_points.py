"""Every public entry point takes its options object the way ``stipple()`` does: keyword
arguments remain, turned into the object in one place, and no default is restated in the
signature."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

from diskpack_cl import stipple, stipple_colors
from diskpack_cl.color import ColorOptions
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
