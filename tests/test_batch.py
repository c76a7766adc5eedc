"""Batch jobs: templates, manifest and resume, worker processes, Dask, bad inputs.

Everything runs for real: spawned worker processes, a child process killed
with SIGTERM, and a ``distributed.LocalCluster`` with two process workers.
Images are tiny and schedules short, so the module runs in about a minute on
two cores.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from diskpack_cl.jobs import executors
from diskpack_cl.jobs import items as jobs
from diskpack_cl.jobs.batch import poisson_many, stipple_many
from diskpack_cl.jobs.executors import Manifest
from diskpack_cl.jobs.items import Item, derive_seeds, expand_inputs, plan_stipple, render_template
from diskpack_cl.cli import main
from diskpack_cl.drawing.writers import WriteOptions

DATA = Path(__file__).parent / "data"
QUICK = dict(schedule=[("pack", 2)])  # a short schedule: the batch layer is under test
QUICK_CLI = ["--beta", "2", "--lloyd", "0", "--rounds", "1"]


def _photos(folder, size=(40, 40)):
    """The three test photographs, shrunk, as PNG files in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in ("astronaut", "camera", "coffee"):
        p = folder / f"{name}.png"
        Image.open(DATA / f"{name}.png").convert("L").resize(size).save(p)
        paths.append(str(p))
    return paths


def _cli(argv, capsys):
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def _files(folder):
    return {p.name: p.read_bytes() for p in sorted(Path(folder).iterdir())
            if p.name != "manifest.jsonl"}


def _differences(folder, *others):
    """Names of the files that are missing or differ between the folders."""
    ref = _files(folder)
    out = set()
    for other in others:
        got = _files(other)
        out |= {name for name in ref.keys() | got.keys() if ref.get(name) != got.get(name)}
    return sorted(out)


def _manifest_lines(path):
    raw = Path(path).read_bytes()
    assert raw.endswith(b"\n")
    return [json.loads(line) for line in raw.decode().splitlines()]


# ----------------------------------------------------------- templates, plans

def test_render_template_fields():
    assert render_template("o/{parent}/{stem}-{n}-{seed}.svg", input="a/b/cat.jpg", n=5,
                           seed=3) == "o/b/cat-5-3.svg"
    assert render_template("{name}.npz", input="x/cat.jpg") == "cat.jpg.npz"
    assert render_template("sets/{i:04d}.npz", i=12) == "sets/0012.npz"
    with pytest.raises(ValueError, match=r"unknown field \{size\}.*\{stem\}"):
        render_template("{size}.svg", input="a.png")
    with pytest.raises(ValueError, match=r"\{stem\} needs an input file"):
        render_template("{stem}.npz", i=0)


def test_expand_inputs_empty_folder(tmp_path):
    with pytest.raises(ValueError, match="no images in folder .*--recursive"):
        expand_inputs([tmp_path])


def test_derived_seeds_are_spawned_children():
    seeds = derive_seeds(7, 5)
    assert seeds == derive_seeds(7, 5) and len(set(seeds)) == 5
    assert derive_seeds(8, 5) != seeds
    assert derive_seeds(7, 6)[:5] == seeds  # a longer batch keeps the first sets


