"""support: dots stay on the ink (white paper stays white, outlines stay sharp); paper_tone."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from diskpack_cl.picture_measures import edge_fidelity, stray_dots
from diskpack_cl.radii import field_at
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import _blend_weights, off_support, stipple


def drawing():
    """A black disc and a black square on white paper, 96x96."""
    g = np.ones((96, 96))
    yy, xx = np.mgrid[0:96, 0:96] + 0.5
    g[np.hypot(xx - 28, yy - 30) < 18] = 0.0
    g[52:84, 50:86] = 0.0
    return g


def test_off_support_reads_the_ink_at_centre_and_centroid():
    ink = np.zeros((10, 10))
    ink[:, :5] = 1.0
    ink[:, 5:7] = 0.25
    m = np.array([[8.0, 1.0], [1.0, 1.0], [5.5, 1.0], [8.0, 1.0], [2.0, 2.0]])
    c = np.array([[2.0, 1.0], [3.0, 4.0], [2.0, 1.0], [9.0, 9.0], [9.0, 9.0]])
    # white paper; the same tone; a quarter of the tone; centre and centroid both
    # off the ink (a curved thin line's cell): all the way; centre on the ink: no pull
    assert off_support(ink, m, c).tolist() == [1.0, 0.0, 0.75, 1.0, 0.0]
    # a gain sends a centre that lost a quarter of the tone all the way, and is clipped
    assert off_support(ink, m, c, gain=4.0).tolist() == [1.0, 0.0, 1.0, 1.0, 0.0]
    ink[:, 5:7] = 0.9
    assert off_support(ink, m, c, gain=4.0)[2] == pytest.approx(0.4)


def test_support_options_resolved_and_checked():
    opt = StippleOptions.resolve(500, 64, 48)
    assert (opt.support, opt.capacity, opt.paper_tone) == (8.0, 0.1, 0.0)
    assert StippleOptions.resolve(500, 64, 48, schedule="classic").support == 0.0
    for name, bad, text in (("support", 16.5, r"in \[0, 16\]"), ("support", np.nan, r"in \[0, 16\]"),
                            ("paper_tone", 1.0, r"in \[0, 1\)"), ("paper_tone", -0.1, r"in \[0, 1\)")):
        with pytest.raises(ValueError, match=f"{name} must be {text}"):
            StippleOptions.resolve(500, 64, 48, **{name: bad})


@pytest.fixture(scope="module")
def runs():
    g = drawing()
    return g, {s: stipple(g, 400, seed=1, support=s) for s in (0.0, 8.0)}


def test_default_keeps_white_paper_white(runs):
    g, res = runs
    dark = 1.0 - g
    assert res[8.0].certificate.valid
    assert stray_dots(res[8.0].points, dark).count == 0
    # without the rule, outline dots drift out to the middle of the paper
    assert stray_dots(res[0.0].points, dark).count >= 3


def test_default_keeps_outlines_sharp(runs):
    g, res = runs
    dark = 1.0 - g
    lloyd = stipple(g, 400, seed=1, method="lloyd")
    sharp = edge_fidelity(res[8.0].points, dark)
    assert sharp >= edge_fidelity(lloyd.points, dark) - 0.01
    assert sharp > edge_fidelity(res[0.0].points, dark) + 0.03


def test_paper_tone_puts_sparse_dots_on_white():
    g = drawing()
    white = g > 0.5
    res = stipple(g, 400, seed=1, paper_tone=0.1)
    col = np.clip(res.points.astype(int), 0, 95)
    on_white = white[col[:, 1], col[:, 0]].sum()
    # 0.1 of darkness over the white 73% of the page: about a fifth of the dots
    assert 0.1 * 400 < on_white < 0.35 * 400
    assert res.certificate.valid and res.params["paper_tone"] == 0.1
    blank = stipple(np.ones((40, 40)), 50, seed=0, paper_tone=0.2)
    assert blank.n == 50 and blank.certificate.valid


def test_support_gain_sharpens_edges_between_two_grays():
    # gray shapes on a light gray paper: no centre leaves the ink altogether, it
    # only loses part of the tone, which a gain above 1 turns into a full pull
    yy, xx = np.mgrid[0:96, 0:96] + 0.5
    g = np.full((96, 96), 0.75)
    g[np.hypot(xx - 30, yy - 34) < 20] = 0.15
    g[56:88, 46:90] = 0.35
    for seed in (0, 1):
        edge = {s: edge_fidelity(stipple(g, 600, seed=seed, support=s).points, 1.0 - g)
                for s in (1.0, 8.0)}
        assert edge[8.0] > edge[1.0] + 0.005


def rings(size=96):
    """Four thin anti-aliased rings (1-2 px) on white paper: a tenth of the page is inked."""
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    r = np.hypot(xx - size / 2, yy - size / 2)
    dark = np.zeros((size, size))
    for radius, width in ((10, 1.0), (20, 1.5), (30, 1.0), (40, 2.0)):
        dark = np.maximum(dark, np.clip(width / 2 + 0.5 - np.abs(r - radius), 0.0, 1.0))
    return 1.0 - dark


def test_dense_thin_lines_keep_their_dots_on_the_ink():
    # 3000 dots on 940 inked pixels, three per pixel of full black: the raster
    # and the centroid blur follow the ink, not the page (auto_supersample,
    # BLACK_SPACING_BLUR); with the page's (supersample 3, blur 0.5 px) the
    # lines' dots spill onto the paper and the rings blur
    g = rings()
    dark = 1.0 - g
    res = stipple(g, 3000, seed=1)
    assert res.certificate.valid and res.params["supersample"] == 4
    lloyd = stipple(g, 3000, seed=1, method="lloyd")
    page = stipple(g, 3000, seed=1, supersample=3, density_sigma=0.5)
    stray = {k: stray_dots(r.points, dark).per_10k for k, r in
             (("default", res), ("lloyd", lloyd), ("page", page))}
    edge = {k: edge_fidelity(r.points, dark) for k, r in
            (("default", res), ("lloyd", lloyd), ("page", page))}
    assert stray["default"] <= stray["lloyd"] + 5 < stray["page"]
    assert edge["default"] >= max(edge["lloyd"] - 0.01, edge["page"] + 0.005)


def _plain_off_support(ink, m, c, gain):
    """off_support's formula as first written."""
    dm, dc = field_at(ink, m), field_at(ink, c)
    ratio = np.divide(dm, dc, out=(dm > 0).astype(np.float64), where=dc > 0)
    return np.clip(gain * (1.0 - ratio), 0.0, 1.0)


