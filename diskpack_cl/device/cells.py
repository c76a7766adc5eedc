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

import math
import weakref

import numpy as np
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
# Inputs of at least this many bytes go to a CPU device as their host array itself
# (DeviceStage.lend): at a million sites a device copy of the 42 MB of inputs costs 10 000
# fresh pages on the first call and a copy on every call; below it the new buffer's
# sub-buffers and kernel arguments (some 100 us) cost more than the copy saves.
LEND_BYTES = 1 << 20

#: Flag bits of the kernel (``diskpack_cl/device/kernels/cells.cl``): why a cell was not proven.
FLAGS = {"list_full": 1, "pivots": 2, "unbounded": 4, "scan_wide": 8, "near_full": 16,
         "rounds": 32, "shift": 64, "nn": 128}
_NN = FLAGS["nn"]

#: Kernel objects of launchers no longer alive, by (program, kernel name): :class:`_Launcher`.
_SPARE_KERNELS = {}
#: Programs (``cl_program`` addresses) whose cell_mic has run once: :meth:`CellMIC._warm`.
_WARMED = set()

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
        self._kernel, self._rows_kernel = _Launcher(kernels["cell_mic"]), _Launcher(kernels["mic_rows"])
        dev = self.ctx.devices[0]
        self.group = group_size(kernels["cell_mic"], dev,
                                max(GROUP, preferred_multiple(kernels["cell_mic"], dev)))
        self._rows_group = group_size(kernels["mic_rows"], dev, 64)
        # whole groups per enqueue: the last group of one must not reach into the next
        self.chunk = CHUNK - CHUNK % self.group
        self._order = None
        self._packs = {}
        self._perm = None     # the last sort's move of sorted positions (_buckets), or None
        self._sorts = 0       # sorts so far (_buckets)
        self._basis = None    # (sort, flip): the sort of the last warm call, which of the
                              # two basis buffers holds its bases
        if self._kernel.program not in _WARMED:
            self._warm()
            _WARMED.add(self._kernel.program)

    def _warm(self):
        """Run the kernel once on a few sites, so that PoCL's lazy compilation
        is not charged to the first real call (once a program: the programs are
        built once a process, and a relaxation of a thousand sites makes an
        engine, whose warm call cost about half a millisecond, each time)."""
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
        # 32-bit ids where they fit: the stable sort below takes a sixth less time than on 64
        ids = np.int32 if nbx * nby < 2**31 else np.int64
        bx = np.clip((pts[:, 0] / bw).astype(ids), 0, nbx - 1)
        by = np.clip((pts[:, 1] / bh).astype(ids), 0, nby - 1)
        bid = by * ids(nbx) + bx
        reuse = self._order is not None and len(self._order) == n
        prev = self._order if reuse else np.arange(n)
        perm = np.argsort(bid[prev], kind="stable")
        order = prev[perm]
        self._order, self._perm = order, perm if reuse else None
        self._sorts += 1
        counts = np.bincount(bid, minlength=nbx * nby)
        start = np.zeros(nbx * nby + 1, np.int32)
        np.cumsum(counts, out=start[1:])
        return order, start, _bucket_maxima(w, bid, nbx * nby), (nbx, nby, bw, bh)

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

        from scipy.ndimage import maximum_filter  # not loaded at start-up: weighted sets only

        win = min(_MAX_WINDOW, int(np.ceil(np.sqrt(wmax) / min(bw, bh))) + 2)
        mode = "wrap" if self.domain.periodic else "constant"
        loc = maximum_filter(bwmax.reshape(nby, nbx), size=2 * win + 1, mode=mode, cval=0.0)
        return loc.ravel(), win

    # -- work --------------------------------------------------------------
    def solve(self, points, weights=None, *, certify=True, cells=None, density=None, warm=False):
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
        warm : bool, optional
            Start each cell's simplex from its optimal basis of the last call,
            where that was a warm call on as many sites (its bases are kept on
            the device) and the basis is in the cell's list and dual feasible,
            else from the sectors' nearest sites; only for all cells (`cells`
            None).  For the steps of a relaxation, whose sites move by a
            fraction of their spacing: the same optimum, found with fewer
            pivots (the centres may differ in the last bits where the basis
            is solved in another order).

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
            :func:`diskpack_cl._checks.check_sites` refuses, cells not
            integer indices of sites, or `warm` with `cells`.

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
            pos, rows = _positions(order, None if cells is None else checked_cells(cells, len(X)))
            warm = self._warm_mode(warm, cells)
            up, win = self._inputs(X, w, order, start, bwmax, grid, pos, rows, warm)
        with self.timings("device"):
            out = self._run(up, grid, win, w.max(), len(pos), certify, warm)
        return self._finish(up.views["site"], up.views["weight"], out, pos, rows)

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
        n, dom = len(X), self.domain
        with self.timings("buckets"):
            order, start, _, (nbx, nby, bw, bh) = self._buckets(X, w)
            up = self._pack("inputs", (("site", np.float64, (n, 2)), ("start", np.int32, start.shape)),
                            lend=True)
            Xs = _take(X, order, up.views["site"])
            up.views["start"][...] = start
        with self.timings("device"):
            up.send(self.queue)
            nn = np.empty(n)
            b_nn = self.buffer("out_nn", nn.nbytes)
            kernel(self.queue, (padded(n, group),), (group,), up.parts["site"], up.parts["start"],
                   np.int32(n), np.int32(nbx), np.int32(nby), np.float64(bw), np.float64(bh),
                   np.float64(dom.width), np.float64(dom.height), b_nn)
            cl.enqueue_copy(self.queue, nn, b_nn)
        far = np.flatnonzero(nn < 0)
        if len(far):
            nn[far] = _nearest(Xs, dom, far)
        return _scatter(nn, order)

    def _pack(self, name, fields, lend=False):
        """The :class:`_Packed` arrays `fields` in device buffer `name` (`lend`: inputs the
        kernels only read): the last one made under that name where its fields are the
        same (a relaxation's every step)."""
        pack = self._packs.get(name)
        if pack is None or pack.fields != fields:
            pack = _Packed(self, name, fields, None if pack is None else pack.room, lend)
            self._packs[name] = pack
        return pack

    def _inputs(self, X, w, order, start, bwmax, grid, pos, rows, warm):
        """The kernels' inputs, written into their packed host array (sites and weights in
        bucket order, the buckets' start and weight maxima, the cells' sorted positions
        and result rows; with `warm` bits, the last sort's move of sorted positions and its
        inverse): one copy to the device.
        ``(packed, win)``, `win` the window of :meth:`_local_wmax`."""
        n, m = len(X), len(pos)
        bwloc, win = self._local_wmax(bwmax, grid, w.max())
        moves = (("prevpos", np.int32, (n,)), ("newpos", np.int32, (n,))) if warm else ()
        up = self._pack("inputs", (("site", np.float64, (n, 2)), ("weight", np.float64, (n,)),
                                   ("start", np.int32, start.shape), ("bwmax", np.float64, bwmax.shape),
                                   ("bwloc", np.float64, bwmax.shape), ("cells", np.int32, (m,)),
                                   ("rows", np.int32, (m,))) + moves, lend=True)
        v = up.views
        _take(X, order, v["site"])
        _take(w, order, v["weight"])
        v["start"][...], v["bwmax"][...], v["bwloc"][...] = start, bwmax, bwloc
        v["cells"][...], v["rows"][...] = pos, rows
        if warm & 1:   # (the positions move little: both passes run through memory in order)
            v["prevpos"][...] = self._perm
            v["newpos"][self._perm] = np.arange(n, dtype=np.int32)
        return up, win

    def _warm_mode(self, warm, cells):
        """cell_mic's ``warm`` bits for this call (after its sort): none without `warm`;
        else write the bases, and read them too where the call before was warm and its
        sort's positions are the ones this sort moved."""
        if not warm:
            return 0
        if cells is not None:
            raise ValueError("a warm start solves all cells: no cells with warm")
        held = self._perm is not None and self._basis is not None and self._basis[0] == self._sorts - 1
        self._basis = (self._sorts, 1 - self._basis[1] if held else 0)
        return 3 if held else 2

    def _run(self, up, grid, win, wmax, n, codes, warm=0):
        """The kernels on the `n` cells of the packed inputs `up` (:meth:`_inputs`, with
        its `win`; `wmax` the largest weight; `warm` the kernel's bits, :meth:`_warm_mode`).
        With `codes`, cell_mic's ``mic`` and
        ``codes`` in the order of the cells, for the host's re-solve (which puts them by
        row itself); else ``center``, ``radius`` and ``nn`` by result row and ``flags`` in
        the order of the cells, as ``mic_rows`` puts them (32 of the 80 bytes a cell).
        One copy up, one down, one wait: at a thousand sites each costs about what the
        kernel does."""
        dom, b = self.domain, up.parts
        mine = (("mic", np.float64, (n, 4)), ("codes", np.int32, (n, 4 + MAXNEAR)))
        rowed = (("center", np.float64, (n, 2)), ("radius", np.float64, (n,)),
                 ("nn", np.float64, (n,)), ("flags", np.int32, (n,)))
        down = self._pack("outputs", mine if codes else rowed + mine)
        out = down.parts
        up.send(self.queue)
        events = self._solve_cells(b, out, n, len(up.views["site"]), grid, win, wmax, warm)
        if not codes:
            self._rows_kernel(self.queue, (padded(n, self._rows_group),), (self._rows_group,),
                              b["site"], b["cells"], b["rows"], np.int32(n), np.float64(dom.width),
                              np.float64(dom.height), out["mic"], out["codes"], out["center"],
                              out["radius"], out["nn"], out["flags"])
        # the results' own arrays, every call: the MIC returned holds them
        views, received = down.receive(self.queue, None if codes else "mic")
        for ev in events:
            # a chunk takes well under a second, so a plain wait per chunk
            # answers Ctrl-C in time without wait_for's helper thread
            ev.wait()
        received.wait()
        if self.profile:
            self.timings.kernel("cell_mic", sum((ev.profile.end - ev.profile.start) * 1e-9
                                                for ev in events))
        self.transfers = {"bytes_to_device": up.nbytes, "bytes_from_device": _nbytes(views)}
        return views

    def _solve_cells(self, b, bufs, n, n_sites, grid, win, wmax, warm):
        """Enqueue cell_mic on the `n` cells of ``b["cells"]`` (uploaded inputs `b`,
        outputs ``bufs["mic"]`` and ``bufs["codes"]``; `warm` its bits, with ``b["prevpos"]``
        and ``b["newpos"]`` where set), a chunk of work items an enqueue; their events."""
        # without warm bits the kernel reads none of these: any buffer will do; the
        # bases alternate between two buffers, read from one, written to the other
        flip = self._basis[1] if warm else 0
        size = 12 * n_sites if warm else 8
        basis = [self.buffer(f"basis{k}", size) for k in (1 - flip, flip)]
        moves = (b["prevpos"], b["newpos"]) if warm else (basis[0], basis[0])
        nbx, nby, bw, bh = grid
        dom = self.domain
        tol = 1e-12 * max(dom.width, dom.height)
        near_tol = 1e-7 * np.sqrt(dom.area / n_sites)
        return [self._kernel(
            self.queue, (padded(min(self.chunk, n - off), self.group),), (self.group,),
            b["site"], b["weight"], b["start"], b["bwmax"], b["bwloc"], np.int32(win),
            b["cells"], np.int32(n), np.int32(nbx), np.int32(nby), np.float64(bw),
            np.float64(bh), np.float64(dom.width), np.float64(dom.height), np.float64(wmax),
            np.float64(tol), np.float64(near_tol), np.int32(off), bufs["mic"], bufs["codes"],
            np.int32(warm), *moves, *basis)
            for off in range(0, n, self.chunk)]

    def _refine(self, X, w, out, pos, sites):
        """Host re-solve and check of the cells at sorted positions `pos` (their `sites`):
        ``(q, R, accepted)``."""
        with self.timings("refine"):
            q, R, ok = refine_active(X, w, self.domain, out["codes"][:, :3], out["codes"][:, 4:],
                                     cells=pos)
            # the device and the host solved the same 3 x 3 system: same radius, same centre
            scale = max(self.domain.width, self.domain.height)
            off = np.abs(sites + q - out["mic"][:, :2])
            # the larger of the two columns, not np.all along rows (several times slower)
            agree = ((np.abs(R - out["mic"][:, 2]) <= 1e-9 * scale)
                     & (np.maximum(off[:, 0], off[:, 1]) <= 1e-9 * scale))
        return q, R, ok & agree

    def _finish(self, X, w, out, pos, rows):
        """The MICs of the cells at sorted positions `pos`, by result row (`rows`): the
        device's, or where :meth:`_run` read back its codes, the host's re-solve of them
        (:meth:`_certified`); exact_mic for the cells the device could not prove or the
        host refused."""
        if "flags" not in out:   # cell_mic's own answers came back: the flags and nn from them
            out["flags"] = np.ascontiguousarray(out["codes"][:, 3])
            out["nn"] = _scatter(out["mic"][:, 3], rows)
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
        raised_flags = flags[raised]
        stats.update({name: int(np.count_nonzero(raised_flags & bit)) if len(raised) else 0
                      for name, bit in FLAGS.items()})
        stats.update(self.transfers)
        return MIC(centers, R, empty, stats, nn)

    def _certified(self, X, w, out, pos, rows):
        """``(centers, R, refused)``: the host's re-solve of the cells at sorted positions
        `pos`, by result row (`rows`), and the positions in `pos` of the cells the device
        proved and the host refused."""
        sites = np.take(X, pos, axis=0)
        q, R, accepted = self._refine(X, w, out, pos, sites)
        refused = np.flatnonzero(~accepted & ((out["flags"] & ~_NN) == 0))
        centers, _ = mic_centres(sites, q, R, self.domain)
        return _scatter(centers, rows), _scatter(R, rows), refused


