"""Tests of diskpack_cl.analysis on cases whose answers are known."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import ndimage
from scipy.spatial import Delaunay

from diskpack_cl import analysis as A
from diskpack_cl import picture_measures as P
from diskpack_cl.domain import Domain

def hex_lattice(m, r, shift=(0.0, 0.0)):
    """r rows of m points on the unit torus, odd rows offset by half a spacing (r even)."""
    iy, ix = np.mgrid[0:r, 0:m]
    x = (ix + 0.5 * (iy % 2)) / m + shift[0]
    y = iy / r + shift[1]
    return np.mod(np.column_stack([x.ravel(), y.ravel()]), 1.0)


def hex_packing(a, m, r, origin=(0.0, 0.0)):
    """Hexagonal packing with spacing a, r rows of m points, in the plane."""
    iy, ix = np.mgrid[0:r, 0:m]
    x = origin[0] + (ix + 0.5 * (iy % 2)) * a
    y = origin[1] + iy * a * math.sqrt(3.0) / 2.0
    return np.column_stack([x.ravel(), y.ravel()])


def direct_periodogram(points, kmax):
    k = np.arange(-kmax, kmax + 1)
    kx, ky = np.meshgrid(k, k)
    phase = np.einsum("ab,j->abj", kx, points[:, 0]) + np.einsum("ab,j->abj", ky, points[:, 1])
    P = np.abs(np.exp(-2j * np.pi * phase).sum(axis=2)) ** 2 / len(points)
    P[kmax, kmax] = 0.0
    return P


# ---------------------------------------------------------------------------
# periodogram


@settings(max_examples=25)
@given(n=st.integers(1, 60), kmax=st.integers(1, 9), seed=st.integers(0, 2**32 - 1))
def test_periodogram_equals_direct_sum(n, kmax, seed):
    pts = np.random.default_rng(seed).random((n, 2))
    freqs, P = A.periodogram(pts, kmax=kmax)
    np.testing.assert_array_equal(freqs, np.arange(-kmax, kmax + 1))
    np.testing.assert_allclose(P, direct_periodogram(pts, kmax), rtol=1e-10, atol=1e-10)


def _degenerate_set(kind, n, rng):
    """Point sets that stress the NUFFT's spreading: lattices, clusters, points on the edges."""
    if kind == "lattice":
        m = max(1, int(math.sqrt(n)))
        return hex_lattice(m, 2 * max(1, n // (2 * m)))
    if kind == "cluster":
        return np.mod(0.999 + 1e-4 * rng.random((n, 2)), 1.0)
    if kind == "edges":
        return rng.choice([0.0, 0.5, 1.0 - 1e-16, 1.0], size=(n, 2))
    return rng.random((n, 2)) * 3 - 1   # outside [0, 1): periodic


@settings(max_examples=25)
@given(kind=st.sampled_from(["lattice", "cluster", "edges", "random"]), n=st.integers(1, 80),
       kmax=st.integers(1, 25), seed=st.integers(0, 2**32 - 1))
def test_nufft_periodogram_equals_direct_sum(kind, n, kmax, seed):
    pts = _degenerate_set(kind, n, np.random.default_rng(seed))
    freqs, P = A.periodogram(pts, kmax=kmax, method="nufft")
    assert P[kmax, kmax] == 0.0
    np.testing.assert_allclose(P, direct_periodogram(pts, kmax), rtol=1e-8, atol=1e-8 * len(pts))


def test_nufft_on_a_blue_noise_set_and_auto():
    from diskpack_cl.sampling import dart_throwing

    pts = dart_throwing(4000, seed=1)
    _, direct = A.periodogram(pts, kmax=60, method="direct")
    _, fast = A.periodogram(pts, kmax=60, method="nufft")
    assert np.abs(fast - direct).max() < 1e-8
    # the spread's width sets the accuracy: a narrow Gaussian is visibly off
    assert np.abs(A._nufft_power(pts, 60, spread=4) - direct).max() > 1e-6
    with pytest.raises(ValueError, match="method must be"):
        A.periodogram(pts, method="fft")


def test_periodogram_large_frequencies_are_accurate():
    pts = np.random.default_rng(0).random((50, 2))
    _, P = A.periodogram(pts, kmax=300)
    k = np.array([[300, -299], [-250, 7], [1, 300]])
    for kx, ky in k:
        direct = abs(np.exp(-2j * np.pi * (kx * pts[:, 0] + ky * pts[:, 1])).sum()) ** 2 / 50
        assert P[300 + ky, 300 + kx] == pytest.approx(direct, rel=1e-9, abs=1e-9)


def test_periodogram_realizations_forms_and_no_mutation():
    rng = np.random.default_rng(1)
    stack = rng.random((3, 40, 2))
    copy = stack.copy()
    f1, P1 = A.periodogram(stack, kmax=5)
    f2, P2 = A.periodogram(list(stack), kmax=5)
    np.testing.assert_array_equal(stack, copy)
    np.testing.assert_allclose(P1, P2)
    mean = np.mean([direct_periodogram(s, 5) for s in stack], axis=0)
    np.testing.assert_allclose(P1, mean, rtol=1e-10, atol=1e-12)
    # realizations of different sizes, each normalized by its own n
    a, b = rng.random((30, 2)), rng.random((70, 2))
    _, P = A.periodogram([a, b], kmax=4)
    np.testing.assert_allclose(P, (direct_periodogram(a, 4) + direct_periodogram(b, 4)) / 2, atol=1e-10)
    # a list of coordinate pairs is one point set
    _, Pl = A.periodogram(a.tolist(), kmax=4)
    np.testing.assert_allclose(Pl, direct_periodogram(a, 4), atol=1e-10)


def test_periodogram_default_kmax_and_symmetry():
    pts = np.random.default_rng(2).random((100, 2))
    freqs, P = A.periodogram(pts)
    assert freqs[-1] == 20  # ceil(2 sqrt(100))
    assert P[20, 20] == 0.0
    np.testing.assert_allclose(P, P[::-1, ::-1], atol=1e-12)


@pytest.mark.parametrize(
    "args, kwargs, match",
    [
        ((np.zeros((5, 3)),), {}, r"points must have shape \(n, 2\), got \(5, 3\)"),
        ((np.zeros((5, 2)),), {"kmax": 0}, "kmax must be a positive integer, got 0"),
        ((np.zeros((5, 2)),), {"kmax": 2.5}, "kmax must be a positive integer, got 2.5"),
        (([],), {}, "need at least one point set"),
        ((np.full((3, 2), np.nan),), {}, "points must be finite"),
    ],
)
def test_periodogram_errors(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        A.periodogram(*args, **kwargs)


def test_uniform_random_has_flat_radial_power_near_one():
    rng = np.random.default_rng(3)
    K, n, kmax = 16, 1024, 32
    freqs, P = A.periodogram(list(rng.random((K, n, 2))), kmax=kmax)
    centres, power = A.radial_power(P, freqs)
    np.testing.assert_array_equal(centres, np.arange(1, kmax + 1))
    # each annulus is a mean of about K * (2 pi r) / 2 independent unit exponentials
    kx, ky = np.meshgrid(freqs, freqs)
    counts = np.array([np.sum(np.floor(np.hypot(kx, ky) + 0.5) == i) for i in centres])
    sd = 1.0 / np.sqrt(K * counts / 2.0)
    assert np.all(np.abs(power - 1.0) < 5 * sd)
    assert abs(power.mean() - 1.0) < 0.03


@settings(max_examples=20)
@given(
    m=st.integers(2, 12),
    half_rows=st.integers(1, 6),
    sx=st.floats(0, 1, exclude_max=True),
    sy=st.floats(0, 1, exclude_max=True),
)
def test_hexagonal_lattice_peaks_sit_on_the_reciprocal_lattice(m, half_rows, sx, sy):
    r = 2 * half_rows
    pts = hex_lattice(m, r, (sx, sy))
    n = len(pts)
    kmax = 2 * max(m, r) + 1
    freqs, P = A.periodogram(pts, kmax=kmax)
    kx, ky = np.meshgrid(freqs, freqs)
    # lattice basis a1 = (1/m, 0), a2 = (1/(2m), 1/r): peaks where k.a1 and k.a2 are integers
    on = (kx % m == 0) & (((kx // m) * r / 2 + ky) % r == 0)
    on[kmax, kmax] = False  # DC is set to 0
    np.testing.assert_allclose(P[on], n, rtol=1e-9)
    assert np.max(P[~on]) < 1e-9 * n
    assert np.count_nonzero(on) > 0


def test_radial_power_and_anisotropy_reject_mismatched_shapes():
    with pytest.raises(ValueError, match=r"P must have shape \(5, 5\) to match freqs, got \(4, 4\)"):
        A.radial_power(np.zeros((4, 4)), np.arange(-2, 3))
    with pytest.raises(ValueError, match="P must have shape"):
        A.anisotropy(np.zeros((4, 4)), np.arange(-2, 3))


def test_anisotropy_of_isotropic_sets():
    rng = np.random.default_rng(4)
    n, kmax = 1024, 32
    freqs, P = A.periodogram(rng.random((n, 2)), kmax=kmax)
    _, a1 = A.anisotropy(P, freqs)
    assert abs(np.mean(a1[7:])) < 0.75  # one realization: about 0 dB
    K = 8
    freqs, P = A.periodogram(list(rng.random((K, n, 2))), kmax=kmax)
    centres, aK = A.anisotropy(P, freqs)
    assert centres.shape == aK.shape == (kmax,)
    assert abs(np.mean(aK[7:]) + 10 * math.log10(K)) < 0.75  # K realizations: -10 log10 K dB


def test_anisotropy_of_a_constant_annulus_is_minus_infinity():
    freqs = np.arange(-3, 4)
    _, a = A.anisotropy(np.ones((7, 7)), freqs)
    assert np.all(np.isneginf(a))


# ---------------------------------------------------------------------------
# distances and rho


@settings(max_examples=25)
@given(n=st.integers(2, 40), seed=st.integers(0, 2**32 - 1), w=st.floats(0.5, 3), h=st.floats(0.5, 3))
def test_nearest_neighbor_distances_match_brute_force(n, seed, w, h):
    rng = np.random.default_rng(seed)
    box = np.array([w, h])
    pts = rng.random((n, 2)) * box
    d = pts[:, None, :] - pts[None, :, :]
    plane = np.hypot(d[..., 0], d[..., 1])
    np.fill_diagonal(plane, np.inf)
    np.testing.assert_allclose(A.nearest_neighbor_distances(pts, domain=False), plane.min(axis=1))
    d = d - box * np.round(d / box)
    torus = np.hypot(d[..., 0], d[..., 1])
    np.fill_diagonal(torus, np.inf)
    np.testing.assert_allclose(A.nearest_neighbor_distances(pts, domain=(w, h)), torus.min(axis=1))
    np.testing.assert_allclose(A.nearest_neighbor_distances(pts, domain=Domain(w, h, True)), torus.min(axis=1))
    np.testing.assert_allclose(A.nearest_neighbor_distances(pts, domain=Domain.rect(w, h)), plane.min(axis=1))


def test_nearest_neighbor_distances_wrap_and_errors():
    np.testing.assert_allclose(A.nearest_neighbor_distances([[0.05, 0.5], [0.95, 0.5]]), [0.1, 0.1])
    np.testing.assert_allclose(A.nearest_neighbor_distances([[1.05, 0.5], [-0.05, 0.5]]), [0.1, 0.1])
    with pytest.raises(ValueError, match="need at least 2 points"):
        A.nearest_neighbor_distances([[0.5, 0.5]])
    with pytest.raises(ValueError, match="periodic must be True, False or a domain size"):
        A.nearest_neighbor_distances([[0.1, 0.5], [0.2, 0.5]], domain=(1.0, -1.0))


@pytest.mark.parametrize("m, r", [(7, 8), (26, 30), (13, 14)])
def test_rho_of_near_hexagonal_lattices(m, r):
    pts = hex_lattice(m, r, (0.3, 0.1))
    n = m * r
    d_min = min(1.0 / m, math.hypot(0.5 / m, 1.0 / r), 1.0 / r * 2)
    r_max = math.sqrt(1.0 / (2.0 * math.sqrt(3.0) * n))
    assert A.normalized_radius(pts) == pytest.approx(d_min / 2 / r_max, rel=1e-9)
    # every point has its nearest neighbour at d_min
    assert A.mean_normalized_radius(pts) == pytest.approx(d_min / 2 / r_max, rel=1e-9)


def test_rho_is_one_only_for_an_exact_hexagonal_tiling():
    # m / r = sqrt(3) / 2 is irrational, so no lattice tiles the square exactly; close ones approach 1
    assert 0.999 < A.normalized_radius(hex_lattice(26, 30)) < 1.0
    assert 0.99 < A.normalized_radius(hex_lattice(7, 8)) < 0.996


def test_rho_of_random_points():
    rng = np.random.default_rng(5)
    pts = rng.random((4096, 2))
    assert A.mean_normalized_radius(pts) == pytest.approx(math.sqrt(2 * math.sqrt(3)) / 4, abs=0.02)
    assert A.normalized_radius(pts) < 0.1  # random points have close pairs


# ---------------------------------------------------------------------------
# hexatic order


def test_psi6_of_hexagonal_lattice_on_the_torus_is_one():
    h = A.hexatic_order(hex_lattice(26, 30, (0.123, 0.456)))
    assert h.psi6.shape == (780,)
    np.testing.assert_allclose(h.psi6, 1.0, atol=1e-5)
    assert h.mean == pytest.approx(1.0, abs=1e-5)


def test_psi6_of_a_perfect_hexagonal_packing_in_a_bounded_domain():
    pts = hex_packing(1.0, 20, 20, origin=(0.5, 0.5))
    h = A.hexatic_order(pts, periodic=False)
    x, y = pts[:, 0], pts[:, 1]
    interior = (x > 1.6) & (x < x.max() - 1.1) & (y > 1.4) & (y < y.max() - 0.9)
    np.testing.assert_allclose(h.psi6[interior], 1.0, atol=1e-9)
    assert h.mean < 1.0


def test_psi6_of_random_points_is_clearly_lower():
    pts = np.random.default_rng(6).random((2000, 2))
    h = A.hexatic_order(pts)
    assert 0.3 < h.mean < 0.42
    assert np.all((h.psi6 >= 0) & (h.psi6 <= 1 + 1e-12))
    hb = A.hexatic_order(pts * 100, periodic=False)
    assert 0.3 < hb.mean < 0.42


def psi6_full_tiling(pts, box):
    """Reference: Delaunay of all 9 periodic copies; neighbours of the central copy."""
    n = len(pts)
    shifts = [(0, 0)] + [(sx, sy) for sx in (-1, 0, 1) for sy in (-1, 0, 1) if (sx, sy) != (0, 0)]
    allp = np.concatenate([pts + box * np.array(s) for s in shifts])
    indptr, indices = Delaunay(allp).vertex_neighbor_vertices
    out = np.empty(n)
    for j in range(n):
        nb = indices[indptr[j]:indptr[j + 1]]
        d = allp[nb] - allp[j]
        out[j] = abs(np.mean(np.exp(6j * np.arctan2(d[:, 1], d[:, 0]))))
    return out


@settings(max_examples=20)
@given(n=st.integers(3, 60), seed=st.integers(0, 2**32 - 1), w=st.floats(0.5, 2))
def test_psi6_on_the_torus_matches_the_full_periodic_tiling(n, seed, w):
    rng = np.random.default_rng(seed)
    box = np.array([w, 1.0])
    pts = rng.random((n, 2)) * box
    h = A.hexatic_order(pts, width=w, height=1.0)
    np.testing.assert_allclose(h.psi6, psi6_full_tiling(pts, box), atol=1e-9)


def test_psi6_is_invariant_under_torus_translation():
    rng = np.random.default_rng(7)
    pts = rng.random((300, 2))
    a = A.hexatic_order(pts).psi6
    b = A.hexatic_order(pts + [0.37, 0.81]).psi6
    np.testing.assert_allclose(a, b, atol=1e-9)


def test_psi6_errors():
    with pytest.raises(ValueError, match="need at least 3 points"):
        A.hexatic_order([[0.1, 0.1], [0.5, 0.5]])
    with pytest.raises(ValueError, match="width and height must be positive, got 0 x 1"):
        A.hexatic_order(np.random.default_rng(0).random((5, 2)), width=0, height=1)
    with pytest.raises(ValueError, match="points are collinear: no Delaunay triangulation"):
        A.hexatic_order([[0.1, 0.5], [0.5, 0.5], [0.9, 0.5]], periodic=False)


# ---------------------------------------------------------------------------
# SSIM and tone


def test_ssim_of_identical_images_is_one():
    img = np.random.default_rng(8).random((40, 30))
    assert P.ssim(img, img) == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=20)
@given(
    ny=st.integers(11, 48),
    nx=st.integers(11, 48),
    seed=st.integers(0, 2**32 - 1),
    blur=st.floats(0, 3),
    noise=st.floats(0, 0.5),
)
def test_ssim_matches_scikit_image(ny, nx, seed, blur, noise):
    skimage_metrics = pytest.importorskip("skimage.metrics")  # a test-only reference
    rng = np.random.default_rng(seed)
    a = ndimage.gaussian_filter(rng.random((ny, nx)), blur)
    b = np.clip(a + noise * rng.standard_normal((ny, nx)), 0, 1)
    ref = skimage_metrics.structural_similarity(
        a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1
    )
    assert P.ssim(a, b) == pytest.approx(ref, abs=1e-6)


def test_ssim_errors():
    with pytest.raises(ValueError, match="images must be at least 11 x 11 pixels"):
        P.ssim(np.zeros((8, 20)), np.zeros((8, 20)))
    with pytest.raises(ValueError, match="images must be 2-D with equal shapes"):
        P.ssim(np.zeros((20, 20)), np.zeros((20, 21)))


def brute_render(points, radius, shape, s=64):
    sub = (np.arange(s) + 0.5) / s
    ny, nx = shape
    ys = (np.arange(ny)[:, None] + sub).ravel()
    xs = (np.arange(nx)[:, None] + sub).ravel()
    X, Y = np.meshgrid(xs, ys)
    img = np.zeros_like(X)
    for (cx, cy), r in zip(points, np.broadcast_to(radius, len(points))):
        img += (X - cx) ** 2 + (Y - cy) ** 2 <= r * r
    return img.reshape(ny, s, nx, s).mean(axis=(1, 3))


@settings(max_examples=20)
@given(
    n=st.integers(1, 6),
    seed=st.integers(0, 2**32 - 1),
    radius=st.floats(0.3, 4.0),
)
def test_render_dots_matches_fine_supersampling(n, seed, radius):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 2)) * [8, 6] + 9
    img = P.render_dots(pts, radius, (24, 26))
    ref = brute_render(pts, radius, (24, 26))
    assert np.max(np.abs(img - ref)) < 0.03 * n
    # each dot holds exactly pi r^2 of ink (they lie inside the image)
    assert img.sum() == pytest.approx(n * math.pi * radius**2, rel=1e-12)


def test_render_dots_clips_at_the_image_edge_and_handles_tiny_dots():
    img = P.render_dots([[0.0, 5.0]], 2.0, (10, 10))
    assert img.sum() == pytest.approx(0.5 * math.pi * 4.0, rel=0.02)
    tiny = P.render_dots([[3.2, 4.7]], 1e-3, (8, 8))
    assert tiny[4, 3] == pytest.approx(math.pi * 1e-6)
    assert tiny.sum() == pytest.approx(math.pi * 1e-6)
    mixed = P.render_dots([[2.0, 2.0], [6.0, 6.0]], [0.5, 1.5], (9, 9))
    assert mixed.sum() == pytest.approx(math.pi * (0.25 + 2.25))
    with pytest.raises(ValueError, match="radius must be positive and finite"):
        P.render_dots([[2.0, 2.0]], 0.0, (5, 5))


@settings(max_examples=15)
@given(n=st.integers(20, 400), level=st.floats(0.05, 1.0), seed=st.integers(0, 2**32 - 1))
def test_tone_drawing_total_ink_equals_total_darkness(n, level, seed):
    rng = np.random.default_rng(seed)
    darkness = level * rng.random((40, 50))
    R = P.tone_radius(n, darkness)
    # keep every dot inside the image so no ink is clipped
    pts = R + rng.random((n, 2)) * (np.array([50, 40]) - 2 * R)
    assume(np.all(pts >= R) and np.all(pts <= [50 - R, 40 - R]))
    drawing = P.render_dots(pts, R, darkness.shape)
    assert drawing.sum() == pytest.approx(darkness.sum(), rel=1e-10)


def test_tone_ssim_prefers_the_stippling_of_the_right_image():
    rng = np.random.default_rng(9)
    ny, nx = 64, 64
    yy, xx = np.mgrid[0:ny, 0:nx]
    ramp = (xx + 0.5) / nx * 0.9 + 0.05
    flipped = ramp[:, ::-1]
    # draw points with density proportional to the ramp's darkness (inverse-CDF in x)
    n = 3000
    u = rng.random(n)
    cdf = np.concatenate([[0.0], np.cumsum(ramp[0]) / ramp[0].sum()])
    x = np.interp(u, cdf, np.arange(nx + 1.0))
    pts = np.column_stack([x, rng.random(n) * ny])
    good = P.tone_ssim(pts, ramp)
    bad = P.tone_ssim(pts, flipped)
    flat = P.tone_ssim(rng.random((n, 2)) * [nx, ny], ramp)
    assert good > 0.7 > flat > 0.2 > bad


def test_tone_ssim_of_a_hexagonal_packing_at_uniform_darkness_is_near_one():
    a = 2.0
    pts = hex_packing(a, 40, 46, origin=(0.5, 0.6))
    darkness = np.full((int(46 * a * math.sqrt(3) / 2), 80), 0.3)
    assert P.tone_ssim(pts, darkness) > 0.95


# ---------------------------------------------------------------------------
# spacing and the bundle


@pytest.mark.parametrize("level", [0.1, 0.5, 1.0])
def test_spacing_of_a_hexagonal_packing_at_uniform_darkness(level):
    a, m, r = 4.0, 25, 29
    pts = hex_packing(a, m, r, origin=(1.0, 1.0))
    width, height = m * a, r * a * math.sqrt(3) / 2  # 100 x 100.46: density n / area
    darkness = np.full((round(height), round(width)), level)
    s = P.spacing(pts, darkness)
    assert s.values.shape == (m * r,)
    assert s.median == pytest.approx(P.HEXAGONAL_SPACING, rel=5e-3)
    assert s.p01 == pytest.approx(P.HEXAGONAL_SPACING, rel=5e-3)
    assert P.HEXAGONAL_SPACING == pytest.approx(1.0746, abs=1e-4)


def two_density_halves(height, step):
    """A dark left half (darkness 0.8, square grid of `step`) beside a light right half
    (0.2, a quarter of the density: grid of 2 `step`), ``(darkness, points)``; the light
    grid's first column stands `step` px right of the boundary."""
    dark = np.full((height, 2 * height), 0.2)
    dark[:, :height] = 0.8
    half = np.arange(step / 2, height, step)
    left = np.stack(np.meshgrid(half, half), -1).reshape(-1, 2)
    right = np.stack(np.meshgrid(np.arange(height + step, 2 * height, 2.0 * step),
                                 np.arange(step, height, 2.0 * step)), -1).reshape(-1, 2)
    return dark, np.concatenate([left, right])


def test_spacing_follows_local_density():
    # two halves: dark left with 4x the density of the light right, each half a square grid
    dark, pts = two_density_halves(80, 2.0)
    s = P.spacing(pts, dark)
    # a square grid gives d * sqrt(1 / d^2) = 1 away from the boundary between halves
    assert s.median == pytest.approx(1.0, abs=0.02)
    # the expected density it used: n D(x_i) / sum(D), 4x on the dark half away from the step
    far_left, far_right = pts[:, 0] < 60, pts[:, 0] > 100
    assert s.density[far_left] == pytest.approx(len(pts) * 0.8 / dark.sum())
    assert s.density[far_right] == pytest.approx(len(pts) * 0.2 / dark.sum())


def test_pair_spacing_against_brute_force():
    # random dots on a smooth ramp with a white corner (zero density there)
    rng = np.random.default_rng(11)
    yy, xx = np.mgrid[0:60, 0:90]
    dark = np.clip((xx - 30) / 60.0, 0.0, 1.0)  # white for x < 30: beyond the blur's reach at x = 3
    pts = rng.random((250, 2)) * [90, 60]
    pts[:3] = [[3.0, 3.0], [3.5, 3.0], [45.0, 30.0]]
    pts[3] = pts[2]  # a coincident pair: distance 0 either way
    s = P.spacing(pts, dark)
    q = P.spacing(pts, dark, normalize="pair")
    D = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(D, np.inf)
    j = D.argmin(1)
    nn = D[np.arange(len(pts)), j]
    a, b = np.sqrt(s.density), np.sqrt(s.density[j])
    with np.errstate(invalid="ignore"):
        expect = np.where(a + b > 0, nn * 2 * a * b / (a + b), 0.0)
    np.testing.assert_allclose(s.values, nn * a, rtol=1e-12)
    np.testing.assert_allclose(q.values, expect, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(q.density, s.density)
    assert q.values[0] == q.values[1] == 0.0  # in the white corner
    assert q.values[2] == q.values[3] == 0.0
    with pytest.raises(ValueError, match="normalize must be 'dot' or 'pair'"):
        P.spacing(pts, dark, normalize="max")


def test_pair_spacing_across_a_tone_edge():
    # dark left half: grid spacing 4; light right half (1/4 the darkness): spacing 8,
    # its first column tangent-like at the mean spacing 6 from the last dark column
    dark, pts = two_density_halves(160, 4.0)
    s = P.spacing(pts, dark)
    q = P.spacing(pts, dark, normalize="pair")
    inner = (np.abs(pts[:, 0] - 160) > 20) & (pts[:, 0] > 10) & (pts[:, 0] < 310) \
        & (pts[:, 1] > 10) & (pts[:, 1] < 150)
    np.testing.assert_allclose(q.values[inner], s.values[inner], rtol=1e-9)
    light_edge = pts[:, 0] == 164
    # read against its own spacing the light-side column is cramped; against the pair's it is not
    assert np.all(s.values[light_edge] < 0.9)
    assert np.all(q.values[light_edge] > 1.05)


def test_stipple_measures_and_errors():
    rng = np.random.default_rng(10)
    dark = np.full((48, 48), 0.3)
    pts = rng.random((300, 2)) * 48
    before = pts.copy()
    m = P.stipple_measures(pts, dark)
    np.testing.assert_array_equal(pts, before)
    assert set(m) == {"n", "tone_ssim", "tone_ssim_fine", "spacing_p01", "spacing_median",
                      "spacing_p01_pair", "psi6_mean", "stray_per_10k", "edge_ssim", "holes_per_10k"}
    assert np.isnan(m["edge_ssim"])      # a flat gray has no strong edge
    assert m["stray_per_10k"] == 0       # every pixel is inked
    assert m["holes_per_10k"] == 0       # no pixel is solid-dark (0.3 < 0.5)
    # uniform random points leave gaps wider than a spacing in a solid-dark region
    assert P.holes(pts, np.full((48, 48), 0.6)).per_10k > 0
    assert m["n"] == 300
    assert 0 < m["spacing_p01"] < m["spacing_median"] < P.HEXAGONAL_SPACING
    assert 0.2 < m["psi6_mean"] < 0.5
    assert -1 <= m["tone_ssim"] <= 1
    with pytest.raises(ValueError, match="darkness is all zero \\(a white image\\): nothing to stipple"):
        P.stipple_measures(pts, np.zeros((48, 48)))
    with pytest.raises(ValueError, match=r"darkness values must lie in \[0, 1\]"):
        P.tone_ssim(pts, np.full((48, 48), 1.5))
    with pytest.raises(ValueError, match="darkness must be a non-empty 2-D array"):
        P.spacing(pts, np.ones(10))


@settings(max_examples=20)
@given(kmax=st.integers(1, 12), seed=st.integers(0, 2**32 - 1))
def test_radial_power_and_anisotropy_against_a_loop_over_the_frequencies(kmax, seed):
    """Annulus i: the frequencies with i - 1/2 <= |k| < i + 1/2, i = 1 .. kmax; its mean
    power, and the sample variance (ddof 1) over the squared mean in dB."""
    freqs = np.arange(-kmax, kmax + 1)
    power = np.random.default_rng(seed).exponential(size=(freqs.size, freqs.size))
    rings = {i: [] for i in range(1, kmax + 1)}
    for row, ky in enumerate(freqs):
        for col, kx in enumerate(freqs):
            for i in rings:
                if i - 0.5 <= math.hypot(kx, ky) < i + 0.5:
                    rings[i].append(power[row, col])
    centres, mean = A.radial_power(power, freqs)
    np.testing.assert_array_equal(centres, np.arange(1, kmax + 1))
    np.testing.assert_allclose(mean, [np.mean(rings[i]) for i in rings], rtol=1e-12)
    _, db = A.anisotropy(power, freqs)
    want = [10 * np.log10(np.var(rings[i], ddof=1) / np.mean(rings[i]) ** 2) for i in rings]
    np.testing.assert_allclose(db, want, rtol=1e-9)
