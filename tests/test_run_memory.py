"""What a stippling holds: the fields go before the certificate, a job holds no float picture."""

import importlib
import weakref

import numpy as np
import pytest
from PIL import Image

from diskpack_cl import stipple
from diskpack_cl.image import load_gray
from diskpack_cl.picture_measures import tone_radius

stipple_module = importlib.import_module("diskpack_cl.stipple")


def _owner(a):
    """The array that owns `a`'s memory (a view's base, followed)."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def _ramp(h=40, w=56):
    return np.tile(np.linspace(0.05, 1.0, w), (h, 1))


@pytest.mark.parametrize("backend", ["exact", "auto"])
def test_the_fields_are_freed_before_the_certificate(monkeypatch, backend):
    """The certificate reuses the memory of the stage's whole-picture fields (the peak of a
    million dots): when it starts, nothing holds them, not the stage, not the engine."""
    fields, alive = [], []
    make_stage, certified_k = stipple_module.make_stage, stipple_module.certified_k

    def watched_stage(*args, **kwargs):
        stage = make_stage(*args, **kwargs)
        fields.extend(weakref.ref(_owner(f)) for f in (stage.radius_field, stage.density))
        return stage

    def watched_certificate(*args, **kwargs):
        alive.append([ref() is not None for ref in fields])
        return certified_k(*args, **kwargs)

    monkeypatch.setattr(stipple_module, "make_stage", watched_stage)
    monkeypatch.setattr(stipple_module, "certified_k", watched_certificate)
    res = stipple(_ramp(), 80, schedule=[("mix", 3, 0.5)], backend=backend)
    assert res.certificate.valid and len(fields) == 2
    assert alive == [[False, False]]


def _png(tmp_path, gray):
    path = tmp_path / "ramp.png"
    Image.fromarray(np.round(gray * 255).astype(np.uint8)).save(path)
    return path


@pytest.mark.parametrize("tone, dtype", [({}, np.uint8), ({"tone_gamma": 1.5}, np.float64)])
def test_a_job_hands_the_stippling_the_8bit_picture(tmp_path, monkeypatch, tone, dtype):
    """An 8-bit picture that the tone controls leave as it is goes to the stippling as its
    8-bit pixels (the run makes the only float copy, and frees it); toned, as the float
    gray.  The tone dots are as large as the gray image's darkness makes them."""
    from diskpack_cl.image import ToneOptions
    from diskpack_cl.jobs import items

    seen, real = [], items.stipple

    def spy(image, *args, **kwargs):
        seen.append(image.dtype)
        return real(image, *args, **kwargs)

    monkeypatch.setattr(items, "stipple", spy)
    png = _png(tmp_path, _ramp())
    item, = items.plan_stipple([str(png)], [str(tmp_path / "a.svg")], n=60, schedule=[("mix", 2, 0.5)],
                               tone=ToneOptions(**tone))
    res, _ = items.stipple_item(item)
    assert seen == [dtype]
    gray = ToneOptions(**tone).adjust(load_gray(png))
    dot_mm, _ = items.write_stipple_outputs(res, None, [str(tmp_path / "b.svg")])
    from_gray, _ = items.write_stipple_outputs(res, gray, [str(tmp_path / "c.svg")])
    assert dot_mm == pytest.approx(from_gray, rel=1e-12)


def test_the_tone_radius_is_the_pictures_darkness_without_the_paper_tone():
    """The tone dots hold the picture's ink on white paper: the same size whether the
    writers have the gray image or only the result (a .npz read back)."""
    g = _ramp()
    res = stipple(g, 80, schedule=[("mix", 2, 0.5)], paper_tone=0.2, backend="exact")
    assert res.tone_radius == pytest.approx(tone_radius(80, 1.0 - g), rel=1e-12)
