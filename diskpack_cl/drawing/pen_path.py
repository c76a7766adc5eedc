"""Pen path: the order in which a plotter visits the dots, and its pen-up travel.

Orders: a Hilbert curve (vectorized sort), greedy nearest neighbour
(cKDTree), and either improved by 2-opt and Or-opt moves towards each dot's
nearest neighbours (evaluated with numpy: all of them in the first round,
then those the last round's moves may have changed; the best ones that
change disjoint edges applied) for a number of rounds that depends on the
number of dots only, so that the order is the same on every machine.
``benchmarks/pen_path.py`` measures them on stippled dots; see
:func:`pen_path_order` for what the default does and why.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..progress import stage

__all__ = ["GREEDY_MAX", "PEN_PATHS", "TWO_OPT_WORK", "greedy_order", "hilbert_order", "path_travel",
           "pen_path_order", "two_opt", "two_opt_rounds"]

#: The ``method`` names of :func:`pen_path_order`.
PEN_PATHS = ("auto", "hilbert", "greedy", "none")


def path_travel(points, order=None, *, start=(0.0, 0.0)):
    """Pen-up travel: from ``start`` through the points in ``order``.

    Examples
    --------
    >>> path_travel([[3.0, 4.0], [3.0, 0.0]])
    9.0
    """
    p = np.asarray(points, dtype=np.float64)
    if order is not None:
        p = p[np.asarray(order)]
    if len(p) == 0:
        return 0.0
    q = np.vstack([np.asarray(start, dtype=np.float64)[None, :], p])
    return float(np.sum(np.hypot(*np.diff(q, axis=0).T)))


def _hilbert_index(ix, iy, order):
    """Hilbert-curve index of integer cells (vectorized; cells in [0, 2^order))."""
    ix = ix.astype(np.int64).copy()
    iy = iy.astype(np.int64).copy()
    d = np.zeros_like(ix)
    s = 1 << (order - 1)
    while s > 0:
        rx = (ix & s) > 0
        ry = (iy & s) > 0
        d += s * s * ((3 * rx) ^ ry)
        # rotate the quadrant
        flip = ~ry
        swap_x = np.where(flip & rx, s - 1 - ix, ix)
        swap_y = np.where(flip & rx, s - 1 - iy, iy)
        ix = np.where(flip, swap_y, swap_x)
        iy = np.where(flip, swap_x, swap_y)
        ix &= s - 1
        iy &= s - 1
        s >>= 1
    return d


def hilbert_order(points):
    """The order of `points` along a Hilbert curve of 2^16 x 2^16 cells over their bounding
    square (ties kept in the given order).

    Examples
    --------
    >>> hilbert_order(np.array([[1.0, 1.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])).tolist()
    [1, 3, 0, 2]
    """
    p = np.asarray(points, dtype=np.float64)
    lo = p.min(axis=0)
    span = max(float(np.max(p.max(axis=0) - lo)), 1e-300)
    order = 16
    cells = (1 << order) - 1
    ix = np.floor((p[:, 0] - lo[0]) / span * cells).astype(np.int64)
    iy = np.floor((p[:, 1] - lo[1]) / span * cells).astype(np.int64)
    return np.argsort(_hilbert_index(ix, iy, order), kind="stable")


def greedy_order(points, start=(0.0, 0.0)):
    """Greedy nearest-neighbour tour of `points` from `start`, with a cKDTree of the
    unvisited points.

    The tree is rebuilt whenever half of its points have been visited, so a
    query for the 16 nearest almost always finds an unvisited one.  Each
    tree's queries from its points are made at once when it is built (a query
    a dot in a Python loop cost most of the tour); a dot whose 16 nearest are
    all visited asks the tree again for more.

    Examples
    --------
    >>> greedy_order(np.array([[3.0, 0.0], [1.0, 0.0], [2.0, 0.0]])).tolist()
    [1, 2, 0]
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    visited = np.zeros(n, dtype=bool)
    order = np.empty(n, dtype=np.int64)
    cur, row = np.asarray(start, dtype=np.float64), -1
    in_tree = 0
    for step in range(n):
        if not step or (n - step) * 2 < in_tree:
            alive = np.flatnonzero(~visited)
            tree, in_tree = cKDTree(p[alive]), alive.size
            kq = min(16, in_tree)
            # the tree's answer to each of its dots, as a query from that dot would give it
            nearest = alive[tree.query(p[alive], k=kq, workers=-1)[1].reshape(in_tree, kq)]
            row_of = np.full(n, -1)
            row_of[alive] = np.arange(in_tree)
            row = -1 if not step else row_of[order[step - 1]]
        cand = nearest[row] if row >= 0 else None
        free = None if cand is None else cand[~visited[cand]]
        k = kq
        while free is None or not (free.size or k >= in_tree):
            k = k if free is None else min(k * 4, in_tree)
            cand = alive[np.atleast_1d(tree.query(cur, k=k)[1])]
            free = cand[~visited[cand]]
        nxt = int(free[0])
        visited[nxt] = True
        order[step] = nxt
        cur, row = p[nxt], row_of[nxt]
    return order


