"""features="detail": feature-aware mix steps."""

import numpy as np
import pytest

from diskpack_cl.radii import detail_fields, radius_field
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import stipple

MIX = [("mix", 6, 0.5)]


def dark_with_spots(h=48, w=64):
    """A dark ground with four small bright spots and a thin bright line."""
    g = np.full((h, w), 0.15)
    for r, c in [(10, 12), (12, 40), (30, 20), (36, 50)]:
        g[r:r + 2, c:c + 2] = 1.0
    g[24, 5:60] = 0.9
    return g


def test_detail_fields_weight_and_dilation():
    g = dark_with_spots()
    base = radius_field(g, radii="density", floor=0.01, sigma=3.0)
    field, weight = detail_fields(g, 600, base)
    assert field.shape == weight.shape == g.shape
    assert np.all(field >= base) and np.all(field <= base.max())
    assert weight.min() >= 0.0 and weight.max() <= 1.0
    assert weight[10, 12] > 0.9  # on a bright spot
    assert weight[44, 2] < 0.05  # smooth dark ground far from any feature
    # a uniform image holds no detail and no edge: weight 0, field unchanged
    flat = np.full((32, 32), 0.4)
    f0 = radius_field(flat, radii="density", floor=0.01, sigma=3.0)
    f1, w1 = detail_fields(flat, 200, f0)
    assert np.allclose(w1, 0.0) and np.array_equal(f1, f0)


def test_options_features_resolved_and_checked():
    assert StippleOptions.resolve(500, 64, 48).features == "none"
    opt = StippleOptions.resolve(500, 64, 48, features="detail")
    assert opt.features == "detail" and opt.params()["features"] == "detail"
    with pytest.raises(ValueError, match="features"):
        StippleOptions.resolve(500, 64, 48, features="edges")


def test_stipple_detail_certified_deterministic_and_different():
    g = dark_with_spots()
    a = stipple(g, 400, seed=1, schedule=MIX, radii="density", floor=0.01, radius_sigma=3.0,
                features="detail")
    b = stipple(g, 400, seed=1, schedule=MIX, radii="density", floor=0.01, radius_sigma=3.0,
                features="detail")
    plain = stipple(g, 400, seed=1, schedule=MIX, radii="density", floor=0.01, radius_sigma=3.0)
    none = stipple(g, 400, seed=1, schedule=MIX, radii="density", floor=0.01, radius_sigma=3.0,
                   features="none")
    assert a.certificate.valid and a.n == 400
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(plain.points, none.points)
    assert not np.array_equal(a.points, plain.points)
    assert a.params["features"] == "detail"
    # the radii the result reports are the dilated field's, certified
    assert np.all(a.base_radii > 0)


def test_detail_schedule_brings_the_option():
    opt = StippleOptions.resolve(500, 64, 48, schedule="detail")
    assert opt.features == "detail" and opt.radii == "density"
    assert opt.phases == (("mix", 18, 0.5), ("mix", 7, 0.4))
    assert StippleOptions.resolve(500, 64, 48, schedule="detail", features="none").features == "none"
