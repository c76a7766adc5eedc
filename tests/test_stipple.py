"""Algorithm 2 (stippling) and the error-diffusion start, on small images."""

import importlib

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from diskpack_cl.dithering import _fs_wavefront, error_diffusion
from diskpack_cl.domain import Domain
from diskpack_cl.geometry import exact_mic
from diskpack_cl.radii import base_radii, detail_fields, field_at, largest_valid_k, radius_field
from diskpack_cl.schedule import SCHEDULE_OPTIONS, StippleOptions, auto_supersample, make_schedule
from diskpack_cl.stipple import INK_RANGE, StippleStage, StippleState, _quantile, lloyd_step, pack_step, stipple
from diskpack_cl.engine import ExactEngine

SHORT = [("pack", 6), ("lloyd", 3), ("pack", 4)]


def gradient(h=64, w=64):
    return np.tile(np.linspace(0.0, 1.0, w), (h, 1))


def _fs_reference(v):
    """Floyd-Steinberg in raster order, each pixel pulling its neighbours' errors in the
    order the wavefronts bring them (up-left, up, left, up-right): the same sums bit for bit."""
    H, W = v.shape
    e = np.zeros((H + 1, W + 2))   # padded: e[r + 1, c + 1] is pixel (r, c)'s error
    q = np.zeros((H, W))
    for r in range(H):
        for c in range(W):
            x = v[r, c]
            for dr, dc, w in ((-1, -1, 1 / 16), (-1, 0, 5 / 16), (0, -1, 7 / 16), (-1, 1, 3 / 16)):
                if 0 <= r + dr and 0 <= c + dc < W:
                    x += e[r + dr + 1, c + dc + 1] * w
            q[r, c] = max(np.floor(x + 0.5), 0.0)
            e[r + 1, c + 1] = x - q[r, c]
    return q, e[1:, 1:W + 1]


def brute_force_valid(p, r, W, H):
    d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    pair = np.all(d > r[:, None] + r[None, :])
    edge = np.all((p[:, 0] - r >= 0) & (p[:, 0] + r <= W) & (p[:, 1] - r >= 0) & (p[:, 1] + r <= H))
    return pair and edge


# ---------------------------------------------------------------- start


@settings(max_examples=60)
@given(h=st.integers(1, 12), w=st.integers(1, 12), scale=st.sampled_from([0.3, 1.0, 2.7]),
       seed=st.integers(0, 2**16))
def test_wavefront_equals_raster_order(h, w, scale, seed):
    """Every shape, down to one row or column and under three columns (a wavefront of
    one pixel), gives the raster order's counts and residuals exactly."""
    v = np.random.default_rng(seed).random((h, w)) * scale
    q, e = _fs_wavefront(v)
    q2, e2 = _fs_reference(v)
    assert q.dtype == np.int64
    np.testing.assert_array_equal(q, q2)
    np.testing.assert_array_equal(e, e2)


@pytest.mark.parametrize("n", [1, 7, 100, 1000, 4096, 20000])
def test_error_diffusion_exact_count_inside(n):
    g = gradient()
    p = error_diffusion(g, n, seed=3)
    assert p.shape == (n, 2)
    assert np.all(p >= 0) and np.all(p[:, 0] < 64) and np.all(p[:, 1] < 64)
    np.testing.assert_array_equal(p, error_diffusion(g, n, seed=3))
    assert not np.array_equal(p, error_diffusion(g, n, seed=4))


@pytest.mark.parametrize("shape", [(64, 64), (61, 50)])   # whole blocks, and blocks past the image
def test_error_diffusion_same_points_in_any_chunks_and_from_gray_or_its_darkness(shape, monkeypatch):
    """The pixels are drawn in chunks of points, and the darkness is read off the gray a band
    at a time: the points do not depend on the chunk, and are those of the same density given
    as an array of its own (the whole darkness, as the start once made it)."""
    import diskpack_cl.dithering as dithering

    g = np.clip(np.random.default_rng(2).random(shape) * 1.3 - 0.1, 0.0, 1.0)
    whole = error_diffusion(g, 150, seed=5)
    np.testing.assert_array_equal(whole, error_diffusion(g, 150, seed=5, density=1.0 - g))
    monkeypatch.setattr(dithering, "PICK_CHUNK", 7)
    np.testing.assert_array_equal(error_diffusion(g, 150, seed=5), whole)


def test_error_diffusion_follows_darkness():
    g = gradient(64, 128)
    p = error_diffusion(g, 3000, seed=0)
    left = np.count_nonzero(p[:, 0] < 64)
    # darkness integrates to 3/4 on the left half and 1/4 on the right
    assert abs(left / 3000 - 0.75) < 0.02
    # white columns (gray exactly 1) get no point
    assert np.all(p[:, 0] < 127)


def test_error_diffusion_bad_input():
    with pytest.raises(ValueError, match="nothing to stipple: the image is white"):
        error_diffusion(np.ones((8, 8)), 10)
    with pytest.raises(ValueError, match="n must be at least 1"):
        error_diffusion(gradient(), 0)


# ---------------------------------------------------------------- schedules


