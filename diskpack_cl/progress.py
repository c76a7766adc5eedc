"""Progress of a whole run, stage by stage, and the seconds each stage took.

A run (``diskpack stipple``, :func:`diskpack_cl.stipple`,
:func:`diskpack_cl.jobs.items.stipple_item` with its writers, ``vpype diskpack``)
goes through named stages (:data:`STAGES`). The caller gives a hook,
``hook(stage, done, total)``, called when a stage starts (``done`` 0), as it
advances and when it ends (``done == total``); ``done`` never decreases
within a stage, and a stage entered again (the pen path of each pen) goes
on counting where it stopped. The same :class:`RunProgress` adds up the
seconds of each stage for the summary (:func:`stage_text`).

The run's :class:`RunProgress` is a context variable (:func:`running`),
so that the stages deep inside the writers (the pen path's 2-opt rounds)
report to it without every function between passing it on; code run
outside a run reports to nothing. :class:`StageBars` renders the events as
one tqdm bar per stage.

Examples
--------
>>> events = []
>>> with running(lambda *e: events.append(e)) as run:
...     with stage("iterations", 3) as advance:
...         for i in range(3):
...             advance(i + 1)
>>> events
[('iterations', 0, 3), ('iterations', 1, 3), ('iterations', 2, 3), ('iterations', 3, 3)]
>>> list(run.seconds)
['iterations']
"""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["STAGES", "RunProgress", "running", "current", "stage", "stage_text", "StageBars",
           "with_bars", "in_stage_order", "unreported"]

#: The stages of a stippling run, in the order a job (:func:`diskpack_cl.jobs.items.stipple_item`)
#: starts them: reading the image and planning the run (``load``), finding the OpenCL
#: device, its known-answer checks on its first run, and building its programs
#: (``device``), the error-diffusion start (``start``), the radius, density and ink fields
#: (``setup``), the schedule's steps (``iterations``), the certified radii
#: (``certificate``), the files (``writing``) and, within an SVG's writing, its dot order
#: (``pen path``). :func:`diskpack_cl.stipple` alone makes the engine, and so meets the
#: device, after the start.
STAGES = ("load", "device", "start", "setup", "iterations", "certificate", "writing", "pen path")


def in_stage_order(seconds):
    """The dict `seconds` (per stage) in the order of :data:`STAGES`, other stages after them.

    Examples
    --------
    >>> list(in_stage_order({"pen path": 2.0, "mine": 0.1, "load": 0.5}))
    ['load', 'pen path', 'mine']
    """
    rank = {name: i for i, name in enumerate(STAGES)}
    return dict(sorted(seconds.items(), key=lambda kv: rank.get(kv[0], len(rank))))


class RunProgress:
    """The stages of one run: their seconds, and the hook told of their progress.

    Seconds go to the innermost open stage: a stage opened inside another
    (the pen path inside writing) pauses the outer one's clock.

    Parameters
    ----------
    hook : callable, optional
        ``hook(stage, done, total)``; `total` is None where it is not known.

    Examples
    --------
    >>> run = RunProgress()
    >>> with run.stage("writing", 2) as advance:
    ...     with run.stage("pen path", 5):
    ...         pass
    ...     advance(1)
    >>> list(run.seconds), run.counts
    (['writing', 'pen path'], {'writing': [2, 2], 'pen path': [5, 5]})
    """

    def __init__(self, hook=None):
        self.hook = hook
        #: Seconds per stage, in the order the stages first ran.
        self.seconds = {}
        #: ``[done, total]`` per stage.
        self.counts = {}
        self._open = []   # [name, when its clock last started], innermost last
        self._started = time.perf_counter()

    def by_stage(self):
        """:attr:`seconds` in the order of :data:`STAGES` (others after them).

        Examples
        --------
        >>> run = RunProgress()
        >>> with run.stage("writing"), run.stage("pen path"):
        ...     pass
        >>> list(run.by_stage())
        ['writing', 'pen path']
        """
        return in_stage_order(self.seconds)

    def elapsed(self):
        """Seconds since the run began."""
        return time.perf_counter() - self._started

    def _clock(self, now):
        """Add the time since the innermost open stage's clock started to that stage."""
        if self._open:
            name, since = self._open[-1]
            self.seconds[name] = self.seconds.get(name, 0.0) + now - since
            self._open[-1][1] = now

    def _emit(self, name):
        if self.hook is not None:
            done, total = self.counts[name]
            self.hook(name, done, total)

    @contextmanager
    def stage(self, name, total=1):
        """Time stage `name` and report it: yields ``advance(done)`` (`done` of `total`
        within this entry). An entry that raises reports no completion; an entry of a
        stage that ran before with `total` 0 adds its time and reports nothing.

        Examples
        --------
        >>> run = RunProgress(print)
        >>> with run.stage("pen path", 2) as advance:
        ...     advance(1)
        pen path 0 2
        pen path 1 2
        pen path 2 2
        """
        self._clock(time.perf_counter())
        self.seconds.setdefault(name, 0.0)
        before, known = self.counts.get(name, (0, 0))
        grown = None if total is None or known is None else known + total
        self.counts[name] = [before, grown]
        if total != 0 or before == 0:
            self._emit(name)
        self._open.append([name, time.perf_counter()])

        mine = [0]   # this entry's done: the stage's is the sum over its entries

        def advance(done):
            more = (done if total is None else min(done, total)) - mine[0]
            if more > 0:
                mine[0] += more
                self.counts[name][0] += more
                self._emit(name)

        try:
            yield advance
            self._clock(time.perf_counter())
            if total is not None:
                advance(total)
        finally:
            self._clock(time.perf_counter())
            self._open.pop()
            if self._open:   # the outer stage's clock goes on from now
                self._open[-1][1] = time.perf_counter()


