"""Progress of the whole run, stage by stage, and the seconds of each stage in the summaries."""

import io
import json
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from diskpack_cl import cli, poisson_disk, relax_poisson, stipple
from diskpack_cl.jobs.items import plan_stipple, stipple_item, write_stipple_outputs
from diskpack_cl.progress import STAGES, RunProgress, StageBars, running, stage, stage_text

GRAY = np.tile(np.linspace(0.0, 1.0, 48), (32, 1))
SHORT = [("mix", 3, 0.5)]


class Events(list):
    """A hook that keeps every ``(stage, done, total)`` event."""

    def __call__(self, name, done, total):
        self.append((name, done, total))

    def order(self):
        """The stages in the order they first reported."""
        return list(dict.fromkeys(name for name, _, _ in self))

    def check_counts(self):
        """Within each stage ``done`` never decreases and ends at the total."""
        last = {}
        for name, done, total in self:
            assert done >= last.get(name, 0), (name, done, last)
            assert total is None or done <= total
            last[name] = done
        ends = {name: (done, total) for name, done, total in self}
        assert all(done == total for done, total in ends.values()), ends


def _gradient_png(path, size=48):
    from PIL import Image

    Image.fromarray(np.tile(np.linspace(0, 255, size), (size, 1)).astype(np.uint8)).save(path)
    return str(path)


def test_stipple_reports_its_stages_in_order():
    events = Events()
    stipple(GRAY, 60, schedule=SHORT, backend="exact", progress=events)
    assert events.order() == ["load", "start", "setup", "iterations", "certificate"]
    assert [e for e in events if e[0] == "iterations"] == [("iterations", i, 3) for i in range(4)]
    events.check_counts()


def test_job_reports_every_stage_of_the_run(ctx, tmp_path):
    """An item stippled on the device and written: every stage in :data:`STAGES`' order."""
    image = _gradient_png(tmp_path / "g.png")
    outputs = [str(tmp_path / "s.svg"), str(tmp_path / "s.png")]
    (item,) = plan_stipple([image], outputs, n=150, schedule=SHORT, make_folders=False)
    events = Events()
    with running(events) as run:
        res, _ = stipple_item(item, device=ctx)
        write_stipple_outputs(res, None, outputs)
    assert events.order() == list(STAGES)
    events.check_counts()
    rounds = [e for e in events if e[0] == "pen path"]
    assert len(rounds) > 3 and rounds[-1][1] == rounds[-1][2] > 2   # each 2-opt round told
    writing = [e for e in events if e[0] == "writing"]
    assert writing[-1][1:] == (1 + 150, 1 + 150)   # the SVG, then the PNG's dots
    assert list(run.by_stage()) == list(STAGES)


def test_point_sets_report_their_iterations():
    events = Events()
    with running(events):
        res = relax_poisson(np.random.default_rng(0).random((256, 2)), eps=0.75, backend="exact",
                            max_iter=50)
        poisson_disk(200, backend="exact", seed=1, options=None)
    relax = [e for e in events if e[0] == "iterations"][:res.iterations + 2]
    assert relax[0] == ("iterations", 0, 50) and relax[res.iterations][1] == res.iterations
    assert events.order() == ["iterations"]
    events.check_counts()   # the second run's iterations count on after the first's


def test_colour_job_reports_every_stage_of_the_run(ctx, tmp_path):
    """A colour stippling's stages: the same, and its pen path only where the SVG is written."""
    from PIL import Image

    y, x = np.mgrid[0:48, 0:64] / 64.0
    rgb = (np.dstack([x, y, 1 - x]) * 255).astype(np.uint8)
    Image.fromarray(rgb).save(tmp_path / "c.png")
    out = str(tmp_path / "c.svg")
    (item,) = plan_stipple([str(tmp_path / "c.png")], [out], n=300, color={"colors": "cmyk"},
                           schedule=SHORT, make_folders=False)
    events = Events()
    with running(events):
        res, _ = stipple_item(item, device=ctx)
        write_stipple_outputs(res, None, [out])
    order = events.order()   # the fields come before the start here
    assert set(order) == set(STAGES) and order[:2] == ["load", "device"]
    assert order[4:] == ["iterations", "certificate", "writing", "pen path"]
    events.check_counts()
    first_write = events.index(("writing", 0, 1))
    assert all(i > first_write for i, e in enumerate(events) if e[0] == "pen path")


def test_stage_outside_a_run_reports_nothing():
    with stage("writing", 3) as advance:
        advance(2)
    events = Events()
    with running(events):
        with running() as joined, stage("load"):
            pass
    assert events == [("load", 0, 1), ("load", 1, 1)] and list(joined.seconds) == ["load"]