def test_schedules():
    paper = [("pack", 40), ("lloyd", 10), ("pack", 40), ("lloyd", 10), ("pack", 20)]
    assert make_schedule("paper") == paper
    assert make_schedule(beta=40, lloyd=10, rounds=3) == paper
    assert make_schedule(method="lloyd") == [("lloyd", 50)]
    assert make_schedule(method="lloyd", lloyd=7) == [("lloyd", 7)]
    with pytest.raises(ValueError, match="unknown schedule"):
        make_schedule("fast")
    with pytest.raises(ValueError, match="method must be"):
        make_schedule(method="cvt")


# ---------------------------------------------------------------- largest k


def test_largest_valid_k_matches_brute_force():
    rng = np.random.default_rng(5)
    p = rng.uniform(1, 49, (300, 2))
    r = rng.uniform(0.01, 1.0, 300) ** 2
    k = largest_valid_k(p, r, 50, 50)
    d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    edge = np.minimum.reduce([p[:, 0], 50 - p[:, 0], p[:, 1], 50 - p[:, 1]])
    k_bf = min(np.min(d / (r[:, None] + r[None, :])), np.min(edge / r))
    assert k == k_bf


@settings(max_examples=150)
@given(st.integers(2, 120), st.integers(0, 2**32 - 1),
       st.sampled_from(["random", "lattice", "clusters", "coincident", "border"]),
       st.sampled_from(["as made", "shuffled", "reversed"]), st.floats(0.0, 6.0))
def test_largest_valid_k_is_the_brute_force_least_ratio(n, seed, kind, order, spread):
    """largest_valid_k is the least of the edge ratios and of every pair's ratio, the same
    float as a brute force over all pairs, whatever the points' order (the bound of its
    pair search comes from consecutive points and a sample's neighbours): lattices,
    clusters, coincident points and points on the border (k = 0), radii over many octaves."""
    rng = np.random.default_rng(seed)
    if kind == "lattice":
        side = int(np.ceil(np.sqrt(n)))
        p = 1.0 + 2.0 * np.column_stack(np.divmod(np.arange(n), side)).astype(float)
    elif kind == "clusters":
        p = rng.uniform(5, 45, (3, 2))[rng.integers(0, 3, n)] + rng.normal(0, 0.01, (n, 2))
    else:
        p = rng.uniform(1, 49, (n, 2))
    if kind == "coincident":
        p[rng.integers(0, n)] = p[rng.integers(0, n)]
    if kind == "border":
        p[rng.integers(0, n), 0] = 0.0
    r = 2.0 ** -rng.uniform(0, spread, n)
    at = {"as made": np.arange(n), "shuffled": rng.permutation(n), "reversed": np.arange(n)[::-1]}[order]
    p, r = p[at], r[at]
    side = max(50.0, float(p.max()) + 1.0)
    d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    edge = np.minimum.reduce([p[:, 0], side - p[:, 0], p[:, 1], side - p[:, 1]])
    brute = min(float(np.min(d / (r[:, None] + r[None, :]))), float(np.min(edge / r)))
    assert largest_valid_k(p, r, side, side) == max(brute, 0.0)


# ---------------------------------------------------------------- stipple


@pytest.fixture(scope="module")
def small_result(ctx):
    return stipple(gradient(), 150, seed=2, schedule=SHORT)


def test_stipple_exact_n_inside_certified(small_result):
    res = small_result
    p, r = res.points, res.radii
    assert p.shape == (150, 2) and r.shape == (150,)
    assert res.width == 64 and res.height == 64
    assert np.all(np.isfinite(p)) and np.all(r > 0)
    assert np.all(p > 0) and np.all(p < 64)
    assert res.certificate.valid
    assert brute_force_valid(p, r, 64, 64)
    # k is the largest valid one: 0.1% more is invalid
    assert not brute_force_valid(p, r * 1.001, 64, 64)
    np.testing.assert_allclose(r, res.k * res.base_radii)
    assert [h["kind"] for h in res.history] == ["pack"] * 6 + ["lloyd"] * 3 + ["pack"] * 4
    assert all(np.isfinite(h["k"]) and h["empty"] >= 0 for h in res.history)


def test_stipple_radii_follow_gray(small_result):
    # radii are re-sampled at the final positions: larger where lighter
    res = small_result
    order = np.argsort(res.points[:, 0])
    assert np.corrcoef(res.points[order, 0], res.base_radii[order])[0, 1] > 0.9


def test_stipple_deterministic(small_result, ctx):
    again = stipple(gradient(), 150, seed=2, schedule=SHORT)
    np.testing.assert_array_equal(again.points, small_result.points)
    np.testing.assert_array_equal(again.radii, small_result.radii)
    other = stipple(gradient(), 150, seed=3, schedule=SHORT)
    assert not np.array_equal(other.points, small_result.points)


def test_stipple_input_not_mutated(ctx):
    g = gradient()
    g0 = g.copy()
    res = stipple(g, 50, seed=0, schedule=[("pack", 2)])
    np.testing.assert_array_equal(g, g0)
    assert not np.may_share_memory(res.points, g)


def test_lloyd_method_certified(ctx):
    res = stipple(gradient(), 120, seed=1, method="lloyd", lloyd=5)
    assert [h["kind"] for h in res.history] == ["lloyd"] * 5
    assert res.certificate.valid and brute_force_valid(res.points, res.radii, 64, 64)


