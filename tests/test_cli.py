import argparse
import importlib
import io
import json
import os
import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from diskpack_cl import cli
from diskpack_cl.io import read_points, write_points
from diskpack_cl.relax import RelaxOptions
from diskpack_cl.sampling import dart_throwing

ROOT = Path(__file__).resolve().parents[1]
JSON_KEYS = {"n", "iterations", "rho_start", "rho_final", "seconds", "stage_seconds", "backend",
             "device", "stop_reason", "output"}
STAGES = {"exact"}   # the exact engine's one stage


def _json_line(out):
    lines = [line for line in out.splitlines() if line.strip()]
    assert len(lines) == 1, out
    return json.loads(lines[0])


@pytest.fixture
def fake_relax(monkeypatch):
    """Replace relax_poisson with a fast stand-in that records its calls."""
    calls = []

    def relax_poisson(points, eps=None, options=None, *, device=None, callback=None,
                      verify=False, profile=False, domain=None, local=False, **overrides):
        opt = (options or RelaxOptions()).replace(**({} if eps is None else {"eps": eps}),
                                                  **overrides)
        backend = opt.backend
        calls.append(dict(points=np.array(points), eps=opt.eps, max_iter=opt.kwargs()["max_iter"],
                          backend=backend, grid=opt.grid, device=device))
        if callback is not None:
            for i in range(1, 4):
                callback(i, 0.7 + 0.01 * i)
        return types.SimpleNamespace(
            points=np.mod(np.asarray(points, dtype=float), 1.0), rho=np.array([0.7, 0.71, 0.72, 0.81]),
            iterations=3, stop_reason="eps", seconds=0.03,
            timings={"raster_labels": 0.01, "mic_estimate": 0.01, "exact_refine": 0.01},
            backend=backend, device="fake", stats={},
            stages={"engine": {"backend": backend, "device": "fake"}})

    monkeypatch.setattr(JOBS, "relax_poisson", relax_poisson)      # relax, poisson --init FILE
    monkeypatch.setattr(POISSON, "relax_poisson", relax_poisson)   # poisson's sets
    return calls


# --------------------------------------------------------------- real runs

