"""Tiled stippling (diskpack_cl.jobs.tiles): one certified packing across seams, the same bytes
wherever the parts ran, resumed and retried parts, fields of a window equal to the picture's."""

import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from diskpack_cl.jobs import tiles
from diskpack_cl.domain import Domain
from diskpack_cl.engine import make_engine
from diskpack_cl.schedule import StippleOptions
from diskpack_cl.stipple import make_stage, field_margin
from diskpack_cl.jobs.tiles import TileOptions, stipple_tiled, tile_grid

SHORT = dict(schedule=[("mix", 3, 0.6), ("mix", 1, 0.75)])


def seam_picture(width=160, height=120):
    """A gray ramp with black bars along the middle row and column: dense dots on the seams."""
    g = np.tile(np.linspace(0.3, 1.0, width), (height, 1))
    g[height // 2 - 3:height // 2 + 3, :] = 0.0
    g[:, width // 2 - 3:width // 2 + 3] = 0.0
    return g


def independent_check(points, radii, width, height):
    """Disjoint and inside, by scipy alone: every pair closer than the largest sum of radii."""
    assert np.all(points[:, 0] - radii >= 0) and np.all(points[:, 0] + radii <= width)
    assert np.all(points[:, 1] - radii >= 0) and np.all(points[:, 1] + radii <= height)
    pairs = cKDTree(points).query_pairs(2 * radii.max(), output_type="ndarray")
    d = np.hypot(*(points[pairs[:, 0]] - points[pairs[:, 1]]).T)
    assert np.all(d >= radii[pairs[:, 0]] + radii[pairs[:, 1]])


def test_union_across_seams_is_one_certified_packing():
    g = seam_picture()
    res = stipple_tiled(g, 1500, tiling=TileOptions(tiles="2x2", seam_band=1, halo=2), **SHORT)
    assert res.n == 1500 and res.certificate.valid
    on_seam = (np.abs(res.points[:, 0] - 80) < 1.0) | (np.abs(res.points[:, 1] - 60) < 1.0)
    assert on_seam.sum() > 20   # the bars hold dots right against the seams
    independent_check(res.points, res.radii, 160, 120)
    assert sorted({h["kind"] for h in res.history}) == ["seam-x", "seam-y", "tile"]


def test_seams_move_only_their_band():
    """Outside every seam's band the dots are the tiles' own: a held dot never moves."""
    g = seam_picture()
    calls = []
    real = tiles.run_part

    def spy(part):
        out = real(part)
        if part.points is not None:
            calls.append((part.points[~part.moving], part))
        return out
    tiles.run_part = spy
    try:
        res = stipple_tiled(g, 1200, tiling=TileOptions(tiles="2x2", seam_band=1, halo=2), **SHORT)
    finally:
        tiles.run_part = real
    assert len(calls) == 2
    held, part = calls[-1]   # the last seams: each held dot is a dot of the result, where it was
    d, _ = cKDTree(res.points).query(held)
    assert len(held) > 100 and np.all(d == 0)


def test_white_paper_along_a_seam():
    g = seam_picture(160, 120)
    g[:, 60:100] = 1.0          # no ink within 20 px of the seam between the columns
    res = stipple_tiled(g, 800, tiling=TileOptions(tiles="1x2", seam_band=1, halo=2), **SHORT)
    assert res.certificate.valid and "seam-x" not in {h["kind"] for h in res.history}


def test_dots_shared_by_ink():
    ink = np.array([[0.0, 1.0], [2.0, 3.0]])
    share = tiles._shares(101, ink)
    assert share.sum() == 101 and share[0, 0] == 0
    assert np.all(np.abs(share - 101 * ink / ink.sum()) < 1)


def test_fields_of_a_window_are_the_pictures():
    rng = np.random.default_rng(3)
    g = np.clip(rng.random((90, 110)) * 0.3 + np.linspace(0, 0.7, 110), 0, 1)
    n = 900
    plan = StippleOptions().plan(n, 110, 90, ink=float((1 - g).sum()))
    from diskpack_cl.radii import detail_scale
    d = 1 - g
    ell = detail_scale(float(d.sum()), n, float(np.median(d[d > 0.05])))
    whole = make_stage(g, plan, make_engine(Domain.rect(110, 90), n, "exact"), ell=ell)
    m = field_margin(plan, ell)
    x0, y0, x1, y1 = 40, 30, 75, 60
    win = g[y0 - m:y1 + m, x0 - m:x1 + m]
    part = make_stage(win, plan, make_engine(Domain.rect(35, 30), n, "exact"),
                       window=(slice(m, m + 30), slice(m, m + 35)), ell=ell)
    s = plan.supersample
    np.testing.assert_allclose(part.radius_field, whole.radius_field[y0:y1, x0:x1], rtol=1e-12)
    np.testing.assert_allclose(part.density, whole.density[s * y0:s * y1, s * x0:s * x1], rtol=1e-12)
    if whole.blend_weight is not None:
        np.testing.assert_allclose(part.blend_weight, whole.blend_weight[y0:y1, x0:x1], atol=1e-12)


def backend_here():
    """This process's engine, named for the workers: they do not see OpenCL hidden here."""
    from diskpack_cl import NoOpenCLError, get_context

    try:
        get_context()
    except NoOpenCLError:
        return "exact"
    return "opencl"


def test_same_bytes_in_process_and_in_two_workers(tmp_path):
    g = seam_picture()
    backend = backend_here()
    one = stipple_tiled(g, 1000, tiling=TileOptions(tiles="2x2", seam_band=1, halo=2),
                        backend=backend, **SHORT)
    two = stipple_tiled(g, 1000, tiling=TileOptions(tiles="2x2", seam_band=1, halo=2), jobs=2,
                        backend=backend, **SHORT)
    assert one.points.tobytes() == two.points.tobytes()
    assert one.radii.tobytes() == two.radii.tobytes()


def test_same_bytes_on_dask():
    distributed = pytest.importorskip("distributed")
    g = seam_picture()
    backend = backend_here()
    here = stipple_tiled(g, 800, tiling=TileOptions(tiles="1x2", seam_band=1, halo=2),
                         backend=backend, **SHORT)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as lc, distributed.Client(lc) as client:
        there = stipple_tiled(g, 800, tiling=TileOptions(tiles="1x2", seam_band=1, halo=2),
                              client=client, backend=backend, **SHORT)
    assert here.points.tobytes() == there.points.tobytes()


def test_interrupted_run_resumes_from_finished_parts(tmp_path):
    g = seam_picture()
    tiling = TileOptions(tiles="2x2", seam_band=1, halo=2, work_dir=str(tmp_path / "work"))
    full = stipple_tiled(g, 1000, tiling=tiling, **SHORT)
    assert not os.path.exists(tmp_path / "work")     # removed when done

    def stop(phase, done, total):
        if phase == "tile" and done == 3:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        stipple_tiled(g, 1000, tiling=tiling, progress=stop, **SHORT)
    assert len([f for f in os.listdir(tmp_path / "work") if f.startswith("diskpack-tile-")]) == 3
    ran = []
    real = tiles.run_part
    tiles.run_part = lambda part: ran.append(part) or real(part)
    try:
        again = stipple_tiled(g, 1000, tiling=tiling, **SHORT)
    finally:
        tiles.run_part = real
    assert sum(p.points is None for p in ran) == 1   # only the fourth tile ran again
    assert again.points.tobytes() == full.points.tobytes()


def test_work_folder_of_another_job_is_not_reused(tmp_path):
    g = seam_picture()
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path))
    (tmp_path / "mine.npz").write_bytes(b"a user's file")   # never read nor removed

    def stop(phase, done, total):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        stipple_tiled(g, 700, tiling=tiling, progress=stop, **SHORT)
    other = stipple_tiled(g, 700, tiling=tiling, seed=5, **SHORT)
    fresh = stipple_tiled(g, 700, tiling=tiling.replace(work_dir=None), seed=5, **SHORT)
    assert other.points.tobytes() == fresh.points.tobytes()
    assert os.listdir(tmp_path) == ["mine.npz"]