def test_empty_power_cell_handled(ctx):
    # a light point (big radius) 0.5 px from a dark point (floor radius):
    # with k0 = 10 the dark point's power cell is empty in the first iteration
    g = np.ones((32, 32))
    g[:, :16] = 0.0
    rng = np.random.default_rng(0)
    start = np.column_stack([rng.uniform(1, 31, 40), rng.uniform(1, 31, 40)])
    start[0] = [16.2, 16.0]   # white pixel, r = 1
    start[1] = [15.7, 16.0]   # black pixel, r = 0.1 ** 1.5
    seen = []
    res = stipple(g, 40, seed=0, start=start, k0=10.0, schedule=[("pack", 4), ("lloyd", 2), ("pack", 2)],
                  callback=seen.append)
    assert res.history[0]["empty"] >= 1
    assert seen == res.history
    assert res.points.shape == (40, 2) and np.all(np.isfinite(res.points))
    assert res.certificate.valid and brute_force_valid(res.points, res.radii, 32, 32)


def test_uniform_gray_and_black_images_work(ctx):
    for v in (0.0, 0.5):
        res = stipple(np.full((32, 40), v), 60, seed=0, schedule=[("pack", 3)])
        assert res.points.shape == (60, 2) and res.certificate.valid


def test_stipple_rgb_uint8_array(ctx):
    rgb = np.zeros((32, 32, 3), np.uint8)
    rgb[:, 16:] = 255
    res = stipple(rgb, 30, seed=0, schedule=[("lloyd", 2)])
    assert res.points.shape == (30, 2)
    assert np.count_nonzero(res.points[:, 0] < 16) >= 28


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n": 0}, "n must be at least 1"),
        ({"n": 2.5}, "n must be an integer"),
        ({"n": 10, "gamma": 0}, "gamma must be > 0"),
        ({"n": 10, "gamma": -1}, "gamma must be > 0"),
        ({"n": 2000, "supersample": 1}, "too large for a 64x64 image at supersample 1"),
        ({"n": 10, "schedule": "nope"}, "unknown schedule"),
        ({"n": 10, "method": "cvt"}, "method must be"),
        ({"n": 10, "floor": 0}, "floor must be in"),
    ],
)
def test_stipple_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        stipple(gradient(), **kwargs)


def test_stipple_white_image():
    with pytest.raises(ValueError, match="nothing to stipple: the image is white"):
        stipple(np.ones((16, 16)), 10)


def test_stipple_float_out_of_range():
    with pytest.raises(ValueError, match=r"must be in \[0, 1\]"):
        stipple(gradient() * 255.0, 10)


# ---------------------------------------------------------------- radius mappings, mix update


def test_radius_field_gray_is_base_radii():
    g = gradient(8, 16)
    pts = np.column_stack([np.arange(16) + 0.5, np.full(16, 3.5)])
    f = radius_field(g, radii="gray", gamma=3.0, floor=0.1)
    np.testing.assert_array_equal(f[3], base_radii(g, pts, gamma=3.0, floor=0.1))


def test_radius_field_density():
    g = gradient(8, 32)
    f = radius_field(g, radii="density", floor=0.01, sigma=0)
    d = np.maximum(1.0 - g, 0.01)
    # r^2 proportional to 1 / darkness: a packing's density ~ 1/r^2 ~ darkness
    np.testing.assert_allclose(f ** 2 * d, 0.01)
    assert f.max() <= 1.0 and np.all(np.diff(f[0]) >= 0)
    assert f.max() / f.min() <= 0.01 ** -0.5 * (1 + 1e-12)
    blurred = radius_field(g, radii="density", floor=0.01, sigma=2.0)
    assert blurred.shape == g.shape and np.all(np.isfinite(blurred))
    with pytest.raises(ValueError, match="radii must be 'gray' or 'density'"):
        radius_field(g, radii="area")


def test_mix_step_is_the_documented_blend(ctx):
    # one "mix" step moves each point to MIC + blend * (centroid - MIC); with
    # the same start and k0 the power diagram is the same for every blend
    g = gradient(32, 32)
    kw = dict(seed=4, schedule=[("mix", 1)], radii="density", floor=0.01)
    mic = stipple(g, 40, blend=0.0, **kw).points
    cen = stipple(g, 40, blend=1.0, **kw).points
    half = stipple(g, 40, blend=0.5, **kw).points
    assert not np.allclose(mic, cen)
    np.testing.assert_allclose(half, mic + 0.5 * (cen - mic), atol=1e-9)
    # blend 0 is a plain disk-packing step
    pack = stipple(g, 40, seed=4, schedule=[("pack", 1)], radii="density", floor=0.01).points
    np.testing.assert_array_equal(mic, pack)


