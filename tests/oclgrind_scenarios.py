"""Small scenarios that run every kernel once, for the Oclgrind pass (tests/test_oclgrind.py).

Each scenario takes a context and returns a dict of arrays.  The test runs
it twice: in a child process on the Oclgrind simulator, which checks every
memory access, data races and API calls and logs what it finds, and in the
test process on the usual device; the results must agree.  Run as a
script, ``python tests/oclgrind_scenarios.py NAME OUT.npz`` writes one
scenario's arrays (the child's side).

Sizes are small on purpose: Oclgrind interprets every work item, about
10^4 times slower than PoCL.
"""

from __future__ import annotations

import sys

import numpy as np

from diskpack_cl.domain import Domain


def _sites(dom, n, seed, heavy=0.0):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 2)) * (dom.width, dom.height)
    spacing = np.sqrt(dom.area / n)
    return pts, (heavy * spacing * rng.random(n)) ** 2


def _raster(ctx, dom, shape, n, heavy):
    """power_labels (both passes), power_labels_tile, cell_max, cell_argmax,
    cell_sums and power_sums_tile, on a raster with partial tiles."""
    from diskpack_cl.device.raster import PowerRaster

    from diskpack_cl.device.checks import verdict_of

    pts, w = _sites(dom, n, 1, heavy)
    out = {}
    # 16 lanes where the device is trusted with 512-bit vectors (device_checks)
    wide = verdict_of(ctx).wide
    for layout, lanes in (("item", None), ("tile", 8)) + ((("tile16", 16),) if wide else ()):
        pr = PowerRaster(dom, shape, device=ctx, layout=layout[:4], lanes=lanes, max_groups=2)
        est = pr.compute(pts, w, neighbors=True)
        out.update({f"{layout}_label": est.labels.copy(), f"{layout}_dist": est.dist.copy(),
                    f"{layout}_nbr": est.neighbor.copy(), f"{layout}_radii": est.radii})
        dens = np.random.default_rng(2).random(shape)
        c, mass = est.centroids(dens)
        out.update({f"{layout}_centroids": c, f"{layout}_mass": mass})
        out[f"{layout}_labels_only"] = pr.compute(pts, w, distance=False).labels.copy()
        if layout != "item":   # the tile layout's one-pass labels and sums
            out[f"{layout}_fused_centroids"], out[f"{layout}_fused_mass"] = pr.centroids(pts, w, dens)
    return out


def raster_rect(ctx):
    """A weighted rectangle."""
    return _raster(ctx, Domain.rect(40.0, 30.0), (19, 21), 30, 0.5)


def raster_torus(ctx):
    """The torus (periodic images, wrapped bucket rings)."""
    return _raster(ctx, Domain.torus(), (17, 20), 24, 0.0)


def raster_streamed(ctx):
    """A raster so coarse that one tile has more candidates than the local
    list holds (CAP = 256): they stream through it in chunks."""
    from diskpack_cl.device.raster import PowerRaster

    dom = Domain.rect(10.0, 10.0)
    pts, w = _sites(dom, 600, 5, 0.3)
    est = PowerRaster(dom, (5, 6), device=ctx, layout="item").compute(pts, w)
    c, mass = PowerRaster(dom, (5, 6), device=ctx, layout="tile").centroids(pts, w, np.ones((5, 6)))
    return {"label": est.labels.copy(), "dist": est.dist.copy(), "radii": est.radii,
            "fused_centroids": c, "fused_mass": mass}


def _cells(ctx, dom, n, heavy):
    from diskpack_cl.device import cells
    pts, w = _sites(dom, n, 3, heavy)
    solver = cells.CellMIC(dom, device=ctx)
    # enqueues of a few groups each, so that the chunking is exercised
    solver.chunk = 2 * solver.group
    r = solver.solve(pts, w)
    return {"centers": r.centers, "radii": r.radii, "nn": r.nn}


def cells_rect(ctx):
    """cell_mic on a weighted rectangle, in several enqueues."""
    return _cells(ctx, Domain.rect(30.0, 20.0), 40, 0.5)


def cells_torus(ctx):
    """cell_mic on the torus."""
    return _cells(ctx, Domain.torus(), 40, 0.0)


def cells_list(ctx):
    """cell_mic on a list of cells (unsorted, repeated) of a weighted torus set."""
    from diskpack_cl.device import cells
    pts, w = _sites(Domain.torus(), 40, 3, 0.5)
    r = cells.CellMIC(Domain.torus(), device=ctx).solve(pts, w, cells=[7, 3, 39, 3, 0])
    return {"centers": r.centers, "radii": r.radii, "nn": r.nn}


