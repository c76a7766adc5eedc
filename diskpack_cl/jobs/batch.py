"""Batch jobs: folders of images and many point sets, resumable, in parallel, on Dask.

:func:`stipple_many`, :func:`poisson_many` and :func:`relax_many` plan the
three kinds of batch (items of :mod:`diskpack_cl.jobs.items`: one input image,
point file or seed, its parameters and its output paths, rendered from
templates) and return a :class:`Batch`. Iterating it runs the items with
:func:`diskpack_cl.jobs.executors.run_batch`: in this process, in ``jobs``
spawned worker processes, or on a ``dask.distributed`` cluster, one record
(a JSON-ready dict) per item as it finishes. Each item writes its outputs
atomically; then the coordinating process appends one line to the manifest
(``manifest.jsonl``). A rerun skips the items whose manifest line matches
and whose outputs exist.

Examples
--------
>>> import tempfile, os
>>> folder = tempfile.mkdtemp()
>>> records = list(poisson_many(3, 64, outputs=[os.path.join(folder, "{i:02d}.npz")],
...                             seed=7, backend="exact"))
>>> [r["status"] for r in records], sorted(os.listdir(folder))
(['ok', 'ok', 'ok'], ['00.npz', '01.npz', '02.npz', 'manifest.jsonl'])
>>> [r["status"] for r in poisson_many(3, 64, outputs=[os.path.join(folder, "{i:02d}.npz")],
...                                    seed=7, backend="exact")]
['skipped', 'skipped', 'skipped']
"""

from __future__ import annotations

from .executors import Manifest, default_manifest, run_batch
from .items import plan_poisson, plan_relax, plan_stipple

__all__ = ["Batch", "stipple_many", "poisson_many", "relax_many"]


class Batch:
    """Planned items; iterating runs them and yields their records as they finish.

    Attributes
    ----------
    items : list of Item
    manifest : str or None
    progress : callable or None
        ``progress(item, iteration, text)``, see :func:`~diskpack_cl.jobs.executors.run_batch`.

    Examples
    --------
    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> batch = poisson_many(2, 64, [os.path.join(out, "{i}.npz")], seed=1)
    >>> len(batch.items), [r["status"] for r in batch]
    (2, ['ok', 'ok'])
    """

    def __init__(self, items, outputs, manifest, **run):
        self.items = items
        self.manifest = (default_manifest(list(outputs)) if manifest is None
                         else manifest or None)
        self.progress = run.pop("progress", None)
        self._run = run

    def __len__(self):
        return len(self.items)

    def __iter__(self):
        return run_batch(self.items, manifest=self.manifest, progress=self.progress,
                         **self._run)


def stipple_many(inputs, outputs, options=None, *, n=None, density=None, dots_per_cm2=None,
                 recursive=False, allow_large=False, write=None, tone=None, color=None,
                 backend="auto", manifest=None,
                 overwrite=False, jobs=1, devices=None, client=None, collect=False,
                 progress=None, **overrides):
    """Stipple many images: a :class:`Batch` that yields one record per image as it finishes.

    Plans with :func:`~diskpack_cl.jobs.items.plan_stipple` now (every template and output is
    checked before any work) and runs with :func:`~diskpack_cl.jobs.executors.run_batch` when iterated.
    ``manifest`` defaults to ``manifest.jsonl`` in the folder of the first
    output template (``False``: none). ``jobs``, ``devices``, ``client``
    (a ``distributed.Client`` or a scheduler address), ``collect`` and
    ``progress`` are those of :func:`~diskpack_cl.jobs.executors.run_batch`.

    Examples
    --------
    >>> import tempfile, os
    >>> from diskpack_cl import sample_image_path
    >>> out = tempfile.mkdtemp()
    >>> recs = stipple_many([sample_image_path()], [os.path.join(out, "{stem}_{n}.npz")],
    ...                     density=400, schedule=[("pack", 1)])
    >>> [(r["status"], os.path.basename(r["outputs"][0])) for r in recs]
    [('ok', 'astronaut_105.npz')]
    """
    items = plan_stipple(inputs, outputs, options, n=n, density=density,
                         dots_per_cm2=dots_per_cm2, recursive=recursive,
                         allow_large=allow_large, write=write, tone=tone, color=color,
                         backend=backend, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)


def poisson_many(count, n, outputs, options=None, *, seed=None, manifest=None, overwrite=False,
                 jobs=1, devices=None, client=None,
                 collect=False, progress=None, **overrides):
    """Make ``count`` independent Poisson disk sets; yield records as they finish.

    Seeds come from ``numpy.random.SeedSequence(seed).spawn(count)``; each
    record's ``seed`` recreates its set alone. Without ``seed``, a rerun
    takes the seed of the run recorded in the manifest (else a fresh one). ``options`` (a
    :class:`~diskpack_cl.poisson.PoissonOptions`) and ``overrides``: see
    :func:`~diskpack_cl.jobs.items.plan_poisson`; and
    :func:`~diskpack_cl.jobs.executors.run_batch`; the module's example shows a run and its resume.

    Examples
    --------
    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> recs = list(poisson_many(2, 64, [os.path.join(out, "{i}.npz")], seed=1))
    >>> sorted(os.path.basename(r["outputs"][0]) for r in recs)
    ['0.npz', '1.npz']
    """
    if manifest is None:
        manifest = default_manifest(list(outputs))
    if seed is None and manifest and not overwrite:  # resume: the earlier run's seed
        seed = next((r["params"]["base_seed"] for r in reversed(Manifest(manifest).records())
                     if r.get("kind") == "poisson" and "base_seed" in r.get("params", {})),
                    None)
    items = plan_poisson(count, n, outputs, options, seed=seed, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)


def relax_many(inputs, outputs, relax=None, *, box=None, columns=None, manifest=None,
               overwrite=False, jobs=1, devices=None, client=None, collect=False, progress=None,
               **overrides):
    """Relax many point files; yield records as they finish (see :func:`~diskpack_cl.jobs.items.plan_relax`
    for ``box`` and ``columns``).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> folder = tempfile.mkdtemp(); np.save(os.path.join(folder, "a.npy"), np.random.default_rng(0).random((64, 2)))
    >>> recs = list(relax_many([os.path.join(folder, "a.npy")], [os.path.join(folder, "{stem}.npz")], eps=0.7))
    >>> [(r["status"], r["summary"]["rho_final"] >= 0.7) for r in recs]
    [('ok', True)]
    """
    items = plan_relax(inputs, outputs, relax, box=box, columns=columns, **overrides)
    return Batch(items, outputs, manifest, overwrite=overwrite, jobs=jobs,
                     devices=devices, client=client, collect=collect, progress=progress)