def test_default_schedule_certified_and_deterministic(ctx):
    g = gradient()
    a = stipple(g, 150, seed=5)
    b = stipple(g, 150, seed=5)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.radii, b.radii)
    assert a.certificate.valid and brute_force_valid(a.points, a.radii, 64, 64)
    assert [list(p) for p in make_schedule("default", spacing=np.sqrt(64 * 64 / 150))] == a.params["schedule"]
    assert a.params["radii"] == SCHEDULE_OPTIONS["default"]["radii"]
    # radii re-sampled from the mapping at the final positions
    f = radius_field(g, radii=a.params["radii"], floor=a.params["floor"], sigma=a.params["radius_sigma"])
    assert a.params["features"] == "detail"    # s = 5.2 px: the band with feature-aware steps
    f = detail_fields(g, 150, f)[0]
    row, col = np.floor(a.points[:, 1]).astype(int), np.floor(a.points[:, 0]).astype(int)
    # the default's equal-ink factors (capacity 0.1) scale the field within their bounds
    factor = a.base_radii / f[row, col]
    assert a.params["capacity"] == 0.1 and np.ptp(factor) > 0
    assert np.all((factor >= 1 / INK_RANGE) & (factor <= INK_RANGE))
    c = stipple(g, 150, seed=5, capacity=0.0)
    row, col = np.floor(c.points[:, 1]).astype(int), np.floor(c.points[:, 0]).astype(int)
    # the stage keeps the field in float32 (read at the dots only)
    np.testing.assert_array_equal(c.base_radii, f.astype(np.float32)[row, col])


def test_paper_schedule_keeps_the_paper_mapping(ctx):
    res = stipple(gradient(), 60, seed=0, beta=2, lloyd=1, rounds=2)
    assert res.params["radii"] == "gray" and res.certificate.valid
    assert [h["kind"] for h in res.history] == ["pack", "pack", "lloyd", "pack"]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"radii": "area"}, "radii must be 'gray' or 'density'"),
        ({"blend": 1.5}, r"blend must be in \[0, 1\]"),
        ({"blend": -0.1}, r"blend must be in \[0, 1\]"),
        ({"blend_cell": "delaunay"}, "blend_cell must be"),
        ({"k_quantile": 1.0}, r"k_quantile must be in \[0, 1\)"),
        ({"schedule": [("jump", 3)]}, "kind must be 'pack', 'mix' or 'lloyd'"),
    ],
)
def test_stipple_bad_new_options(kwargs, match):
    with pytest.raises(ValueError, match=match):
        stipple(gradient(), 10, **kwargs)


def test_default_schedule_follows_the_dot_spacing():
    """The default's phases and options come from the band of s = sqrt(W H / n)."""
    from diskpack_cl.schedule import SPACING_BANDS, default_band

    bounds = [b for b, _, _ in SPACING_BANDS]
    assert bounds == sorted(bounds) and bounds[-1] == np.inf
    for lo, (hi, phases, extra) in zip([1e-3] + bounds[:-1], SPACING_BANDS):
        for s in (lo, np.nextafter(min(hi, 1e6), 0)):
            assert default_band(s) == (list(phases), extra)
    with pytest.raises(ValueError, match="follows the dot spacing"):
        make_schedule("default")
    with pytest.raises(ValueError, match="positive"):
        default_band(0.0)
    dense = StippleOptions.resolve(50000, 512, 512)      # s = 2.29 px
    sparse = StippleOptions.resolve(5000, 512, 512)      # s = 7.24 px
    assert dense.phases == (("mix", 16, 0.7), ("pack", 2), ("mix", 1, 0.5)) and dense.radius_sigma == 1.5
    assert dense.features == "none"
    assert sparse.phases == (("mix", 20, 0.6), ("mix", 6, 0.4), ("mix", 1, 0.75))
    assert sparse.features == "detail"
    assert sparse.radius_sigma == 2.0
    # sparse dots follow the unblurred darkness and leave the white side sooner
    assert (sparse.density_sigma, sparse.support) == (0.0, 16.0)
    assert (dense.density_sigma, dense.support) == (0.5, 8.0)
    # an explicit option still overrides the band's
    assert StippleOptions.resolve(50000, 512, 512, radius_sigma=3.0).radius_sigma == 3.0
    assert make_schedule(method="lloyd", lloyd=0) == []


def test_make_schedule_mix_phases():
    assert make_schedule([("mix", 3, 0.2), ("lloyd", 0), ("pack", 2), ("mix", 1)]) == [
        ("mix", 3, 0.2), ("pack", 2), ("mix", 1)]
    with pytest.raises(ValueError, match=r"blend must be in \[0, 1\]"):
        make_schedule([("mix", 3, 1.2)])
    with pytest.raises(ValueError, match="bad schedule phase"):
        make_schedule([("lloyd", 3, 0.5)])


def test_schedule_options_resolution():
    def params(**kw):
        return StippleOptions.resolve(30, 32, 32, **kw).params()

    # Lloyd baseline and explicit lists use the paper's options
    lo = params(method="lloyd", lloyd=2)
    assert lo["density_sigma"] == 0.0 and lo["radii"] == "gray"
    ex = params(schedule=[("mix", 2, 0.5)])
    assert ex["radii"] == "gray" and ex["k_quantile"] == 0.0
    # a named schedule's options, one overridden by a keyword
    d = params(schedule="default", k_quantile=0.0)
    for key, v in SCHEDULE_OPTIONS["default"].items():
        assert d[key] == (0.0 if key == "k_quantile" else v)


