import io
import json
import os
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from diskpack_cl import cli
from diskpack_cl.io import read_points, write_points
from diskpack_cl.sampling import dart_throwing

ROOT = Path(__file__).resolve().parents[1]
JSON_KEYS = {"n", "iterations", "rho_start", "rho_final", "seconds", "seconds_per_iteration",
             "stage_seconds", "backend", "device", "stop_reason", "output"}
STAGES = {"raster_labels", "mic_estimate", "exact_refine"}


def _json_line(out):
    lines = [line for line in out.splitlines() if line.strip()]
    assert len(lines) == 1, out
    return json.loads(lines[0])


@pytest.fixture
def fake_relax(monkeypatch):
    """Replace relax_poisson with a fast stand-in that records its calls."""
    calls = []

    def relax_poisson(points, eps=0.8, *, max_iter=1000, backend="auto", grid=None,
                      device=None, callback=None):
        calls.append(dict(points=np.array(points), eps=eps, max_iter=max_iter,
                          backend=backend, grid=grid, device=device))
        if callback is not None:
            for i in range(1, 4):
                callback(i, 0.7 + 0.01 * i)
        return types.SimpleNamespace(
            points=np.mod(np.asarray(points, dtype=float), 1.0), rho=np.array([0.7, 0.71, 0.72, 0.73]),
            iterations=3, stop_reason="max_iter", seconds=0.03,
            timings={"raster_labels": 0.01, "mic_estimate": 0.01, "exact_refine": 0.01},
            backend=backend, device="fake", stats={})

    import diskpack_cl.relax

    monkeypatch.setattr(diskpack_cl.relax, "relax_poisson", relax_poisson)
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
    assert s["rho_start"] >= 0.74 and s["rho_final"] >= s["rho_start"]
    assert s["stop_reason"] in {"eps", "stalled", "max_iter"}
    if s["stop_reason"] == "eps":
        assert s["rho_final"] >= 0.8
    pts = read_points(out)
    assert pts.shape == (128, 2) and ((pts >= 0) & (pts < 1)).all()
    with np.load(out) as z:
        assert z["rho"].shape == (s["iterations"] + 1,)
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
    from diskpack_cl.geometry import normalized_radius

    assert normalized_radius(pts) == pytest.approx(s["rho_final"], rel=1e-9)


def test_poisson_opencl_backend(ctx, tmp_path, capsys):
    out = tmp_path / "p.npy"
    rc = cli.main(["poisson", "-n", "64", "-o", str(out), "--backend", "opencl", "--seed", "0",
                   "--json", "--max-iter", "3", "--grid", "64"])
    assert rc == 0
    s = _json_line(capsys.readouterr().out)
    assert s["backend"] == "opencl" and s["iterations"] <= 3


def test_devices(capsys):
    from diskpack_cl._device import NoOpenCLError, list_devices

    try:
        list_devices()
    except NoOpenCLError:
        pytest.skip("no OpenCL platform")
    assert cli.main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "using:" in out and "0:0" in out


# ------------------------------------------------------- with a fake relax

def test_poisson_passes_options(fake_relax, tmp_path, capsys):
    out = tmp_path / "p.npz"
    rc = cli.main(["poisson", "-n", "20", "-o", str(out), "--eps", "0.7", "--max-iter", "9",
                   "--backend", "opencl", "--grid", "32", "--device", "pocl", "--json"])
    assert rc == 0
    (call,) = fake_relax
    assert call["points"].shape == (20, 2)
    assert (call["eps"], call["max_iter"], call["backend"], call["grid"], call["device"]) == \
        (0.7, 9, "opencl", 32, "pocl")
    s = _json_line(capsys.readouterr().out)
    assert s["seconds_per_iteration"] == pytest.approx(0.01)
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


def test_progress_bar_on_a_terminal(fake_relax, tmp_path, monkeypatch):
    class Tty(io.StringIO):
        def isatty(self):
            return True

    err = Tty()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setenv("TQDM_MININTERVAL", "0")  # draw every update
    assert cli.main(["poisson", "-n", "10", "-o", str(tmp_path / "o.npz"), "--seed", "0"]) == 0
    text = err.getvalue()
    assert "rho=0.73" in text and "relax" in text


def test_no_progress_bar_when_quiet_or_not_a_terminal(fake_relax, tmp_path, capsys):
    assert cli.main(["poisson", "-n", "10", "-o", str(tmp_path / "o.npz")]) == 0
    assert "rho=" not in capsys.readouterr().err


def test_keyboard_interrupt(monkeypatch, tmp_path, capsys):
    import diskpack_cl.relax

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(diskpack_cl.relax, "relax_poisson", interrupted)
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
    assert "usage: diskpack" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_help_returns_zero(capsys):
    assert cli.main(["--help"]) == 0
    assert "poisson" in capsys.readouterr().out


def test_devices_without_opencl(monkeypatch, capsys):
    import diskpack_cl._device as dev

    def none():
        raise dev.NoOpenCLError("no OpenCL platform found; install an OpenCL driver")

    monkeypatch.setattr(dev, "list_devices", none)
    assert cli.main(["devices"]) == 1
    assert "diskpack: error: no OpenCL platform found; install" in capsys.readouterr().err


def test_subcommands_are_registered_from_add_functions():
    names = [n[5:] for n in vars(cli) if n.startswith("_add_")]
    assert {"devices", "poisson", "relax"} <= set(names)
    for name in names:
        assert callable(getattr(cli, f"_run_{name}"))


# ------------------------------------------------------ README and .ci/run

def test_readme_commands_match_ci():
    readme = (ROOT / "README.md").read_text()
    test_cmd = ('python3 -m venv .venv && .venv/bin/pip install -e ".[test]" '
                "&& .venv/bin/python -m pytest -q")
    head = "\n".join(readme.splitlines()[:25])
    assert test_cmd in head
    assert "diskpack poisson -n 1024 -o out/points.npz" in head
    ci = (ROOT / ".ci" / "run").read_text()
    assert '.venv/bin/pip install -e ".[test]"' in ci and ".venv/bin/python -m pytest -q" in ci
    assert os.access(ROOT / ".ci" / "run", os.X_OK)
