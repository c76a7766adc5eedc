"""The pen path's 2-opt against brute force: every move tried, on small sets of dots."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import diskpack_cl.drawing.pen_path as pen_path
from diskpack_cl.drawing.pen_path import path_travel, two_opt


def _length(q):
    return float(np.sum(np.hypot(*np.diff(q, axis=0).T)))


def _best_reversal(q):
    """The largest gain of any 2-opt move of the open path ``q`` (``q[0]``, the start, fixed),
    each move made and measured."""
    best = 0.0
    for a in range(len(q) - 2):
        for b in range(a + 2, len(q)):
            moved = np.concatenate([q[: a + 1], q[a + 1 : b + 1][::-1], q[b + 1 :]])
            best = max(best, _length(q) - _length(moved))
    return best


def _best_relocation(q, span):
    """The largest gain of moving one dot (not the start) to between two others at most
    `span` positions away, each move made and measured."""
    best = 0.0
    for i in range(1, len(q)):
        rest = np.delete(q, i, axis=0)
        for j in range(max(0, i - span), min(len(q), i + span + 1)):
            if j in (i, i - 1):
                continue
            at = j + 1 if j < i else j   # after position j of q, counted in `rest`
            moved = np.insert(rest, at, q[i], axis=0)
            best = max(best, _length(q) - _length(moved))
    return best


_DOTS = st.integers(4, 24).flatmap(
    lambda n: st.lists(st.tuples(st.floats(0, 100), st.floats(0, 100)), min_size=n, max_size=n))


@settings(max_examples=40)
@given(dots=_DOTS, chunk=st.sampled_from([1, 3, 1 << 16]), span=st.sampled_from([1, 3, 64]))
# paths whose one gaining move, once the 2-opt is done, takes the last dot elsewhere
@example(dots=[(25, 72), (50, 44), (48, 14), (4, 84), (63, 93)], chunk=1 << 16, span=64)
@example(dots=[(12, 31), (48, 51), (42, 67), (94, 79), (39, 64), (62, 8)], chunk=3, span=64)
# a dot moved exactly `span` places
@example(dots=[(43, 52), (98, 18), (75, 3), (5, 35), (69, 94)], chunk=1 << 16, span=3)
# and the first dot
@example(dots=[(88, 18), (8, 56), (29, 64), (36, 92), (11, 38)], chunk=1 << 16, span=64)
@example(dots=[(30, 7), (86, 79), (94, 73), (21, 56), (63, 16), (5, 31)], chunk=1, span=64)
def test_two_opt_leaves_no_improving_move_of_any_chunking(dots, chunk, span):
    """With every dot a neighbour and no round limit, no 2-opt move, nor Or-opt move of
    at most `span` places, of the path through `dots` in their order gains: the candidates
    of every chunk and of every dot (the first and the last too) are kept, and every last
    move is made."""
    p = np.array(dots, dtype=np.float64)
    given_order = np.arange(len(p))
    mp = pytest.MonkeyPatch()
    mp.setattr(pen_path, "MOVE_CHUNK", chunk)
    mp.setattr(pen_path, "_OR_SPAN", span)
    try:
        order = two_opt(p, given_order, neighbors=len(p))
    finally:
        mp.undo()
    np.testing.assert_array_equal(np.sort(order), given_order)
    q = np.vstack([[0.0, 0.0], p[order]])
    tol = 2e-9 * float(np.ptp(q, axis=0).max())
    assert _best_reversal(q) <= tol
    assert _best_relocation(q, span) <= tol
    assert path_travel(p, order) <= path_travel(p) + tol


@settings(max_examples=25)
@given(n=st.integers(4, 60), seed=st.integers(0, 2**16), rounds=st.integers(1, 4))
def test_two_opt_rounds_compose_and_never_lengthen(n, seed, rounds):
    """``rounds + 1`` rounds are `rounds` rounds and then one more, each no longer than the
    last (a round skipped or a move undone shows here), and the order is deterministic.
    Random dots: no two neighbours at the same distance, whose order would be a tie."""
    rng = np.random.default_rng(seed)
    p = rng.random((n, 2)) * 100
    order = rng.permutation(n)
    before = two_opt(p, order, rounds=rounds)
    after = two_opt(p, before, rounds=1)
    np.testing.assert_array_equal(two_opt(p, order, rounds=rounds + 1), after)
    np.testing.assert_array_equal(two_opt(p, order, rounds=rounds), before)
    assert path_travel(p, after) <= path_travel(p, before) <= path_travel(p, order)


def test_brute_force_finds_the_moves_it_should():
    """The brute force of the tests above: a crossing found by the 2-opt, a dot out of
    place by the Or-opt."""
    crossing = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [2.0, 0.0], [3.0, 1.0]])
    assert _best_reversal(crossing) == pytest.approx(2 * np.sqrt(2) - 2)
    stray = np.array([[0.0, 0.0], [5.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    assert _best_relocation(stray, 64) > 0
    assert _best_reversal(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])) == 0.0


def _greedy(p, start):
    """Nearest unvisited dot next, from `start`: every distance computed."""
    left, cur, order = list(range(len(p))), np.asarray(start, np.float64), []
    while left:
        nxt = left[int(np.argmin(np.hypot(*(p[left] - cur).T)))]
        order.append(nxt)
        left.remove(nxt)
        cur = p[nxt]
    return np.array(order)


@settings(max_examples=30)
@given(n=st.integers(2, 80), seed=st.integers(0, 2**16))
def test_greedy_is_the_nearest_unvisited_dot_next_unless_the_given_order_is_as_short(n, seed):
    """The travel before is the given order's and after the returned order's, from the start."""
    rng = np.random.default_rng(seed)
    p, start = rng.random((n, 2)) * 100, rng.random(2) * 100
    order, before, after = pen_path.pen_path_order(p, method="greedy", start=start)
    expected = _greedy(p, start)
    if path_travel(p, expected, start=start) >= path_travel(p, start=start):
        expected = np.arange(n)
    np.testing.assert_array_equal(order, expected)
    assert before == path_travel(p, start=start)
    assert after == path_travel(p, order, start=start)


def _grid(scale, offset, extra=()):
    """A 16 x 16 grid of `scale` spacing from `offset`, shuffled, then the `extra` dots."""
    x, y = np.meshgrid(np.arange(16.0), np.arange(16.0))
    p = np.column_stack([x.ravel(), y.ravel()])[np.random.default_rng(1).permutation(256)]
    return np.vstack([p * scale + offset, np.reshape(extra, (-1, 2))])


@pytest.mark.parametrize("scale, offset", [(1.0, (0.0, 0.0)), (3.0, (10.0, -7.0))])
def test_hilbert_visits_a_grid_one_step_at_a_time(scale, offset):
    """From its corner at the start the Hilbert curve goes to a neighbouring dot each step:
    255 steps of one spacing."""
    p = _grid(scale, offset)
    order, _, after = pen_path.pen_path_order(p, method="hilbert", start=offset)
    np.testing.assert_allclose(np.hypot(*np.diff(p[order], axis=0).T), scale)
    assert after == pytest.approx(255 * scale)


def test_hilbert_visits_a_grid_of_whole_quadrants_one_step_at_a_time():
    """The grid's dots each on the first cell of a quadrant of the curve's 65535 x 65535
    cells (a dot on the last cell sets the span): no cell below a quadrant's first tells
    the quadrants' turns apart."""
    p = _grid(4096.0, (0.0, 0.0), extra=(65535.0, 65535.0))
    order, _, _ = pen_path.pen_path_order(p, method="hilbert")
    grid = p[order[order < 256]]
    np.testing.assert_array_equal(np.abs(np.diff(grid, axis=0)).sum(axis=1), 4096.0)


