"""Every door: no output replaces an input, every reader checks what it reads, names are
escaped in every SVG, messages are one line."""

import importlib
import os
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from diskpack_cl import cli
from diskpack_cl.domain import Domain
from diskpack_cl.export import write_stipple
from diskpack_cl.geometry import certify_disks
from diskpack_cl.image import sample_image_path
from diskpack_cl.io import write_points


def _run(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a computation or a reader starts."""
    def not_called(*args, **kwargs):
        raise AssertionError("the work started although an output is an input")

    for module, name in [("diskpack_cl.jobs", "stipple"), ("diskpack_cl.jobs", "relax_poisson"),
                         ("diskpack_cl.poisson", "poisson_disk"), ("diskpack_cl.batch", "run_batch"),
                         ("diskpack_cl.export", "read_stipple"), ("diskpack_cl.reports", "analyze")]:
        monkeypatch.setattr(importlib.import_module(module), name, not_called)


def _stippling(n=16, w=40, h=30):
    """A small certified stippling: a grid of disjoint disks inside the picture."""
    gx, gy = np.meshgrid(np.linspace(4, w - 4, 4), np.linspace(4, h - 4, n // 4))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    radii = np.full(len(pts), 1.5)
    return SimpleNamespace(points=pts, radii=radii, width=w, height=h, k=0.5, tone_radius=1.0,
                           certificate=certify_disks(pts, radii, Domain.rect(w, h)),
                           params={"n": n})


# ------------------------------------------------------------ outputs never replace inputs

@pytest.fixture
def photo(tmp_path):
    path = tmp_path / "photo.png"
    shutil.copy(sample_image_path(), path)
    return path


def _unchanged(path, before):
    assert path.read_bytes() == before


def _refused(rc, err, *names):
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "would replace the input" in lines[0], err
    assert all(name in lines[0] for name in names), err
    assert "Traceback" not in err


def test_stipple_output_is_its_input(photo, no_work, capsys):
    before = photo.read_bytes()
    rc, _, err = _run(["stipple", str(photo), "-n", "500", "-o", str(photo)], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)


def test_stipple_output_reaches_its_input_through_a_symlink_and_a_hard_link(photo, no_work,
                                                                           capsys):
    before = photo.read_bytes()
    (photo.parent / "link.png").symlink_to(photo)
    os.link(photo, photo.parent / "hard.png")
    for out in ("link.png", "hard.png", "./sub/../photo.png"):
        (photo.parent / "sub").mkdir(exist_ok=True)
        rc, _, err = _run(["stipple", str(photo), "-n", "500", "-o",
                           str(photo.parent / "a.svg"), "-o", f"{photo.parent}/{out}"], capsys)
        _refused(rc, err, out.split("/")[-1])
    _unchanged(photo, before)
    assert not (photo.parent / "a.svg").exists()


def test_stipple_batch_template_over_its_inputs(photo, no_work, capsys):
    shutil.copy(photo, photo.parent / "second.png")
    before = photo.read_bytes()
    rc, _, err = _run(["stipple", str(photo.parent), "-n", "500", "-o",
                       str(photo.parent / "{stem}.png")], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)
    assert not (photo.parent / "manifest.jsonl").exists()


def test_relax_output_is_a_hard_link_of_its_input(tmp_path, no_work, capsys):
    src = tmp_path / "a.npz"
    write_points(src, np.random.default_rng(0).random((64, 2)))
    os.link(src, tmp_path / "b.npz")
    before = src.read_bytes()
    for out in (src, tmp_path / "b.npz"):
        rc, _, err = _run(["relax", str(src), "-o", str(out), "-q"], capsys)
        _refused(rc, err, str(out))
    rc, _, err = _run(["relax", str(src), str(tmp_path / "b.npz"), "-o",
                       str(tmp_path / "{stem}.npz"), "-q"], capsys)
    _refused(rc, err)
    _unchanged(src, before)


@pytest.mark.parametrize("ext", [".npz", ".csv"])
def test_export_output_is_its_input(tmp_path, no_work, capsys, ext):
    src = tmp_path / f"dots{ext}"
    write_stipple(src, _stippling())
    before = src.read_bytes()
    rc, _, err = _run(["export", str(src), "-o", str(tmp_path / "a.svg"), "-o", str(src)],
                      capsys)
    _refused(rc, err, src.name)
    _unchanged(src, before)


def test_analyze_report_over_its_image(tmp_path, photo, no_work, capsys):
    src = tmp_path / "dots.npz"
    write_stipple(src, _stippling())
    before = photo.read_bytes()
    rc, _, err = _run(["analyze", str(src), "--image", str(photo), "-o", str(photo)], capsys)
    _refused(rc, err, "photo.png")
    _unchanged(photo, before)


@pytest.mark.parametrize("flag", ["--init", "--mask", "--density"])
def test_poisson_output_is_its_start_or_field_file(tmp_path, no_work, capsys, flag):
    src = tmp_path / "start.npz"
    write_points(src, np.random.default_rng(0).random((64, 2)))
    before = src.read_bytes()
    rc, _, err = _run(["poisson", flag, str(src), "-o", str(src), "-q"], capsys)
    _refused(rc, err, "start.npz")
    _unchanged(src, before)


# ------------------------------------------------------------------------ tests that end

def test_every_test_has_a_time_limit(request):
    assert float(request.config.getini("timeout")) > 0