def test_failed_part_is_retried():
    g = seam_picture()
    real, failed = tiles.run_part, []

    def flaky(part):
        if not failed:
            failed.append(part)
            raise RuntimeError("lost worker")
        return real(part)
    tiles.run_part = flaky
    try:
        res = stipple_tiled(g, 600, tiling=TileOptions(tiles="1x2", seam_band=1, halo=2), **SHORT)
    finally:
        tiles.run_part = real
    assert failed and res.n == 600 and res.certificate.valid


@pytest.mark.parametrize("text,message", [("2by2", "ROWSxCOLUMNS"), ("0x2", "room for"),
                                          ("500x1", "room for")])
def test_bad_tiles_are_refused(text, message):
    with pytest.raises(ValueError, match=message):
        tile_grid(text, 100, 80)


def test_tiles_too_small_for_the_seams():
    with pytest.raises(ValueError, match="too small"):
        stipple_tiled(seam_picture(), 300, tiling=TileOptions(tiles="4x4"), **SHORT)


def test_command_line_tiles(tmp_path):
    out = tmp_path / "a.npz"
    cmd = [sys.executable, "-m", "diskpack_cl.cli", "stipple", "sample", "-n", "3000", "--tiles",
           "2x2", "-o", str(out), "-o", str(tmp_path / "a.svg"), "--schedule", "classic"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "2x2 tiles" in done.stderr and not os.path.exists(str(out) + ".tiles")
    with np.load(out) as z:
        independent_check(z["points"], z["radii"], 512, 512)
    bad = subprocess.run(cmd[:-2] + ["--colors", "cmyk"], capture_output=True, text=True)
    assert bad.returncode == 2 and "--tiles" in bad.stderr


@pytest.mark.parametrize("mode", ["RGB", "P", "I;16", "LA", "I"])
def test_strips_of_a_file_are_its_gray_image(tmp_path, mode):
    from PIL import Image

    from diskpack_cl.image import gray_strips, load_gray

    rng = np.random.default_rng(1)
    rgb = Image.fromarray(rng.integers(0, 256, (37, 29, 3), dtype=np.uint8))
    im = {"RGB": rgb, "P": rgb.convert("P"), "LA": rgb.convert("LA"),
          "I;16": Image.fromarray(rng.integers(0, 65536, (37, 29)).astype(np.uint16)),
          "I": Image.fromarray(rng.integers(0, 40000, (37, 29)).astype(np.int32))}[mode]
    path = str(tmp_path / ("a.tif" if mode == "I" else "a.png"))
    im.save(path)
    shape, strips = gray_strips(path, rows=8)
    whole = np.concatenate([s for _, s in strips])
    assert shape == whole.shape and np.array_equal(whole, load_gray(path))


# ------------------------------------------------------------- the work folder


def _stopped_after_tiles(g, tiling, n=700):
    """A run stopped after its tiles: the work folder holds the raster and the tiles."""
    def stop(phase, done, total):
        if phase != "tile":
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        stipple_tiled(g, n, tiling=tiling, progress=stop, **SHORT)


def _spy_parts(monkeypatch):
    ran = []
    real = tiles.run_part
    monkeypatch.setattr(tiles, "run_part", lambda part: ran.append(part) or real(part))
    return ran


def _truncate(path):
    with open(path, "r+b") as fh:
        fh.truncate(os.path.getsize(path) // 2)


def _forge_points(path):
    """The tile's dots moved outside it, with a digest made for the forgery."""
    with np.load(path) as z:
        part = {k: z[k] for k in z.files}
    part["points"] = part["points"] + 1000.0
    part["digest"] = tiles._arrays_digest(part)
    with open(path, "wb") as fh:
        np.savez(fh, **part)


def _copy_of_another_tile(path):
    with open(path.replace("tile-0", "tile-1"), "rb") as fh:
        data = fh.read()
    with open(path, "wb") as fh:
        fh.write(data)


@pytest.mark.parametrize("damage", [_truncate, _forge_points, _copy_of_another_tile])
def test_a_broken_part_is_named_and_computed_again(tmp_path, monkeypatch, damage):
    """A truncated tile raised zipfile.BadZipFile at every rerun; a forged one was used."""
    g = seam_picture()
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path / "w"))
    full = stipple_tiled(g, 700, tiling=tiling.replace(work_dir=None), **SHORT)
    _stopped_after_tiles(g, tiling)
    broken = str(tmp_path / "w" / "diskpack-tile-0.npz")
    damage(broken)
    ran, notes = _spy_parts(monkeypatch), []
    again = stipple_tiled(g, 700, tiling=tiling, note=notes.append, **SHORT)
    assert len(notes) == 1 and notes[0].startswith(broken + ": ")
    assert [p.rect for p in ran if p.points is None] == [(0, 0, 80, 120)]   # that tile alone
    assert again.points.tobytes() == full.points.tobytes()