@pytest.mark.parametrize("method", ["auto", "hilbert", "greedy"])
def test_two_dots_given_the_long_way_round_are_turned(method):
    order, before, after = pen_path.pen_path_order([[10.0, 10.0], [1.0, 1.0]], method=method)
    np.testing.assert_array_equal(order, [1, 0])
    assert (before, after) == (pytest.approx(np.hypot(10, 10) + np.hypot(9, 9)),
                               pytest.approx(np.hypot(10, 10)))


def test_none_keeps_the_given_order():
    p = np.random.default_rng(2).random((50, 2))
    order, before, after = pen_path.pen_path_order(p, method="none")
    np.testing.assert_array_equal(order, np.arange(50))
    assert before == after == path_travel(p)


@pytest.mark.parametrize("n, rounds", [(1, 1_000_000), (3000, 334), (999_999, 2),
                                       (1_000_000, 1), (1_000_001, 1), (0, 1_000_000)])
def test_two_opt_rounds_are_the_work_over_the_dots_rounded_up(n, rounds):
    assert pen_path.two_opt_rounds(n) == rounds


@settings(max_examples=60)
@given(n=st.integers(4, 300), seed=st.integers(0, 2**16), lattice=st.booleans(),
       rounds=st.sampled_from([1, 2, 5, None]), chunk=st.sampled_from([5, 1 << 16]))
def test_two_opt_evaluates_again_only_what_its_moves_changed(n, seed, lattice, rounds, chunk):
    """After the first round a round evaluates only the moves of the positions next to
    those whose dot changed and of the dots with such a dot among their neighbours, and
    keeps the others' moves: the order of a 2-opt that evaluates every move every round,
    on random dots and on lattices (equal gains, whose order decides)."""
    rng = np.random.default_rng(seed)
    p = (np.column_stack([np.arange(n) % 9, np.arange(n) // 9]).astype(float) if lattice
         else rng.random((n, 2)) * 100)
    order = rng.permutation(n)
    mp = pytest.MonkeyPatch()
    mp.setattr(pen_path, "MOVE_CHUNK", chunk)
    try:
        kept = two_opt(p, order, rounds=rounds)
        mp.setattr(pen_path, "_rows_to_evaluate", lambda changed, *rest: np.ones(len(changed), dtype=bool))
        every = two_opt(p, order, rounds=rounds)
    finally:
        mp.undo()
    np.testing.assert_array_equal(kept, every)
