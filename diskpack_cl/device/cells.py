"""Per-cell stage: the maximal inscribed circle of every power cell on the device.

``diskpack_cl/device/kernels/cells.cl`` gives each site one work item that gathers its
neighbours from a bucket grid, solves its cell's Chebyshev-centre linear
program in float64 by the dual simplex method, proves the answer against
every site that could cut the disk, and reports the three active
constraints.  The host then re-solves every cell from those constraints in
float64 (vectorized numpy), checks dual feasibility and the near-tight
constraints, and sends the few cells the device could not prove, or that
fail the check, to :func:`diskpack_cl.geometry.exact_mic`.  The results are
the same MICs as ``exact_mic`` computes for all cells, at a fraction of its
cost.  ``solve(..., certify=False)`` skips the host's re-solve and takes the
device's answer wherever the device proved it (the global iterates of
``relax_poisson(local=True)``, whose returned rho a KD-tree measures); the
kernel ``mic_rows`` then puts those answers into the caller's order on the
device, and they are all that comes back.

Devices without ``cl_khr_fp64`` cannot run this kernel; :func:`~diskpack_cl.device.stage.has_fp64`
tells, and the engines fall back to the raster estimate refined by
``exact_mic``.
"""

from __future__ import annotations


import numpy as np
from scipy.ndimage import maximum_filter
from scipy.spatial import cKDTree
import pyopencl as cl

from .._checks import check_sites
from .context import group_size, padded, preferred_multiple
from .stage import DeviceStage
from ..domain import Domain
from ..geometry import MIC, mic_centres, checked_cells, cramer_inverse, power_vertex, exact_mic

__all__ = ["CellMIC", "FLAGS"]

MAXC = 64        # constraint list capacity per work item
MAXNEAR = 8      # near-tight constraints reported besides the basis
NO_CODE = -9     # empty slot of the near-tight list
CHUNK = 1 << 17  # work items per enqueue (rounded down to whole groups): each wait lets Ctrl-C through
# Work-group size asked for (at least the kernel's preferred multiple, a
# GPU's warp; at most the kernel's and the device's limits): each work item
# keeps a ~2.3 KB constraint list in private memory, and PoCL lays a whole
# work-group's out on one thread's stack; 16 also balances small sets over
# the cores.
GROUP = 16
_MAX_WINDOW = 8  # widest weight window of the proof scan, in buckets (CellMIC._local_wmax)

#: Flag bits of the kernel (``diskpack_cl/device/kernels/cells.cl``): why a cell was not proven.
FLAGS = {"list_full": 1, "pivots": 2, "unbounded": 4, "scan_wide": 8, "near_full": 16,
         "rounds": 32, "shift": 64, "nn": 128}
_NN = FLAGS["nn"]

_EDGE_NORMALS = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])