def test_stem_collision_refused_before_any_work(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    _photos(a)
    _photos(b)
    out = tmp_path / "out"
    rc, _, err = _cli(["stipple", a, b, "-n", 50, "-o", f"{out}/{{stem}}.svg", *QUICK_CLI],
                      capsys)
    assert rc == 1
    assert "map " in err and "astronaut.png" in err and "{parent}" in err
    assert not out.exists() or not any(out.iterdir())
    with pytest.raises(ValueError, match="output given twice"):
        plan_stipple([str(a / "camera.png")], [f"{out}/x.svg", f"{out}/x.svg"], n=10)


def test_density_sets_n_per_image(tmp_path):
    small, large = _photos(tmp_path / "s", (40, 40))[0], _photos(tmp_path / "l", (80, 40))[0]
    items = plan_stipple([small, large], [str(tmp_path / "o" / "{parent}_{n}.npz")],
                         density=50000)
    assert [os.path.basename(it.outputs[0]) for it in items] == ["s_80.npz", "l_160.npz"]
    recs = list(stipple_many([small, large], [str(tmp_path / "o" / "{parent}_{n}.npz")],
                             density=50000, **QUICK))
    assert sorted(r["summary"]["n"] for r in recs) == [80, 160]
    with pytest.raises(ValueError, match="--dots-per-cm2 needs the print size"):
        plan_stipple([small], [str(tmp_path / "{stem}.svg")], dots_per_cm2=10)
    (item,) = plan_stipple([small], [str(tmp_path / "{stem}_{n}.svg")], dots_per_cm2=10,
                           write=WriteOptions(width_mm=100.0))
    assert item.outputs[0].endswith("_1000.svg")  # 10 cm x 10 cm


# ------------------------------------------------------------- bad inputs

def test_bad_inputs_are_recorded_and_the_rest_completes(ctx, tmp_path, capsys):
    photos = tmp_path / "in"
    good = _photos(photos)
    (photos / "broken.png").write_bytes(b"not an image at all")
    Image.fromarray(np.full((30, 30), 255, np.uint8)).save(photos / "white.png")
    missing = photos / "gone.png"
    out = tmp_path / "out"
    rc, _, err = _cli(["stipple", photos, missing, "-n", 60, "-o", f"{out}/{{stem}}.npz",
                       "--jobs", 1, *QUICK_CLI], capsys)
    assert rc == 1
    assert "not an image Pillow can read" in err and "broken.png" in err
    assert "white.png: nothing to stipple" in err
    assert "image file not found" in err and "gone.png" in err
    assert "3 done, 3 failed" in err
    assert sorted(_files(out)) == sorted(Path(g).stem + ".npz" for g in good)
    lines = _manifest_lines(out / "manifest.jsonl")
    assert sorted(r["status"] for r in lines) == ["failed"] * 3 + ["ok"] * 3
    assert all(r["error"] for r in lines if r["status"] == "failed")


# ----------------------------------------------------------------- resume

def test_rerun_skips_done_and_redoes_changed(tmp_path, capsys):
    src = tmp_path / "src"
    src.mkdir()
    rng = np.random.default_rng(0)
    for k in range(3):
        np.save(src / f"p{k}.npy", rng.random((100, 2)))
    inputs = sorted(str(p) for p in src.iterdir())
    argv = ["relax", *inputs, "-o", f"{tmp_path}/out/{{stem}}.npz", "--backend", "exact",
            "--jobs", 1, "--json", "-q"]
    rc, out, _ = _cli(argv, capsys)
    assert rc == 0 and json.loads(out.splitlines()[-1])["ok"] == 3
    rc, out, _ = _cli(argv, capsys)
    assert json.loads(out.splitlines()[-1])["skipped"] == 3
    np.save(src / "p1.npy", rng.random((100, 2)))  # a changed input is redone
    os.utime(src / "p1.npy", ns=(time.time_ns() + 10**9,) * 2)
    rc, out, _ = _cli(argv, capsys)
    summary = json.loads(out.splitlines()[-1])
    assert (summary["ok"], summary["skipped"]) == (1, 2)
    rc, out, _ = _cli(argv[:-2] + ["--eps", "0.79", "--json", "-q"], capsys)  # new parameter
    assert json.loads(out.splitlines()[-1])["ok"] == 3
    os.unlink(tmp_path / "out" / "p0.npz")  # a missing output is redone
    rc, out, _ = _cli(argv[:-2] + ["--eps", "0.79", "--json", "-q"], capsys)
    assert json.loads(out.splitlines()[-1])["ok"] == 1
    rc, out, _ = _cli(argv + ["--overwrite"], capsys)
    assert json.loads(out.splitlines()[-1])["ok"] == 3
    assert len(_manifest_lines(tmp_path / "out" / "manifest.jsonl")) == 3 + 1 + 3 + 1 + 3


def test_a_new_image_in_the_folder_leaves_the_others_done(ctx, tmp_path, capsys):
    photos = tmp_path / "in"
    _photos(photos)
    argv = ["stipple", photos, "-n", 40, "-o", f"{tmp_path}/out/{{stem}}.npz", "--jobs", 1,
            *QUICK_CLI, "--json", "-q"]
    assert _cli(argv, capsys)[0] == 0
    (photos / "aaa.png").write_bytes((photos / "camera.png").read_bytes())  # sorts first
    rc, out, _ = _cli(argv, capsys)
    summary = json.loads(out.splitlines()[-1])
    assert (rc, summary["ok"], summary["skipped"]) == (0, 1, 3)


def _kill_part_way(argv, manifest, after_lines, timeout=120):
    """Start the CLI as a child, SIGTERM it once the manifest has ``after_lines`` lines."""
    proc = subprocess.Popen([sys.executable, "-m", "diskpack_cl.cli", *map(str, argv)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if manifest.exists() and manifest.read_bytes().count(b"\n") >= after_lines:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the batch ended before it could be killed"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err.decode()


@pytest.mark.parametrize("jobs", [1, 2])
def test_sigterm_part_way_then_resume(tmp_path, jobs):
    out = tmp_path / "sets"
    manifest = out / "manifest.jsonl"
    count = 24
    argv = ["poisson", "--count", count, "-n", 3000, "--seed", 5, "--backend", "exact",
            "-o", f"{out}/{{i:03d}}.npz", "--jobs", jobs]
    rc, err = _kill_part_way(argv, manifest, after_lines=3)
    assert rc == 143, err
    assert "interrupted after" in err and "rerun the same command" in err
    first = _manifest_lines(manifest)  # every line whole
    assert 3 <= len(first) < count
    written = sorted(p.name for p in out.iterdir())
    assert not [name for name in written if name.endswith(".part")]
    time.sleep(1.5)  # the workers stopped with the batch: nothing more appears
    assert sorted(p.name for p in out.iterdir()) == written
    for p in out.glob("*.npz"):  # whatever exists is complete
        assert np.load(p)["points"].shape == (3000, 2)
    rc = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", *map(str, argv), "-q"]).returncode
    assert rc == 0
    lines = _manifest_lines(manifest)
    ok = [r["outputs"][0] for r in lines if r["status"] == "ok"]
    assert len(ok) == len(set(ok)) == count  # every item done exactly once
    assert len(lines) == count
    seeds = derive_seeds(5, count)
    assert [r["seed"] for r in sorted(lines, key=lambda r: r["i"])] == seeds


def test_one_set_recreated_alone(tmp_path, capsys):
    """A single run is a one-item plan with its seed itself (not derived), run by the
    batch's code (poisson_job): the same seed writes the same bytes."""
    recs = list(poisson_many(3, 200, [str(tmp_path / "{i}.npz")], seed=11, backend="exact",
                             jobs=1))
    rec = next(r for r in recs if r["i"] == 2)
    rc, _, _ = _cli(["poisson", "-n", 200, "--seed", rec["seed"], "--backend", "exact",
                     "-o", tmp_path / "alone.npz", "-q"], capsys)
    assert rc == 0
    assert (tmp_path / "alone.npz").read_bytes() == (tmp_path / "2.npz").read_bytes()


def test_rerun_without_seed_takes_the_recorded_one(tmp_path):
    outputs = [str(tmp_path / "{i}.npz")]
    first = list(poisson_many(3, 64, outputs, backend="exact", jobs=1))
    again = list(poisson_many(3, 64, outputs, backend="exact", jobs=1))
    assert [r["status"] for r in again] == ["skipped"] * 3
    assert [r["seed"] for r in again] == [r["seed"] for r in first]


def test_manifest_ignores_a_torn_line(tmp_path):
    path = tmp_path / "m.jsonl"
    m = Manifest(path)
    m.append({"outputs": ["a"], "status": "ok"})
    with open(path, "ab") as fh:
        fh.write(b'{"outputs": ["b"], "sta')  # a power cut mid-line
    assert m.finished() == {("a",): {"outputs": ["a"], "status": "ok"}}


def test_one_input_writes_no_manifest(ctx, tmp_path, capsys):
    img = _photos(tmp_path / "in")[0]
    rc, _, _ = _cli(["stipple", img, "-n", 40, "-o", tmp_path / "one.npz", *QUICK_CLI, "-q"],
                    capsys)
    assert rc == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "one.npz"]


# ------------------------------------------------------- worker processes

def test_jobs_two_gives_the_files_of_jobs_one(ctx, tmp_path):
    photos = _photos(tmp_path / "in")
    one = list(stipple_many(photos, [str(tmp_path / "j1" / "{stem}.svg"),
                                     str(tmp_path / "j1" / "{stem}.npz")], n=80, jobs=1,
                            **QUICK))
    two = list(stipple_many(photos, [str(tmp_path / "j2" / "{stem}.svg"),
                                     str(tmp_path / "j2" / "{stem}.npz")], n=80, jobs=2,
                            devices=["cpu", "cpu"], **QUICK))
    assert [r["status"] for r in one + two] == ["ok"] * 6
    assert len(_files(tmp_path / "j1")) == 6
    assert _differences(tmp_path / "j1", tmp_path / "j2") == []
    workers = {r["worker"] for r in two}
    # every item ran in a worker process; how the pool spreads three quick items over
    # its two workers is the scheduler's (one worker can take all of them while the
    # other is still starting), so the pool's size is read from what it gave each
    # worker: half the cores for PoCL
    assert 1 <= len(workers) <= 2 and os.getpid() not in {int(w.split(":")[1]) for w in workers}
    cores = executors.default_jobs()
    for r in two:  # PoCL capped per worker, one device each
        assert r["worker_env"]["POCL_MAX_PTHREAD_COUNT"] == str(max(1, cores // 2))
        assert r["worker_env"]["DISKPACK_DEVICE"] == "cpu"


# ------------------------------------------------------------------- Dask

@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as lc, \
            distributed.Client(lc) as client:
        yield lc, client


def test_dask_matches_jobs_one(ctx, tmp_path, cluster):
    lc, client = cluster
    photos = _photos(tmp_path / "in")
    outs = lambda d: [str(tmp_path / d / "{stem}.svg"), str(tmp_path / d / "{stem}.npz")]
    local = list(stipple_many(photos, outs("local"), n=80, jobs=1, **QUICK))
    shared = list(stipple_many(photos, outs("dask"), n=80, client=client, **QUICK))
    collected = list(stipple_many(photos, outs("collect"), n=80, client=client, collect=True,
                                  **QUICK))
    assert [r["status"] for r in local + shared + collected] == ["ok"] * 9
    assert len(_files(tmp_path / "local")) == 6
    assert _differences(tmp_path / "local", tmp_path / "dask", tmp_path / "collect") == []
    worker_pids = {w.pid for w in lc.workers.values()}
    for d, recs in (("dask", shared), ("collect", collected)):
        lines = _manifest_lines(tmp_path / d / "manifest.jsonl")  # written by the client
        assert sorted(r["input"] for r in lines) == sorted(photos)
        assert {int(r["worker"].split(":")[1]) for r in lines} <= worker_pids
        assert all("data" not in r for r in lines)


def test_dask_poisson_and_cli_scheduler(tmp_path, cluster, capsys):
    lc, _ = cluster
    argv = ["poisson", "--count", 4, "-n", 256, "--seed", 3, "--backend", "exact", "--json",
            "-q"]
    rc, out, _ = _cli(argv + ["-o", f"{tmp_path}/d/{{i}}.npz", "--scheduler",
                              lc.scheduler_address], capsys)
    assert rc == 0 and json.loads(out.splitlines()[-1])["ok"] == 4
    rc, out, _ = _cli(argv + ["-o", f"{tmp_path}/l/{{i}}.npz", "--jobs", 1], capsys)
    assert rc == 0
    assert len(_files(tmp_path / "d")) == 4
    assert _differences(tmp_path / "d", tmp_path / "l") == []


@pytest.fixture
def remote_cluster(tmp_path):
    """A scheduler and a worker started as ``dask`` commands in a folder of their own: a
    cluster whose working folder is not the caller's, as on other machines."""
    pytest.importorskip("distributed")
    away = tmp_path / "cluster"
    away.mkdir()
    dask = [str(Path(sys.executable).parent / "dask")]
    file = away / "scheduler.json"
    common = dict(cwd=away, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen(dask + ["scheduler", "--host", "127.0.0.1", "--port", "0",
                                      "--no-dashboard", "--scheduler-file", str(file)], **common)]
    try:
        for _ in range(600):
            if file.exists() and file.stat().st_size:
                break
            time.sleep(0.1)
        procs.append(subprocess.Popen(dask + ["worker", "--scheduler-file", str(file),
                                              "--nworkers", "1", "--nthreads", "1",
                                              "--no-dashboard"], **common))
        address = json.loads(file.read_text())["address"]
        import distributed

        with distributed.Client(address) as client:
            client.wait_for_workers(1, timeout=120)
        yield address, away
    finally:
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(timeout=60)


@pytest.mark.parametrize("collect", [[], ["--collect"]])
def test_dask_relative_paths_resolve_in_the_callers_folder(ctx, tmp_path, remote_cluster,
                                                          monkeypatch, capsys, collect):
    """Relative inputs and outputs mean the caller's folder, not the workers' (each item
    failed "image file not found: photos/astronaut.png" on a cluster started elsewhere)."""
    address, away = remote_cluster
    caller = tmp_path / "caller"
    _photos(caller / "photos", size=(24, 24))
    monkeypatch.chdir(caller)
    rc, _, err = _cli(["stipple", "photos/", "-n", 40, *QUICK_CLI, "-o", "out/{stem}.npz",
                       "--scheduler", address, *collect], capsys)
    assert rc == 0, err
    assert sorted(_files(caller / "out")) == ["astronaut.npz", "camera.npz", "coffee.npz"]
    assert not (away / "out").exists()


def test_scheduler_without_dask_names_the_extra(tmp_path):
    code = ("import sys; sys.modules['distributed'] = None\n"
            "from diskpack_cl.cli import main\n"
            f"sys.exit(main(['poisson', '--count', '2', '-o', r'{tmp_path}/{{i}}.npz', "
            "'--scheduler', 'tcp://127.0.0.1:1']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 1
    assert '.venv/bin/pip install ".[dask]"' in proc.stderr


def test_item_identity_follows_the_input(tmp_path):
    p = tmp_path / "a.npy"
    np.save(p, np.zeros((3, 2)))
    item = Item("relax", 0, str(p), None, {"eps": 0.8}, (str(tmp_path / "o.npz"),))
    before = item.identity()
    os.utime(p, ns=(1, 1))
    assert item.identity() != before


@pytest.mark.parametrize("flags", [["--verify"], ["--profile"], ["--verify", "--profile"]])
def test_single_input_switches_refused_on_a_batch(tmp_path, capsys, flags):
    """--verify and --profile check or time one run; a batch says so instead
    of ignoring them, before any work."""
    a = tmp_path / "a"
    _photos(a)
    out = tmp_path / "out"
    rc, _, err = _cli(["stipple", a, "-n", 50, "-o", f"{out}/{{stem}}.svg", *flags], capsys)
    assert rc == 2
    assert " and ".join(flags) in err and "one input" in err
    assert not out.exists()
    rc, _, err = _cli(["relax", tmp_path / "x.npz", tmp_path / "y.npz", "-o", f"{out}/{{stem}}.npz",
                       *flags], capsys)
    assert rc == 2 and "one input" in err


def test_collision_hint_names_the_field_that_differs(tmp_path):
    from diskpack_cl.jobs.items import check_outputs

    a = Item("stipple", 0, str(tmp_path / "cat.jpg"), 0, {}, (str(tmp_path / "cat.svg"),))
    b = Item("stipple", 1, str(tmp_path / "cat.png"), 0, {}, (str(tmp_path / "cat.svg"),))
    with pytest.raises(ValueError, match=r"add \{name\} or \{i\} to tell them apart"):
        check_outputs([a, b], lambda p: None)


# ---------------------------------------------------- one input: a one-item plan

def test_one_input_and_the_same_image_in_a_batch_write_the_same_bytes(ctx, tmp_path, capsys):
    """A single input and a batch item run the same code (jobs.stipple_item): the
    same image gives the same files, tone controls and all. (The batch once
    dropped the tone controls from the .npz params that the single run wrote.)"""
    img = _photos(tmp_path / "in")[1]
    opts = ["-n", 60, "--schedule", "pack", "--black-point", "0.1", "--seed", "3"]
    one = tmp_path / "one"
    one.mkdir()
    rc, _, _ = _cli(["stipple", img, *opts, "-o", one / "camera.npz", "-o", one / "camera.svg",
                     "-q"], capsys)
    assert rc == 0
    many = tmp_path / "many"
    rc, _, _ = _cli(["stipple", tmp_path / "in", *opts, "-o", f"{many}/{{stem}}.npz",
                     "-o", f"{many}/{{stem}}.svg", "-q"], capsys)
    assert rc == 0
    got = _files(many)
    assert {k: got[k] for k in ("camera.npz", "camera.svg")} == _files(one)


def test_the_batch_rule_one_input_runs_here_a_template_makes_a_batch(ctx, tmp_path, capsys):
    """The rule (BATCH_RULE): one input and a plain output run here, no manifest; the
    same input with an output template is a batch, with its manifest."""
    img = _photos(tmp_path / "in")[0]
    rc, _, _ = _cli(["stipple", img, "-n", 40, "-o", tmp_path / "plain.npz", *QUICK_CLI, "-q"],
                    capsys)
    assert rc == 0 and sorted(p.name for p in tmp_path.iterdir()) == ["in", "plain.npz"]
    rc, _, _ = _cli(["stipple", img, "-n", 40, "-o", tmp_path / "t" / "{stem}_{n}.npz",
                     *QUICK_CLI, "-q"], capsys)
    assert rc == 0
    assert sorted(p.name for p in (tmp_path / "t").iterdir()) == ["astronaut_40.npz",
                                                                  "manifest.jsonl"]


def test_a_device_list_does_not_make_a_batch(tmp_path, capsys):
    """A comma in --device no longer turns one input into a batch behind the user's
    back: the list is for a batch's workers, and one input says so."""
    img = _photos(tmp_path / "in")[0]
    rc, _, err = _cli(["stipple", img, "-n", 40, "-o", tmp_path / "o.npz", "--device",
                       "cpu,cpu"], capsys)
    assert rc == 2 and "a device list is for the workers of a batch" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]


@pytest.mark.parametrize("command", ["stipple", "poisson", "relax"])
def test_the_batch_rule_is_in_help(command, capsys):
    from diskpack_cl.cli._batches import BATCH_OPTIONS, BATCH_RULE

    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert " ".join(BATCH_RULE.split()) in text
    # every option the rule names is in the group that --help shows under it
    group = text[text.index(" ".join(BATCH_RULE.split())):]
    shown = [k for k in BATCH_OPTIONS if f"--{k}" in group]
    assert set(shown) == set(BATCH_OPTIONS) - ({"count"} if command != "poisson" else set())


def _start_sets(folder):
    """Two uniform start sets (.npy) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, n in enumerate((120, 90)):
        p = folder / f"s{k}.npy"
        np.save(p, np.random.default_rng(k).random((n, 2)))
        paths.append(p)
    return paths


def test_one_relax_input_and_the_same_file_in_a_batch_write_the_same_bytes(tmp_path, capsys):
    """relax: a single input and a batch item run the same code (jobs.relax_item), in a
    --box too, which a batch once refused (the two had separate paths)."""
    paths = _start_sets(tmp_path / "in")
    opts = ["--box", "2x1", "--eps", "0.7", "--backend", "exact", "-q"]
    rc, _, _ = _cli(["relax", paths[0], "-o", tmp_path / "one.npz", *opts], capsys)
    assert rc == 0
    rc, _, err = _cli(["relax", *paths, "-o", tmp_path / "many" / "{stem}.npz", *opts], capsys)
    assert rc == 0, err
    one = (tmp_path / "one.npz").read_bytes()
    assert (tmp_path / "many" / "s0.npz").read_bytes() == one
    assert np.load(tmp_path / "many" / "s1.npz")["box"].tolist() == [2.0, 1.0]
    line, = _manifest_lines(tmp_path / "many" / "manifest.jsonl")[:1]
    assert line["params"]["box"] == "2x1"


def test_relax_columns_reach_the_batch_items(tmp_path, capsys):
    """--columns reads the same columns in a batch as for one input (once refused there)."""
    src = tmp_path / "xyz.csv"
    xyz = np.random.default_rng(2).random((80, 3))
    np.savetxt(src, xyz, delimiter=",", header="x,y,z", comments="")
    opts = ["--columns", "z,x", "--eps", "0.6", "--backend", "exact", "-q"]
    rc, _, _ = _cli(["relax", src, "-o", tmp_path / "one.npz", *opts], capsys)
    assert rc == 0
    rc, _, err = _cli(["relax", src, "-o", tmp_path / "b" / "{stem}.npz", *opts], capsys)
    assert rc == 0, err
    assert (tmp_path / "b" / "xyz.npz").read_bytes() == (tmp_path / "one.npz").read_bytes()


def test_a_relax_plan_without_box_keeps_the_old_identity(tmp_path):
    """box and columns enter an item's params only when given: a manifest written before
    them still marks its items done."""
    src, = _start_sets(tmp_path / "in")[:1]
    item, = jobs.plan_relax([str(src)], [str(tmp_path / "o.npz")])
    assert sorted(item.params) == ["backend", "eps", "grid", "max_iter"]


def test_a_worker_ignores_a_second_sigterm_while_it_cleans_up():
    """The first SIGTERM ends a worker with SystemExit(143), which removes its
    partial files on the way out; the pool may terminate the worker again
    meanwhile (it does when another worker exits), and that second SIGTERM must
    not interrupt the removal (a .part file was left behind)."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        executors._ignore_interrupts_and_exit_on_term()
        handler = signal.getsignal(signal.SIGTERM)
        with pytest.raises(SystemExit) as exc:
            handler(signal.SIGTERM, None)
        assert exc.value.code == 143
        assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    finally:
        for s, h in saved.items():
            signal.signal(s, h)


# ------------------------------------------------------- workers end with their run


def _group(pgid):
    """Process ids of the process group `pgid`, from /proc (no psutil)."""
    out = []
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):   # not a process, or it ended meanwhile
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            out.append(int(entry))
    return out


def _pipe_closed(pipe, seconds):
    """Whether reading `pipe` reaches its end within `seconds`."""
    import select

    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ready, _, _ = select.select([pipe], [], [], 0.2)
        if ready and not os.read(pipe.fileno(), 65536):
            return True
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc")
@pytest.mark.parametrize("argv", [
    ["stipple", "sample", "-n", "20000", "--tiles", "2x2", "--jobs", "2", "-o", "{out}/t.npz"],
    ["poisson", "--count", "40", "-n", "3000", "--backend", "exact", "--jobs", "2",
     "-o", "{out}/{{i}}.npz"]], ids=["tiles", "batch"])
def test_workers_end_when_the_coordinator_is_killed(tmp_path, argv):
    """SIGKILL (the OOM killer, timeout -s KILL) runs no cleanup in the coordinator: its
    spawned workers lived on (> 90 s, ~190 MiB each) and held its stderr open."""
    argv = [a.format(out=tmp_path) for a in argv]
    proc = subprocess.Popen([sys.executable, "-m", "diskpack_cl.cli", *argv],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        for _ in range(1200):   # until both workers run
            if len(_group(proc.pid)) >= 3 or proc.poll() is not None:
                break
            time.sleep(0.05)
        time.sleep(1.0)   # the workers past their start, at work
        assert proc.poll() is None, "the run ended before it could be killed"
        proc.kill()
        proc.wait()
        assert _pipe_closed(proc.stderr, 20), "a worker still holds stderr"
        for _ in range(100):
            if not _group(proc.pid):
                break
            time.sleep(0.1)
        assert _group(proc.pid) == []
    finally:
        proc.stderr.close()
        for pid in _group(proc.pid):
            os.kill(pid, signal.SIGKILL)


NO_MAIN_GUARD = """
import sys
from diskpack_cl.jobs.batch import poisson_many

for rec in poisson_many(2, 64, [sys.argv[1] + "/{i}.npz"], seed=1, backend="exact", jobs=2):
    print(rec["status"], rec.get("error"), flush=True)
"""


def test_a_script_without_the_main_guard_is_named_with_the_fix(tmp_path):
    """Spawned workers import the user's script again; without the guard each worker
    starts the batch again and dies, reported only as 'worker process died'."""
    script = tmp_path / "user_script.py"
    script.write_text(NO_MAIN_GUARD)
    done = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True,
                          text=True, timeout=300)
    lines = done.stdout.splitlines()
    assert len(lines) == 2 and all(line.startswith("failed ") for line in lines), done.stdout
    assert all("if __name__ == \"__main__\":" in line and str(script) in line for line in lines)


def test_overwrite_redoes_the_items_done(tmp_path, capsys):
    """--overwrite redoes items whose manifest line matches (the same command again)."""
    argv = ["poisson", "--count", 2, "-n", 64, "--seed", 3, "--backend", "exact",
            "-o", f"{tmp_path}/{{i}}.npz", "--json", "-q"]
    counts = []
    for extra in ([], [], ["--overwrite"]):
        rc, out, _ = _cli(argv + extra, capsys)
        summary = json.loads(out.splitlines()[-1])
        counts.append((rc, summary["ok"], summary["skipped"]))
    assert counts == [(0, 2, 0), (0, 0, 2), (0, 2, 0)]
    assert len(_manifest_lines(tmp_path / "manifest.jsonl")) == 4


def _fails_at_first(task):
    """Raise at the first `fails` calls for the `path` of ``task = (path, fails)``; then the
    number of calls before (a file counts them: calls run in other processes)."""
    path, fails = task
    with open(path, "a+") as fh:
        fh.seek(0)
        calls = len(fh.read())
        fh.write("x")
    if calls < fails:
        raise RuntimeError(f"call {calls + 1} fails")
    return calls


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_task_is_tried_retries_more_times(tmp_path, jobs):
    tasks = [(str(tmp_path / "a"), 2), (str(tmp_path / "b"), 0)]
    assert sorted(executors.map_tasks(_fails_at_first, tasks, jobs=jobs, retries=2)) == \
        [(0, 2), (1, 0)]
    tasks = [(str(tmp_path / "c"), 3), (str(tmp_path / "d"), 0)]
    with pytest.raises(RuntimeError, match="call 3 fails"):
        list(executors.map_tasks(_fails_at_first, tasks, jobs=jobs, retries=2))


def test_a_manager_waiting_for_the_rest_of_a_killed_workers_result_is_released():
    """A worker stopped halfway through sending its result left the pool's manager thread
    waiting for the rest: the pool's shutdown, then the interpreter's exit, hung (a tiled run
    interrupted with Ctrl-C never ended)."""
    import multiprocessing
    import struct
    import threading

    results = multiprocessing.get_context("spawn").SimpleQueue()
    os.write(results._writer.fileno(), struct.pack("!i", 100000) + b"x" * 10)   # a torn message
    errors = []

    def manager():
        try:
            results._reader.recv()
        except Exception as exc:   # what the pool's manager takes for a broken pool
            errors.append(exc)
    thread = threading.Thread(target=manager, daemon=True)
    thread.start()
    thread.join(0.2)
    assert thread.is_alive()   # waiting for bytes no process will send
    executors._release(thread, results)
    assert not thread.is_alive() and errors


def test_a_killed_worker_leaves_no_partial_file(tmp_path, monkeypatch):
    """A worker that did not end within the grace after SIGTERM is killed and cannot remove
    its partial file (a heavy C call defers the signal): the coordinator removes the partial
    files of the items it had not finished, and only theirs."""
    items = jobs.plan_poisson(3, 64, [str(tmp_path / "{i}.npz")], seed=3, eps=0.7)
    left = [tmp_path / f".{i}.npz.abc{i}.part" for i in range(3)]
    for p in left:
        p.write_bytes(b"partial")

    def killed(pool):   # as if every worker had to be SIGKILLed
        for proc in (pool._processes or {}).values():
            proc.kill()
        return True

    monkeypatch.setattr(executors, "_stop_workers", killed)
    records = executors._local_pool(items, 1, None, False)
    first = next(records)
    records.close()
    done = first["i"]
    assert left[done].exists()   # a finished item's folder is not swept
    assert [p.exists() for i, p in enumerate(left) if i != done] == [False, False]