def test_a_truncated_raster_is_named_and_read_again(tmp_path):
    """It gave "mmap length is greater than file size", naming no file."""
    g = seam_picture()
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path / "w"))
    _stopped_after_tiles(g, tiling)
    raster = str(tmp_path / "w" / tiles.RASTER)
    _truncate(raster)
    notes = []
    res = stipple_tiled(g, 700, tiling=tiling, note=notes.append, **SHORT)
    assert res.certificate.valid and notes[0].startswith(raster + ": ")


def test_another_picture_of_the_same_size_and_time_is_not_resumed(tmp_path):
    """The picture is known by its bytes: one replaced by another of the same size and
    modification time was resumed from the old raster (dots of the old picture)."""
    from PIL import Image

    path = str(tmp_path / "p.bmp")   # uncompressed: both pictures of one size
    pictures = [seam_picture(), seam_picture()[:, ::-1]]
    Image.fromarray((pictures[0] * 255).astype(np.uint8)).save(path)
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path / "w"))
    _stopped_after_tiles(path, tiling)
    stamp = os.stat(path)
    Image.fromarray((pictures[1] * 255).astype(np.uint8)).save(path)
    os.utime(path, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))
    assert os.path.getsize(path) == stamp.st_size
    resumed = stipple_tiled(path, 700, tiling=tiling, **SHORT)
    fresh = stipple_tiled(path, 700, tiling=tiling.replace(work_dir=None), **SHORT)
    assert resumed.points.tobytes() == fresh.points.tobytes()


