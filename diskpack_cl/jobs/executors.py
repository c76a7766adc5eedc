"""Running many items: here, in spawned worker processes or on a Dask cluster, resumable.

:func:`run_batch` runs items (:class:`~diskpack_cl.jobs.items.Item`, planned by
:mod:`diskpack_cl.jobs.items`) in this process, in ``jobs`` spawned worker
processes, or on a ``dask.distributed`` cluster, and yields one record (a
JSON-ready dict, :func:`run_item`) per item as it finishes. Each item writes
its outputs atomically; then the coordinating process appends one line to
the :class:`Manifest` (``manifest.jsonl``). A rerun skips the items whose
manifest line matches and whose outputs exist (the example of :func:`run_batch`).
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import multiprocessing
import os
import platform
import signal
import sys
import tempfile
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, as_completed, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import replace
from pathlib import Path

from .._cores import usable_cores
from ..extras import install_command
from ..io import atomic_write, atomic_writes, remove_partial_files
from ..io import json_default
from .items import run_job

__all__ = [
    "POCL_THREAD_VARS", "DASK_HINT", "MANIFEST_NAME", "Manifest", "default_manifest",
    "default_jobs", "run_item", "run_batch", "map_tasks",
]


POCL_THREAD_VARS = ("POCL_MAX_PTHREAD_COUNT", "POCL_CPU_MAX_CU_NUM")
"""PoCL's CPU thread count: ``POCL_MAX_PTHREAD_COUNT`` up to PoCL 3 (the
pip build: its device then reports that many compute units),
``POCL_CPU_MAX_CU_NUM`` in later releases. Both are set for each worker."""


DASK_HINT = "the Dask path needs the dask extra: " + install_command("dask")


MANIFEST_NAME = "manifest.jsonl"


# ------------------------------------------------------------- manifest


def default_manifest(templates):
    """``manifest.jsonl`` in the folder of the first output template.

    A folder part with template fields is cut at the first of them.

    Examples
    --------
    >>> default_manifest(["out/{parent}/{stem}.svg"])
    'out/manifest.jsonl'
    >>> default_manifest(["{stem}.png"])
    'manifest.jsonl'
    """
    parts = []
    for part in Path(os.path.dirname(templates[0])).parts:
        if "{" in part:
            break
        parts.append(part)
    return os.path.join(*parts, MANIFEST_NAME)


class Manifest:
    """An append-only JSON-lines record of finished items.

    Each line is written with one ``os.write`` on an ``O_APPEND`` descriptor
    and synced, so a killed run leaves only whole lines (a line torn by a
    power cut is ignored when read).

    Examples
    --------
    >>> import tempfile, os
    >>> m = Manifest(os.path.join(tempfile.mkdtemp(), "manifest.jsonl"))
    >>> m.append({"outputs": ["a.npz"], "status": "ok"})
    >>> m.records()
    [{'outputs': ['a.npz'], 'status': 'ok'}]
    """

    def __init__(self, path):
        self.path = os.fspath(path)

    def records(self):
        """Every whole line of the manifest, oldest first."""
        try:
            with open(self.path, "rb") as fh:
                lines = fh.read().split(b"\n")
        except FileNotFoundError:
            return []
        out = []
        for line in lines:
            with contextlib.suppress(ValueError):
                record = json.loads(line)
                if isinstance(record, dict):
                    out.append(record)
        return out

    def finished(self):
        """The latest record per output set: ``{tuple(outputs): record}``."""
        return {tuple(r.get("outputs") or ()): r for r in self.records()}

    def append(self, record):
        """Append one record as one line, atomically with respect to other lines."""
        data = (json.dumps(record, default=json_default) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)


def _is_done(item, record):
    if record is None or record.get("status") != "ok":
        return False
    ident = item.identity()
    if any(record.get(k) != v for k, v in ident.items()):
        return False
    return all(os.path.exists(p) for p in item.outputs)


# --------------------------------------------------- one item, recorded


def default_jobs(devices=None):
    """Worker processes when ``jobs`` is not given: one per listed device, else one per core.

    On the 2-core development VM two workers (one PoCL thread each) stippled
    24.4 images a minute at n = 20000, one process with two threads 12.7
    (README, "Performance").

    Examples
    --------
    >>> default_jobs(["0:0", "0:1", "1:0"])
    3
    """
    if devices:
        return len(devices)
    return usable_cores()


def peak_rss_mib():
    try:
        import resource  # POSIX only: elsewhere no peak RSS
    except ImportError:  # pragma: no cover - not POSIX
        return None
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(rss / (1 << 20 if sys.platform == "darwin" else 1 << 10), 1)


def run_item(item, *, device=None, collect=False, progress=None):
    """Run one item and return its record; a failure is recorded, not raised.

    Parameters
    ----------
    item : Item
    device : str, optional
        OpenCL device (default: ``DISKPACK_DEVICE``, then the usual choice).
    collect : bool
        Write the outputs in a temporary folder and return their bytes under
        ``"data"`` (``{path: bytes}``) for the caller to write (Dask
        ``--collect``), instead of writing them in place.
    progress : callable, optional
        ``progress(iteration, text)`` after each iteration.

    Returns
    -------
    dict
        The item's identity plus ``status`` (``"ok"`` or ``"failed"``),
        ``error``, ``summary``, ``certificate``, ``seconds``, ``worker``
        (host and process id), ``peak_rss_mib`` of the process so far and
        ``worker_env`` (the PoCL thread cap and ``DISKPACK_DEVICE``, if set).

    Examples
    --------
    >>> from diskpack_cl.jobs.items import Item
    >>> rec = run_item(Item("relax", 0, "missing.npz", None, {}, ("out.npz",)))
    >>> rec["status"], rec["error"]
    ('failed', 'missing.npz: no such file')
    """
    t0 = time.perf_counter()
    record = {"i": item.i, **item.identity(), "status": "failed", "error": item.error}
    if item.error is None:
        try:
            with tempfile.TemporaryDirectory(prefix="diskpack-collect-") if collect \
                    else contextlib.nullcontext() as tmp:
                run = item
                if collect:
                    run = replace(item, outputs=tuple(
                        os.path.join(tmp, f"{k}-{os.path.basename(p)}")
                        for k, p in enumerate(item.outputs)))
                summary = run_job(run, device=device, progress=progress)
                if collect:
                    record["data"] = {}
                    for out, tmp_out in zip(item.outputs, run.outputs):
                        with open(tmp_out, "rb") as fh:
                            record["data"][out] = fh.read()
                    for f in summary.get("files", ()):
                        f["path"] = item.outputs[run.outputs.index(f["path"])]
            record.update(status="ok", summary=summary,
                          certificate=summary.pop("certificate", None))
        except Exception as exc:  # recorded, the batch goes on
            record["error"] = _error_text(item, exc)
    record.update(seconds=time.perf_counter() - t0, finished=time.time(),
                  worker=f"{platform.node()}:{os.getpid()}", peak_rss_mib=peak_rss_mib(),
                  worker_env={k: os.environ[k] for k in (*POCL_THREAD_VARS, "DISKPACK_DEVICE")
                              if k in os.environ})
    return record


def _error_text(item, exc):
    text = str(exc) or type(exc).__name__
    if not isinstance(exc, (ValueError, FileNotFoundError, OSError)):
        text = f"{type(exc).__name__}: {text}"
    if item.input is not None and item.input not in text:
        text = f"{item.input}: {text}"
    return text


# ------------------------------------------------------------ executors


def _ignore_interrupts_and_exit_on_term():
    """Worker signals: Ctrl-C is the coordinator's; SIGTERM ends cleanly (no .part files)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_first_term)