def cells_warm(ctx):
    """cell_mic started warm: a weighted rectangle's set, then the set moved a little
    (the bases read through the map of sorted positions), in several enqueues."""
    from diskpack_cl.device import cells
    dom = Domain.rect(30.0, 20.0)
    pts, w = _sites(dom, 40, 3, 0.5)
    solver = cells.CellMIC(dom, device=ctx)
    solver.chunk = 2 * solver.group
    solver.solve(pts, w, warm=True)
    moved = np.clip(pts + 0.3 * np.random.default_rng(4).standard_normal(pts.shape), 0.0, 19.99)
    r = solver.solve(moved, w, warm=True)
    return {"centers": r.centers, "radii": r.radii, "nn": r.nn}


def nearest(ctx):
    """nearest (the nearest-neighbour distances alone) on the torus and on a rectangle."""
    from diskpack_cl.device import cells
    out = {}
    for name, dom in (("torus", Domain.torus()), ("rect", Domain.rect(30.0, 20.0))):
        pts, _ = _sites(dom, 40, 5)
        out[name] = cells.CellMIC(dom, device=ctx).nearest(pts)
    return out


def cells_full(ctx):
    """cell_mic where a cell has 40 tight sides (full constraint list, full
    near-tight slots) and a site alone beside a cluster (wide rings, scans
    past one period: the flag paths)."""
    from diskpack_cl.device.cells import CellMIC

    t = np.arange(40) * 2 * np.pi / 40
    ring = np.column_stack([5 + np.cos(t), 5 + np.sin(t)])
    other = np.random.default_rng(8).random((60, 2)) * 10
    other = other[np.hypot(*(other - 5).T) > 1.5]
    a = CellMIC(Domain.rect(10.0, 10.0), device=ctx).solve(np.vstack([[5.0, 5.0], ring, other]))
    cluster = np.vstack([0.05 * np.random.default_rng(7).random((150, 2)), [[0.55, 0.55]]])
    b = CellMIC(Domain.torus(), device=ctx).solve(cluster)
    return {"ring_radii": a.radii, "ring_flagged": np.array(a.stats["flagged"]),
            "cluster_radii": b.radii, "cluster_nn": b.nn, "cluster_flagged": np.array(b.stats["flagged"])}


def _cells3(ctx, dom, n):
    from diskpack_cl.device import cells3
    pts = np.random.default_rng(6).random((n, 3)) * dom.size
    solver = cells3.CellMIC3(dom, device=ctx)
    chunk = cells3.CHUNK
    cells3.CHUNK = 2 * solver.group   # enqueues of two groups each: the offsets are exercised
    try:
        order, start, nb = solver._buckets(pts)
        mic, codes = solver._run(np.ascontiguousarray(pts[order]), start, nb)
        r = solver.solve(pts)
    finally:
        cells3.CHUNK = chunk
    return {"mic": mic, "codes": codes, "centers": r.centers, "radii": r.radii,
            "flagged": np.array(r.stats["flagged"])}


def cells3_box(ctx):
    """cell_mic3 in a box (the six walls as constraints), in several enqueues."""
    from diskpack_cl.device.cells3 import Domain3

    return _cells3(ctx, Domain3.box(3.0, 2.0, 1.5), 40)


def cells3_torus(ctx):
    """cell_mic3 on the 3-torus (27 period shifts of the bucket rings)."""
    from diskpack_cl.device.cells3 import Domain3

    return _cells3(ctx, Domain3.torus(), 36)


def dart_round(ctx):
    """fill, dart_place, set_prio, dart_free, dart_keep, cell_covered and put_pair: parallel dart
    throwing on a 68 x 68 grid (edge cells wrap)."""
    from diskpack_cl.parallel_darts import parallel_darts

    return {"points": parallel_darts(1300, seed=0, device=ctx, max_rounds=3)}


def end_to_end(ctx):
    """Relaxation on both engine routes and a short stippling, as the public functions run them."""
    from diskpack_cl import relax_poisson, stipple

    pts = np.random.default_rng(4).random((48, 2))
    out = {route: relax_poisson(pts, eps=0.99, max_iter=2, backend="opencl", device=ctx,
                                route=route).points for route in ("cells", "raster")}
    gray = np.linspace(0.1, 0.9, 32 * 24).reshape(24, 32)
    res = stipple(gray, 40, seed=0, device=ctx, backend="opencl",
                  schedule=[("pack", 2), ("lloyd", 1)])
    out.update(stipple_points=res.points, stipple_radii=res.radii)
    return out