class CellMIC(DeviceStage):
    """OpenCL processing object for the exact MICs of all power cells.

    Parameters
    ----------
    domain : Domain
        Unit torus or image rectangle.
    device : str or pyopencl.Context, optional
        See :func:`diskpack_cl.get_context`.
    profile : bool, optional
        Profile the kernel with OpenCL events (``kernel_cell_mic`` and
        ``kernel`` in `timings`).
    sites_per_bucket : float, optional
        Mean occupancy of the bucket grid that the gather walks.
    timings : Stopwatch, optional
        Where the seconds of each stage go: ``buckets``, ``device``
        (upload, kernel, readback), ``refine`` (host re-solve and check),
        ``fallback`` (default: a new one, :attr:`timings`); an engine
        passes its own.

    Raises
    ------
    NoOpenCLError
        No OpenCL device.
    RuntimeError
        The device has no float64 support.

    Examples
    --------
    >>> import numpy as np
    >>> from diskpack_cl.geometry import Domain, exact_mic
    >>> pts = np.random.default_rng(0).random((500, 2))
    >>> res = CellMIC(Domain.torus()).solve(pts)
    >>> bool(np.allclose(res.radii, exact_mic(pts).radii, rtol=0, atol=1e-12))
    True
    """

    def __init__(self, domain: Domain, device=None, *, profile=False, sites_per_bucket=2.0,
                 timings=None):
        self.domain = domain
        super().__init__(device, profile=profile, timings=timings, fp64=True)
        self.sites_per_bucket = float(sites_per_bucket)
        defines = {"PERIODIC": int(domain.periodic), "MAXC": MAXC, "MAXNEAR": MAXNEAR}
        kernels = self.program("cells", defines)
        self._kernel, self._rows_kernel = kernels["cell_mic"], kernels["mic_rows"]
        dev = self.ctx.devices[0]
        self.group = group_size(self._kernel, dev, max(GROUP, preferred_multiple(self._kernel, dev)))
        self._rows_group = group_size(self._rows_kernel, dev, 64)
        # whole groups per enqueue: the last group of one must not reach into the next
        self.chunk = CHUNK - CHUNK % self.group
        self._order = None
        self._warm()

    def _warm(self):
        """Run the kernel once on a few sites, so that PoCL's lazy compilation
        is not charged to the first real call."""
        dom = self.domain
        pts = (np.random.default_rng(0).random((16, 2)) * (dom.width, dom.height))
        with self.timings.discarded():
            self.solve(pts)
        self._order = None

    def _grid(self, n, density=None):
        dom = self.domain
        density = max(n, 1) / dom.area if density is None else density
        side = np.sqrt(self.sites_per_bucket / density)
        nbx = max(1, int(np.ceil(dom.width / side)))
        nby = max(1, int(np.ceil(dom.height / side)))
        return nbx, nby, dom.width / nbx, dom.height / nby

    def _buckets(self, pts, w, density=None):
        """Sites sorted by bucket (a grid for `density`, :meth:`solve`); the last order is
        reused, so re-sorting a slowly moving set costs about a linear pass (timsort on
        sorted runs)."""
        n = len(pts)
        nbx, nby, bw, bh = self._grid(n, density)
        bx = np.clip((pts[:, 0] / bw).astype(np.int64), 0, nbx - 1)
        by = np.clip((pts[:, 1] / bh).astype(np.int64), 0, nby - 1)
        bid = by * nbx + bx
        prev = self._order if self._order is not None and len(self._order) == n else np.arange(n)
        order = prev[np.argsort(bid[prev], kind="stable")]
        self._order = order
        counts = np.bincount(bid, minlength=nbx * nby)
        start = np.zeros(nbx * nby + 1, np.int32)
        np.cumsum(counts, out=start[1:])
        bwmax = np.zeros(nbx * nby)
        if w.any():   # a Voronoi diagram's weights and maxima are all 0 (15 ms at 1M saved)
            nonempty = counts > 0
            bwmax[nonempty] = np.maximum.reduceat(w[order], start[:-1][nonempty])
        return order, start, bwmax, (nbx, nby, bw, bh)

    def _local_wmax(self, bwmax, grid, wmax):
        """Largest weight within ``win`` buckets of each bucket, and ``win``.

        The kernel's proof scan reaches as far as the heaviest site could
        cut; with the weights of a stippling (100x apart) the global maximum
        would send every cell's scan several spacings out, where the local
        one keeps it at its neighbours.  The window is wide enough for the
        global maximum's reach to fit in it, so the kernel can use the local
        value wherever no site outside the window can reach.
        """
        nbx, nby, bw, bh = grid
        if wmax == 0.0:
            return bwmax, 0

        win = min(_MAX_WINDOW, int(np.ceil(np.sqrt(wmax) / min(bw, bh))) + 2)
        mode = "wrap" if self.domain.periodic else "constant"
        loc = maximum_filter(bwmax.reshape(nby, nbx), size=2 * win + 1, mode=mode, cval=0.0)
        return loc.ravel(), win

    # -- work --------------------------------------------------------------
    def solve(self, points, weights=None, *, certify=True, cells=None, density=None):
        """MIC of every power cell, or of the cells `cells`, certified as by :func:`exact_mic`.

        Parameters
        ----------
        points : (n, 2) array_like
            Sites (wrapped into the torus when periodic; inside the
            rectangle otherwise).
        weights : (n,) array_like, optional
            Power weights (squared radii); None for the Voronoi diagram.
        certify : bool, optional
            False: take the device's answer for every cell it proved, without
            the host's re-solve and check (``rejected`` is then 0); cells it
            could not prove still go to :func:`exact_mic`.  For iterates
            whose caller certifies the set it returns (about a fifth of a
            call's time at a million sites).
        cells : (m,) array_like of int, optional
            Solve only these cells (every site still constrains them); the
            result has one row per entry, in their order (as
            ``exact_mic(..., cells=cells)``).  The kernel runs on these cells
            only: the few cells of a local step cost what they cost on the
            device, not about 25 us each in ``exact_mic``.
        density : float, optional
            Sites per unit area where the sites lie, which sizes the grid of
            buckets the kernel gathers from (default: their number over the
            domain's area).  A sub-problem in a small part of the domain (a
            local step's) passes its whole set's: a grid sized for its own
            count would put tens of sites in each bucket there, and every
            cell's scan would go through them.

        Returns
        -------
        MIC
            With ``nn``, and ``stats``: ``flagged`` (cells the device could
            not prove), ``rejected`` (cells the host check refused),
            ``fallback`` (cells solved by ``exact_mic``), flag counts by
            reason, ``bytes_to_device`` and ``bytes_from_device`` (the
            transfers of this call).

        Raises
        ------
        ValueError
            Fewer than two sites, sites or weights that
            :func:`diskpack_cl._checks.check_sites` refuses, or cells not
            integer indices of sites.

        Examples
        --------
        >>> pts = np.random.default_rng(0).random((500, 2))
        >>> res = CellMIC(Domain.torus()).solve(pts, cells=[7, 3])
        >>> bool(np.allclose(res.radii, exact_mic(pts, cells=[7, 3]).radii, rtol=0, atol=1e-12))
        True
        """
        X, w = check_sites(points, weights, self.domain, minimum=2)
        w -= w.min()   # as exact_mic: the diagram ignores a common shift
        # everything below runs in bucket order: neighbours sit close in memory
        with self.timings("buckets"):
            order, start, bwmax, grid = self._buckets(X, w, density)
            # np.take: numpy's row gather X[order] is several times slower (40 against 5 ms at 1M)
            Xs, ws = np.take(X, order, axis=0), w[order]
            pos, rows = _positions(order, None if cells is None else checked_cells(cells, len(X)))
        with self.timings("device"):
            out = self._run(Xs, ws, start, bwmax, grid, pos, rows, certify)
        return self._finish(Xs, ws, out, pos, rows)

    def nearest(self, points):
        """Distance from every site to its nearest other site (periodic on a torus), exact.

        :meth:`solve` finds these on its way (``nn``); here they come alone,
        from ``kernels/cells_nearest.cl`` (at a million sites about a tenth of a
        :meth:`solve`), for a set whose MICs are not needed: the iterate
        where :func:`~diskpack_cl.relax_poisson` goes local.  A site with no
        other within a bucket side of it is measured by a KD-tree.

        Examples
        --------
        >>> from diskpack_cl.measures import nearest_neighbor_distances
        >>> pts = np.random.default_rng(0).random((500, 2))
        >>> nn = CellMIC(Domain.torus()).nearest(pts)
        >>> bool(np.allclose(nn, nearest_neighbor_distances(pts), rtol=0, atol=1e-15))
        True
        """
        X, w = check_sites(points, None, self.domain, minimum=2)
        if not self.trusts("cells_nearest"):
            return _nearest(X, self.domain, np.arange(len(X)))
        # built on the first call: the stippling's cells never need it
        kernel = self.program("cells_nearest", {"PERIODIC": int(self.domain.periodic)})["nearest"]
        group = group_size(kernel, self.ctx.devices[0], 64)
        with self.timings("buckets"):
            order, start, _, (nbx, nby, bw, bh) = self._buckets(X, w)
            Xs = np.take(X, order, axis=0)
        with self.timings("device"):
            n, dom = len(Xs), self.domain
            nn = np.empty(n)
            b_nn = self.buffer("out_nn", nn.nbytes)
            kernel(self.queue, (padded(n, group),), (group,),
                   self.upload("site", Xs, wait=False), self.upload("start", start, wait=False), np.int32(n),
                   np.int32(nbx), np.int32(nby), np.float64(bw), np.float64(bh),
                   np.float64(dom.width), np.float64(dom.height), b_nn)
            cl.enqueue_copy(self.queue, nn, b_nn)
        far = np.flatnonzero(nn < 0)
        if len(far):
            nn[far] = _nearest(Xs, dom, far)
        return _scatter(nn, order)

    def _run(self, Xs, ws, start, bwmax, grid, pos, rows, codes):
        """The kernels on the cells at sorted positions `pos`: ``center``, ``radius`` and
        ``nn`` by result row (`rows`: ``mic_rows`` puts them there), ``flags`` in the order
        of `pos`, and with `codes`, cell_mic's ``mic`` and ``codes`` in that order too (for
        the host's re-solve; 48 of the 80 bytes a cell)."""
        n, dom = len(pos), self.domain
        bwloc, win = self._local_wmax(bwmax, grid, ws.max())
        up = {"site": np.ascontiguousarray(Xs), "weight": np.ascontiguousarray(ws), "start": start,
              "bwmax": bwmax, "bwloc": bwloc, "cells": pos, "rows": rows.astype(np.int32)}
        b = {k: self.upload(k, v, wait=False) for k, v in up.items()}
        outs = {"mic": np.empty((n, 4)), "codes": np.empty((n, 4 + MAXNEAR), np.int32),
                "center": np.empty((n, 2)), "radius": np.empty(n), "nn": np.empty(n),
                "flags": np.empty(n, np.int32)}
        bufs = {k: self.buffer("out_" + k, v.nbytes) for k, v in outs.items()}
        self._solve_cells(b, bufs, n, len(Xs), grid, win, ws.max())
        self._rows_kernel(self.queue, (padded(n, self._rows_group),), (self._rows_group,),
                          b["site"], b["cells"], b["rows"], np.int32(n), np.float64(dom.width),
                          np.float64(dom.height), bufs["mic"], bufs["codes"], bufs["center"],
                          bufs["radius"], bufs["nn"], bufs["flags"])
        if not codes:
            del outs["mic"], outs["codes"]
        for k, v in outs.items():
            cl.enqueue_copy(self.queue, v, bufs[k], is_blocking=False)
        self.queue.finish()
        self.transfers = {"bytes_to_device": int(sum(v.nbytes for v in up.values())),
                          "bytes_from_device": int(sum(v.nbytes for v in outs.values()))}
        return outs

    def _solve_cells(self, b, bufs, n, n_sites, grid, win, wmax):
        """cell_mic on the `n` cells of ``b["cells"]`` (uploaded inputs `b`, outputs
        ``bufs["mic"]`` and ``bufs["codes"]``), a chunk of work items an enqueue."""
        nbx, nby, bw, bh = grid
        dom = self.domain
        tol = 1e-12 * max(dom.width, dom.height)
        near_tol = 1e-7 * np.sqrt(dom.area / n_sites)
        events = []
        for off in range(0, n, self.chunk):
            events.append(self._kernel(
                self.queue, (padded(min(self.chunk, n - off), self.group),), (self.group,),
                b["site"], b["weight"], b["start"], b["bwmax"], b["bwloc"], np.int32(win),
                b["cells"], np.int32(n), np.int32(nbx), np.int32(nby), np.float64(bw),
                np.float64(bh), np.float64(dom.width), np.float64(dom.height), np.float64(wmax),
                np.float64(tol), np.float64(near_tol), np.int32(off), bufs["mic"], bufs["codes"]))
        for ev in events:
            # a chunk takes well under a second, so a plain wait per chunk
            # answers Ctrl-C in time without wait_for's helper thread
            ev.wait()
        if self.profile:
            self.timings.kernel("cell_mic", sum((ev.profile.end - ev.profile.start) * 1e-9
                                                for ev in events))

    def _refine(self, X, w, out, pos):
        """Host re-solve and check of the cells at sorted positions `pos`: ``(q, R, accepted)``."""
        with self.timings("refine"):
            q, R, ok = refine_active(X, w, self.domain, out["codes"][:, :3], out["codes"][:, 4:],
                                     cells=pos)
            # the device and the host solved the same 3 x 3 system: same radius, same centre
            scale = max(self.domain.width, self.domain.height)
            agree = ((np.abs(R - out["mic"][:, 2]) <= 1e-9 * scale)
                     & np.all(np.abs(X[pos] + q - out["mic"][:, :2]) <= 1e-9 * scale, axis=1))
        return q, R, ok & agree

    def _finish(self, X, w, out, pos, rows):
        """The MICs of the cells at sorted positions `pos`, by result row (`rows`): the
        device's, or where :meth:`_run` read back its codes, the host's re-solve of them
        (:meth:`_certified`); exact_mic for the cells the device could not prove or the
        host refused."""
        flags = out["flags"]
        raised = np.flatnonzero(flags)   # few cells: one pass over all, then over these
        unproven = raised[(flags[raised] & ~_NN) != 0]
        if "codes" in out:
            centers, R, refused = self._certified(X, w, out, pos, rows)
        else:
            centers, R, refused = out["center"], out["radius"], unproven[:0]
        bad = np.concatenate([unproven, refused])
        with self.timings("fallback"):
            if len(bad):
                mic = exact_mic(X, w, self.domain, cells=pos[bad])
                centers[rows[bad]] = mic.centers
                R[rows[bad]] = mic.radii
        nn = out["nn"]
        far = raised[(flags[raised] & _NN) != 0]   # only these: a cell's nn must not depend on the others
        if len(far):
            nn[rows[far]] = _nearest(X, self.domain, pos[far])
        empty = R < 0
        stats = {"flagged": len(unproven), "rejected": len(refused), "fallback": len(bad),
                 "empty": int(empty.sum())}
        stats.update({name: int(np.count_nonzero(flags[raised] & bit)) for name, bit in FLAGS.items()})
        stats.update(self.transfers)
        return MIC(centers, R, empty, stats, nn)

    def _certified(self, X, w, out, pos, rows):
        """``(centers, R, refused)``: the host's re-solve of the cells at sorted positions
        `pos`, by result row (`rows`), and the positions in `pos` of the cells the device
        proved and the host refused."""
        q, R, accepted = self._refine(X, w, out, pos)
        refused = np.flatnonzero(~accepted & ((out["flags"] & ~_NN) == 0))
        centers, _ = mic_centres(np.take(X, pos, axis=0), q, R, self.domain)
        return _scatter(centers, rows), _scatter(R, rows), refused