@st.composite
def _stage_plans(draw):
    """Nested stages: each ``(name, total, steps, inner)``, steps its advances in order."""
    names = st.sampled_from(["load", "pen path", "writing"])

    def plan(depth):
        total = draw(st.integers(0, 6))
        steps = sorted(draw(st.lists(st.integers(0, total), max_size=4)))
        inner = draw(st.integers(0, 2 if depth < 2 else 0))
        return draw(names), total, steps, [plan(depth + 1) for _ in range(inner)]

    return [plan(0) for _ in range(draw(st.integers(1, 4)))]


def _run_plan(run, plans):
    for name, total, steps, inner in plans:
        with run.stage(name, total) as advance:
            for done in steps:
                advance(done)
            _run_plan(run, inner)


@settings(max_examples=60)
@given(_stage_plans())
def test_counts_never_go_back(plans):
    """However stages nest and repeat, each stage's ``done`` never decreases, ends at its
    total, and the seconds go to one stage at a time (they add up to no more than the run)."""
    events = Events()
    run = RunProgress(events)
    _run_plan(run, plans)
    whole = run.elapsed()
    events.check_counts()
    assert set(run.seconds) == {name for name, _, _, _ in _flat(plans)}
    assert sum(run.seconds.values()) <= whole


def _flat(plans):
    for plan in plans:
        yield plan
        yield from _flat(plan[3])


def test_a_failed_stage_reports_no_end():
    events = Events()
    with pytest.raises(RuntimeError), running(events), stage("pen path", 4) as advance:
        advance(1)
        raise RuntimeError("stop")
    assert events == [("pen path", 0, 4), ("pen path", 1, 4)]


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_bars_need_a_terminal_and_survive_a_closed_one():
    quiet = io.StringIO()
    StageBars(quiet)("iterations", 1, 3)
    assert quiet.getvalue() == ""
    term = _Terminal()
    bars = StageBars(term)
    bars("iterations", 0, 3)
    bars("iterations", 2, 3)
    bars("pen path", 0, 5)
    bars.note("2-opt")
    assert "iterations" in term.getvalue() and "pen path" in term.getvalue()
    assert "2-opt" in term.getvalue()
    term.close()
    bars("pen path", 3, 5)   # the closed stream ends the bars, not the run
    bars.close()


def test_stage_text_orders_the_stages():
    text = stage_text({"pen path": 10.93, "writing": 0.8, "iterations": 2.41}, 25, 14.9)
    assert text == "25 iterations 2.4 s, writing 0.8 s, pen path 11 s; 14.9 s in all"


def _main(argv, stderr, monkeypatch):
    """Run the command with `stderr`; its stdout."""
    out = io.StringIO()
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stderr", stderr)
    assert cli.main(argv) == 0, stderr.getvalue()
    return out.getvalue()


@pytest.fixture(scope="module")
def image(tmp_path_factory):
    return _gradient_png(tmp_path_factory.mktemp("progress") / "g.png")


def test_cli_draws_a_bar_per_stage(ctx, image, tmp_path, monkeypatch):
    err = _Terminal()
    _main(["stipple", image, "-n", "150", "--schedule", "classic", "-o", str(tmp_path / "a.svg")],
          err, monkeypatch)
    text = err.getvalue()
    shown = [name for name in STAGES if f"{name}:" in text]
    assert shown == list(STAGES), text


@pytest.mark.parametrize("flag", ["--quiet", "--json"])
def test_cli_bars_quiet(ctx, image, tmp_path, flag, monkeypatch):
    err = _Terminal()
    _main(["stipple", image, "-n", "150", "--schedule", "classic", "-o", str(tmp_path / "a.svg"),
           flag], err, monkeypatch)
    assert not any(f"{name}:" in err.getvalue() for name in STAGES)


def test_summary_gives_each_stage(ctx, image, tmp_path, monkeypatch):
    err = io.StringIO()
    out = _main(["stipple", image, "-n", "150", "--schedule", "classic", "--json",
                 "-o", str(tmp_path / "a.svg"), "-o", str(tmp_path / "a.png")], err, monkeypatch)
    summary = json.loads(out.strip().splitlines()[-1])
    seconds = summary["stage_seconds"]
    assert list(seconds) == list(STAGES)
    # the stages cover the command: what is left is a few statements between them
    assert sum(seconds.values()) <= summary["seconds"]
    assert sum(seconds.values()) >= 0.8 * summary["seconds"]
    line = err.getvalue()
    assert f"{summary['iterations']} iterations " in line and " s in all " in line
    assert all(f" {name} " in line for name in STAGES if name != "iterations")


def test_vpype_draws_a_bar_per_stage(ctx, image, monkeypatch):
    import vpype_cli

    err = _Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    vpype_cli.execute(f"diskpack {image} -n 150 --schedule classic")
    shown = [name for name in STAGES if f"{name}:" in err.getvalue()]
    assert shown == list(STAGES), err.getvalue()