def refused(ctx):
    """NaN weights in a box and on a torus: a ValueError, no kernel runs."""
    from diskpack_cl.device.raster import PowerRaster

    out = {}
    for name, dom in (("rect", Domain.rect(8.0, 8.0)), ("torus", Domain.torus())):
        pr = PowerRaster(dom, (8, 8), device=ctx)
        pts = np.random.default_rng(0).random((5, 2)) * (dom.width, dom.height)
        try:
            pr.compute(pts, [0.1, np.nan, 0.2, 0.1, 0.3], distance=True)
        except ValueError as exc:
            out[name] = np.array(str(exc))
    return out


def bad_labels(ctx):
    """cell_max and cell_sums given labels that name no site (INT_MAX, -2):
    those grid cells must touch no per-site buffer."""
    import pyopencl as cl

    from diskpack_cl.device.raster import INT_MAX, PowerRaster

    pr = PowerRaster(Domain.rect(8.0, 4.0), (4, 8), device=ctx)
    est = pr.compute(np.array([[2.0, 2.0], [6.0, 2.0]]))
    lab = est.labels.copy()
    lab[:, 2] = INT_MAX
    lab[:, 5] = -2
    b_lab = pr._maps["label"]   # the device map the result reads
    cl.enqueue_copy(pr.queue, b_lab, lab)
    est._maps["label"] = (b_lab, np.int32)
    _, mass = est.centroids(np.ones((4, 8)))
    n, npix = np.int32(2), np.int32(lab.size)
    rbits = np.full(2, -1, np.int32)
    b_r = cl.Buffer(pr.ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=rbits)
    pr._k_max(pr.queue, (npix,), None, b_lab, pr._maps["dist"], npix, n, b_r)
    cl.enqueue_copy(pr.queue, rbits, b_r)
    return {"mass": mass, "rbits": rbits}


def unowned(ctx):
    """NaN weights past the host check: the kernels' own guards keep every
    access in bounds and every ring search finite, and the host refuses."""
    from diskpack_cl.device import raster
    out = {}
    check = raster.check_sites
    for name, dom in (("rect", Domain.rect(8.0, 8.0)), ("torus", Domain.torus())):
        pts = np.random.default_rng(0).random((5, 2)) * (dom.width, dom.height)
        for layout, distance in (("item", True), ("tile", False), ("fused", False)):
            pr = raster.PowerRaster(dom, (9, 10), device=ctx, layout=layout.replace("fused", "tile"))
            raster.check_sites = lambda p, w, d: (np.asarray(p, float), np.asarray(w, float))
            w = np.array([0.1, np.nan, 0.2, 0.1, 0.3])
            try:
                if layout == "fused":
                    pr.centroids(pts, w, np.ones((9, 10)))
                else:
                    pr.compute(pts, w, distance=distance)
            except RuntimeError as exc:
                out[f"{name}_{layout}"] = np.array(str(exc))
            finally:
                raster.check_sites = check
    return out


def blur(ctx):
    """blur_columns and blur_rows: vector runs, the partial run at the right edge, and
    lines shorter than the blur's reach (reflected more than once)."""
    from diskpack_cl.device.blur import DeviceBlur

    b = DeviceBlur(ctx)
    a = np.random.default_rng(5).random((13, 21))
    return {"wide": b(a, 2.0), "thin": b(a[:2, :3], 1.5), "fine": b(a, 0.5)}


SCENARIOS = {f.__name__: f for f in (blur, raster_rect, raster_torus, raster_streamed, cells_rect,
                                     cells_torus, cells_list, cells_warm, nearest, cells_full, cells3_box,
                                     cells3_torus, dart_round, end_to_end, refused, bad_labels,
                                     unowned)}


def _trust_wide():
    """Take the device as trusted with 512-bit vectors (``DISKPACK_TEST_WIDE=1``): every
    program built with ``WIDE_BUILTINS=1`` and the 16-lane tiles taken.  For the simulator,
    which runs any vector width as written, so that the wide builds are checked wherever the
    Oclgrind pass runs, not only where the machine's own driver is trusted with them."""
    import dataclasses

    from diskpack_cl.device import checks, stage

    checked = checks.verdict_of

    def wide(ctx, **kw):
        return dataclasses.replace(checked(ctx, **kw), wide=True)

    checks.verdict_of = stage.verdict_of = wide


def main(argv):
    """Write scenario ``argv[0]``'s arrays, and the device's name as ``device``, to ``argv[1]``."""
    import os

    from diskpack_cl import describe, get_context

    name, path = argv
    if os.environ.get("DISKPACK_TEST_WIDE") == "1":
        _trust_wide()
    ctx = get_context()
    np.savez(path, device=np.array(describe(ctx)), **SCENARIOS[name](ctx))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
