"""``diskpack devices``: list the OpenCL platforms and devices; ``--check`` their known answers."""

from __future__ import annotations

import argparse

from ._common import device_options
from ._help import with_examples


def add_devices(subparsers):
    p = subparsers.add_parser(
        "devices", help="list OpenCL platforms and devices; --check: which programs each runs",
        description=with_examples(
            "List OpenCL platforms (with their version and where their driver comes from) and "
            "devices, and say which one diskpack would use. With --check, run the chosen "
            "device's known-answer checks (or read their cached verdict) and print, per "
            "program, whether the device gave the host's answers.",
            ["diskpack devices", "diskpack devices --check",
             "diskpack devices --check --recheck --device cpu"]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    device_options(p)
    p.add_argument("--check", action="store_true",
                   help="print the device's known-answer verdicts (run now where none is cached)")
    p.add_argument("--recheck", action="store_true",
                   help="with --check: run the checks again even where a verdict is cached")
    p.set_defaults(run=_run_devices)


def _run_devices(args):
    from diskpack_cl import describe, get_context, list_devices, list_platforms  # not loaded at start-up

    print("platforms:")
    for index, name, version, origin in list_platforms():
        print(f"{index:>5}  {name}  |  {version}\n         from {origin}")
    rows = list_devices()
    print("devices:")
    for index, platform, device, kind in rows:
        print(f"{index:>5}  {platform}  |  {device}  [{kind}]")
    if not rows:
        print("(no OpenCL devices)")
    if args.check:
        from diskpack_cl.device.checks import check_table  # not loaded at start-up
        from diskpack_cl.device.known_answers import check_device  # not loaded at start-up

        print("\n".join(check_table(check_device(args.device, refresh=args.recheck))))
    ctx = get_context(args.device)
    print(f"using: {describe(ctx)}, {ctx.devices[0].platform.version.strip()}")
    return 0