@pytest.mark.parametrize("kwargs, match", [
    ({"k0": 0.0}, "k0 must be > 0, got 0.0"),
    ({"k0": np.inf}, "k0 must be > 0, got inf"),
    ({"refine_every": -1}, "refine_every must be an integer >= 0, got -1"),
    ({"refine_every": 1.5}, "refine_every must be an integer >= 0, got 1.5"),
    ({"radius_sigma": -1}, "radius_sigma must be >= 0, got -1.0"),
    ({"density_sigma": np.nan}, "density_sigma must be >= 0, got nan"),
    ({"supersample": 0}, "supersample must be an integer >= 1, got 0"),
])
def test_options_checked_before_any_work(kwargs, match):
    with pytest.raises(ValueError, match=match):
        StippleOptions.resolve(30, 32, 32, **kwargs)
    # stipple() checks them before the start set and the engine exist
    with pytest.raises(ValueError, match=match):
        stipple(gradient(32, 32), 30, backend="no such backend", **kwargs)


@settings(max_examples=200)
@given(n=st.integers(1, 10**6), width=st.integers(8, 4096), height=st.integers(8, 4096),
       ink_share=st.one_of(st.none(), st.floats(1e-4, 1.0)))
def test_auto_supersample_gives_enough_grid_cells_per_dot(n, width, height, ink_share):
    ink = None if ink_share is None else ink_share * width * height
    s = auto_supersample(n, width, height, ink)

    def share(t):  # of the grid cells needed: 16 per average dot, 4 per dot on full black
        return min(t * t * width * height / (16 * n), np.inf if ink is None else t * t * ink / (4 * n))
    # the smallest s with enough, never more than 8 (to rounding)
    assert 1 <= s <= 8
    assert s == 8 or share(s) >= 1 - 1e-9
    assert s == 1 or share(s - 1) < 1 + 1e-9


def test_plan_blurs_the_centroid_density_less_than_the_spacing_on_black():
    plan = StippleOptions().plan
    assert plan(50000, 384, 384).density_sigma == 0.5
    # thin lines: 50000 dots on 10 000 px of full black, 0.45 px apart there
    thin = plan(50000, 384, 384, ink=10000.0)
    assert thin.density_sigma == pytest.approx(0.5 * (10000 / 50000) ** 0.5)
    assert thin.supersample == 5 > plan(50000, 384, 384).supersample
    # a photograph's dots are farther apart than 1 px: nothing changes
    assert plan(50000, 512, 512, ink=0.5 * 512 * 512) == plan(50000, 512, 512)
    # the user's blur and raster are the user's
    mine = StippleOptions(density_sigma=0.5, supersample=3).plan(50000, 384, 384, ink=10000.0)
    assert (mine.density_sigma, mine.supersample) == (0.5, 3)


def test_options_are_frozen():
    opt = StippleOptions.resolve(30, 32, 32)
    with pytest.raises(AttributeError):
        opt.blend = 0.3
    assert opt.grid_shape(32, 16) == (16 * opt.supersample, 32 * opt.supersample)


@pytest.mark.parametrize("q", [0.0, 0.15, 0.5])
def test_pack_step_k_is_the_quantile_of_mic_over_base_radius(q):
    """After a packing step, k is the k_quantile quantile of R_i / r_i (q = 0: the minimum)."""
    g = gradient(32, 32)
    x = error_diffusion(g, 60, seed=1)
    rfield = radius_field(g, radii="density", floor=0.01, sigma=0)
    opt = StippleOptions.resolve(60, 32, 32, schedule=[("pack", 1)], radii="density", floor=0.01,
                                 k_quantile=q)
    dom = Domain.rect(32, 32)
    stage = StippleStage(ExactEngine(dom, opt.grid_shape(32, 32)), opt, rfield, None)
    state, entry = pack_step(StippleState(x, 0.05), stage)
    r = field_at(rfield, x)
    mic = exact_mic(x, (0.05 * r) ** 2, dom)
    ok = ~mic.empty
    ratio = mic.radii[ok] / r[ok]
    assert state.k == (np.quantile(ratio, q) if q > 0 else ratio.min())
    assert state.packs == 1 and entry["empty"] == int(mic.empty.sum())
    np.testing.assert_array_equal(state.points[ok], mic.centers[ok])


@pytest.mark.parametrize("blend_cell", ["power", "voronoi"])
def test_mix_step_blends_the_mic_towards_the_cell_centroid(blend_cell):
    from diskpack_cl.labels import cell_centroids, grid_power_labels

    g = gradient(24, 32)
    x = error_diffusion(g, 40, seed=5)
    opt = StippleOptions.resolve(40, 32, 24, schedule=[("mix", 1, 0.3)], radii="density",
                                 floor=0.01, blend_cell=blend_cell)
    rfield = radius_field(g, radii="density", floor=0.01, sigma=opt.radius_sigma)
    dom, shape = Domain.rect(32, 24), opt.grid_shape(32, 24)
    dens = np.random.default_rng(6).random(shape) + 0.01
    stage = StippleStage(ExactEngine(dom, shape), opt, rfield, dens)
    state, _ = pack_step(StippleState(x, 0.2), stage, blend=0.3)
    w = (0.2 * field_at(rfield, x)) ** 2
    mic = exact_mic(x, w, dom)
    cells_w = w if blend_cell == "power" else None
    c, mass = cell_centroids(grid_power_labels(x, cells_w, dom, shape), x, dens, dom)
    ok = ~mic.empty & (mass > 0)
    np.testing.assert_allclose(state.points[ok], mic.centers[ok] + 0.3 * (c[ok] - mic.centers[ok]),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [2, 3, 5, 8])