def _exit_on_first_term(*_):
    """SystemExit(143), once: a second SIGTERM (the pool terminates its other workers
    when one exits) must not interrupt the removal of the partial files."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.exit(143)


def _init_worker(slots, devices, threads, parent, ready):
    _die_with(parent)
    slot = slots.get()
    if threads:
        for var in POCL_THREAD_VARS:
            os.environ.setdefault(var, str(threads))
    if devices:
        os.environ["DISKPACK_DEVICE"] = devices[slot % len(devices)]
    _ignore_interrupts_and_exit_on_term()
    with ready.get_lock():
        ready.value += 1


#: Linux's prctl option that sends this process a signal when its parent ends.
PR_SET_PDEATHSIG = 1
#: Seconds between a worker's looks at its parent, and from the parent's end (and the
#: SIGTERM then sent) to the worker's forced exit.
PARENT_POLL_S, PARENT_GONE_GRACE_S = 0.5, 10.0


def _die_with(parent):
    """End this worker when its coordinator (process id `parent`) ends, however it ends.

    A SIGKILLed coordinator runs no cleanup, and the workers' queues do not
    close (each worker holds both ends of them), so without this they lived
    on, holding memory and the caller's stderr. Linux sends SIGTERM at the
    parent's death (``PR_SET_PDEATHSIG``, which removes the partial files);
    a thread watching the parent process id does it elsewhere, and ends a
    worker that the SIGTERM did not end.
    """
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    if os.getppid() != parent:   # it ended before the request above could see it
        os._exit(143)
    threading.Thread(target=_watch_parent, args=(parent,), name="diskpack-parent-watch",
                     daemon=True).start()


def _watch_parent(parent):
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(PARENT_GONE_GRACE_S)
    os._exit(143)


def _run_in_worker(item, collect):
    try:
        return run_item(item, collect=collect)
    except SystemExit:  # SIGTERM: the partial files are removed on the way here
        os._exit(143)


def _failed(item, error):
    return {"i": item.i, **item.identity(), "status": "failed", "error": error,
            "finished": time.time()}


class _WorkerPool(ProcessPoolExecutor):
    """A process pool whose workers start with Ctrl-C ignored and end with their coordinator.

    A Ctrl-C sent to the terminal's process group reaches the workers too;
    one that arrives while a worker imports (before its initializer ignores
    it) printed a KeyboardInterrupt traceback there. A process started while
    SIGINT is ignored keeps it ignored, through ``exec``, from its first
    instruction; the coordinator answers Ctrl-C for all of them.
    """

    def __init__(self, jobs, devices):
        ctx = multiprocessing.get_context("spawn")  # OpenCL does not survive fork
        slots = ctx.Queue()
        for k in range(jobs):
            slots.put(k)
        #: Workers whose initializer finished (see :meth:`died_starting`).
        self.ready = ctx.Value("i", 0)
        threads = max(1, default_jobs() // jobs)
        super().__init__(max_workers=jobs, mp_context=ctx, initializer=_init_worker,
                         initargs=(slots, devices, threads, os.getpid(), self.ready))

    def _spawn_process(self):
        if threading.current_thread() is not threading.main_thread() \
                or not hasattr(signal, "pthread_sigmask"):
            return super()._spawn_process()   # signal handlers belong to the main thread
        # While SIGINT is ignored (the worker inherits that) it is blocked too, so that a
        # Ctrl-C then waits instead of being dropped; one already waiting is taken and sent
        # again after, as ignoring a waiting signal drops it. SIGTERM is let through: the
        # worker inherits the mask, and the pool stops it with SIGTERM.
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        waiting = signal.SIGINT in signal.sigpending()
        if waiting:
            signal.sigwait({signal.SIGINT})
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM, signal.SIGHUP})
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            super()._spawn_process()
        finally:
            signal.signal(signal.SIGINT, old)
            if waiting:
                signal.pthread_kill(threading.get_ident(), signal.SIGINT)
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)

    def died_starting(self):
        """Whether the workers died before any of them was ready (their start failed)."""
        return self.ready.value == 0

    def submit_all(self, fn, argss):
        """``{future: k}`` for ``fn(*argss[k])``, submitted with signals deferred.

        Ctrl-C, SIGTERM or SIGHUP while the pool starts (it spawns a worker
        and starts its manager thread in ``submit``) left it half made: its
        shutdown then raised "cannot join thread before it is started". Such
        a signal is answered once every task is submitted.
        """
        with _signals_deferred():
            return {self.submit(fn, *args): k for k, args in enumerate(argss)}


@contextlib.contextmanager
def _signals_deferred():
    """SIGINT, SIGTERM and SIGHUP that arrive in the block are answered after it.

    They are blocked in this thread and in the threads it starts (the pool's),
    and recorded where another thread takes them: while a worker is spawned
    SIGINT is ignored, and a Ctrl-C taken then was lost.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []
    sigs = [s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None))
            if s is not None and callable(signal.getsignal(s))]
    old = {s: signal.signal(s, lambda num, frame: got.append(num)) for s in sigs}
    posix = hasattr(signal, "pthread_sigmask")
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, sigs) if posix else None
    try:
        yield
    finally:
        for s in reversed(sigs):   # SIGINT last: one answered now finds the others restored
            signal.signal(s, old[s])
        if posix:   # a pending one is answered here
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if got:
            old[got[0]](got[0], None)