def test_poisson_exact_json(tmp_path, capsys):
    out = tmp_path / "points.npz"
    rc = cli.main(["poisson", "-n", "128", "-o", str(out), "--backend", "exact",
                   "--seed", "3", "--json", "--max-iter", "50"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    s = _json_line(captured.out)
    assert JSON_KEYS <= set(s) and set(s["stage_seconds"]) == STAGES
    assert s["n"] == 128 and s["backend"] == "exact" and s["output"] == str(out)
    assert s["rho_start"] >= 0.7 and s["rho_final"] >= s["rho_start"]
    assert s["stop_reason"] in {"eps", "stalled", "max_iter"}
    if s["stop_reason"] == "eps":
        assert s["rho_final"] >= 0.8
    pts = read_points(out)
    assert pts.shape == (128, 2) and ((pts >= 0) & (pts < 1)).all()
    with np.load(out) as z:
        assert (float(z["rho"]), float(z["eps"])) == (s["rho_final"], 0.8)
    assert "rho" in captured.err and "wrote" in captured.err
    assert sorted(os.listdir(tmp_path)) == ["points.npz"]


def test_poisson_random_init_quiet(tmp_path, capsys):
    out = tmp_path / "p.txt"
    rc = cli.main(["poisson", "-n", "50", "--init", "random", "-o", str(out), "--backend",
                   "exact", "--seed", "1", "--eps", "0.6", "--quiet"])
    captured = capsys.readouterr()
    assert rc == 0 and captured.out == "" and captured.err == ""
    assert read_points(out).shape == (50, 2)


def test_relax_exact_csv(tmp_path, capsys):
    src = tmp_path / "in.csv"
    write_points(src, dart_throwing(100, seed=2) + 1.0)  # outside [0,1): wrapped
    out = tmp_path / "out.csv"
    rc = cli.main(["relax", str(src), "-o", str(out), "--eps", "0.78", "--backend", "exact",
                   "--json", "-q"])
    assert rc == 0
    s = _json_line(capsys.readouterr().out)
    assert s["n"] == 100 and s["input"] == str(src)
    pts = read_points(out)
    assert ((pts >= 0) & (pts < 1)).all()
    from diskpack_cl.measures import normalized_radius

    assert normalized_radius(pts) == pytest.approx(s["rho_final"], rel=1e-9)


def test_poisson_opencl_backend(ctx, tmp_path, capsys):
    out = tmp_path / "p.npy"
    rc = cli.main(["poisson", "-n", "64", "-o", str(out), "--backend", "opencl", "--seed", "0",
                   "--json", "--max-iter", "3", "--grid", "64", "--allow-unreached"])
    assert rc == 0
    s = _json_line(capsys.readouterr().out)
    assert s["backend"] == "opencl" and s["iterations"] <= 3


def test_devices(ctx, capsys):
    # ctx: skipped without OpenCL, a failure when CI requires it
    assert cli.main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "using:" in out and "0:0" in out
    # each platform with its version and where its driver comes from
    assert out.startswith("platforms:\n    0  ") and "  |  OpenCL " in out
    assert "\n         from pip: " in out or "\n         from system: " in out


# ------------------------------------------------------- with a fake relax

def test_poisson_passes_options(fake_relax, tmp_path, capsys, ctx):   # --device pocl is probed
    out = tmp_path / "p.npz"
    rc = cli.main(["poisson", "-n", "20", "-o", str(out), "--eps", "0.7", "--max-iter", "9",
                   "--backend", "opencl", "--grid", "32", "--device", "pocl", "--json"])
    assert rc == 0
    (call,) = fake_relax
    assert call["points"].shape == (20, 2)
    assert (call["eps"], call["max_iter"], call["backend"], call["grid"], call["device"]) == \
        (0.7, 9, "opencl", 32, "pocl")
    s = _json_line(capsys.readouterr().out)
    assert s["stage_seconds"] == {"raster_labels": 0.01, "mic_estimate": 0.01, "exact_refine": 0.01}


def test_poisson_init_file(fake_relax, tmp_path):
    src = tmp_path / "start.xy"
    start = np.random.default_rng(0).random((30, 2))
    write_points(src, start)
    assert cli.main(["poisson", "--init", str(src), "-o", str(tmp_path / "o.npz"), "-q"]) == 0
    np.testing.assert_array_equal(fake_relax[0]["points"], start)


def test_poisson_default_n_is_1024(fake_relax, tmp_path):
    assert cli.main(["poisson", "-o", str(tmp_path / "o.npz"), "-q", "--seed", "1"]) == 0
    assert fake_relax[0]["points"].shape == (1024, 2)


@pytest.fixture
def every_update(monkeypatch):
    """tqdm draws every update (its TQDM_ variables are read when tqdm is first imported,
    which an earlier test may have done)."""
    from functools import partialmethod

    from tqdm import tqdm
    monkeypatch.setattr(tqdm, "__init__", partialmethod(tqdm.__init__, mininterval=0))


def test_progress_bar_on_a_terminal(fake_relax, tmp_path, monkeypatch, every_update):
    class Tty(io.StringIO):
        def isatty(self):
            return True

    err = Tty()
    monkeypatch.setattr(sys, "stderr", err)
    assert cli.main(["poisson", "-n", "10", "-o", str(tmp_path / "o.npz"), "--seed", "0"]) == 0
    text = err.getvalue()
    assert "rho=0.73" in text and "relax" in text


def test_no_progress_bar_when_quiet_or_not_a_terminal(fake_relax, tmp_path, capsys):
    assert cli.main(["poisson", "-n", "10", "-o", str(tmp_path / "o.npz")]) == 0
    assert "rho=" not in capsys.readouterr().err


def test_keyboard_interrupt(monkeypatch, tmp_path, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(POISSON, "relax_poisson", interrupted)
    rc = cli.main(["poisson", "-n", "10", "-o", str(tmp_path / "o.npz")])
    assert rc == 130
    assert "diskpack: error: interrupted, nothing written" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------- bad inputs

def _bad(tmp_path, capsys, argv, code, message):
    before = set(os.listdir(tmp_path))
    rc = cli.main(argv)
    err = capsys.readouterr().err
    assert rc == code, err
    assert message in err
    assert set(os.listdir(tmp_path)) == before  # no output file, no .part file


@pytest.mark.parametrize("content, message", [
    ("0.1 0.2\nnan 0.3\n0.5 0.5\n", "NaN or infinite"),
    ("0.1 0.2\n", "has 1 point, need at least 2"),
    ("0.1 0.2 0.3\n0.1 0.2 0.3\n", "shape (n, 2)"),
    ("0.1 zero\n0.2 0.3\n", "malformed .txt file"),
    ("0.1 0.2\n0.1 0.2\n0.5 0.5\n", "coincident"),
])
def test_relax_bad_input_files(tmp_path, capsys, content, message):
    src = tmp_path / "in.txt"
    src.write_text(content)
    _bad(tmp_path, capsys, ["relax", str(src), "-o", str(tmp_path / "out.npz"), "--backend",
                            "exact"], 1, message)


def test_relax_missing_input(tmp_path, capsys):
    _bad(tmp_path, capsys, ["relax", str(tmp_path / "none.npz"), "-o", str(tmp_path / "o.npz")],
         1, "diskpack: error: ")


def test_unknown_output_extension_fails_before_work(fake_relax, tmp_path, capsys):
    _bad(tmp_path, capsys, ["poisson", "-n", "10", "-o", str(tmp_path / "o.png")], 1,
         "unknown point file extension '.png'")
    assert fake_relax == []


def test_missing_output_directory(fake_relax, tmp_path, capsys):
    _bad(tmp_path, capsys, ["poisson", "-n", "10", "-o", str(tmp_path / "no" / "o.npz")], 1,
         "output directory does not exist")
    assert fake_relax == []


def test_init_file_count_mismatch(fake_relax, tmp_path, capsys):
    src = tmp_path / "s.npy"
    write_points(src, np.random.default_rng(0).random((5, 2)))
    _bad(tmp_path, capsys, ["poisson", "--init", str(src), "-n", "6", "-o", str(tmp_path / "o.npz")],
         1, "-n 6 does not match the 5 points")


@pytest.mark.parametrize("argv", [
    ["poisson", "-o", "x.npz", "--eps", "1.5"],
    ["poisson", "-o", "x.npz", "--eps", "0"],
    ["poisson", "-o", "x.npz", "-n", "0"],
    ["poisson", "-o", "x.npz", "-n", "1"],
    ["poisson", "-o", "x.npz", "--max-iter", "-1"],
    ["poisson", "-o", "x.npz", "--backend", "cuda"],
    ["poisson"],
    ["frobnicate"],
    [],
])
def test_usage_errors(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("diskpack") and "--help')" in err and "usage:" not in err
    assert os.listdir(tmp_path) == []


def test_help_returns_zero(capsys):
    assert cli.main(["--help"]) == 0
    assert "poisson" in capsys.readouterr().out


def test_devices_without_opencl(monkeypatch, capsys):
    import diskpack_cl

    def none():
        raise diskpack_cl.NoOpenCLError("no OpenCL platform found; install an OpenCL driver")

    monkeypatch.setattr(diskpack_cl, "list_devices", none)
    monkeypatch.setattr(diskpack_cl, "list_platforms", none)   # listed first
    assert cli.main(["devices"]) == 1
    assert "diskpack: error: no OpenCL platform found; install" in capsys.readouterr().err


def test_every_command_module_is_registered():
    """One module per subcommand, each with ``add_NAME`` and ``_run_NAME``; all registered."""
    import importlib
    import pkgutil

    modules = [m.name for m in pkgutil.iter_modules(cli.__path__) if not m.name.startswith("_")]
    names = list(cli._SUBCOMMANDS)
    assert sorted(names) == sorted(modules)
    assert names[:3] == ["devices", "poisson", "relax"]
    for name in names:
        module = importlib.import_module(f"diskpack_cl.cli.{name}")
        assert callable(getattr(module, f"add_{name}")) and callable(getattr(module, f"_run_{name}"))


# ------------------------------------------------------ README and .ci/run

def test_readme_commands_match_ci():
    readme = (ROOT / "README.md").read_text()
    test_cmd = ('python3 -m venv .venv && .venv/bin/pip install -e ".[test]" '
                "&& .venv/bin/python -m pytest -q")
    head = "\n".join(readme.splitlines()[:25])
    assert test_cmd in head
    assert "diskpack poisson -n 1024 -o out/points.npz" in head
    assert "diskpack stipple sample -n 20000 -o out/stipple.svg -o out/stipple.png" in head
    ci = (ROOT / ".ci" / "run").read_text()
    assert '.venv/bin/pip install -e ".[test]"' in ci and ".venv/bin/python -m pytest -q" in ci
    assert os.access(ROOT / ".ci" / "run", os.X_OK)



# ------------------------------------------------------------------ stipple

# the package re-exports the function under the module's name: patch the module
JOBS = importlib.import_module("diskpack_cl.jobs.items")  # every run looks stipple up there
POISSON = importlib.import_module("diskpack_cl.poisson")  # poisson sets look relax_poisson up there
STIPPLE_ARGS = ["-n", "150", "--beta", "3", "--lloyd", "2", "--rounds", "2"]  # 3+2+2 iterations


def _gradient_png(path, size=48):
    from PIL import Image

    g = np.tile(np.linspace(0, 255, size), (size, 1)).astype(np.uint8)
    Image.fromarray(g).save(path)
    return path


@pytest.fixture(scope="module")
def stippled(ctx, tmp_path_factory):
    """One real small stippling, written in all four formats with --json."""
    d = tmp_path_factory.mktemp("stipple")
    image = _gradient_png(d / "grad.png")
    outs = {ext: d / f"out.{ext}" for ext in ("svg", "png", "npz", "csv")}
    argv = ["stipple", str(image), *STIPPLE_ARGS, "--json", "--seed", "1"]
    for path in outs.values():
        argv += ["-o", str(path)]
    out, err = io.StringIO(), io.StringIO()
    old = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = out, err
    try:
        rc = cli.main(argv)
    finally:
        sys.stdout, sys.stderr = old
    assert rc == 0, err.getvalue()
    return types.SimpleNamespace(dir=d, image=image, outs=outs, summary=_json_line(out.getvalue()),
                                 err=err.getvalue())


def test_stipple_writes_every_format(stippled):
    outs = stippled.outs
    assert sorted(os.listdir(stippled.dir)) == sorted(["grad.png"] + [p.name for p in outs.values()])
    svg = outs["svg"].read_text()
    assert svg.count("<circle ") == 150 and 'inkscape:groupmode="layer"' in svg
    import re

    radii = {float(r) for r in re.findall(r' r="([0-9.]+)"', svg)}
    assert len(radii) == 1  # --dots tone (default): one size, ink = darkness
    # the SVG rounds radii inward on its 0.0001 mm grid: never larger than asked
    assert 0 <= stippled.summary["dot_mm"] - 2 * radii.pop() <= 2e-4
    from PIL import Image

    with Image.open(outs["png"]) as im:
        assert im.size == (96, 96)  # --png-scale 2 by default
    with np.load(outs["npz"]) as z:
        assert {"points", "radii", "k", "width", "height"} <= set(z.files)
        assert z["points"].shape == (150, 2) and int(z["width"]) == 48
    lines = outs["csv"].read_text().splitlines()
    assert lines[0].startswith("# diskpack_cl stippling width=48 height=48 ")
    assert lines[1] == "x,y,r" and len(lines) == 152
    assert "150 dots on 48x48 px" in stippled.err and "certified valid" in stippled.err


def test_stipple_json(stippled):
    s = stippled.summary
    assert {"n", "width", "height", "k", "min_radius", "max_radius", "iterations", "certificate",
            "timings", "params", "outputs", "seconds", "image"} <= set(s)
    assert s["n"] == 150 and s["iterations"] == 7 and s["certificate"]["valid"] is True
    assert s["stages"]["engine"]["backend"] == "opencl" and s["stages"]["engine"]["device"]
    assert " 7 iterations " in stippled.err and " s in all on OpenCL (" in stippled.err
    assert s["params"]["schedule"] == [["pack", 3], ["lloyd", 2], ["pack", 2]]
    fmts = [o["format"] for o in s["outputs"]]
    assert fmts == ["svg", "png", "npz", "csv"]
    svg = s["outputs"][0]
    assert svg["travel_after_mm"] <= svg["travel_before_mm"]
    assert s["seconds"] >= s["timings"]["total"]


def test_stipple_packing_dots(ctx, tmp_path, capsys):
    import re

    image = _gradient_png(tmp_path / "g.png", 32)
    out = tmp_path / "o.svg"
    assert cli.main(["stipple", str(image), "-n", "40", "--beta", "2", "--lloyd", "0",
                     "--rounds", "1", "--dots", "packing", "--dpi", "25.4", "-o", str(out),
                     "-o", str(tmp_path / "o.npz"), "--json", "-q"]) == 0
    assert _json_line(capsys.readouterr().out)["dot_mm"] is None
    svg_r = np.array([float(r) for r in re.findall(r' r="([0-9.]+)"', out.read_text())])
    with np.load(tmp_path / "o.npz") as z:  # 25.4 dpi: 1 mm per pixel
        # rounded inward on the SVG's grid by what rounding moved the centres (drawing.on_grid)
        np.testing.assert_allclose(np.sort(svg_r), np.sort(z["radii"]), atol=4e-4)
        assert np.all(np.sort(svg_r) <= np.sort(z["radii"]))


def test_stipple_progress_bar_on_a_terminal(ctx, tmp_path, monkeypatch, every_update):
    class Tty(io.StringIO):
        def isatty(self):
            return True

    err = Tty()
    monkeypatch.setattr(sys, "stderr", err)
    image = _gradient_png(tmp_path / "g.png", 32)
    rc = cli.main(["stipple", str(image), "-n", "40", "--beta", "2", "--lloyd", "1",
                   "--rounds", "2", "-o", str(tmp_path / "o.npz")])
    assert rc == 0, err.getvalue()
    text = err.getvalue()
    assert "stipple" in text and "pack k=" in text and "lloyd k=" in text


@pytest.fixture
def fake_stipple(monkeypatch):
    """Record stipple()'s arguments, then fail as a user error would."""
    calls = []

    def stipple(image, n, options=None, **kwargs):
        calls.append(dict(image=np.asarray(image), n=n, options=options, **kwargs))
        raise ValueError("fake stipple stops here")

    monkeypatch.setattr(JOBS, "stipple", stipple)
    return calls


def test_stipple_passes_options_and_sample(fake_stipple, tmp_path, capsys, ctx):   # --device pocl is probed
    rc = cli.main(["stipple", "sample", "-n", "77", "-o", str(tmp_path / "a.svg"), "--gamma", "2",
                   "--floor", "0.2", "--schedule", "paper", "--supersample", "3", "--seed", "5",
                   "--invert", "--refine-every", "2", "--device", "pocl", "--features", "detail",
                   "--capacity", "0.25", "--support", "0.5", "--paper-tone", "0.05", "--profile"])
    assert rc == 1 and "fake stipple stops here" in capsys.readouterr().err
    (call,) = fake_stipple
    assert call["image"].shape == (512, 512) and call["n"] == 77
    call.update({k: getattr(call["options"], k) for k in (
        "gamma", "floor", "schedule", "supersample", "seed", "method", "invert", "refine_every",
        "features", "capacity", "support", "paper_tone")})
    assert {k: call[k] for k in ("gamma", "floor", "schedule", "supersample", "seed", "method",
                                 "invert", "refine_every", "device", "features", "capacity",
                                 "support", "paper_tone", "profile")} == dict(
        gamma=2.0, floor=0.2, schedule="paper", supersample=3, seed=5, method="diskpack",
        invert=True, refine_every=2, device="pocl", features="detail", capacity=0.25, support=0.5,
        paper_tone=0.05, profile=True)
    assert os.listdir(tmp_path) == []


def test_stipple_schedule_choices_follow_the_library():
    from diskpack_cl.schedule import SCHEDULE_NAMES

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    action = next(a for a in sub.choices["stipple"]._actions if a.dest == "schedule")
    assert set(action.choices) == set(SCHEDULE_NAMES)


def test_stipple_interrupt_writes_nothing(monkeypatch, tmp_path, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(JOBS, "stipple", interrupted)
    image = _gradient_png(tmp_path / "g.png", 16)
    rc = cli.main(["stipple", str(image), "-n", "10", "-o", str(tmp_path / "o.svg")])
    assert rc == 130 and "interrupted, nothing written" in capsys.readouterr().err
    assert os.listdir(tmp_path) == ["g.png"]


def test_stipple_failed_writer_removes_earlier_outputs(ctx, monkeypatch, tmp_path, capsys):
    import diskpack_cl.drawing.writers as export

    def boom(path, result, **opts):
        raise ValueError("disk full (fake)")

    monkeypatch.setitem(export.WRITERS, ".csv", boom)
    image = _gradient_png(tmp_path / "g.png", 24)
    _bad(tmp_path, capsys, ["stipple", str(image), "-n", "30", "--beta", "1", "--lloyd", "0",
                            "--rounds", "1", "-o", str(tmp_path / "a.svg"),
                            "-o", str(tmp_path / "b.csv")], 1, "disk full (fake)")


@pytest.mark.parametrize("case, message", [
    ("missing image", "image file not found"),
    ("not an image", "not an image Pillow can read"),
    ("white image", "nothing to stipple"),
    ("unknown extension", "unknown output extension '.gif'"),
    ("missing output dir", "output directory does not exist"),
    ("output twice", "output given twice"),
    ("output folder", "is a folder, not a file name: give one in it, such as"),
    ("too many points", "too large"),
])
def test_stipple_bad_inputs(monkeypatch, tmp_path, capsys, case, message):
    from PIL import Image

    if case not in ("white image", "too many points"):  # refused before stipple() runs
        def not_called(*args, **kwargs):
            raise AssertionError("stipple() ran although the input was bad")

        monkeypatch.setattr(JOBS, "stipple", not_called)
    image = _gradient_png(tmp_path / "g.png", 16)
    out = tmp_path / "o.svg"
    extra = []
    if case == "missing image":
        image = tmp_path / "none.png"
    elif case == "not an image":
        image = tmp_path / "text.png"
        image.write_text("hello")
    elif case == "white image":
        image = tmp_path / "white.png"
        Image.new("L", (16, 16), 255).save(image)
    elif case == "unknown extension":
        out = tmp_path / "o.gif"
    elif case == "missing output dir":
        out = tmp_path / "no" / "o.svg"
    elif case == "output twice":
        extra = ["-o", str(out)]
    elif case == "output folder":
        out = tmp_path
    if case == "too many points":
        extra = ["--supersample", "1", "-n", "100"]  # 4 grid cells per point: at most 64
    _bad(tmp_path, capsys, ["stipple", str(image), "-n", "10", "-o", str(out), *extra], 1, message)


@pytest.mark.parametrize("argv", [
    ["stipple", "g.png", "-n", "0", "-o", "o.svg"],
    ["stipple", "g.png", "-n", "10", "-o", "o.svg", "--gamma", "0"],
    ["stipple", "g.png", "-n", "10", "-o", "o.svg", "--floor", "0"],
    ["stipple", "g.png", "-n", "10", "-o", "o.svg", "--schedule", "fast"],
    ["stipple", "g.png", "-n", "10", "-o", "o.svg", "--capacity", "1.5"],
    ["stipple", "g.png", "-n", "10"],
    ["stipple", "g.png", "-o", "o.svg"],
    ["analyze"],
])
def test_stipple_usage_errors(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("diskpack") and "--help')" in err and "usage:" not in err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("argv, message", [
    (["stipple", "g.png", "-n", "1", "-o", "o.svg"], "argument -n: need at least 2 points, got 1"),
    (["stipple", "g.png", "-n", "5", "--seed", "-1", "-o", "o.svg"],
     "argument --seed: must be at least 0, got -1"),
    (["poisson", "-n", "5", "--seed", "-1", "-o", "o.npz"],
     "argument --seed: must be at least 0, got -1"),
    (["stipple", "g.png", "-n", "5", "--dpi", "300", "--width-mm", "100", "-o", "o.svg"],
     "either by --width-mm/--height-mm or by --dpi, not both"),
    (["stiple", "g.png"], "invalid choice: 'stiple'"),
    (["stiple", "g.png"], "; did you mean stipple?"),
    (["stipple", "g.png", "-n", "5", "--pen-mn", "0.3", "-o", "o.svg"], "did you mean --pen-mm?"),
    (["stipple", "g.png", "-n", "5", "--schedule", "defualt", "-o", "o.svg"],
     "did you mean default?"),
])
def test_option_faults_are_usage_errors_that_name_the_option(tmp_path, capsys, monkeypatch,
                                                            argv, message):
    monkeypatch.chdir(tmp_path)
    _gradient_png(tmp_path / "g.png", 16)
    assert cli.main(argv) == 2
    assert message in capsys.readouterr().err
    assert os.listdir(tmp_path) == ["g.png"]


def test_stipple_help_describes_the_default(capsys):
    assert cli.main(["stipple", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "the default schedule" in text and "--schedule paper runs the paper's" in text


# ------------------------------------------------------------------ analyze

@pytest.fixture
def point_files(tmp_path):
    a, b = tmp_path / "a.npz", tmp_path / "b.csv"
    write_points(a, dart_throwing(200, seed=1))
    write_points(b, dart_throwing(200, seed=2))
    return [str(a), str(b)]


def test_analyze_point_sets_json(point_files, capsys):
    assert cli.main(["analyze", *point_files, "--json"]) == 0
    s = _json_line(capsys.readouterr().out)
    assert s["n"] == 200 and s["realizations"] == 2
    assert s["rho"] >= 0.7 and s["anisotropy_reference_db"] == pytest.approx(-3.0103, abs=1e-4)
    assert len(s["radial_power"]) == len(s["radial_frequency"]) == len(s["anisotropy_db"])


def test_analyze_point_sets_figure(point_files, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "report.png"
    assert cli.main(["analyze", *point_files, "-o", str(out), "--json"]) == 0
    s = _json_line(capsys.readouterr().out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the numbers computed without matplotlib are those of the figure
    assert cli.main(["analyze", *point_files, "--json"]) == 0
    assert _json_line(capsys.readouterr().out) == s


def test_analyze_without_matplotlib(point_files, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    out = tmp_path / "report.png"
    before = set(os.listdir(tmp_path))
    assert cli.main(["analyze", *point_files, "-o", str(out), "--json"]) == 1
    captured = capsys.readouterr()
    assert _json_line(captured.out)["n"] == 200
    assert '.venv/bin/pip install ".[plot]"' in captured.err
    assert set(os.listdir(tmp_path)) == before
    # without --json it fails before any work
    assert cli.main(["analyze", *point_files, "-o", str(out)]) == 1
    assert '.venv/bin/pip install ".[plot]"' in capsys.readouterr().err
    assert set(os.listdir(tmp_path)) == before


def test_analyze_stippling(stippled, tmp_path, capsys):
    npz = str(stippled.outs["npz"])
    assert cli.main(["analyze", npz, "--image", str(stippled.image), "--json"]) == 0
    s = _json_line(capsys.readouterr().out)
    assert s["n"] == 150 and 0 < s["tone_ssim"] <= 1 and s["certificate"]["valid"] is True
    assert s["radius_max"] == pytest.approx(stippled.summary["max_radius"])
    pytest.importorskip("matplotlib")
    out = tmp_path / "s.png"
    assert cli.main(["analyze", npz, "--image", str(stippled.image), "-o", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("case, message", [
    ("no image", "is a stippling: give its input image with --image"),
    ("wrong image size", "is a stippling of a 48x48 px image"),
    ("mixed", "is analyzed alone"),
    ("pixel units", "must lie on the unit torus"),
    ("no output", "nothing to do"),
    ("figure extension", "unknown figure extension"),
])
def test_analyze_bad_inputs(stippled, point_files, tmp_path, capsys, case, message):
    npz = str(stippled.outs["npz"])
    out = ["-o", str(tmp_path / "r.png")]
    argv = {
        "no image": [npz, *out],
        "wrong image size": [npz, "--image", str(_gradient_png(tmp_path / "g.png", 20)), "--json"],
        "mixed": [npz, point_files[0], "--image", "sample", *out],
        "pixel units": [str(stippled.outs["csv"]), *out],
        "no output": point_files,
        "figure extension": [*point_files, "-o", str(tmp_path / "r.gif")],
    }[case]
    _bad(tmp_path, capsys, ["analyze", *argv], 1, message)


# --------------------------------------------------------- poisson --radius

def test_poisson_radius_passes_options(monkeypatch, tmp_path, capsys):
    import diskpack_cl.cli.poisson
    import diskpack_cl.relax

    calls = []

    def fake(radius, options, **kwargs):
        calls.append(dict(radius=radius, options=options, **kwargs))
        pts = dart_throwing(30, seed=0)
        return diskpack_cl.relax.RadiusResult(pts, 30, radius, 0.0801, 0.9,
                                              [{"n": 30, "reached": True}], 0.5)

    monkeypatch.setattr(diskpack_cl.cli.poisson, "max_points_for_radius", fake)
    out = tmp_path / "r.npz"
    rc = cli.main(["poisson", "--radius", "0.08", "--init", "random", "--seed", "4", "--backend",
                   "exact", "--max-iter", "50", "-o", str(out), "--json"])
    assert rc == 0
    (call,) = calls
    assert (call["radius"], call["start"], call["seed"], call["options"]) == \
        (0.08, "random", 4, RelaxOptions(backend="exact", max_iter=50, patience=60))
    s = _json_line(capsys.readouterr().out)
    assert s["n"] == 30 and s["radius"] == 0.08 and s["achieved_radius"] == 0.0801
    assert read_points(out).shape == (30, 2)


def test_poisson_radius_real(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert cli.main(["poisson", "--radius", "0.12", "--backend", "exact", "-o", str(out),
                     "--json", "-q"]) == 0
    s = _json_line(capsys.readouterr().out)
    from diskpack_cl.measures import min_distance

    pts = read_points(out)
    assert len(pts) == s["n"] >= 12 and min_distance(pts) / 2 >= 0.12


@pytest.mark.parametrize("argv, code, message", [
    (["--radius", "0.05", "-n", "10"], 2, "not allowed with argument --radius"),
    (["--radius", "0.3"], 2, "must be in (0, 0.25)"),
    (["--radius", "0.05", "--init", "x.npz"], 1, "use --init dart or random"),
])
def test_poisson_radius_errors(tmp_path, capsys, argv, code, message):
    _bad(tmp_path, capsys, ["poisson", *argv, "-o", str(tmp_path / "o.npz")], code, message)


def test_opencl_failure_is_an_error_message(monkeypatch, tmp_path, capsys):
    pyopencl = pytest.importorskip("pyopencl")

    def broken(*args, **kwargs):
        raise pyopencl.LogicError("clEnqueueNDRangeKernel failed: INVALID_WORK_GROUP_SIZE")

    monkeypatch.setattr(JOBS, "stipple", broken)
    image = _gradient_png(tmp_path / "g.png", 16)
    _bad(tmp_path, capsys, ["stipple", str(image), "-n", "10", "-o", str(tmp_path / "o.svg")], 1,
         "diskpack: error: OpenCL failed (LogicError")


# ------------------------------------------------------------------- export

def _run_json(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    assert rc == 0, err
    return _json_line(out), err


def test_stipple_json_has_the_plot(stippled):
    plot = stippled.summary["plot"]
    svg = stippled.summary["outputs"][0]
    assert plot["pen_downs"] == 150 and plot["plot_speed_mm_s"] == 50.0
    assert plot["travel_after_mm"] == svg["travel_after_mm"] < plot["travel_before_mm"]
    assert plot["plot_seconds"] == pytest.approx(
        (plot["draw_mm"] + plot["travel_after_mm"]) / 50.0 + 150 * 0.3)
    assert "plot about 0 h 0" in stippled.err


def test_export_draws_the_stippling_again_without_recomputing(stippled, tmp_path, capsys):
    again = tmp_path / "again.svg"
    s, err = _run_json(["export", str(stippled.outs["npz"]), "-o", str(again), "--json"], capsys)
    assert again.read_bytes() == stippled.outs["svg"].read_bytes()
    assert s["n"] == 150 and s["plot"]["pen_downs"] == 150 and "150 dots of" in err
    # the summary line gives each stage's seconds, as stipple's does
    line = next(t for t in err.splitlines() if "150 dots of" in t)
    assert re.search(r"; writing [0-9.e-]+ s, pen path [0-9.e-]+ s; [0-9.e-]+ s in all;", line), line
    # another paper, pen and speed; the .svg it wrote reads back too
    a4 = tmp_path / "a4.svg"
    s, _ = _run_json(["export", str(stippled.outs["svg"]), "-o", str(a4), "-o",
                      str(tmp_path / "a4.png"), "--page", "a4", "--landscape", "--margin-mm",
                      "20", "--pen-mm", "0.3", "--plot-speed-mm-s", "25", "--json"], capsys)
    assert s["outputs"][0]["page_mm"] == [297.0, 210.0]
    assert s["outputs"][0]["height_mm"] == pytest.approx(170.0)  # fitted inside the margins
    assert s["plot"]["plot_speed_mm_s"] == 25.0


@pytest.mark.parametrize("argv, message", [
    (["--margin-mm", "10"], "--margin-mm is for a --page paper"),
    (["--landscape"], "--landscape is for a --page paper"),
    (["--page", "b4"], "argument --page: page must be a3, a4, a5, letter or WxHmm"),
])
def test_page_options_need_a_page(stippled, tmp_path, capsys, argv, message):
    rc = cli.main(["export", str(stippled.outs["npz"]), "-o", str(tmp_path / "x.svg"), *argv])
    assert rc == 2 and message in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_dot_count_from_the_pen(ctx, tmp_path, capsys):
    image = _gradient_png(tmp_path / "g.png", 24)
    base = ["stipple", str(image), "--width-mm", "60", "--dot-mm", "2", "--schedule", "pack",
            "--json", "-o", str(tmp_path / "o.svg")]
    s, err = _run_json([*base, "-n", "tone"], capsys)
    # mean darkness 1/2 of 60 x 60 mm, dots of pi mm^2
    tone = s["tone_n"]["n"]
    assert s["n"] == tone == pytest.approx(0.5 * 3600 / np.pi, rel=0.01) and "note" not in err
    s, err = _run_json([*base, "-n", "100"], capsys)
    assert s["n"] == 100 and s["tone_n"] == {"n": tone, "dot_mm": 2.0}
    assert f"{tone} dots of 2 mm give the image's ink on this paper; -n 100 will look " \
           f"lighter" in err
    assert cli.main(["stipple", str(image), "-n", "tone", "-o", str(tmp_path / "x.svg")]) == 2
    assert "-n tone needs the dot size" in capsys.readouterr().err


def test_tone_controls_act_on_the_default_schedule(ctx, tmp_path, capsys):
    image = _gradient_png(tmp_path / "g.png", 40)   # dark on the left, white on the right
    out = tmp_path / "o.npz"
    s, _ = _run_json(["stipple", str(image), "-n", "200", "--white-point", "0.5",
                      "--black-point", "0.1", "--tone-gamma", "1.5", "--json", "-o", str(out)],
                     capsys)
    assert s["params"]["schedule"] != "paper"
    assert s["params"]["tone"] == {"black": 0.1, "white": 0.5, "gamma": 1.5}
    with np.load(out) as z:
        # levels above the white point are blank paper: (almost) no dot right of the
        # middle, where a quarter of them are without it
        assert np.mean(z["points"][:, 0] > 20) < 0.05
        assert json.loads(str(z["params"]))["tone"]["white"] == 0.5
    assert cli.main(["stipple", str(image), "-n", "8", "--black-point", "0.6",
                     "--white-point", "0.5", "-o", str(tmp_path / "x.svg")]) == 2
    assert "--black-point 0.6 must be below --white-point 0.5" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["stipple", "export"])
def test_pen_width_changes_what_is_drawn(stippled, tmp_path, capsys, command):
    """--pen-mm reaches the writers: a dot narrower than the pen is one pen touch, drawn
    as a path (SVG) and previewed as wide as the pen (PNG); without it, a small circle."""
    head = (["export", str(stippled.outs["npz"])] if command == "export" else
            ["stipple", str(stippled.outs["png"].parent / "grad.png"), *STIPPLE_ARGS,
             "--seed", "1"])
    drawn = {}
    for pen in ([], ["--pen-mm", "1.0"]):
        out = tmp_path / f"pen{len(pen)}"
        out.mkdir()
        assert cli.main([*head, "--dot-mm", "0.3", "-q", *pen, "-o", str(out / "a.svg"),
                         "-o", str(out / "a.png")]) == 0
        drawn[bool(pen)] = {ext: (out / f"a.{ext}").read_bytes() for ext in ("svg", "png")}
    assert drawn[True]["svg"] != drawn[False]["svg"]
    assert drawn[True]["png"] != drawn[False]["png"]
    assert b"<circle" in drawn[False]["svg"] and b"<circle" not in drawn[True]["svg"]


# ------------------------------------------------------------------ plotter options

@pytest.mark.parametrize("lift", [0.0, 1.25])
def test_pen_lift_sets_the_plot_time(stippled, tmp_path, capsys, lift):
    """--pen-lift-s replaces the 0.3 s per dot of the plot-time estimate (JSON and summary)."""
    s, err = _run_json(["export", str(stippled.outs["npz"]), "-o", str(tmp_path / "a.svg"),
                        "--pen-lift-s", str(lift), "--json"], capsys)
    plot = s["plot"]
    assert plot["pen_lift_s"] == lift
    assert plot["plot_seconds"] == pytest.approx(
        (plot["draw_mm"] + plot["travel_after_mm"]) / 50.0 + 150 * lift)
    assert f"{lift:g} s a pen lift" in err


@pytest.mark.parametrize("command", ["stipple", "export"])
def test_pen_path_help_says_what_it_runs(capsys, command):
    """The 2-opt of --pen-path auto is a number of rounds, not a time bound."""
    from diskpack_cl.drawing.pen_path import TWO_OPT_WORK

    assert cli.main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "at most 2 s" not in text
    assert f"ceil({TWO_OPT_WORK} / dots) rounds of 2-opt" in text


# ------------------------------------------------------------------ help

def _help(command, capsys):
    assert cli.main([command, "--help"]) == 0
    return capsys.readouterr().out


def _examples(text):
    """The argument lists of the help's examples: each line of its ``examples:`` block,
    joined with its `` \\`` continuations, without ``diskpack``."""
    import shlex

    found, current = [], None
    block = text.partition("\nexamples:\n")[2].partition("\n\n")[0]
    for line in block.splitlines():
        words = line.strip()
        current = words.rstrip("\\") if current is None else current + " " + words.rstrip("\\")
        if not words.endswith("\\"):
            found.append(shlex.split(current)[1:])
            current = None
    return found


def test_stipple_help_leads_with_what_users_came_for(capsys):
    """The first screen (40 lines): the usage, a plotter example and the everyday options."""
    first = _help("stipple", capsys).splitlines()[:40]
    assert first[0] == "usage: diskpack stipple IMAGE -n N -o OUT [options]"
    flags = {word.rstrip(",") for line in first for word in line.split()[:3]}
    assert {"-n", "-o", "--page", "--pen-mm", "--plotter"} <= flags
    example = _examples("\n".join(first))[0]
    assert "--plotter" in example and "--pen-mm" in example


@pytest.mark.parametrize("command", ["stipple", "export"])
def test_leading_options_have_one_line_helps(command):
    """Each help of the leading groups fits beside its option on an 80-column terminal."""
    from diskpack_cl.cli._help import EVERYDAY, PLOTTER

    parser = cli.build_parser(command)._subparsers._group_actions[0].choices[command]
    formatter = parser._get_formatter()
    leading = [g for g in parser._action_groups if g.title in (EVERYDAY, PLOTTER)]
    assert [g.title for g in parser._action_groups if g._group_actions][1:3] == [EVERYDAY, PLOTTER]
    for action in (a for g in leading for a in g._group_actions):
        assert len(formatter._expand_help(action)) <= 80 - 24, action.option_strings


@pytest.mark.parametrize("command", ["stipple", "poisson", "relax", "export", "analyze",
                                     "devices"])
def test_every_subcommand_has_examples_that_parse(capsys, command):
    examples = _examples(_help(command, capsys))
    assert examples and all(argv[0] == command for argv in examples)
    for argv in examples:
        assert cli.build_parser(command).parse_args(argv).command == command, argv


# ------------------------------------------------------------------ notes

@pytest.mark.parametrize("pen, note", [("0.5", None), ("5", "-n 200 will look darker")])
def test_ink_note_is_computed_from_the_drawn_dots(ctx, tmp_path, capsys, pen, note):
    """With --pen-mm alone the dots are drawn at the tone size, whose ink is the image's
    at any n: no note; a pen wider than the tone dots draws them darker: a note."""
    image = _gradient_png(tmp_path / "g.png", 24)
    _, err = _run_json(["stipple", str(image), "-n", "200", "--width-mm", "60", "--pen-mm", pen,
                        "--schedule", "pack", "--json", "-o", str(tmp_path / "o.svg")], capsys)
    assert ("will look" in err) == (note is not None)
    assert note is None or note in err


@pytest.mark.parametrize("palette", [["--colors", "cmyk"], ["--colors", "cmy"],
                                     ["--pens", "black=#000,red=#c00"], ["--colors", "auto:3"]])
def test_every_palette_route_says_the_image_has_no_hue(ctx, tmp_path, capsys, palette):
    """A grey image in colour: cmyk, cmy and pens say so as auto:N does (its error)."""
    from PIL import Image

    from diskpack_cl.palette import NO_HUE

    image = tmp_path / "g.png"
    grey = np.tile(np.linspace(0, 255, 24), (24, 1)).astype(np.uint8)
    Image.fromarray(np.dstack([grey] * 3)).save(image)
    rc = cli.main(["stipple", str(image), "-n", "60", *palette, "--beta", "2", "--lloyd", "1",
                   "--rounds", "1", "-o", str(tmp_path / "o.npz")])
    err = capsys.readouterr().err
    assert rc == (1 if palette[1].startswith("auto") else 0), err
    assert f"diskpack: {'error' if rc else 'note'}: {NO_HUE}" in err
