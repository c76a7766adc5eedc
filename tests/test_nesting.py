"""Outermost: the switch is on from the first of nested or concurrent blocks to the last."""

import threading

import pytest

from diskpack_cl._nesting import Outermost


def _switch():
    events = []
    return Outermost(lambda: events.append("on"), lambda: events.append("off")), events


def test_overlapping_blocks_of_two_threads_turn_it_on_and_off_once():
    switch, events = _switch()
    inside, release = threading.Event(), threading.Event()

    def other():
        with switch.block():
            inside.set()
            release.wait(5)

    thread = threading.Thread(target=other)
    with switch.block():
        thread.start()
        assert inside.wait(5)
    assert switch.on and events == ["on"]   # the other thread's block is still open
    release.set()
    thread.join(5)
    assert not switch.on and events == ["on", "off"]


def test_an_error_inside_still_turns_it_off_and_it_turns_on_again():
    switch, events = _switch()
    with pytest.raises(RuntimeError):
        with switch.block():
            raise RuntimeError("inside")
    assert not switch.on
    with switch.block():
        assert switch.on
    assert events == ["on", "off", "on", "off"]
