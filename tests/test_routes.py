"""One route per job: a colour stippling and a relaxation give the same bytes through the
command line, a batch item and the library's plan (the Poisson jobs: test_poisson_route.py)."""

from pathlib import Path

import numpy as np
from PIL import Image

from diskpack_cl import cli
from diskpack_cl.jobs.batch import relax_many, stipple_many
from diskpack_cl.pens import ColorOptions
from diskpack_cl.jobs.items import plan_relax, plan_stipple, relax_item, run_job
from diskpack_cl.schedule import StippleOptions

DATA = Path(__file__).parent / "data"
ROUNDS = ["--beta", "2", "--lloyd", "0", "--rounds", "1", "--seed", "4"]


def _bytes(folder):
    return {p.name: p.read_bytes() for p in sorted(Path(folder).iterdir())
            if p.name != "manifest.jsonl"}


def test_a_colour_stippling_is_the_same_through_every_door(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    Image.open(DATA / "coffee.png").convert("RGB").resize((48, 40)).save(src / "coffee.png")
    image = str(src / "coffee.png")
    for door in ("cli", "batch", "library"):
        (tmp_path / door).mkdir()
    outputs = ["npz", "svg"]
    argv = ["stipple", image, "-n", "120", "--colors", "cmy", *ROUNDS, "-q"]
    assert cli.main([*argv, *sum((["-o", str(tmp_path / "cli" / f"coffee.{e}")]
                                  for e in outputs), [])]) == 0
    options = StippleOptions(beta=2.0, lloyd=0, rounds=1, seed=4)
    templates = [str(tmp_path / "batch" / f"{{stem}}.{e}") for e in outputs]
    color = ColorOptions(colors="cmy")
    records = list(stipple_many([str(src)], templates, options, n=120, color=color, jobs=1))
    assert [r["status"] for r in records] == ["ok"]
    item, = plan_stipple([image], [str(tmp_path / "library" / f"coffee.{e}") for e in outputs],
                         options, n=120, color=color)
    run_job(item)
    assert _bytes(tmp_path / "cli") == _bytes(tmp_path / "batch") == _bytes(tmp_path / "library")


def test_a_relaxation_is_the_same_through_every_door(tmp_path):
    start = tmp_path / "start.npy"
    np.save(start, np.random.default_rng(2).random((150, 2)))
    for door in ("cli", "batch", "library"):
        (tmp_path / door).mkdir()
    assert cli.main(["relax", str(start), "--eps", "0.75", "--backend", "exact", "-q", "-o",
                     str(tmp_path / "cli" / "start.npz")]) == 0
    records = list(relax_many([str(start)], [str(tmp_path / "batch" / "{stem}.npz")],
                              eps=0.75, backend="exact", jobs=1))
    assert [r["status"] for r in records] == ["ok"]
    item, = plan_relax([str(start)], [str(tmp_path / "library" / "start.npz")], eps=0.75,
                       backend="exact")
    relax_item(item)
    assert _bytes(tmp_path / "cli") == _bytes(tmp_path / "batch") == _bytes(tmp_path / "library")
