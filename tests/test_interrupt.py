"""Long device work answers Ctrl-C: OpenCL waits let signals through, and the
raster is labelled in bounded enqueues (bands of tile rows)."""

import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from diskpack_cl.domain import Domain

pytest.importorskip("pyopencl")

# A kernel that spins for minutes, a wait on it, and a report of the event's
# state when Ctrl-C arrives (os._exit: the process does not wait for the kernel).
CHILD = textwrap.dedent("""
    import os, sys
    import numpy as np
    import pyopencl as cl
    from diskpack_cl.device.context import get_context, wait_for

    ctx = get_context()
    queue = cl.CommandQueue(ctx)
    prg = cl.Program(ctx, '''
        __kernel void spin(__global float *out, const int n) {
            float x = 0.0f;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < 1000; ++j)
                    x = x * 0.9999f + 1.0f;
            out[get_global_id(0)] = x;
        }''').build()
    out = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, 4 * 64)
    ev = prg.spin(queue, (64,), None, out, np.int32(2_000_000_000))
    queue.flush()
    try:
        print("waiting", flush=True)
        wait_for(ev)
        print("finished", flush=True)
    except KeyboardInterrupt:
        running = ev.command_execution_status != cl.command_execution_status.COMPLETE
        print("interrupted while running" if running else "interrupted after", flush=True)
    os._exit(0)
""")


def test_ctrl_c_is_answered_while_a_kernel_runs(ctx):
    child = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "waiting\n"
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=300)
    finally:
        child.kill()
    # a plain event.wait() would only return (and see the signal) after the kernel
    assert out == "interrupted while running\n", err


def test_wait_for_raises_the_wait_error(ctx):
    from diskpack_cl.device.context import wait_for

    class Broken:
        command_execution_status = -5   # a failed command's status: an OpenCL error code

        def wait(self):
            raise RuntimeError("device lost")

    with pytest.raises(RuntimeError, match="device lost"):
        wait_for(Broken())


class _Watched:
    """An event whose waits are recorded: by which thread."""

    def __init__(self, event):
        self.event, self.waiters = event, []

    @property
    def command_execution_status(self):
        return self.event.command_execution_status

    def wait(self):
        import threading

        self.waiters.append(threading.current_thread().name)
        self.event.wait()


def test_wait_for_a_finished_event_needs_no_helper(ctx):
    """An event already complete (a pass that ran beside another, a later band) is
    answered at once; one still running is waited for by a helper thread of the pool,
    the same one wait after wait."""
    import threading

    import pyopencl as cl

    from diskpack_cl.device.context import wait_for

    queue = cl.CommandQueue(ctx)
    done = _Watched(cl.enqueue_marker(queue))
    queue.finish()
    wait_for(done)
    assert done.waiters == []
    names = []
    for _ in range(3):
        user = _Watched(cl.UserEvent(ctx))   # complete only when set
        threading.Timer(0.05, lambda: user.event.set_status(cl.command_execution_status.COMPLETE)).start()
        wait_for(user)
        names += user.waiters
    assert len(set(names)) == 1 and names[0].startswith("diskpack-opencl-wait")


def test_wait_for_in_a_forked_child_makes_its_own_helpers(ctx):
    """A child forked after the parent's waits (multiprocessing's default on Linux) has
    none of the parent's helper threads: its waits start their own, and end."""
    import multiprocessing

    from diskpack_cl.device.context import wait_for

    wait_for(_Watched(_SlowEvent()))   # the parent's pool made
    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork here")
    child = multiprocessing.get_context("fork").Process(target=wait_for, args=(_SlowEvent(),))
    child.start()
    child.join(20)
    if child.is_alive():   # its wait never ended: the test fails, the child goes
        child.kill()
        child.join()
    assert child.exitcode == 0


class _SlowEvent:
    """Not complete until 0.05 s after its first wait begins."""

    command_execution_status = 1   # CL_RUNNING

    def wait(self):
        import time

        time.sleep(0.05)


