"""Every failure answered: signals, unwritable outputs, contradicting options.

Signals are sent to a real child process; read-only folders are a read-only
tmpfs mount when running as root (permissions do not stop root), else a
folder without write permission.
"""

import errno
import importlib
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from diskpack_cl import cli, memory
from diskpack_cl.io import write_points

JOBS = importlib.import_module("diskpack_cl.jobs.items")  # every run looks stipple up there


@pytest.fixture
def read_only_dir(tmp_path):
    """A folder in which no file can be created, whoever runs the tests."""
    path = tmp_path / "ro"
    path.mkdir()
    if os.geteuid() != 0:
        path.chmod(0o500)
        yield path
        path.chmod(0o700)
        return
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro", "tmpfs", str(path)],
                             capture_output=True).returncode == 0
    # without mount privileges, /proc refuses new files even to root
    yield path if mounted else type(path)("/proc")
    if mounted:
        subprocess.run(["umount", str(path)], check=True)


def _run(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture
def no_stipple(monkeypatch):
    """Fail the test if the computation starts."""
    def not_called(*args, **kwargs):
        raise AssertionError("the computation ran although an output was unwritable")

    monkeypatch.setattr(JOBS, "stipple", not_called)
    monkeypatch.setattr(JOBS, "relax_poisson", not_called)


# ------------------------------------------------------------------ signals

CHILD = textwrap.dedent("""
    import sys, time
    import diskpack_cl.drawing.writers as export

    def png_that_hangs(path, result, *options, **overrides):
        print("writing png", flush=True)   # the .npz and .svg are written by now
        time.sleep(600)

    export.WRITERS[".png"] = png_that_hangs
    from diskpack_cl.cli import main
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.parametrize("sig, code, name", [(signal.SIGTERM, 143, "SIGTERM"),
                                             (signal.SIGHUP, 129, "SIGHUP"),
                                             (signal.SIGINT, 130, "interrupted")])
def test_signal_while_writing_leaves_no_output(ctx, tmp_path, sig, code, name):
    from PIL import Image

    Image.fromarray(np.tile(np.linspace(0, 255, 24), (24, 1)).astype(np.uint8)).save(
        tmp_path / "g.png")
    out = tmp_path / "out"
    out.mkdir()
    argv = [str(tmp_path / "g.png"), "-n", "30", "--schedule", "pack", "-q",
            "-o", str(out / "a.npz"), "-o", str(out / "a.svg"), "-o", str(out / "a.png")]
    with subprocess.Popen([sys.executable, "-c", CHILD, "stipple", *argv],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as child:
        try:
            assert child.stdout.readline() == "writing png\n"
            # the .npz and .svg are written, as temporaries renamed only when all are done
            assert sorted(name.split(".")[1] for name in os.listdir(out)) == ["a", "a"]
            assert all(name.endswith(".part") for name in os.listdir(out))
            child.send_signal(sig)
            _, err = child.communicate(timeout=120)
        finally:
            child.kill()
    assert child.returncode == code, err
    assert f"diskpack: error: {name}, nothing written" in err
    assert "Traceback" not in err
    assert os.listdir(out) == []


# -------------------------------------------------------- unwritable outputs

def test_stipple_output_in_read_only_folder(read_only_dir, no_stipple, capsys):
    rc, out, err = _run(["stipple", "sample", "-n", "100", "-o", str(read_only_dir / "a.svg")],
                        capsys)
    assert rc == 1, err
    assert err.startswith("diskpack: error: ") and "cannot write in" in err
    assert "Traceback" not in err and "[Errno" not in err


def test_stipple_output_that_is_a_folder(tmp_path, no_stipple, capsys):
    (tmp_path / "d.svg").mkdir()
    rc, _, err = _run(["stipple", "sample", "-n", "100", "-o", str(tmp_path / "d.svg")], capsys)
    assert rc == 1 and "d.svg is a folder, not a file name" in err
    assert os.listdir(tmp_path) == ["d.svg"] and os.listdir(tmp_path / "d.svg") == []


def test_poisson_output_in_read_only_folder(read_only_dir, no_stipple, capsys):
    rc, _, err = _run(["poisson", "-n", "64", "-o", str(read_only_dir / "p.npz")], capsys)
    assert rc == 1 and "cannot write in" in err


def test_analyze_report_in_read_only_folder(read_only_dir, tmp_path, monkeypatch, capsys):
    import diskpack_cl.analysis

    pts = tmp_path / "p.npz"
    write_points(pts, np.random.default_rng(0).random((50, 2)))

    def not_called(*args, **kwargs):
        raise AssertionError("analysis ran although the report was unwritable")

    monkeypatch.setattr(diskpack_cl.analysis, "periodogram", not_called)
    rc, out, err = _run(["analyze", str(pts), "--json", "-o", str(read_only_dir / "r.png")],
                        capsys)
    assert rc == 1 and "cannot write in" in err and out == ""


def test_write_failure_after_the_work_is_an_error_message(tmp_path, monkeypatch, capsys):
    """A disk that fills up during the write: a message naming the file, nothing left."""
    import diskpack_cl.io

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(diskpack_cl.io.os, "fsync", full)
    target = tmp_path / "p.npz"
    rc, _, err = _run(["poisson", "-n", "16", "--backend", "exact", "--max-iter", "1", "-q",
                       "-o", str(target)], capsys)
    assert rc == 1, err
    assert f"diskpack: error: {target}: No space left on device; nothing written" in err
    assert os.listdir(tmp_path) == []


def test_check_writable_leaves_nothing(tmp_path):
    from diskpack_cl.io import check_writable

    check_writable(tmp_path / "new.svg")
    (tmp_path / "old.svg").write_text("x")
    check_writable(tmp_path / "old.svg")
    assert sorted(os.listdir(tmp_path)) == ["old.svg"]
    assert (tmp_path / "old.svg").read_text() == "x"


# ---------------------------------------------------------- usage conflicts

@pytest.mark.parametrize("argv, names", [
    (["poisson", "-n", "16", "-o", "a.npz", "-o", "b.npz"], ["-o given twice", "a.npz", "b.npz"]),
    (["relax", "in.npz", "-o", "a.npz", "-o", "b.npz"], ["-o given twice"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--dot-mm", "0.5", "--dots", "packing"],
     ["--dot-mm", "--dots packing"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--method", "lloyd", "--schedule", "paper"],
     ["--method lloyd", "--schedule paper"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--beta", "5", "--schedule", "pack"],
     ["--beta", "--schedule pack"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--method", "lloyd", "--rounds", "2"],
     ["--method lloyd", "--rounds"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--gamma", "2"],
     ["--gamma", "default schedule", "--schedule paper"]),
    (["stipple", "sample", "-n", "9", "-o", "a.svg", "--schedule", "paper", "--radii", "density",
      "--gamma", "2"], ["--gamma", "--radii density"]),
])
def test_contradicting_options_are_usage_errors(tmp_path, no_stipple, capsys, monkeypatch,
                                                argv, names):
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(argv, capsys)
    assert rc == 2, err
    assert "error:" in err
    for name in names:
        assert name in err
    assert os.listdir(tmp_path) == []


def test_gamma_is_accepted_where_it_acts(monkeypatch, tmp_path, capsys):
    calls = []

    def fake(image, n, options=None, **kwargs):
        calls.append({"gamma": options.gamma, **kwargs})
        raise ValueError("stop")

    monkeypatch.setattr(JOBS, "stipple", fake)
    for extra in (["--schedule", "paper"], ["--radii", "gray"], ["--beta", "4"],
                  ["--method", "lloyd"]):
        rc, _, err = _run(["stipple", "sample", "-n", "9", "-o", str(tmp_path / "a.svg"),
                           "--gamma", "2", *extra], capsys)
        assert rc == 1 and "stop" in err
    assert [c["gamma"] for c in calls] == [2.0] * 4


# ------------------------------------------------------------------ analyze

@pytest.mark.parametrize("n", [2, 1000])
def test_analyze_identical_points_is_an_error(tmp_path, capsys, n):
    pts = tmp_path / "same.npz"
    write_points(pts, np.full((n, 2), 0.3))
    rc, out, err = _run(["analyze", str(pts), "--json"], capsys)
    assert rc == 1 and out == ""
    assert f"same.npz: {n} of {n} points coincide" in err


def test_hexatic_order_of_identical_points_is_a_value_error():
    from diskpack_cl.analysis import hexatic_order

    with pytest.raises(ValueError, match="degenerate"):
        hexatic_order(np.full((1000, 2), 0.3))


def test_closed_stdout_ends_quietly(tmp_path):
    """``diskpack analyze good.npz --json | head -c 0``: no traceback, status 141."""
    pts = tmp_path / "good.npz"
    write_points(pts, np.random.default_rng(0).random((300, 2)))
    with subprocess.Popen([sys.executable, "-m", "diskpack_cl.cli", "analyze", str(pts),
                           "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE) as child:
        child.stdout.close()   # the reader went away before the first byte
        err = child.stderr.read().decode()
        child.wait(timeout=120)
    assert child.returncode == 141, err
    assert err == ""


@pytest.mark.parametrize("closed", ["2>&-", ">&-"])
@pytest.mark.parametrize("argv", [["stipple", "sample", "-n", "2000", "-o", "x.png"],
                                  ["poisson", "-n", "200", "--count", "2", "--jobs", "2",
                                   "-o", "p{i}.npz"]], ids=["stipple", "batch"])
def test_a_closed_standard_stream_does_not_stop_the_run(tmp_path, argv, closed):
    """With stderr closed a stippling died in the progress bar (AttributeError on None)."""
    import shlex

    command = shlex.join([sys.executable, "-m", "diskpack_cl.cli", *argv])
    done = subprocess.run(f"{command} {closed}", shell=True, cwd=tmp_path, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Traceback" not in done.stdout + done.stderr
    assert os.path.exists(tmp_path / argv[-1].format(i=1))
    if closed == "2>&-":   # nothing meant for stderr on stdout
        assert done.stdout == ""


# ------------------------------------------------------------ image on a pipe

@pytest.mark.parametrize("name", ["-", "/dev/stdin"])
def test_stipple_reads_the_image_from_a_pipe(ctx, tmp_path, name):
    from diskpack_cl.image import sample_image_path

    data = sample_image_path().read_bytes()
    args = ["-n", "50", "--schedule", "pack", "-q"]
    piped = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", "stipple", name, *args,
                            "-o", str(tmp_path / "pipe.npz")], input=data,
                           capture_output=True)
    assert piped.returncode == 0, piped.stderr.decode()
    assert cli.main(["stipple", "sample", *args, "-o", str(tmp_path / "file.npz")]) == 0
    with np.load(tmp_path / "pipe.npz") as a, np.load(tmp_path / "file.npz") as b:
        np.testing.assert_array_equal(a["points"], b["points"])


def test_empty_pipe_is_an_error(tmp_path):
    piped = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", "stipple", "-", "-n", "5",
                            "-o", str(tmp_path / "a.npz")], input=b"", capture_output=True)
    assert piped.returncode == 1
    assert b"diskpack: error: no image data (0 bytes) on standard input" in piped.stderr
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ devices

@pytest.mark.parametrize("argv", [
    ["poisson", "-n", "64", "-o", "p.npz"],
    ["poisson", "-n", "64", "-o", "p.npz", "--backend", "exact"],
    ["poisson", "--radius", "0.1", "-o", "p.npz"],
    ["relax", "in.npz", "-o", "p.npz"],
    ["stipple", "sample", "-n", "20", "-o", "s.npz"],
])
def test_explicit_device_that_matches_nothing_is_an_error(ctx, tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    write_points("in.npz", np.random.default_rng(0).random((64, 2)))
    rc, _, err = _run([*argv, "--device", "no-such-device-xyz"], capsys)
    assert rc == 1, err
    assert "diskpack: error: no OpenCL device matches 'no-such-device-xyz'" in err
    assert sorted(os.listdir(tmp_path)) == ["in.npz"]


@pytest.fixture
def no_opencl(monkeypatch):
    """No OpenCL platform, and no context cached from earlier tests."""
    import pyopencl

    import diskpack_cl.device.context as dev

    monkeypatch.setattr(pyopencl, "get_platforms", lambda: [])
    monkeypatch.setattr(dev, "_CONTEXTS", {})


def test_auto_falls_back_and_says_so(tmp_path, no_opencl, capsys):
    rc, _, err = _run(["poisson", "-n", "64", "--max-iter", "2", "--allow-unreached", "-o",
                       str(tmp_path / "p.npz")], capsys)
    assert rc == 0, err
    assert "on the host (exact engine)" in err
    assert "diskpack: note: engine ran on the host: no OpenCL device" in err
    rc, _, err = _run(["poisson", "-n", "64", "--backend", "opencl", "-o",
                       str(tmp_path / "q.npz")], capsys)
    assert rc == 1 and "no OpenCL platform" in err
    assert os.listdir(tmp_path) == ["p.npz"]


def test_stipple_without_opencl_says_which_engine(tmp_path, no_opencl, capsys):
    from PIL import Image

    Image.fromarray(np.tile(np.linspace(0, 255, 20), (20, 1)).astype(np.uint8)).save(
        tmp_path / "g.png")
    rc, _, err = _run(["stipple", str(tmp_path / "g.png"), "-n", "20", "--schedule", "pack",
                       "-o", str(tmp_path / "s.npz")], capsys)
    assert rc == 0, err
    assert "s in all on the host (exact engine); wrote " in err
    assert "diskpack: note: engine ran on the host: no OpenCL device" in err


# ------------------------------------------------------------ sizes vs memory

@pytest.mark.parametrize("argv, option", [
    (["--supersample", "100"], "lower --supersample (at most "),
    (["--png-scale", "200", "-o", "big.png"], "lower --png-scale (at most "),
])
def test_sizes_beyond_memory_are_refused_before_the_work(tmp_path, monkeypatch, no_stipple,
                                                         capsys, argv, option):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(memory, "available_memory", lambda: 2**30)  # a 1 GiB machine
    rc, _, err = _run(["stipple", "sample", "-n", "100", "-o", "s.npz", *argv], capsys)
    assert rc == 1, err
    assert option in err and "more than" in err
    assert os.listdir(tmp_path) == []


def test_supersample_beyond_the_device_buffer_is_refused(ctx, tmp_path, monkeypatch, no_stipple,
                                                         capsys):
    """The device's largest buffer, not the machine, is the limit here."""
    monkeypatch.setattr(memory, "available_memory", lambda: None)  # unknown: not checked
    biggest = ctx.devices[0].max_mem_alloc_size
    s = int(np.ceil(np.sqrt(biggest / 4 / (512 * 512)))) + 1
    rc, _, err = _run(["stipple", "sample", "-n", "100", "--supersample", str(s), "-o",
                       str(tmp_path / "s.npz")], capsys)
    assert rc == 1, err
    assert "the OpenCL device's largest buffer" in err and "lower --supersample" in err