class _Launcher:
    """A kernel of this stage's own (the program's kernels are shared by every stage built
    with the same switches), called as pyopencl's are, that sets its arguments only where
    they differ from the last call's: setting cell_mic's twenty costs about 90 us, more
    than the kernel at a thousand sites, and a relaxation's steps pass the same ones.

    Its kernel object comes from :data:`_SPARE_KERNELS` where a launcher no longer alive
    left one (it sets all arguments on its first call), else it is made: a fresh kernel
    object costs about 0.35 ms (pyopencl looks its invoker up in a cache on disk), and a
    relaxation of a thousand sites makes two each time it makes an engine."""

    def __init__(self, kernel):
        self.program = kernel.program.int_ptr
        key = (self.program, kernel.function_name)
        spare = _SPARE_KERNELS.setdefault(key, [])
        try:
            self.kernel = spare.pop()
        except IndexError:
            # a fresh kernel object of the same program: cl.Kernel(kernel.program, name)
            # would look for the program's source first, by creating a kernel named "_source"
            self.kernel = next(k for k in kernel.program.all_kernels()
                               if k.function_name == kernel.function_name)
        weakref.finalize(self, spare.append, self.kernel)
        self._args = None   # held: no buffer of theirs is freed and its address reused

    def __call__(self, queue, global_size, local_size, *args):
        if self._args is None or len(args) != len(self._args) or not all(
                a is b or (type(a) is type(b) and a == b) for a, b in zip(args, self._args)):
            self.kernel.set_args(*args)
            self._args = args
        return cl.enqueue_nd_range_kernel(queue, self.kernel, global_size, local_size)


