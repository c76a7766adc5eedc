"""Batch mode (several inputs, a folder, a template, a batch option): where items run, the report."""

from __future__ import annotations

import json
import os
import sys
import time

from diskpack_cl.extras import install_command
from diskpack_cl.io import json_default

from ._common import PROG, UsageError, terminal_bar, positive_int


#: The options of the batch group (:func:`batch_options`): any of them makes a batch.
BATCH_OPTIONS = ("jobs", "manifest", "overwrite", "scheduler", "collect", "count")

#: The rule, as ``--help`` states it.
BATCH_RULE = ("A command is a batch when it has several inputs, a folder, an output template "
              "({...}) or any option of this group; otherwise its one input runs in this process, "
              "with no manifest.")


def batch_options(p):
    g = p.add_argument_group(
        "batch",
        BATCH_RULE + " Output templates: {stem} {name} {parent} (of the input), {n}, {seed}, "
        "{i} (item index, e.g. {i:04d}). Each item writes its outputs atomically, then one "
        "line of the manifest; a rerun of the same command skips the items done.")
    g.add_argument("--jobs", "-j", type=positive_int, default=None, metavar="N",
                   help="worker processes (spawned; PoCL threads per worker capped to "
                        "cores/N; default: one per --device listed (--device A,B), else one "
                        "per core)")
    g.add_argument("--manifest", default=None, metavar="PATH",
                   help="manifest file (default: manifest.jsonl in the folder of the first -o)")
    g.add_argument("--overwrite", action="store_true",
                   help="redo every item, also those the manifest records as done")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="send the items to this dask.distributed scheduler (default: "
                        "DASK_SCHEDULER_ADDRESS when set); needs "
                        + install_command("dask"))
    g.add_argument("--collect", action="store_true",
                   help="with --scheduler: workers return the outputs' bytes and this "
                        "command writes them (no shared output folder needed)")
    return g


def batch_mode(args, inputs, outputs):
    """Whether the command is a batch (:data:`BATCH_RULE`).

    Raises UsageError for a batch with --verify or --profile, which apply
    to one input, and for a device list (``--device A,B``, the workers'
    devices) without a batch.
    """
    batch = (len(inputs) > 1 or any(os.path.isdir(x) for x in inputs)
             or any("{" in str(o) for o in outputs)
             or any(getattr(args, k, None) for k in BATCH_OPTIONS))
    single = [f"--{k}" for k in ("verify", "profile") if getattr(args, k, False)]
    if batch and single:
        verb = "apply" if len(single) > 1 else "applies"
        raise UsageError(f"{' and '.join(single)} {verb} to one input; this command is a batch "
                          "(several inputs, a folder, a template or a batch option)")
    if not batch and "," in (args.device or ""):
        raise UsageError(f"--device {args.device}: a device list is for the workers of a batch; "
                          "one input runs on one device")
    return batch


def batch_run(args):
    """Keyword arguments of the batch functions for where and how items run."""
    devices = [d.strip() for d in args.device.split(",") if d.strip()] if args.device else None
    scheduler = args.scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    if args.collect and scheduler is None:
        raise ValueError("--collect is for a Dask cluster: give --scheduler ADDRESS too")
    if scheduler is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            from diskpack_cl.jobs.executors import DASK_HINT  # not loaded at start-up

            raise ValueError(f"--scheduler: {DASK_HINT}") from None
    from diskpack_cl.jobs.executors import default_jobs  # not loaded at start-up

    return dict(manifest=args.manifest, overwrite=args.overwrite, devices=devices,
                jobs=args.jobs or default_jobs(devices), client=scheduler,
                collect=args.collect)


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP during a batch."""


def raise_terminated(signum, frame):
    raise Terminated(signum)


def report_batch(args, batch):
    """Run a planned batch with a progress bar / log lines / JSON; the exit status.

    :func:`main` turns SIGTERM and SIGHUP into :class:`Terminated`; an
    interrupted batch says how far it came and how to resume.
    """
    total = len(batch)
    bar = terminal_bar(args, args.command, "item", total, leave=True)
    counts = {"ok": 0, "failed": 0, "skipped": 0}
    failures = []
    t0 = time.perf_counter()

    def tally():
        return f"ok {counts['ok']} failed {counts['failed']} skipped {counts['skipped']}"

    def on_iteration(item, iteration, text):
        bar.set_postfix_str(f"{tally()} | {os.path.basename(item.input or item.outputs[0])} "
                            f"it {iteration} {text}")

    if bar is not None:
        batch.progress = on_iteration
    try:
        for rec in batch:
            counts[rec["status"]] += 1
            name = rec.get("input") or rec["outputs"][0]
            if rec["status"] == "failed":
                failures.append({"input": name, "error": rec.get("error")})
            if args.json:
                print(json.dumps(rec, default=json_default), flush=True)
            if bar is not None:
                bar.set_postfix_str(tally(), refresh=False)
                bar.update(1)
            elif not args.quiet:
                done = sum(counts.values())
                took = f" ({rec['seconds']:.3g} s)" if rec["status"] != "skipped" else ""
                error = f": {rec['error']}" if rec["status"] == "failed" else ""
                print(f"{PROG}: [{done}/{total}] {rec['status']} {name}{took}{error}",
                      file=sys.stderr, flush=True)
    except KeyboardInterrupt as exc:
        if bar is not None:
            bar.close()
        done = sum(counts.values())
        kept = (f"the finished ones are in {batch.manifest}" if batch.manifest
                and os.path.exists(batch.manifest) else "none had finished")
        print(f"{PROG}: error: interrupted after {done} of {total} items; {kept}: rerun the "
              f"same command to resume", file=sys.stderr)
        return 128 + exc.args[0] if isinstance(exc, Terminated) else 130
    if bar is not None:
        bar.close()
    seconds = time.perf_counter() - t0
    ran = counts["ok"] + counts["failed"]
    summary = {"summary": True, "items": total, **counts, "seconds": seconds,
               "items_per_minute": 60.0 * ran / seconds if ran and seconds > 0 else None,
               "manifest": batch.manifest, "failures": failures}
    if args.json:
        print(json.dumps(summary), flush=True)
    if not args.quiet:
        print(f"{PROG}: {counts['ok']} done, {counts['failed']} failed, {counts['skipped']} "
              f"skipped (already done) of {total} in {seconds:.3g} s; manifest "
              f"{batch.manifest}", file=sys.stderr)
        for f in failures:
            print(f"{PROG}: failed: {f['error']}", file=sys.stderr)
    return 1 if failures else 0