def _reversals(q, edge, i, j):
    """2-opt moves joining positions ``i`` and ``j`` (near neighbours) of the open path ``q``.

    Reversing ``q[a+1 .. b]`` replaces the edges (a, a+1) and (b, b+1) by
    (a, b) and (a+1, b+1); the last point has no edge after it. Returns
    (gain, first edge, last edge, slice start, slice stop, kind 0), and the
    indices of the pairs ``(i, j)`` these moves are of.
    """
    m = len(q)
    a, b = np.minimum(i, j), np.maximum(i, j)
    ok = np.flatnonzero(b >= a + 2)
    a, b = a[ok], b[ok]
    bn = np.minimum(b + 1, m - 1)
    gain = (edge[a] + edge[b] - _dist(q, a, b)
            - np.where(b == m - 1, 0.0, _dist(q, a + 1, bn)))
    return (gain, a, b, a + 1, b + 1, np.zeros_like(a)), ok


# Or-opt moves a dot at most this many path positions (a longer move rotates a
# long stretch and blocks every other move on it in its round)
_OR_SPAN = 64


def _relocations(q, edge, i, j):
    """Or-opt moves: the dot at position ``i`` moves between positions ``j`` and ``j + 1``
    (next to its near neighbour at ``c``: ``j = c`` or ``c - 1``). Returns
    (gain, first edge, last edge, slice start, slice stop, kind): the slice
    rotates by -1 (kind 1, i < j) or +1 (kind 2, i > j); and the indices of the
    pairs ``(i, j)`` these moves are of.
    """
    m = len(q)
    ok = np.flatnonzero((i >= 1) & (j >= 0) & (j != i) & (j != i - 1) & (np.abs(i - j) <= _OR_SPAN))
    i, j = i[ok], j[ok]
    last_i, last_j = i == m - 1, j == m - 1
    inext, jnext = np.minimum(i + 1, m - 1), np.minimum(j + 1, m - 1)
    removed = edge[i - 1] + np.where(last_i, 0.0, edge[i] - _dist(q, i - 1, inext))
    inserted = _dist(q, j, i) + np.where(last_j, 0.0, _dist(q, i, jnext) - edge[j])
    fwd = i < j
    return (removed - inserted, np.where(fwd, i - 1, j), np.where(fwd, j, i),
            np.where(fwd, i, j + 1), np.where(fwd, j + 1, i + 1), np.where(fwd, 1, 2)), ok


#: Dots whose candidate moves :func:`_candidates` makes at a time.
MOVE_CHUNK = 1 << 16


def _candidates(q, edge, near, place, pos, tol, rows):
    """The moves that gain more than `tol` of the dots at positions `rows` (ascending):
    each one's 2-opt moves towards its near neighbours, then its Or-opt moves next to
    them (after, then before each), as one tuple of arrays (:func:`_reversals`) and
    their keys, ``(kind of move, position, neighbour)`` as one number, in increasing
    order: the order of one pass over all of them.

    Made for :data:`MOVE_CHUNK` dots at a time: a million dots' 18 million candidates
    would otherwise take temporaries of gigabytes, each touched once, for the few that
    gain."""
    k = near.shape[1]
    parts = [[], [], []]
    for a in range(0, len(rows), MOVE_CHUNK):
        at = rows[a:a + MOVE_CHUNK]
        i = np.repeat(at, k)
        c = pos[near[place[at]]].ravel()
        key = i * k + np.tile(np.arange(k), len(at))
        for kind, (part, (move, ok)) in enumerate(zip(parts, (
                _reversals(q, edge, i, c), _relocations(q, edge, i, c), _relocations(q, edge, i, c - 1)))):
            gains = np.flatnonzero(move[0] > tol)
            part.append([field[gains] for field in move] + [key[ok[gains]] + kind * len(q) * k])
    return [np.concatenate([move[f] for part in parts for move in part]) for f in range(7)]


