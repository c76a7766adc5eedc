"""Command line interface: ``diskpack <subcommand> ...``.

One module per subcommand (``devices``, ``poisson``, ``relax``, ``stipple``,
``export``, ``analyze``), each thin: it parses arguments, reads and writes
files and calls the public Python API. Heavy modules are imported inside the
subcommand functions, so ``diskpack --help`` stays fast.

Adding a subcommand means adding a module with two functions,
``add_NAME(subparsers)`` (creates the parser with
``subparsers.add_parser("NAME", ...)`` and calls
``parser.set_defaults(run=_run_NAME)``) and ``_run_NAME(args) -> int``, and
listing ``NAME`` in :data:`_SUBCOMMANDS`.

Raise ``ValueError``/``OSError`` for user errors: :func:`main` prints
``diskpack: error: ...`` and returns 1 (2 for a usage error or an
:class:`~diskpack_cl.options.OptionConflict`, 130 on Ctrl-C, 143 on SIGTERM,
129 on SIGHUP). Check outputs with :func:`diskpack_cl.io.check_writable`
before the work and write them with the atomic writers of
:mod:`diskpack_cl.io` after it, all in one :func:`diskpack_cl.io.atomic_writes`,
so that a failed or interrupted run writes no output and leaves every earlier
file as it was.
"""

from __future__ import annotations

import importlib
import os
import sys
import signal
import threading

from ._batches import raise_terminated, Terminated
from ._common import (PROG, HelpFormatter, Parser, UsageError, open_closed_streams,
                      show_device_notes)
from ._help import LEADING, one_line_help
from diskpack_cl import __version__
from diskpack_cl.io import OutputIsInputError
from diskpack_cl.options import NamedOptionError, OptionConflict, flag_name

__all__ = ["main", "build_parser", "LEADING", "one_line_help"]


#: The subcommands, in the order of ``diskpack --help``: module ``NAME`` holds ``add_NAME``.
_SUBCOMMANDS = ("devices", "poisson", "relax", "stipple", "export", "analyze")


def _adder(name):
    """``add_NAME`` of subcommand `name`, its module imported now: a run imports only the
    module of the subcommand it names (``analyze``'s alone took 26 ms of a ``poisson``)."""
    return getattr(importlib.import_module(f".{name}", __name__), f"add_{name}")


def build_parser(only=None):
    """The argument parser, with the subcommands of :data:`_SUBCOMMANDS` (`only`: that one).

    A run builds only the subcommand it names: the options of the others load
    the modules that define them (the stippling's options cost a third of a
    second), which a ``diskpack poisson`` never uses.

    Examples
    --------
    >>> args = build_parser().parse_args(["poisson", "-n", "64", "-o", "points.npz"])
    >>> args.command, args.n
    ('poisson', 64)
    """
    parser = Parser(
        prog=PROG, description="Poisson disk sampling and image stippling by disk packing.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                       parser_class=Parser)
    for name in _SUBCOMMANDS:
        if only is None or name == only:
            _adder(name)(subparsers)
    for sub in subparsers.choices.values():   # long paragraphs wrapped, examples kept
        sub.formatter_class = HelpFormatter
    return parser


def _terminate_handlers():
    """Make SIGTERM and SIGHUP raise :class:`Terminated`, as Ctrl-C raises
    KeyboardInterrupt, so that a killed run cleans up like an interrupted
    one; return the handlers to restore (none off the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    handlers = {}
    for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None and signal.getsignal(sig) is signal.SIG_DFL:
            handlers[sig] = signal.signal(sig, raise_terminated)
    return handlers


def _stdout_closed():
    """After a BrokenPipeError (``diskpack ... --json | head``): end quietly.

    Point the stdout descriptor at /dev/null so that the interpreter's final
    flush does not raise again; return 141, the status of a SIGPIPE death.
    """
    with open(os.devnull, "wb") as null:
        try:
            os.dup2(null.fileno(), sys.stdout.fileno())
        except (OSError, ValueError):  # stdout is no real file (tests)
            pass
    return 128 + 13


def _os_error_text(exc):
    """``path: reason`` for an OSError, without the raw ``[Errno N]`` prefix."""
    reason = exc.strerror or str(exc)
    return f"{exc.filename}: {reason}" if exc.filename else reason


def main(argv=None):
    """Run the CLI; return the exit status (see :func:`_main`); Ctrl-C at any moment,
    also while the parser is built, ends with one line and 130.

    Examples
    --------
    >>> main(["poisson", "-n", "1"])
    2
    """
    open_closed_streams()
    try:
        return _main(argv)
    except KeyboardInterrupt:   # before _main's own handlers, or inside them
        print(f"{PROG}: error: interrupted, nothing written", file=sys.stderr)
        return 130


def _main(argv):
    """Run the CLI; return the exit status.

    0 ok, 1 error, 2 usage error, 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP (an
    interrupted run writes none of its outputs and leaves earlier files as
    they were), 141 when stdout was closed.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "points.npz")
    >>> main(["poisson", "-n", "64", "--eps", "0.7", "-o", path, "--quiet"])
    0
    >>> main(["poisson", "-n", "64", "--eps", "2", "-o", path, "--quiet"])
    2
    """
    from diskpack_cl import NoOpenCLError  # not loaded at start-up

    argv = sys.argv[1:] if argv is None else list(argv)
    named = argv[0] if argv and argv[0] in _SUBCOMMANDS else None
    parser = build_parser(named)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 1
    handlers = _terminate_handlers()
    show_device_notes(getattr(args, "quiet", False))
    try:
        # a device asked for (--device, DISKPACK_DEVICE, PYOPENCL_CTX) must exist, on every
        # command that has one
        if hasattr(args, "device"):
            from diskpack_cl.device.context import check_requested_device  # not loaded at start-up

            check_requested_device(args.device)
        return int(args.run(args) or 0)
    except NamedOptionError as exc:   # the options named as flags
        usage = isinstance(exc, OptionConflict)
        print(f"{PROG}{f' {args.command}' if usage else ''}: error: {exc.render(flag_name)}",
              file=sys.stderr)
        return 2 if usage else 1
    except (UsageError, OutputIsInputError) as exc:
        print(f"{PROG} {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        how = (signal.Signals(exc.args[0]).name if isinstance(exc, Terminated)
               else "interrupted")
        print(f"{PROG}: error: {how}, nothing written", file=sys.stderr)
        return 128 + exc.args[0] if isinstance(exc, Terminated) else 130
    except BrokenPipeError:
        return _stdout_closed()
    except (ValueError, NoOpenCLError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:  # a write failed: read-only, full, gone
        print(f"{PROG}: error: {_os_error_text(exc)}; nothing written", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"{PROG}: error: out of memory, nothing written", file=sys.stderr)
        return 1
    except Exception as exc:
        if type(exc).__module__.split(".")[0] != "pyopencl":
            raise
        print(f"{PROG}: error: OpenCL failed ({type(exc).__name__}: {exc}); try another "
              f"--device (see 'diskpack devices'); nothing written", file=sys.stderr)
        return 1
    finally:
        for sig, old in handlers.items():
            signal.signal(sig, old)