def _scatter(a, rows):
    """``b`` with ``b[rows] = a``: an (n, 2) float64 `a` moves as complex numbers, one
    16-byte element a row (numpy's row scatter, like its row gather, is several times
    slower: 30 against 7 ms at a million rows)."""
    b = np.empty(a.shape, a.dtype)   # C order, whatever `a`'s, for the view
    if a.ndim == 2:
        b.view(np.complex128).ravel()[rows] = np.ascontiguousarray(a).view(np.complex128).ravel()
    else:
        b[rows] = a
    return b


def _positions(order, cells):
    """The sorted positions of the cells to solve (all: None), ascending, and the result
    row of each: the kernel walks the sites in bucket order, neighbours close in memory."""
    if cells is None:
        return np.arange(len(order), dtype=np.int32), order
    inv = np.empty(len(order), dtype=np.int64)
    inv[order] = np.arange(len(order))
    pos = inv[cells]
    rows = np.argsort(pos, kind="stable")
    return pos[rows].astype(np.int32), rows


_SHIFT = np.array([-1 - 1j, -1, -1 + 1j, -1j, 0, 1j, 1 - 1j, 1, 1 + 1j])   # code % 9 -> (sx, sy)


def _code_constraints(X, w, cells, codes, domain):
    """Half-planes ``q . n <= beta`` of `cells` from the kernel's constraint codes.

    codes >= 0 name site ``code // 9`` shifted by ``(code % 9 // 3 - 1,
    code % 3 - 1)`` periods; -1..-4 the left, right, top and bottom edges;
    anything else is an unused slot (beta = 1e300).  Returns arrays of
    shape ``codes.shape + (2,)`` and ``codes.shape``.  Points are gathered
    as complex numbers (one 16-byte load each, several times faster than
    numpy's row gather) and lengths are ``sqrt(x^2 + y^2)``, as in the kernel.
    """
    Z = np.ascontiguousarray(X).view(np.complex128).ravel()
    c = codes.ravel()
    i = np.repeat(cells, codes.shape[1])
    site = c >= 0
    j, r = np.divmod(np.where(site, c, 4), 9)
    s = _SHIFT[r]
    a = Z[j] + (s.real * domain.width + 1j * s.imag * domain.height) - Z[i]
    L2 = a.real * a.real + a.imag * a.imag
    L = np.sqrt(L2)
    other = np.nonzero(~site | (L == 0))[0]
    L[other] = 1.0
    N = a / L
    B = (L2 - w[j] + w[i]) / (2 * L) if w.any() else L2 / (2 * L)
    N[other] = 1.0
    B[other] = 1e300
    edge = other[(c[other] <= -1) & (c[other] >= -4)]
    if len(edge) and not domain.periodic:
        e = -c[edge] - 1
        xi = X[i[edge]]
        lim = np.stack([xi[:, 0], domain.width - xi[:, 0], xi[:, 1], domain.height - xi[:, 1]], 1)
        N[edge] = _EDGE_NORMALS[e] @ (1, 1j)
        B[edge] = lim[np.arange(len(edge)), e]
    return N.view(np.float64).reshape(codes.shape + (2,)), B.reshape(codes.shape)


