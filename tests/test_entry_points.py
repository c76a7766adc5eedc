"""Every public entry point takes its options object the way ``stipple()`` does: keyword
arguments remain, turned into the object in one place, and no default is restated in the
signature."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

from diskpack_cl import stipple
from diskpack_cl.relax import (TRIAL_RELAX, RelaxOptions, max_points_for_radius,
                               relax_poisson)
from diskpack_cl.schedule import StippleOptions

#: Each entry point, its options class, and the parameters that stand for a field of it
#: without restating its default (None: "the options' value").
ENTRY_POINTS = [
    (stipple, StippleOptions, ()),
    (relax_poisson, RelaxOptions, ("eps",)),
    (max_points_for_radius, RelaxOptions, ()),
]


@pytest.mark.parametrize("func, cls, standing", ENTRY_POINTS,
                         ids=[f.__name__ for f, _, _ in ENTRY_POINTS])
def test_an_entry_point_takes_its_object_and_restates_no_default(func, cls, standing):
    params = inspect.signature(func).parameters
    assert params["options"].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    assert params["options"].default is None
    assert any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    for f in dataclasses.fields(cls):
        if f.name in params:
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
