"""``diskpack devices``: list the OpenCL platforms and devices."""

from __future__ import annotations


from ._common import _device_options


def _add_devices(subparsers):
    p = subparsers.add_parser("devices", help="list OpenCL platforms and devices",
                              description="List OpenCL platforms and devices and say which "
                                          "one diskpack would use.")
    _device_options(p)
    p.set_defaults(run=_run_devices)


def _run_devices(args):
    from diskpack_cl import describe, get_context, list_devices  # not loaded at start-up

    rows = list_devices()
    for index, platform, device, kind in rows:
        print(f"{index:>5}  {platform}  |  {device}  [{kind}]")
    if not rows:
        print("(no OpenCL devices)")
    print(f"using: {describe(get_context(args.device))}")
    return 0