def _plain_blend_weights(stage, x, m, c, blend):
    """_blend_weights' formula as first written (the blend weight read at the dots `x`)."""
    a = np.full(len(x), float(blend))
    if blend > 0 and stage.blend_weight is not None:
        a = blend + (1.0 - blend) * field_at(stage.blend_weight, x)
    if stage.options.support > 0:
        a = np.maximum(a, _plain_off_support(stage.ink, m, c, stage.options.support))
    return a


@given(st.integers(1, 60), st.sampled_from([0.0, 0.4, 0.6, 0.75]), st.booleans(),
       st.sampled_from([0.0, 1.0, 8.0, 16.0]), st.integers(0, 2**32 - 1))
def test_blend_weights_are_their_plain_formula_bit_for_bit(n, blend, detail, support, seed):
    """The per-dot blend (in place, the blend weight read with the radii) and off_support
    against the formulas as first written, on ink with white paper and thin lines."""
    rng = np.random.default_rng(seed)
    H, W = 12, 17
    ink = (rng.random((H, W)) * (rng.random((H, W)) < 0.5)).astype(np.float32)
    weight = rng.random((H, W)).astype(np.float32) if detail else None
    stage = SimpleNamespace(ink=ink, blend_weight=weight, options=SimpleNamespace(support=support))
    x, m, c = (rng.uniform(-1, 18, (n, 2)) for _ in range(3))
    at_x = field_at(weight, x) if detail and blend > 0 else None
    got = _blend_weights(stage, at_x, m, c, blend)
    assert got.tobytes() == _plain_blend_weights(stage, x, m, c, blend).tobytes()
    if support > 0:
        assert off_support(ink, m, c, support).tobytes() == _plain_off_support(ink, m, c, support).tobytes()


@given(st.integers(1, 400), st.integers(1, 60), st.sampled_from(["spread", "ties", "dead"]),
       st.integers(0, 2**32 - 1))
def test_heaviest_are_the_stable_ranking_of_all_live_dots(n, k, kind, seed):
    """The heaviest live dots from a sampled few are the first k of the plain ranking of
    every live dot (least_k of the negated masses), ties in index order."""
    from diskpack_cl.dithering import least_k
    from diskpack_cl.stipple import _heaviest

    rng = np.random.default_rng(seed)
    mass = {"spread": 10.0 ** rng.uniform(-3, 3, n), "ties": rng.integers(0, 3, n).astype(float),
            "dead": rng.random(n) * (rng.random(n) < 0.3)}[kind]
    live = rng.random(n) < 0.9
    idx = np.flatnonzero(live)
    assert np.array_equal(_heaviest(mass, live, k), idx[least_k(-mass[idx], k)])