def _spawn_pool(jobs, devices):
    """``jobs`` spawned worker processes, PoCL threads capped to ``cores // jobs``, one
    device of `devices` each (:class:`_WorkerPool`)."""
    return _WorkerPool(jobs, devices)


#: What a worker that died while it started most often means, and the fix.
MAIN_GUARD_HINT = ("spawned workers import the main script again: a script that runs "
                   "a batch or tiles with jobs > 1 must put its code under "
                   "'if __name__ == \"__main__\":'")


def _death_text(pool, exc):
    """Why a worker of `pool` died (`exc`, a BrokenProcessPool), with the likely cause."""
    if not pool.died_starting():
        return f"worker process died: {exc}"
    main = getattr(sys.modules.get("__main__"), "__file__", None)
    cause = f"; {MAIN_GUARD_HINT} ({main})" if main else ""
    return f"worker process died while it started, before it ran anything{cause}"


def _local_pool(todo, jobs, devices, collect):
    """Yield records from ``jobs`` spawned worker processes."""
    pool, unfinished = _spawn_pool(jobs, devices), set(range(len(todo)))
    try:
        futures = pool.submit_all(_run_in_worker, [(item, collect) for item in todo])
        for fut in as_completed(futures):
            unfinished.discard(futures[fut])
            try:
                yield fut.result()
            except BrokenProcessPool as exc:
                yield _failed(todo[futures[fut]], _death_text(pool, exc))
    finally:
        if _close(pool):   # a killed worker could not remove its partial files
            for i in unfinished:
                for out in todo[i].outputs:
                    remove_partial_files(out)


