"""One route per Poisson job: the command line, a batch item and the library give the same set.

Every door builds a :class:`~diskpack_cl.poisson.PoissonOptions` and runs
:func:`~diskpack_cl.poisson.poisson_job` (itself :func:`~diskpack_cl.poisson.poisson_disk`
and the writer), so the same seed and options give the same bytes.
"""

import dataclasses
import json

import numpy as np
import pytest
from PIL import Image

from diskpack_cl import cli
from diskpack_cl.jobs.batch import poisson_many
from diskpack_cl.options import flag_name
from diskpack_cl.poisson import PoissonOptions, poisson_disk, poisson_job

# each job: (command-line arguments, poisson_job keyword arguments); the exact backend
# runs without an OpenCL device too
JOBS = {
    "torus": (["-n", "300"], dict(n=300)),
    "random": (["-n", "300", "--init", "random", "--eps", "0.75"],
               dict(n=300, init="random", eps=0.75)),
    "box": (["-n", "300", "--box", "2x1"], dict(n=300, box="2x1")),
    "distance": (["--min-distance", "0.08"], dict(n=None, min_distance=0.08)),
    "3d": (["-n", "200", "--dim", "3"], dict(n=200, dim=3)),
    "3d_box": (["-n", "200", "--dim", "3", "--box", "2x1x1"], dict(n=200, dim=3, box="2x1x1")),
}


def _cli(tmp_path, name, args, seed):
    out = tmp_path / f"{name}.npz"
    rc = cli.main(["poisson", *args, "--seed", str(seed), "--backend", "exact", "-q", "-o",
                   str(out)])
    assert rc == 0
    return out.read_bytes()


def _library(tmp_path, name, kwargs, seed):
    out = tmp_path / f"{name}.lib.npz"
    kwargs = dict(kwargs)
    n = kwargs.pop("n")
    poisson_job(n, [str(out)], seed=seed, backend="exact", **kwargs)
    return out.read_bytes()


@pytest.mark.parametrize("job", sorted(JOBS))
def test_command_line_and_library_write_the_same_bytes(tmp_path, job):
    args, kwargs = JOBS[job]
    assert _cli(tmp_path, job, args, 5) == _library(tmp_path, job, kwargs, 5)


@pytest.mark.parametrize("job", ["torus", "random", "3d"])
def test_a_batch_item_writes_the_bytes_of_the_command_line(tmp_path, job):
    args, kwargs = JOBS[job]
    options = PoissonOptions(backend="exact", **{k: v for k, v in kwargs.items() if k != "n"})
    records = list(poisson_many(2, kwargs["n"], [str(tmp_path / "set{i}.npz")], options,
                                seed=11, jobs=1))
    assert [r["status"] for r in records] == ["ok", "ok"]
    for r in records:
        assert (tmp_path / f"set{r['i']}.npz").read_bytes() == _cli(tmp_path, job, args, r["seed"])


def test_the_library_call_gives_the_points_of_the_command_line(tmp_path):
    out = tmp_path / "a.npz"
    assert cli.main(["poisson", "-n", "400", "--seed", "2", "-q", "-o", str(out)]) == 0
    np.testing.assert_array_equal(np.load(out)["points"], poisson_disk(400, seed=2).points)


def test_mask_and_density_take_the_library_route(tmp_path):
    img = np.full((40, 80), 255, np.uint8)
    img[:, :20] = 0
    path = tmp_path / "field.png"
    Image.fromarray(img).save(path)
    gray = np.asarray(Image.open(path), dtype=np.float64) / 255.0
    for flag, where in (("--mask", dict(mask=gray)), ("--density", dict(density=1.0 - gray))):
        out = tmp_path / f"{flag[2:]}.npz"
        assert cli.main(["poisson", "-n", "150", flag, str(path), "--seed", "3", "--backend",
                         "exact", "-q", "-o", str(out)]) == 0
        lib = tmp_path / f"{flag[2:]}.lib.npz"
        poisson_job(150, [str(lib)], seed=3, backend="exact", box=(1.0, 0.5), **where)
        assert out.read_bytes() == lib.read_bytes(), flag


def test_every_option_field_is_a_flag_with_the_field_default():
    parser = cli.build_parser()
    sub = parser._subparsers._group_actions[0].choices["poisson"]
    actions = {a.dest: a for a in sub._actions}
    for f in dataclasses.fields(PoissonOptions):
        if not f.metadata.get("cli"):
            continue
        assert f.name in actions, flag_name(f.name)
        assert actions[f.name].default == f.default, f.name
    args = parser.parse_args(["poisson", "-o", "x.npz"])
    from diskpack_cl.options import from_namespace
    assert from_namespace(PoissonOptions, args) == PoissonOptions()


def _summary(tmp_path, capsys, args):
    out = tmp_path / "s.npz"
    assert cli.main(["poisson", *args, "--backend", "exact", "--seed", "1", "--json", "-q",
                     "-o", str(out)]) == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_2d_and_3d_summaries_have_the_same_keys(tmp_path, capsys):
    two = _summary(tmp_path, capsys, ["-n", "100"])
    three = _summary(tmp_path, capsys, ["-n", "100", "--dim", "3"])
    assert set(two) == set(three)
    assert (two["dim"], three["dim"]) == (2, 3)
    assert two["rho_final"] >= 0.8 and three["rho_final"] >= 0.8
    assert two["rho_start"] < two["rho_final"]


def test_the_relax_summary_names_the_same_quantities_alike(tmp_path, capsys):
    start = tmp_path / "start.npy"
    np.save(start, np.random.default_rng(0).random((100, 2)))
    out = tmp_path / "r.npz"
    assert cli.main(["relax", str(start), "--backend", "exact", "--json", "-q", "-o",
                     str(out)]) == 0
    relax = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    poisson = _summary(tmp_path, capsys, ["-n", "100"])
    shared = {"n", "dim", "iterations", "rho_start", "rho_final", "eps", "stop_reason",
              "seconds", "backend", "device", "stage_seconds"}
    assert shared <= set(relax) and shared <= set(poisson)