def test_lloyd_step_moves_to_the_voronoi_centroids_and_takes_the_largest_k(seed):
    """k is the largest valid one at the new positions, with the radii there."""
    from diskpack_cl.labels import cell_centroids, grid_power_labels

    g = gradient(24, 32)
    x = error_diffusion(g, 40, seed=seed)
    opt = StippleOptions.resolve(40, 32, 24, schedule=[("lloyd", 1)])
    rfield = radius_field(g, radii=opt.radii, gamma=opt.gamma, floor=opt.floor)
    dom, shape = Domain.rect(32, 24), opt.grid_shape(32, 24)
    dens = np.random.default_rng(3).random(shape) + 0.01
    stage = StippleStage(ExactEngine(dom, shape), opt, rfield, dens)
    state, entry = lloyd_step(StippleState(x, 0.5, packs=3), stage)
    want, mass = cell_centroids(grid_power_labels(x, None, dom, shape), x, dens, dom)
    np.testing.assert_array_equal(state.points, np.where((mass > 0)[:, None], want, x))
    assert state.k == max(largest_valid_k(state.points, field_at(rfield, state.points), 32, 24), 1e-6)
    assert state.packs == 3 and entry["empty"] == int(np.count_nonzero(mass == 0))
    assert entry["moved"] == pytest.approx(np.mean(np.hypot(*(state.points - x).T)))


def test_k_quantile_changes_weights_not_certificate(ctx):
    # k from a quantile of R_i / r_i: heavier weights in the next iteration,
    # so the trajectory differs; the output is still certified
    g = gradient(32, 32)
    kw = dict(seed=1, schedule=[("mix", 4, 0.5)], radii="density", floor=0.01)
    a = stipple(g, 60, k_quantile=0.0, **kw)
    b = stipple(g, 60, k_quantile=0.5, **kw)
    assert b.history[0]["k"] > a.history[0]["k"]
    assert not np.array_equal(a.points, b.points)
    for r in (a, b):
        assert r.certificate.valid and brute_force_valid(r.points, r.radii, 32, 32)


def test_gamma_is_refused_where_the_radii_have_no_exponent():
    """The API, like the CLI, refuses a gamma the default schedule would ignore."""
    gray = np.linspace(0.1, 0.9, 32 * 32).reshape(32, 32)
    with pytest.raises(ValueError, match="gamma = 1 has no effect with density radii"):
        stipple(gray, 50, gamma=1.0, backend="exact", schedule=[("pack", 1)], radii="density")
    with pytest.raises(ValueError, match="has no effect"):
        stipple(gray, 50, gamma=6.0)
    a = stipple(gray, 50, gamma=1.0, backend="exact", beta=2, lloyd=1, rounds=1)
    b = stipple(gray, 50, gamma=6.0, backend="exact", beta=2, lloyd=1, rounds=1)
    assert not np.allclose(a.base_radii, b.base_radii)      # gamma acts on gray radii


def test_largest_valid_k_finds_a_binding_pair_that_no_nearest_neighbour_forms():
    """Two large disks 5 apart bind (k = 5 / (5 + 5)); each has a tiny disk 3 away as its
    nearest neighbour, so the nearest-neighbour bound alone would give k = 0.6."""

    p = np.array([[45.0, 50.0], [50.0, 50.0], [45.0, 47.0], [50.0, 53.0]])
    r = np.array([5.0, 5.0, 1e-3, 1e-3])
    brute = min(np.hypot(*(p[i] - p[j])) / (r[i] + r[j])
                for i in range(4) for j in range(i + 1, 4))
    assert brute == 0.5
    assert largest_valid_k(p, r, 100.0, 100.0) == 0.5
    assert largest_valid_k(p[[2, 0, 3, 1]], r[[2, 0, 3, 1]], 100.0, 100.0) == 0.5


# -- one timing collector for the whole run ----------------------------------

ENGINE_STAGES = ("exact", "raster_labels", "centroids")


def _check_one_collector(res, own):
    """`own` stages first and last, the engine's stages as the steps' sum, no stage
    counted twice (they are disjoint in time, so they fit in the total)."""
    assert list(res.timings)[:len(own[0])] == list(own[0])
    assert list(res.timings)[-len(own[1]):] == list(own[1])
    for stage in ENGINE_STAGES:
        steps = sum(h.get(f"{stage}_s", 0.0) for h in res.history)
        assert steps > 0 and res.timings[stage] == pytest.approx(steps)
    assert sum(v for k, v in res.timings.items() if k != "total") <= res.timings["total"]


def test_one_collector_times_a_stippling():
    res = stipple(gradient(32, 48), 60, schedule=[("mix", 2, 0.5), ("lloyd", 1), ("pack", 1)],
                  backend="exact")
    _check_one_collector(res, (("load", "start", "setup"), ("certify", "total")))