def test_one_run_at_a_time_holds_the_folder(tmp_path):
    g = seam_picture()
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path / "w"))
    with tiles._WorkFolder(tiling.work_dir, {"another": "job"}):
        with pytest.raises(tiles.WorkFolderBusy, match=f"in use by another run \\(pid {os.getpid()}"):
            stipple_tiled(g, 700, tiling=tiling, **SHORT)
    assert stipple_tiled(g, 700, tiling=tiling, **SHORT).certificate.valid   # released


def test_the_folder_is_kept_until_the_outputs_are_written(tmp_path, monkeypatch):
    """It was removed before the outputs were written: a signal while writing them left
    nothing to resume, and the rerun computed every part again."""
    g = seam_picture()
    tiling = TileOptions(tiles="1x2", seam_band=1, halo=2, work_dir=str(tmp_path / "w"))

    def interrupted(result):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        stipple_tiled(g, 700, tiling=tiling, finish=interrupted, **SHORT)
    ran, written = _spy_parts(monkeypatch), []
    stipple_tiled(g, 700, tiling=tiling, finish=written.append, **SHORT)
    assert ran == [] and len(written) == 1
    assert not os.path.exists(tmp_path / "w")   # made by a run: removed at the clean end


def test_nothing_is_left_behind_after_a_clean_end(tmp_path, monkeypatch):
    """A temporary work folder (no work_dir) was left in the temporary folder every run."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    stipple_tiled(seam_picture(), 500, tiling=TileOptions(tiles="1x2", seam_band=1, halo=2),
                  **SHORT)
    with pytest.raises(ValueError, match="white"):
        stipple_tiled(np.ones((40, 60)), 50, **SHORT)
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ the seams


def test_a_seam_moves_its_band_and_holds_the_rest(monkeypatch):
    """In every seam's run the held dots end where they were and the band's dots move."""
    runs, parts = [], []
    real_run, real_part = tiles.run_schedule, tiles.run_part

    def spy_run(state, *args, **kwargs):
        out = real_run(state, *args, **kwargs)
        runs.append((state.points.copy(), out[0].points))
        return out
    monkeypatch.setattr(tiles, "run_schedule", spy_run)
    monkeypatch.setattr(tiles, "run_part", lambda part: parts.append(part) or real_part(part))
    stipple_tiled(seam_picture(), 1200, tiling=TileOptions(tiles="2x2", seam_band=1, halo=2),
                  **SHORT)
    seams = [(p, r) for p, r in zip(parts, runs) if p.points is not None]
    assert len(seams) == 2
    for part, (start, end) in seams:
        held = ~part.moving
        assert held.sum() > 50 and part.moving.sum() > 50
        np.testing.assert_array_equal(end[held], start[held])
        assert np.mean(np.any(end[part.moving] != start[part.moving], axis=1)) > 0.5


@given(width=st.integers(60, 400), height=st.integers(60, 400), axis=st.integers(0, 1),
       at=st.floats(0.2, 0.8), reach=st.floats(1, 40), seed=st.integers(0, 2**16))
@settings(max_examples=60)
def test_a_seams_window_spans_the_picture_across_it(width, height, axis, at, reach, seed):
    """A seam between columns (axis 0) spans the picture's height, one between rows its
    width; along the seam's axis the window reaches band + halo each side, inside the picture."""
    size = (width, height)
    edge = round(at * size[axis])
    assume(0 < edge - reach and edge + reach < size[axis])
    rng = np.random.default_rng(seed)
    points = rng.random((400, 2)) * size
    base = tiles.Part("raster.npy", (0, 0, width, height), 0,
                      StippleOptions().plan(400, width, height))
    parts, index = tiles._seam_parts(points, np.ones(400), 1.0, [0, edge, size[axis]], axis,
                                     size, reach / 2, reach / 2, base)
    assume(parts)
    x0, y0, x1, y1 = parts[0].rect
    lo, hi = (x0, x1) if axis == 0 else (y0, y1)
    assert (lo, hi) == (max(0, math.floor(edge - reach)), min(size[axis], math.ceil(edge + reach)))
    assert ((y0, y1) if axis == 0 else (x0, x1)) == (0, size[1 - axis])
    inside = (points[:, axis] > lo) & (points[:, axis] < hi)
    np.testing.assert_array_equal(parts[0].points, points[inside])