@pytest.mark.parametrize("max_groups", [1, 2, 5])
def test_labels_in_bands_equal_labels_in_one_enqueue(ctx, monkeypatch, max_groups):
    import diskpack_cl.device.raster as raster

    rng = np.random.default_rng(2)
    dom = Domain.rect(30.0, 20.0)
    pts = rng.random((40, 2)) * (30.0, 20.0)
    w = rng.random(40) * 0.5
    shape = (44, 61)  # 6 x 8 tiles, the last ones partial
    one = raster.PowerRaster(dom, shape, device=ctx).compute(pts, w)
    pr = raster.PowerRaster(dom, shape, device=ctx, max_groups=max_groups)
    waits = []
    from diskpack_cl.device import stage as device_stage
    real = device_stage.wait_for
    monkeypatch.setattr(device_stage, "wait_for", lambda ev: (waits.append(ev), real(ev)))
    banded = pr.compute(pts, w)
    np.testing.assert_array_equal(banded.labels, one.labels)
    np.testing.assert_array_equal(banded.dist, one.dist)
    np.testing.assert_array_equal(banded.radii, one.radii)
    rows_per_band = max(1, max_groups // 8)
    assert len(waits) == -(-6 // rows_per_band)  # one bounded enqueue per band of tile rows


# `diskpack stipple` whose PNG writer stops (after the SVG is written) until a
# signal arrives: the run is interrupted while its outputs are being written.
WRITING_CHILD = textwrap.dedent("""
    import sys, time
    import numpy as np
    from PIL import Image
    from diskpack_cl import cli
    from diskpack_cl.drawing import writers as export

    folder = sys.argv[1]
    Image.fromarray(np.tile(np.linspace(0, 255, 24), (24, 1)).astype(np.uint8)).save(
        folder + "/g.png")

    def stuck(path, result, *options, **overrides):
        print("writing", path, flush=True)
        time.sleep(120)

    export.WRITERS[".png"] = stuck
    sys.exit(cli.main(["stipple", folder + "/g.png", "-n", "30", "--schedule", "pack", "-q",
                       "-o", folder + "/a.svg", "-o", folder + "/a.png"]))
""")


@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_while_writing_keeps_every_earlier_file(ctx, tmp_path, sig, status):
    (tmp_path / "a.svg").write_text("OLD svg")
    (tmp_path / "a.png").write_text("OLD png")
    child = subprocess.Popen([sys.executable, "-c", WRITING_CHILD, str(tmp_path)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = child.stdout.readline()
        assert line.startswith("writing") and line.rstrip().endswith("a.png"), \
            line + child.stderr.read()
        child.send_signal(sig)
        _, err = child.communicate(timeout=120)
    finally:
        child.kill()
    assert child.returncode == status, err
    assert (tmp_path / "a.svg").read_text() == "OLD svg"
    assert (tmp_path / "a.png").read_text() == "OLD png"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.svg", "g.png"]


# A tiled run or a --jobs 2 batch whose process group gets Ctrl-C just as the worker pool
# starts its manager thread, or a moment after, while the first worker imports.
POOL_START_CHILD = textwrap.dedent("""
    import os, signal, sys, time
    from concurrent.futures import process

    real = process._ExecutorManagerThread.start
    delay = float(sys.argv.pop(1))

    def start(self):
        if delay:
            real(self)
            time.sleep(delay)
        os.killpg(0, signal.SIGINT)   # the terminal's Ctrl-C reaches the whole group
        if not delay:
            real(self)

    process._ExecutorManagerThread.start = start
    from diskpack_cl.cli import main
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.parametrize("argv", [
    ["stipple", "sample", "-n", "3000", "--tiles", "2x2", "--jobs", "2", "-o", "t.npz"],
    ["poisson", "--count", "4", "-n", "500", "--backend", "exact", "--jobs", "2",
     "-o", "{i}.npz"]], ids=["tiles", "batch"])
@pytest.mark.parametrize("delay", ["0", "0.4"])
def test_ctrl_c_as_the_pool_starts_is_one_line_and_130(tmp_path, argv, delay):
    """It ended in 'RuntimeError: cannot join thread before it is started', status 1, and
    the starting workers printed KeyboardInterrupt tracebacks."""
    done = subprocess.run([sys.executable, "-c", POOL_START_CHILD, delay, *argv], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300, start_new_session=True)
    assert done.returncode == 130, done.stderr
    # (a worker stopped while PoCL builds a kernel may add clang's '1 error generated.')
    ours = [line for line in done.stderr.splitlines() if "error generated" not in line]
    assert len(ours) == 1 and "interrupted" in ours[0], done.stderr