#: Seconds the stopped workers get to remove their partial files before they are killed.
STOP_GRACE_S = 5.0


def _stop_workers(pool):
    """Send SIGTERM to the pool's workers (they remove their partial files and exit), and
    SIGKILL to those still there after :data:`STOP_GRACE_S`: a worker can hang in its exit,
    joining a queue thread that writes to a pipe nobody reads, and the pool's shutdown
    waits for every worker. True if one had to be killed."""
    procs = list((pool._processes or {}).values())
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    end, killed = time.monotonic() + STOP_GRACE_S, False
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(max(0.0, end - time.monotonic()))
            if proc.is_alive():
                proc.kill()
                killed = True
    return killed


def _close(pool):
    """Stop the workers of `pool` (:func:`_stop_workers`; first: shutdown forgets them), then
    shut it down, its manager thread released if a worker died halfway through a result.
    True if a worker had to be killed."""
    killed = _stop_workers(pool)
    manager, results = pool._executor_manager_thread, pool._result_queue
    pool.shutdown(wait=False, cancel_futures=True)
    if manager is not None:
        _release(manager, results)
    return killed


def _release(manager, results):
    """Wait for the pool's `manager` thread; if a stopped worker died halfway through
    sending its result, send it bytes that complete the message and do not unpickle.

    The manager waits for the rest of that message, which no live process can
    send; the pool's shutdown and the interpreter's exit both wait for the
    manager (a tiled run interrupted with Ctrl-C hung there). A message that
    does not unpickle makes it mark the pool broken and end.
    """
    manager.join(STOP_GRACE_S)
    if manager.is_alive():
        fd = results._writer.fileno()
        os.set_blocking(fd, False)   # no process reads what the manager does not take
        while manager.is_alive():
            with contextlib.suppress(BlockingIOError, BrokenPipeError):
                os.write(fd, b"\0" * 65536)
            manager.join(0.05)
    results.close()