def refine_active(X, w, domain, active, near, cells=None):
    """Re-solve each cell (or each of `cells`) from its three active constraints in
    float64 and check it.

    Parameters
    ----------
    X : (n, 2) float64
        Sites.
    w : (n,) float64
        Weights, shifted so that the smallest is 0 (as the kernel had them).
    domain : Domain
    active : (n, 3) int
        Constraint codes of each cell's optimal basis (see
        :func:`_code_constraints`).
    near : (n, m) int
        Other near-tight constraint codes (``NO_CODE`` for none).
    cells : (k,) int, optional
        The cells `active` and `near` have rows for (default: all n).

    Returns
    -------
    q : (k, 2) float64
        MIC centre relative to the site, one row per cell (k = n without `cells`).
    R : (k,) float64
        MIC radius.
    ok : (k,) bool
        The basis is dual feasible (so R bounds the optimum from above, weak
        duality) and the vertex satisfies every near-tight constraint; with
        the device's proof that no other site comes near, the vertex is the
        optimum.
    """
    cells = np.arange(len(X)) if cells is None else cells
    tol = 1e-11 * max(domain.width, domain.height)
    N, B = _code_constraints(X, w, cells, active, domain)
    R, inv, ok = cramer_inverse(N[..., 0], N[..., 1], B)
    q = np.stack(power_vertex(N[..., 0], N[..., 1], B, inv), 1)
    ok &= np.all((active >= 0) | ((active <= -1) & (active >= -4)), axis=1)
    rows, cols = np.nonzero(near != NO_CODE)
    if len(rows):
        Nn, Bn = _code_constraints(X, w, cells[rows], near[rows, cols][:, None], domain)
        slack = Bn[:, 0] - np.einsum("kj,kj->k", Nn[:, 0], q[rows]) - R[rows]
        np.logical_and.at(ok, rows, slack >= -tol)
    return q, R, ok


def _nearest(X, domain, at):
    """Distance from the points `at` (indices) to their nearest other point (cKDTree)."""
    box = (domain.width, domain.height) if domain.periodic else None
    d, _ = cKDTree(X, boxsize=box).query(X[at], k=2)
    return d[:, 1]