def test_one_collector_times_a_colour_stippling():
    from diskpack_cl.multipen import stipple_colors

    img = np.zeros((32, 48, 3))
    img[..., 0] = np.linspace(0, 1, 48)
    img[..., 2] = 0.6
    res = stipple_colors(img, 120, "cmy", schedule=[("mix", 4, 0.5)], backend="exact")
    # the pens' own centroids count in the steps and the totals alike
    _check_one_collector(res, (("separate",), ("certify", "total")))


@pytest.mark.parametrize("n, shape, supersample", [(900, (90, 110), None), (900, (90, 110), 2),
                                                   (20000, (300, 260), None)])
def test_fields_made_in_bands_are_the_whole_pictures(n, shape, supersample):
    """A large picture's stage fields come band by band (peak memory); every value is the same,
    also where the bands consume the picture as they go."""
    from diskpack_cl import memory
    from diskpack_cl.engine import make_engine
    from diskpack_cl.radii import detail_ell
    from diskpack_cl.stipple import make_stage

    H, W = shape
    rng = np.random.default_rng(3)
    g = np.clip(rng.random(shape) * 0.3 + np.linspace(0, 0.7, W), 0, 1)
    g[H // 3:H // 2] = 1.0   # white paper across band borders
    options = StippleOptions() if supersample is None else StippleOptions(supersample=supersample)
    plan = options.plan(n, W, H, ink=float((1 - g).sum()))
    engine = make_engine(Domain.rect(W, H), n, "exact")
    whole = make_stage(g, plan, engine, band_rows=H)
    for rows, consume in ((7, False), (16, False), (40, False), (7, True), (40, True)):
        # consumed: the picture's pages go back as the bands pass, as zeros
        picture = g.copy() if consume else g
        part = make_stage(picture, plan, engine, band_rows=rows, consume=consume)
        for name in ("radius_field", "density", "blend_weight", "ink"):
            a, b = getattr(whole, name), getattr(part, name)
            assert (a is None) == (b is None), name
            if a is not None:
                np.testing.assert_array_equal(b, a, err_msg=f"{name}, bands of {rows} rows")
        if consume and memory._glibc() is not None:
            assert (picture[:H // 2] == 0).mean() > 0.25   # (no level of g is 0)
    # a tile's window of the picture, with its margin around it (stipple_tiled), the same
    ell = detail_ell(g, n)
    window = (slice(11, H - 5), slice(13, W - 17))
    whole = make_stage(g, plan, engine, window=window, ell=ell, band_rows=H)
    for rows in (7, 16):
        part = make_stage(g.copy(), plan, engine, window=window, ell=ell, band_rows=rows, consume=True)
        for name in ("radius_field", "density", "blend_weight", "ink"):
            a, b = getattr(whole, name), getattr(part, name)
            assert (a is None) == (b is None), name
            if a is not None:
                np.testing.assert_array_equal(b, a, err_msg=f"{name} of the window, bands of {rows}")


def _plain_fields(g, plan, ell):
    """The stage's fields as written out plainly with scipy: each blur of the darkness on
    its own, the detail radius field dilated over the disk in float64, then rounded."""
    from scipy import ndimage

    from diskpack_cl.stipple import INK_SIGMA

    d = 1.0 - g
    blur = lambda sigma: ndimage.gaussian_filter(d, sigma, mode="reflect") if sigma > 0 else d.copy()   # noqa: E731
    if plan.radii == "density":
        r = np.sqrt(plan.floor / np.maximum(blur(plan.radius_sigma), plan.floor))
    else:
        r = np.maximum(g, plan.floor) ** (0.5 * plan.gamma)
    weight = None
    if plan.features == "detail":
        coarse = blur(ell / 2.0)
        weight = np.clip(1.5 * np.abs(blur(0.5) - coarse) / np.maximum(coarse, 0.1), 0.0, 1.0)
        rad = max(1, int(round(ell / 4.0)))
        disk = np.add.outer(np.arange(-rad, rad + 1) ** 2, np.arange(-rad, rad + 1) ** 2) <= rad * rad
        r = ndimage.grey_dilation(r, footprint=disk, mode="reflect")
    s = plan.supersample
    density = np.maximum(blur(plan.density_sigma), 1e-6).astype(np.float32)
    ink = blur(INK_SIGMA).astype(np.float32) if plan.support > 0 else None
    return {"radius_field": r.astype(np.float32), "blend_weight": None if weight is None else weight.astype(np.float32),
            "ink": ink, "density": np.repeat(np.repeat(density, s, axis=0), s, axis=1)}


@settings(max_examples=25)
@given(h=st.integers(8, 70), w=st.integers(8, 70), n=st.integers(20, 2000),
       schedule=st.sampled_from(["default", "classic", "detail", "paper"]), supersample=st.sampled_from([None, 2]),
       rows=st.sampled_from([3, 5, 1000]), cores=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_stage_fields_are_the_plain_computations(h, w, n, schedule, supersample, rows, cores, seed):
    """The stage's fields (one darkness, its blurs at once, the radius field rounded before
    its dilation by chords, whole or in bands of `rows`, the arithmetic shared by `cores`
    cores in runs of rows as short as one) against the plain computations, bit for bit,
    for every schedule's options."""
    from unittest import mock

    from diskpack_cl.engine import make_engine
    from diskpack_cl.radii import detail_ell
    from diskpack_cl.stipple import make_stage

    rng = np.random.default_rng(seed)
    g = np.clip(rng.random((h, w)) * 1.3 - 0.1, 0.0, 1.0)
    g[rng.integers(0, h):, :rng.integers(0, w)] = 1.0   # white paper, across band borders
    assume(g.min() < 1.0 and 4 * n <= h * w)   # ink to stipple, and 4 grid cells a dot
    options = StippleOptions(schedule=schedule, **({} if supersample is None else {"supersample": supersample}))
    plan = options.plan(n, w, h, ink=float((1 - g).sum()))
    with mock.patch.object(importlib.import_module("diskpack_cl.stipple"), "FIELD_PART", 1), \
            mock.patch("os.cpu_count", return_value=cores):
        stage = make_stage(g, plan, make_engine(Domain.rect(w, h), n, "exact"), band_rows=rows)
    want = _plain_fields(g, plan, detail_ell(g, n))
    for name, field in want.items():
        got = getattr(stage, name)
        assert (got is None) == (field is None), name
        if field is not None:
            assert got.dtype == np.float32 and np.array_equal(got, field), name


@settings(max_examples=50)
@given(st.lists(st.tuples(st.sampled_from([0.0, -1.5, 2.0, np.nan, np.inf, -np.inf]),
                          st.sampled_from([0.0, 3.0, np.nan, np.inf, -np.inf])), max_size=40))
def test_finite_rows_is_all_isfinite_along_rows(rows):
    """The steps' row test, column by column, against numpy's reduction along the rows."""
    from diskpack_cl.stipple import _finite_rows

    a = np.array(rows, dtype=np.float64).reshape(-1, 2)
    np.testing.assert_array_equal(_finite_rows(a), np.all(np.isfinite(a), axis=1))


@settings(max_examples=50)
@given(st.lists(st.tuples(st.booleans(), st.sampled_from([0.0, -0.0, 2.5, np.nan, np.inf]),
                          st.floats(-1e3, 1e3)), max_size=40))
def test_where_rows_is_the_broadcast_where(rows):
    """The steps' row choice (a copy and its dropped rows) against ``np.where`` broadcast
    over the rows, bit for bit (signed zeros and NaN included)."""
    from diskpack_cl.stipple import _where_rows

    keep = np.array([r[0] for r in rows], dtype=bool)
    a = np.array([[r[1], r[2]] for r in rows], dtype=np.float64).reshape(-1, 2)
    b = np.array([[r[2], -r[1]] for r in rows], dtype=np.float64).reshape(-1, 2)
    got, want = _where_rows(keep, a, b), np.where(keep[:, None], a, b)
    assert got.tobytes() == want.tobytes()
    assert got is not a


@settings(max_examples=50)
@given(st.lists(st.tuples(st.floats(0, 9000), st.floats(0, 9000), st.floats(-5, 5), st.floats(-5, 5)),
                min_size=1, max_size=40))
def test_moved_is_the_mean_hypot(rows):
    """The steps' mean displacement against ``np.hypot``'s, to a few ulps (and within
    1e-150 px: a move below 1e-154 px squares to 0, where hypot keeps it)."""
    from diskpack_cl.stipple import _moved

    a = np.array(rows, dtype=np.float64)
    old, new = a[:, :2], a[:, :2] + a[:, 2:]
    assert _moved(old, new) == pytest.approx(np.mean(np.hypot(*(new - old).T)), rel=1e-14, abs=1e-150)


@given(st.integers(1, 100_000), st.floats(0.0, 1.0), st.sampled_from([1, 50, 1 << 16]),
       st.sampled_from(["uniform", "spread", "ties", "sorted", "periodic", "spiky", "nan"]),
       st.integers(0, 2**32 - 1))
@example(1000, 0.15, 1, "spread", 3)   # interpolated from the upper end: not from the lower
def test_quantile_is_numpys_bit_for_bit(n, q, small, kind, seed):
    """The k quantile from a bracket of its order statistics (from `small` values on; any
    order of the values, ties, infinities) or from np.quantile: np.quantile's float."""
    rng = np.random.default_rng(seed)
    v = {"uniform": rng.random(n), "spread": 10.0 ** rng.uniform(-5, 5, n),
         "ties": rng.integers(0, 4, n).astype(float),
         "sorted": np.sort(rng.exponential(size=n)), "periodic": np.tile([0.0, 1.0, 5.0], n)[:n],
         "spiky": rng.choice([-np.inf, 1.0, 2.5, np.inf], n), "nan": rng.random(n)}[kind]
    if kind == "nan":
        v[rng.integers(0, n)] = np.nan
    with np.errstate(invalid="ignore"):   # inf - inf in both
        want = np.quantile(v, q)
        got = _quantile(v.copy(), q, small=small)
    assert type(got) is float
    assert np.array_equal(got, want, equal_nan=True) and np.signbit(got) == np.signbit(want)
