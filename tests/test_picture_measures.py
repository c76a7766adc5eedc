"""The measures that see what the eye sees (stray dots, edge fidelity, holes),
each against a brute-force computation on small synthetic cases."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy import ndimage

from diskpack_cl import picture_measures as P


def brute_stray(points, darkness, threshold):
    p = np.asarray(points, dtype=float)
    d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(-1)
    np.fill_diagonal(d2, np.inf)
    nn = np.sqrt(d2.min(axis=1))
    out = []
    for (x, y), reach in zip(p, nn / 2):
        best = np.inf
        for r in range(darkness.shape[0]):
            for c in range(darkness.shape[1]):
                if darkness[r, c] > threshold:
                    gx = max(c - x, 0.0, x - (c + 1))
                    gy = max(r - y, 0.0, y - (r + 1))
                    best = min(best, math.hypot(gx, gy))
        out.append(best > reach)
    return np.array(out)


@settings(max_examples=40)
@given(st.integers(0, 2**31 - 1), st.integers(2, 30), st.sampled_from([0.0, 0.02, 0.5]))
def test_stray_dots_match_brute_force(seed, n, threshold):
    rng = np.random.default_rng(seed)
    dark = np.where(rng.random((9, 11)) < 0.15, rng.random((9, 11)), 0.0)
    dark[4, 5] = 1.0   # never all white
    pts = rng.random((n, 2)) * [11, 9]
    if n > 3:
        pts[1] = pts[0] + 1e-3 * rng.random(2)   # a near-coincident pair: reach ~0
        pts[2] = np.floor(pts[2])                # a dot on pixel corners
    got = P.stray_dots(pts, dark, threshold=threshold)
    want = brute_stray(pts, dark, threshold)
    np.testing.assert_array_equal(got.mask, want)
    assert got.count == want.sum()
    assert got.per_10k == pytest.approx(1e4 * want.sum() / n)


def test_stray_dots_on_a_drawing():
    dark = np.zeros((30, 30))
    dark[10:20, 10:20] = 1.0
    inside = np.array([[12.0, 12.0], [15.0, 15.0], [18.0, 12.0]])
    on_paper = np.array([[27.0, 27.0], [3.0, 25.0]])
    res = P.stray_dots(np.vstack([inside, on_paper]), dark)
    assert res.mask.tolist() == [False, False, False, True, True]
    assert res.per_10k == pytest.approx(4000.0)


def test_ssim_map_matches_scikit_image():
    metrics = pytest.importorskip("skimage.metrics")
    rng = np.random.default_rng(3)
    a = ndimage.gaussian_filter(rng.random((40, 36)), 1.0)
    b = ndimage.gaussian_filter(rng.random((40, 36)), 1.0)
    _, full = metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                            use_sample_covariance=False, data_range=1.0, full=True)
    np.testing.assert_allclose(P.ssim_map(a, b), full, atol=1e-12)
    assert P.ssim(a, b) == pytest.approx(float(full[5:-5, 5:-5].mean()), abs=1e-12)


def brute_edge_band(dark, edge, width):
    ny, nx = dark.shape
    g = np.zeros_like(dark)
    for r in range(ny):
        for c in range(nx):
            # np.gradient: central differences inside, one-sided at the border
            def diff(v, i, m):
                if i == 0:
                    return v(1) - v(0)
                if i == m - 1:
                    return v(m - 1) - v(m - 2)
                return (v(i + 1) - v(i - 1)) / 2
            gx = diff(lambda j: dark[r, j], c, nx)
            gy = diff(lambda i: dark[i, c], r, ny)
            g[r, c] = math.hypot(gx, gy)
    edges = np.argwhere(g >= edge)
    band = np.zeros_like(dark, dtype=bool)
    for r in range(ny):
        for c in range(nx):
            band[r, c] = np.min(np.hypot(*(edges - [r, c]).T)) <= width
    return edges, band


def test_edge_fidelity_matches_brute_force():
    rng = np.random.default_rng(8)
    dark = np.zeros((36, 40))
    dark[8:28, 6:22] = 1.0
    dark[12:20, 28:36] = 0.6
    pts = rng.random((150, 2)) * [40, 36]
    edges, _ = brute_edge_band(dark, 0.25, 0.0)
    level = np.median([dark[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2].max() for r, c in edges])
    width = 2.0 * math.sqrt(dark.sum() / (150 * level))
    _, band = brute_edge_band(dark, 0.25, width)
    band[:5], band[-5:], band[:, :5], band[:, -5:] = False, False, False, False
    drawing = P.render_dots(pts, P.tone_radius(150, dark), dark.shape)
    smap = P.ssim_map(ndimage.gaussian_filter(drawing, 1.0), ndimage.gaussian_filter(dark, 1.0))
    assert P.edge_fidelity(pts, dark) == pytest.approx(float(smap[band].mean()), abs=1e-12)


def test_edge_fidelity_sees_a_ragged_edge():
    dark = np.zeros((48, 48))
    dark[:, :24] = 1.0
    iy, ix = np.mgrid[0:24, 0:12]
    sharp = np.column_stack([2.0 * ix.ravel() + 1.0, 2.0 * iy.ravel() + 1.0])
    ragged = sharp.copy()
    rim = sharp[:, 0] > 20
    ragged[rim, 0] += np.where(np.arange(rim.sum()) % 2, 3.0, -3.0)   # a scalloped outline
    assert P.edge_fidelity(sharp, dark) > P.edge_fidelity(ragged, dark) + 0.02
    assert np.isnan(P.edge_fidelity(sharp, np.full((48, 48), 0.5)))


def brute_holes(points, dark, solid, sigma):
    p = np.asarray(points, dtype=float)
    blurred = ndimage.gaussian_filter(dark, sigma, mode="reflect")
    out = np.zeros(dark.shape, dtype=bool)
    for r in range(dark.shape[0]):
        for c in range(dark.shape[1]):
            if dark[r, c] >= solid:
                rho = len(p) * blurred[r, c] / dark.sum()
                out[r, c] = np.min(np.hypot(p[:, 0] - c - 0.5, p[:, 1] - r - 0.5)) > 1 / math.sqrt(rho)
    return out


@settings(max_examples=25)
@given(st.integers(0, 2**31 - 1), st.integers(1, 40))
def test_holes_match_brute_force(seed, n):
    rng = np.random.default_rng(seed)
    dark = ndimage.gaussian_filter(rng.random((14, 12)), 1.5)
    dark = np.clip((dark - dark.min()) / max(np.ptp(dark), 1e-9), 0, 1)
    pts = rng.random((n, 2)) * [12, 14]
    got = P.holes(pts, dark, solid=0.5, sigma=2.0)
    want = brute_holes(pts, dark, 0.5, 2.0)
    np.testing.assert_array_equal(got.mask, want)
    assert got.per_10k == pytest.approx(1e4 * want.sum() / max((dark >= 0.5).sum(), 1))


def test_holes_see_a_broken_line():
    dark = np.zeros((40, 60))
    dark[18:22, :] = 1.0   # a 4 px line
    xs = np.arange(1.0, 60.0, 2.0)
    whole = np.column_stack([xs, np.full_like(xs, 20.0)])
    broken = whole[(xs < 20) | (xs > 40)]
    assert P.holes(whole, dark).count == 0
    assert P.holes(broken, dark).count > 0
