"""Elongated images and rectangles (1 x N, N x 1, 2 x 50000): the raster's
bucket grid and ring searches must not degenerate on extreme aspect ratios."""

import numpy as np
import pytest

import reference as ref
from diskpack_cl.domain import Domain

pytest.importorskip("pyopencl")


@pytest.mark.parametrize("width, height", [(1000.0, 1.0), (1.0, 1000.0), (50000.0, 2.0),
                                           (30.0, 20.0)])
def test_bucket_grid_is_square_and_covers_a_rectangle(ctx, width, height):
    from diskpack_cl.device.raster import PowerRaster

    pr = PowerRaster(Domain.rect(width, height), (4, 4), device=ctx)
    pts = np.random.default_rng(0).random((100, 2)) * (width, height)
    order, start, _, _, (nbx, nby, bw, bh) = pr._buckets(pts, np.zeros(100, np.float32))
    assert bw == bh
    assert nbx * bw >= width and nby * bh >= height
    assert (nbx - 1) * bw < width and (nby - 1) * bh < height
    assert sorted(order) == list(range(100)) and start[-1] == 100


@pytest.mark.parametrize("width, height, shape", [(1000.0, 1.0, (2, 2000)),
                                                  (1.0, 1000.0, (2000, 2))])
def test_labels_on_an_elongated_rectangle_with_an_empty_end(ctx, width, height, shape):
    """All sites in the first tenth, weighted: the far end's grid cells must
    reach across 900 px of empty buckets (this took seconds per call)."""
    from diskpack_cl.device.raster import PowerRaster

    rng = np.random.default_rng(1)
    long_side = max(width, height)
    t = np.sort(rng.random(60)) * 0.1 * long_side
    u = rng.random(60) * min(width, height)
    pts = np.column_stack([t, u] if width > height else [u, t])
    w = rng.random(60) * 0.2
    pr = PowerRaster(Domain.rect(width, height), shape, device=ctx)
    est = pr.compute(pts, w)
    lab, gap = ref.power_labels_ref(pts, w, Domain.rect(width, height), shape)
    bad = (est.labels != lab) & (gap > 1e-5 * long_side ** 2)
    assert not bad.any()
    dist, _ = ref.boundary_distance_ref(pts, w, Domain.rect(width, height), shape)
    same = est.labels == lab
    assert np.all(np.abs(est.dist[same] - dist[same]) <= 1e-4 * long_side)


@pytest.mark.parametrize("shape, n", [((1, 1000), 100), ((1000, 1), 100), ((2, 50000), 500),
                                      ((1, 4000), 500)])
def test_stipple_elongated_images(ctx, tmp_path, shape, n):
    from PIL import Image

    from diskpack_cl.stipple import stipple

    h, w = shape
    ramp = np.linspace(0, 255, max(h, w)).astype(np.uint8)
    img = np.broadcast_to(ramp[None, :] if w >= h else ramp[:, None], shape)
    path = tmp_path / "long.png"
    Image.fromarray(np.ascontiguousarray(img)).save(path)
    res = stipple(str(path), n, schedule=[("mix", 3, 0.5)], device=ctx)
    assert (res.width, res.height) == (w, h)
    assert res.certificate.valid
    assert np.all(res.points >= 0) and np.all(res.points <= (w, h))