def _bucket_maxima(w, bid, nb):
    """The largest weight of each of `nb` buckets (`bid`: each site's), 0 in an empty one.

    The weights are shifted so that the least is 0 (:meth:`CellMIC.solve`), so a maximum
    from 0 is the bucket's own: ``np.maximum.at`` is several times faster than a
    ``reduceat`` over the sites in bucket order (1M sites, about 2 a bucket: 4 against 30
    ms), and a maximum is the same in any order.

    Examples
    --------
    >>> _bucket_maxima(np.array([0.0, 2.0, 1.0]), np.array([2, 0, 0]), 4).tolist()
    [2.0, 0.0, 0.0, 0.0]
    """
    bwmax = np.zeros(nb)
    if w.any():   # a Voronoi diagram's weights and maxima are all 0 (a pass saved)
        np.maximum.at(bwmax, bid, w)
    return bwmax


def _take(a, order, out):
    """``a[order]`` written into `out`: np.take, as numpy's row gather ``X[order]`` is several
    times slower (40 against 5 ms at 1M); mode "clip" so that it writes `out` directly
    (with "raise" numpy buffers it), `order` holding valid indices."""
    return np.take(a, order, axis=0, out=out, mode="clip")


def _layout(fields, align):
    """Byte offset of each of `fields` (``(name, dtype, shape)``) in one packed array, each
    aligned to `align` bytes (a sub-buffer's origin must be) and at least `align` long
    (a sub-buffer is never empty), and the total size."""
    offsets, at = {}, 0
    for name, dtype, shape in fields:
        offsets[name] = at
        at += max(1, -(-np.dtype(dtype).itemsize * math.prod(shape) // align)) * align
    return offsets, at


class _Packed:
    """Arrays packed into one host array and one device buffer (`name` of `stage`), so
    that a call moves them in one copy: PoCL spends about 45 us on a copy, and at a
    thousand sites seven copies up and six down cost more than the kernel.

    ``parts``: sub-buffers at the fields' offsets, the kernels' arguments, by field
    name; ``views``: typed views of the host array the inputs are written into, made
    on first use (the outputs come back into a new array every call, :meth:`receive`),
    in ``room``, the host memory of the last layout (`room`) where it is large
    enough: a local step's sub-problem has a size of its own every call, and new
    pages for it each time cost more than its copy.  `lend`: inputs that the kernels
    only read, which a CPU device takes as the host array itself where they fill
    :data:`LEND_BYTES` (:meth:`send`: no device buffer, no copy).
    """

    def __init__(self, stage, name, fields, room=None, lend=False):
        self.stage, self.name, self.fields = stage, name, fields
        align = stage.device.mem_base_addr_align // 8
        self.offsets, self.total = _layout(fields, align)
        self.lent = lend and stage.is_cpu and self.total >= LEND_BYTES
        self.parts = {}
        self.buffer = None if self.lent else stage.buffer(name, self.total)
        if not self.lent:
            self._split()
        self.room = room if room is not None and len(room) >= self.total else None
        self._host = self._sent = self._all = None

    def _split(self):
        """``parts``: the sub-buffers of ``buffer`` at the fields' offsets (in place: a
        caller may hold the dict)."""
        ends = list(self.offsets.values())[1:] + [self.total]
        self.parts.update({f: self.buffer.get_sub_region(o, e - o)
                           for (f, o), e in zip(self.offsets.items(), ends)})

    def _views(self, host, names):
        # math.prod: np.prod of a shape tuple costs some microseconds, five fields a call
        return {f: host[self.offsets[f]:].view(dtype)[:math.prod(shape)].reshape(shape)
                for f, dtype, shape in self.fields if f in names}

    @property
    def views(self):
        if self._host is None:
            if self.room is None:
                self.room = _aligned(self.total, self.stage.device.mem_base_addr_align // 8)
            self._host = self.room[:self.total]
            self._all = self._views(self._host, self.offsets)
        return self._all

    @property
    def nbytes(self):
        return _nbytes(self.views)

    def send(self, queue):
        """Queue the copy of the host array to the device, or lend it (``lent``: its
        sub-buffers new in ``parts``); the host array must not change until the queue
        has read it (a copy's event is kept till the next send: pyopencl waits for a host
        copy whose event goes)."""
        if self.lent:
            self.buffer = self.stage.lend(self.name, self._host)
            self._split()
        else:
            self._sent = cl.enqueue_copy(queue, self.buffer, self._host, is_blocking=False)

    def receive(self, queue, upto=None):
        """Queue the copy of the device buffer (the fields before `upto`; None: all) into
        a new host array: ``(views, event)``, the views valid once the event is done (keep
        the event till then: pyopencl waits for a host copy whose event goes)."""
        names = list(self.offsets)
        names = names[:names.index(upto)] if upto else names
        host = np.empty(self.offsets[upto] if upto else self.total, np.uint8)
        return self._views(host, names), cl.enqueue_copy(queue, host, self.buffer, is_blocking=False)


def _aligned(nbytes, align):
    """An uninitialized uint8 array of `nbytes` whose start is a multiple of `align` bytes
    (a lent host array's sub-buffers start at the same offsets as a device buffer's)."""
    raw = np.empty(nbytes + align, np.uint8)
    skip = -raw.ctypes.data % align
    return raw[skip:skip + nbytes]


def _nbytes(views):
    """Bytes of the arrays `views` (a dict)."""
    return int(sum(v.nbytes for v in views.values()))


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


def _code_constraints(X, w, i, c, domain):
    """Half-planes ``q . n <= beta`` of cells `i` from the kernel's constraint codes `c`
    (one code a cell of `i`: flat arrays of the same length).

    codes >= 0 name site ``code // 9`` shifted by ``(code % 9 // 3 - 1,
    code % 3 - 1)`` periods; -1..-4 the left, right, top and bottom edges;
    anything else is an unused slot (beta = 1e300).  Returns arrays of
    shape ``(len(c), 2)`` and ``(len(c),)``.  Points are gathered
    as complex numbers (one 16-byte load each, several times faster than
    numpy's row gather) and lengths are ``sqrt(x^2 + y^2)``, as in the kernel.
    """
    Z = np.ascontiguousarray(X).view(np.complex128).ravel()
    site = c >= 0
    j, r = np.divmod(np.where(site, c, 4), 9)
    # the nine shifts in the domain's periods first, then one gather: 3 passes fewer
    a = Z[j] + (_SHIFT.real * domain.width + 1j * _SHIFT.imag * domain.height)[r] - Z[i]
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
    return N.view(np.float64).reshape(len(c), 2), B


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
    # flat indices, not np.nonzero's pairs or reductions along rows of three: at a
    # thousand cells these calls are most of the re-solve's cost
    rows, cols = np.divmod(np.flatnonzero(near != NO_CODE), near.shape[1])
    basis = active.ravel()
    k = len(basis)
    # the basis and the near-tight constraints in one pass (a pass is some 30 numpy calls)
    N, B = _code_constraints(X, w, np.concatenate([np.repeat(cells, 3), cells[rows]]),
                             np.concatenate([basis, near[rows, cols]]), domain)
    # the basis' normals as contiguous (k, 3) arrays: the arithmetic is faster on them
    a, b = (np.ascontiguousarray(N[:k, j]).reshape(-1, 3) for j in (0, 1))
    Ba = B[:k].reshape(-1, 3)
    R, inv, ok = cramer_inverse(a, b, Ba)
    q = np.stack(power_vertex(a, b, Ba, inv), 1)
    ok[np.flatnonzero(basis < -4) // 3] = False   # a code that is neither a site nor an edge
    if len(rows):
        slack = B[k:] - np.einsum("kj,kj->k", N[k:], q[rows]) - R[rows]
        ok[rows[~(slack >= -tol)]] = False   # NaN too
    return q, R, ok


def _nearest(X, domain, at):
    """Distance from the points `at` (indices) to their nearest other point (cKDTree)."""
    from scipy.spatial import cKDTree  # not loaded at start-up: few sets have a site this far

    box = (domain.width, domain.height) if domain.periodic else None
    d, _ = cKDTree(X, boxsize=box).query(X[at], k=2)
    return d[:, 1]