def _merged(kept, new):
    """The moves `kept` (of rows not evaluated again) and `new`, in the order of their keys
    (the last of each tuple of arrays)."""
    if kept is None:
        return new
    both = [np.concatenate(pair) for pair in zip(kept, new)]
    order = np.argsort(both[6], kind="stable")   # two sorted runs: a merge
    return [field[order] for field in both]


def _rows_to_evaluate(changed, near, place, pos):
    """The mask of the positions whose moves may differ once the dots at the positions
    `changed` (a boolean mask) did: those within one of a changed position (a move reads
    the positions next to its own and next to its neighbour's), and those whose dots
    have the dot at such a position among their near neighbours (`near`, by place)."""
    around = changed.copy()
    around[1:] |= changed[:-1]
    around[:-1] |= changed[1:]
    hit = np.zeros(len(place), dtype=bool)
    hit[place[around]] = True
    hit_near = hit[near]
    mine = hit_near[:, 0].copy()   # by column: numpy's reduction along rows of k is slow
    for col in range(1, near.shape[1]):
        mine |= hit_near[:, col]
    around[pos[mine]] = True
    return around


def _dist(q, a, b):
    # rows gathered as complex numbers (one 16-byte load each, not numpy's row gather of
    # two values); np.hypot of the same differences: the same distances to the bit
    z = q.view(np.complex128).ravel()
    d = z[a] - z[b]
    return np.hypot(d.real, d.imag)


def _apply_moves(moves, arrays, pos):
    """Apply the best of the gaining `moves` that change disjoint edges; return the mask of
    the positions whose dot changed (None where no move gains)."""
    gain, e0, e1, s0, s1, kind = moves
    good = np.lexsort((-gain, e0))
    good = good[np.diff(e0[good], prepend=-1) != 0]  # the best per first edge
    used = np.zeros(len(arrays[0]), dtype=bool)
    # the moves' slices lie within their edges, so they are disjoint too: each
    # one rearranges the positions of one permutation, applied to all at the end
    perm = np.arange(len(arrays[0]))
    done = 0
    for k in good[np.argsort(-gain[good], kind="stable")]:
        if used[e0[k] : e1[k] + 1].any():
            continue
        used[e0[k] : e1[k] + 1] = True
        sl = perm[s0[k]:s1[k]]
        if kind[k] == 0:
            sl[:] = sl[::-1]
        else:   # a rotation by -1 (kind 1) or +1 (kind 2)
            sl[:] = np.concatenate((sl[1:], sl[:1]) if kind[k] == 1 else (sl[-1:], sl[:-1]))
        done += 1
    if not done:
        return None
    for arr in arrays:
        arr[:] = arr[perm]
    pos[arrays[2]] = np.arange(len(perm))
    return perm != np.arange(len(perm))


#: Work of the 2-opt of :func:`pen_path_order`'s ``"auto"``, in dots times
#: rounds: the first round costs a few microseconds a dot, the later ones what the
#: moves before them changed. Counted in rounds, not seconds, so the order never
#: depends on the machine's speed or load.
TWO_OPT_WORK = 1_000_000