def _dask_client(client):
    try:
        import distributed  # the optional dask extra, loaded only for a cluster
    except ImportError:
        raise ImportError(DASK_HINT) from None
    if isinstance(client, distributed.Client):
        return client, False
    return distributed.Client(client), True


def _dask(todo, client, device, collect):
    """Yield records from the items sent to a ``dask.distributed`` cluster."""
    from distributed import as_completed  # the optional dask extra, loaded only for a cluster

    client, own = _dask_client(client)
    futures = {}
    try:
        for item in todo:
            fut = client.submit(run_item, item, device=device, collect=collect, pure=False,
                                key=f"diskpack-{item.kind}-{item.i}-{os.getpid()}-{time.time_ns()}")
            futures[fut] = item
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except Exception as exc:  # the worker died or the cluster lost the task
                yield _failed(futures[fut], f"Dask task failed: {type(exc).__name__}: {exc}")
    finally:
        client.cancel(list(futures))
        if own:
            client.close()


# ------------------------------------------------- tasks of one large job


def map_tasks(fn, tasks, *, jobs=1, devices=None, client=None, retries=2):
    """Yield ``(index, fn(task))`` for each task as it finishes: here, in workers or on Dask.

    The parts of one job (the tiles of :func:`diskpack_cl.jobs.tiles.stipple_tiled`)
    run where the items of a batch run (:func:`run_batch`). A task that
    raises, or whose worker process dies, runs again, up to `retries` more
    times; then its last error is raised.

    Parameters
    ----------
    fn : callable
        A module-level function (it is sent to the workers).
    tasks : list
        Its arguments, one per call.
    jobs, devices, client
        As for :func:`run_batch`.
    retries : int
        Further tries of a failed task.

    Examples
    --------
    >>> sorted(map_tasks(abs, [-2, 3]))
    [(0, 2), (1, 3)]
    """
    if client is not None:
        yield from _dask_map(fn, tasks, client, retries)
    elif jobs > 1 and len(tasks) > 1:
        yield from _pool_map(fn, tasks, min(jobs, len(tasks)), devices, retries)
    else:
        for i, task in enumerate(tasks):
            for attempt in range(retries + 1):
                try:
                    result = fn(task)
                    break
                except Exception:
                    if attempt == retries:
                        raise
            yield i, result


def _call_in_worker(fn, task):
    try:
        return fn(task)
    except SystemExit:  # SIGTERM
        os._exit(143)


def _pool_map(fn, tasks, jobs, devices, retries):
    """:func:`map_tasks` on spawned workers; a pool whose worker died is replaced."""
    failures = [0] * len(tasks)
    left = set(range(len(tasks)))
    while left:
        pool = _spawn_pool(jobs, devices)
        try:
            order = sorted(left)
            pending = {fut: order[k] for fut, k in
                       pool.submit_all(_call_in_worker, [(fn, tasks[i]) for i in order]).items()}
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    i = pending.pop(fut)
                    try:
                        result = fut.result()
                    except Exception as exc:
                        failures[i] += 1
                        if failures[i] > retries:
                            if isinstance(exc, BrokenProcessPool):
                                raise BrokenProcessPool(_death_text(pool, exc)) from exc
                            raise
                        if not isinstance(exc, BrokenProcessPool):   # else: a new pool
                            pending[pool.submit(_call_in_worker, fn, tasks[i])] = i
                        continue
                    left.discard(i)
                    yield i, result
        finally:
            _close(pool)