_CURRENT: ContextVar = ContextVar("diskpack_run", default=None)


@contextmanager
def running(progress=None):
    """The block as one run: yields its :class:`RunProgress`.

    `progress` is a hook (``hook(stage, done, total)``), a
    :class:`RunProgress`, or None. Inside a run already going on (the job
    around :func:`diskpack_cl.stipple`), None joins that run, and a hook
    or :class:`RunProgress` of its own starts a new one for the block.

    Examples
    --------
    >>> with running() as outer, running() as inner:
    ...     inner is outer
    True
    """
    current = _CURRENT.get()
    if progress is None and current is not None:
        yield current
        return
    run = progress if isinstance(progress, RunProgress) else RunProgress(progress)
    token = _CURRENT.set(run)
    try:
        yield run
    finally:
        _CURRENT.reset(token)


@contextmanager
def unreported():
    """A block whose stages report to no run: work inside one of the run's stages that is
    none of its own (an order that ranks dots is no pen path); its time stays the
    enclosing stage's.

    Examples
    --------
    >>> with running() as run, stage("iterations"), unreported(), stage("pen path"):
    ...     pass
    >>> list(run.seconds)
    ['iterations']
    """
    token = _CURRENT.set(None)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def current():
    """The :class:`RunProgress` of the run going on (:func:`running`), or None.

    Examples
    --------
    >>> current() is None
    True
    """
    return _CURRENT.get()


def _ignore(done):
    """The ``advance`` of a stage outside any run."""


@contextmanager
def stage(name, total=1):
    """Stage `name` of the current run (:func:`running`), as :meth:`RunProgress.stage`;
    outside a run nothing is timed or reported.

    Examples
    --------
    >>> with stage("writing") as advance:
    ...     advance(1)
    """
    run = _CURRENT.get()
    if run is None:
        yield _ignore
        return
    with run.stage(name, total) as advance:
        yield advance


def stage_text(seconds, iterations=None, whole=None):
    """The stages' seconds for a summary line.

    Parameters
    ----------
    seconds : dict
        Seconds per stage (:attr:`RunProgress.seconds`).
    iterations : int, optional
        Counted before the ``iterations`` stage's name.
    whole : float, optional
        The whole run's seconds, said last.

    Examples
    --------
    >>> stage_text({"start": 0.31, "iterations": 2.41, "pen path": 10.93}, 25, 14.9)
    'start 0.31 s, 25 iterations 2.4 s, pen path 11 s; 14.9 s in all'
    """
    parts = []
    for name, secs in in_stage_order(seconds).items():
        label = f"{iterations} {name}" if name == "iterations" and iterations is not None else name
        parts.append(f"{label} {secs:.2g} s")
    text = ", ".join(parts)
    return text if whole is None else f"{text}; {whole:.3g} s in all"


class StageBars:
    """A hook that draws each stage as a tqdm bar on `file` (stderr by default).

    One bar at a time: an event of another stage closes the bar before.
    Nothing is drawn where `file` is not a terminal, and a `file` that
    fails (closed, a broken pipe) ends the drawing, not the run.

    Examples
    --------
    >>> import io
    >>> bars = StageBars(io.StringIO())   # not a terminal: draws nothing
    >>> bars("iterations", 0, 25); bars.close()
    """

    def __init__(self, file=None):
        self.file = sys.stderr if file is None else file
        self._bar, self._stage = None, None
        self._live = _is_terminal(self.file)

    def __call__(self, stage, done, total):
        if self._live:
            self._drawn(self._draw, stage, done, total)

    def note(self, text):
        """Write `text` beside the bar drawn now (the iterations' kind and k)."""
        if self._live and self._bar is not None:
            self._drawn(self._bar.set_postfix_str, text)

    def _drawn(self, draw, *args):
        """``draw(*args)``; a file that fails ends the drawing."""
        try:
            draw(*args)
        except (OSError, ValueError):   # ValueError: the file was closed
            self._live = False
            self.close()   # tqdm keeps every open bar: one left open misplaces the next

    def _draw(self, stage, done, total):
        if stage != self._stage:
            self._close_bar()
            self._open_bar(stage, done, total)
        else:
            self._bar.total = total
            self._bar.update(done - self._bar.n)

    def _open_bar(self, stage, done, total):
        from tqdm import tqdm  # not loaded at start-up

        self._stage = stage
        self._bar = tqdm(total=total, initial=done, desc=stage, file=self.file,
                         dynamic_ncols=True, leave=False)

    def _close_bar(self):
        bar, self._bar, self._stage = self._bar, None, None
        if bar is not None:
            bar.close()

    def close(self):
        """Close the last bar."""
        try:
            self._close_bar()
        except (OSError, ValueError):
            self._live = False


@contextmanager
def with_bars(quiet=False, file=None):
    """A run (:func:`running`) whose stages are drawn as :class:`StageBars` on `file`
    (stderr by default; none when `quiet`): yields its :class:`RunProgress`, the last
    bar closed at the end. Inside a run already going on, that run.

    Examples
    --------
    >>> with with_bars(quiet=True) as run:
    ...     with stage("writing"):
    ...         pass
    >>> list(run.seconds)
    ['writing']
    """
    if current() is not None:
        yield current()
        return
    bars = None if quiet else StageBars(file)
    try:
        with running(RunProgress(bars)) as run:
            yield run
    finally:
        if bars is not None:
            bars.close()


def _is_terminal(file):
    try:
        return file.isatty()
    except (AttributeError, OSError, ValueError):
        return False