def two_opt_rounds(n):
    """Rounds of :func:`two_opt` that ``"auto"`` runs on `n` dots: ``ceil(TWO_OPT_WORK / n)``.

    Examples
    --------
    >>> two_opt_rounds(2000), two_opt_rounds(20000), two_opt_rounds(3_000_000)
    (500, 50, 1)
    """
    return max(1, -(-TWO_OPT_WORK // max(int(n), 1)))


def two_opt(points, order, *, start=(0.0, 0.0), neighbors=8, rounds=None, progress=None):
    """Shorten an open pen path by 2-opt and Or-opt moves towards near neighbours.

    Each round evaluates, for every dot and each of its ``neighbors``
    nearest dots (a k-d tree, once), the reversal that joins them (2-opt)
    and the moves of the dot next to it (Or-opt), all with numpy, applies
    the best ones that change disjoint edges, and stops when none gains or
    after `rounds` rounds (None: no limit). The start is fixed.  After the
    first round only the moves that read a position whose dot changed are
    evaluated again (:func:`_rows_to_evaluate`); the others keep their gains,
    so the order is that of evaluating every move every round.
    ``progress(done)``, if given, after each round.

    Examples
    --------
    >>> p = np.array([[1.0, 0.0], [3.0, 0.0], [2.0, 0.0], [4.0, 0.0]])
    >>> two_opt(p, np.arange(4)).tolist()
    [0, 2, 1, 3]
    >>> two_opt(p, np.arange(4), rounds=0).tolist()
    [0, 1, 2, 3]
    """
    p = np.asarray(points, dtype=np.float64)
    idx = np.concatenate([[-1], np.asarray(order, dtype=np.int64)])
    q = np.vstack([np.asarray(start, dtype=np.float64)[None, :], p[idx[1:]]])
    if len(q) <= 3:
        return idx[1:]
    k = min(neighbors, len(q) - 1)
    near = cKDTree(q).query(q, k=k + 1, workers=-1)[1][:, 1:]  # by place in the starting q
    place = np.arange(len(q))  # place[position now] = place in the starting q
    pos = np.arange(len(q))  # its inverse
    tol = 1e-9 * float(np.ptp(q, axis=0).max())
    done = 0
    # every position's moves, then those of the positions the last moves may have changed
    rows, kept = np.arange(len(q)), None
    while rounds is None or done < rounds:
        done += 1
        edge = np.append(np.hypot(*np.diff(q, axis=0).T), 0.0)  # edge[a] = |q[a+1] - q[a]|
        moves = _merged(kept, _candidates(q, edge, near, place, pos, tol, rows))
        changed = _apply_moves(moves[:6], (q, idx, place), pos)
        if changed is None:
            break
        again = _rows_to_evaluate(changed, near, place, pos)
        rows = np.flatnonzero(again)
        # the other positions' moves read nothing that changed: the same gains, kept
        keep = ~again[moves[6] % (len(q) * k) // k]
        kept = [field[keep] for field in moves]
        if progress is not None:
            progress(done)
    return idx[1:]


#: Above this many dots ``"auto"`` skips the greedy order (a Python loop).
GREEDY_MAX = 200_000


def pen_path_order(points, *, method="auto", start=(0.0, 0.0), rounds=None):
    """Order the dots along a short pen path.

    Parameters
    ----------
    points : (n, 2) array_like
    method : {"auto", "hilbert", "greedy", "none"}
        ``"hilbert"``: sort along a Hilbert curve (vectorized, about 0.5 us
        per dot); ``"greedy"``: nearest unvisited dot next (cKDTree, a
        Python loop, about 40 us per dot); ``"auto"`` (default): the shorter
        of the two (Hilbert only above :data:`GREEDY_MAX` dots), then
        :func:`two_opt` (``benchmarks/pen_path.py`` measures them; the table
        is in the docs' plotter guide);
        ``"none"``: as given. Every method keeps the given order when it is
        not longer.
    start : (2,) array_like
        Where the pen starts (the SVG origin by default).
    rounds : int, optional
        Rounds of the 2-opt of ``"auto"`` (default :func:`two_opt_rounds`
        of the number of dots: the same order on every machine).

    Returns
    -------
    order : (n,) int64
        A permutation of ``range(n)``.
    travel_before, travel_after : float
        Pen-up travel (same units as ``points``) in the given order and in
        the new order, both from ``start``.

    Examples
    --------
    >>> p = np.random.default_rng(0).random((500, 2))
    >>> order, before, after = pen_path_order(p)
    >>> sorted(order) == list(range(500)), after < before
    (True, True)
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    if method not in PEN_PATHS:
        raise ValueError(f"pen path method must be one of {', '.join(PEN_PATHS)}, got {method!r}")
    rounds = (two_opt_rounds(n) if rounds is None else rounds) if method == "auto" and n >= 2 else 0
    # the run's stage (diskpack_cl.progress): the first orders, then each 2-opt round
    with stage("pen path", 1 + rounds) as advance:
        orders = [np.arange(n)]
        if n >= 2 and method in ("auto", "hilbert"):
            orders.append(hilbert_order(p))
        if n >= 2 and (method == "greedy" or (method == "auto" and n <= GREEDY_MAX)):
            orders.append(greedy_order(p, start))
        order, before, after = _shortest(p, orders, start)
        advance(1)
        if rounds:
            order = two_opt(p, order, start=start, rounds=rounds, progress=lambda k: advance(1 + k))
            after = path_travel(p, order, start=start)
    return order, before, after


def _shortest(p, orders, start):
    """``(order, travel of the first order, travel)`` of the shortest of `orders`."""
    travel = [path_travel(p, o, start=start) for o in orders]
    best = int(np.argmin(travel))
    return orders[best], travel[0], travel[best]