def _dask_map(fn, tasks, client, retries):
    """:func:`map_tasks` on a ``dask.distributed`` cluster (its own retries)."""
    from distributed import as_completed  # the optional dask extra, loaded only for a cluster

    client, own = _dask_client(client)
    stamp = f"{os.getpid()}-{time.time_ns()}"
    futures = {client.submit(fn, task, retries=retries, pure=False,
                             key=f"diskpack-task-{i}-{stamp}"): i for i, task in enumerate(tasks)}
    try:
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
    finally:
        client.cancel(list(futures))
        if own:
            client.close()


def _write_collected(record):
    """Write the bytes a worker returned (``collect``), atomically; the record updated."""
    data = record.pop("data", None)
    if not data:
        return record
    try:
        with atomic_writes():
            for path, blob in data.items():
                with atomic_write(path, "wb") as fh:
                    fh.write(blob)
    except OSError as exc:
        record.update(status="failed", error=f"writing {path}: {exc}")
    return record


def run_batch(items, *, manifest=None, overwrite=False, jobs=1, devices=None, client=None,
              collect=False, progress=None):
    """Run items and yield one record per item, as each finishes.

    Items whose manifest line matches (same input size and time, parameters,
    seed and outputs, status ok) and whose outputs exist are yielded with
    status ``"skipped"`` and get no new line. Every other item runs and its
    record is appended to the manifest, by this process only.

    Parameters
    ----------
    items : list of Item
    manifest : str, optional
        Manifest path; None: no manifest (nothing is skipped).
    overwrite : bool
        Redo every item.
    jobs : int
        1: run in this process; more: that many spawned worker processes,
        each with its own OpenCL context, PoCL capped at ``cores // jobs``
        threads (:data:`POCL_THREAD_VARS`), and with ``devices`` one device
        per worker (through ``DISKPACK_DEVICE``).
    devices : list of str, optional
        OpenCL devices (``jobs == 1`` or Dask: the first is used).
    client : distributed.Client or str, optional
        Send the items to this Dask cluster (a client or a scheduler
        address) instead; ``jobs`` is then not used.
    collect : bool
        With Dask: workers return the outputs' bytes and this process writes
        them (for workers without the shared output folder).
    progress : callable, optional
        ``progress(item, iteration, text)`` during an item, in this process
        only (``jobs == 1`` without Dask).

    Yields
    ------
    dict
        The record (see :func:`run_item`); ``"skipped"`` ones hold the
        identity and the earlier record's ``summary``.

    Examples
    --------
    >>> import os, tempfile
    >>> from diskpack_cl.jobs.items import plan_poisson
    >>> out = tempfile.mkdtemp()
    >>> items = plan_poisson(2, 64, [os.path.join(out, "{i}.npz")], seed=1)
    >>> manifest = os.path.join(out, "manifest.jsonl")
    >>> [r["status"] for r in run_batch(items, manifest=manifest)]
    ['ok', 'ok']
    >>> [r["status"] for r in run_batch(items, manifest=manifest)]   # done already
    ['skipped', 'skipped']
    """
    man = Manifest(manifest) if manifest is not None else None
    folder = os.path.dirname(manifest or "")
    if folder and not os.path.isdir(folder):
        raise FileNotFoundError(f"the manifest's folder does not exist: {folder}")
    finished = {} if (man is None or overwrite) else man.finished()
    todo = []
    for item in items:
        old = finished.get(tuple(item.outputs))
        if _is_done(item, old):
            yield {**old, "status": "skipped"}
        else:
            todo.append(item)
    if client is not None:
        source = _dask(todo, client, devices[0] if devices else None, collect)
    elif jobs > 1 and len(todo) > 1:
        source = _local_pool(todo, min(jobs, len(todo)), devices, collect)
    else:
        source = (run_item(item, device=devices[0] if devices else None, collect=collect,
                           progress=None if progress is None
                           else (lambda it, text, item=item: progress(item, it, text)))
                  for item in todo)
    with contextlib.closing(source):
        for record in source:
            record = _write_collected(record)
            if man is not None:
                man.append(record)
            yield record
