"""The ``diskpack`` command's entry point, outside the package on purpose.

Importing :mod:`diskpack_cl` takes a few seconds (numpy, scipy, pyopencl);
a Ctrl-C in that time would end in a ``KeyboardInterrupt`` traceback if the
entry point lived in the package. Here the import itself is guarded, so
Ctrl-C at any moment ends with one line and status 130, as
:func:`diskpack_cl.cli.main` does once it runs.
"""

import sys


def main():
    """Import and run :func:`diskpack_cl.cli.main`; 130 on Ctrl-C while importing."""
    try:
        from diskpack_cl.cli import main as run
    except KeyboardInterrupt:
        print("diskpack: error: interrupted, nothing written", file=sys.stderr)
        return 130
    return run()
