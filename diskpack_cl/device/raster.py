"""Raster stage: discrete power diagram and inscribed-circle estimates in OpenCL.

The kernels (``kernels/raster_labels.cl``, ``kernels/raster_mic.cl``)
label every grid cell with the site of least power distance, give it its
analytic distance to the boundary of that site's power cell, and reduce the
distances per site to a maximal-inscribed-circle estimate.  The estimate is
only a starting point: :func:`diskpack_cl.geometry.exact_mic` refines it to a
certified float64 result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from . import context as _device
from .._checks import check_sites
from .context import group_size, padded
from .stage import DeviceStage
from ..domain import Domain
from ..labels import cell_centroids
from ..measures import bucket_order

__all__ = ["PowerRaster", "RasterResult", "auto_grid"]

INT_MAX = np.iinfo(np.int32).max
TILE = 8   # widest work-group side of power_labels (diskpack_cl/device/kernels/raster_labels.cl)
CELL_SUMS_SEG, CELL_SUMS_FIX = 32, 2.0 ** 24   # SEG and FIX of diskpack_cl/device/kernels/raster_sums.cl
TILE_ROWS = 16   # grid rows of a work item's tile in the CPU layout (TH in power_gather.h)
# 8 x 8 work-groups per enqueue of power_labels (about 4 M grid cells): each enqueue is
# waited for on its own (wait_for's helper thread); bands of 0.26 M grid cells made an
# 8192 x 8192 raster 256 waits a pass (1M sites, 2 loaded cores: 2.0-2.3 s a labels and
# sums pass, against 1.4-1.6 s in bands of 4 M)
MAX_GROUPS = 65536
# work items per group of cell_max, cell_argmax and cell_sums, at most (the
# kernel and device limits may give fewer); their atomics make the result
# independent of the group size
REDUCE_GROUP = 256
# Bucket rings of the largest weight near each bucket (NEAR_RINGS of power_gather.h): the
# CPU tiles' walks stop where the weights left nearby, not the largest of all, pass no
# site.  A picture's few largest dots set the largest weight (at 8192^2 and 1M dots: 1200
# above most, their radius 3 buckets), and every tile walked the rings out to it; 4
# rings reach past that there (the labels are the same with any value)
NEAR_RINGS = 4
#: Status bits of diskpack_cl/device/kernels/raster_labels.cl (ST_* in common.h): why a labelling is refused.
STATUS = {"ring_limit": 1, "no_owner": 2}


def near_max(a, k, periodic):
    """The largest value of the 2-D array `a` within `k` cells of each (in both axes):
    ``scipy.ndimage.maximum_filter(a, 2 * k + 1)``, with -inf past a rectangle's edges or
    wrapped on a torus (`periodic`), in a few whole-array maxima (7 times faster there).

    Examples
    --------
    >>> near_max(np.array([[0.0, 1.0, 0.0, 0.0, 2.0]]), 1, False).tolist()
    [[1.0, 1.0, 1.0, 2.0, 2.0]]
    >>> near_max(np.array([[0.0, 1.0, 0.0, 0.0, 2.0]]), 1, True).tolist()
    [[2.0, 1.0, 1.0, 2.0, 2.0]]
    """
    m = np.pad(a, k, mode="wrap") if periodic else np.pad(a, k, constant_values=-np.inf)
    for axis in (0, 1):
        m = np.moveaxis(m, axis, 0)
        width = 1   # m holds the maxima of windows of `width` cells: double it
        while 2 * width <= 2 * k + 1:
            m = np.maximum(m[:-width], m[width:])
            width *= 2
        rest = 2 * k + 1 - width   # two windows of `width`, overlapping, make one of 2k + 1
        m = np.maximum(m[:len(m) - rest], m[rest:])
        m = np.moveaxis(m, 0, axis)
    return m


def auto_grid(n, domain, cells_per_site=16):
    """Raster shape ``(ny, nx)`` with about `cells_per_site` grid cells per site.

    16 grid cells (4 x 4 across a cell) put the raster MIC estimate within
    about half a grid cell of the exact one (median), close enough for the
    exact stage to find the active constraints among the six least slack on
    almost every cell; finer grids cost raster time and save little there.

    Examples
    --------
    >>> auto_grid(1024, Domain.torus())
    (128, 128)
    """
    h = np.sqrt(domain.area / (max(int(n), 1) * cells_per_site))
    return (max(int(np.ceil(domain.height / h)), 4), max(int(np.ceil(domain.width / h)), 4))


@dataclass
class RasterResult:
    """Output of :meth:`PowerRaster.compute`.

    Attributes
    ----------
    centers : (n, 2) float64
        Grid-cell centre where each power cell's distance map peaks.
    radii : (n,) float64
        That peak distance (raster MIC radius estimate); -1 where the cell
        owns no grid cell (empty, or smaller than the raster resolves).

    Examples
    --------
    Made by :meth:`PowerRaster.compute` (on an OpenCL device):

    >>> raster = PowerRaster(Domain.torus(), (64, 64))
    >>> res = raster.compute(np.random.default_rng(0).random((50, 2)))
    >>> res.centers.shape, res.radii.shape, res.shape
    ((50, 2), (50,), (64, 64))
    """

    centers: np.ndarray
    radii: np.ndarray
    shape: tuple
    cell_size: tuple
    _owner: object = None

    _maps: dict = field(default_factory=dict)
    _generation: int = 0
    _sites: np.ndarray = None

    def _fetch_check(self, name):
        if self._owner._generation != self._generation:
            raise RuntimeError(f"the {name} map of this result was overwritten by a later "
                               "compute() (the raster reuses its device buffers): read it first")

    def _fetch(self, name):
        """Copy one of this result's device maps to the host (once)."""
        entry = self._maps[name]
        if isinstance(entry, tuple):
            self._fetch_check(name)
            buf, dtype = entry
            out = np.empty(self.shape, dtype)
            cl.enqueue_copy(self._owner.queue, out, buf)
            self._maps[name] = entry = out
        return entry

    def centroids(self, density=None):
        """Density-weighted centroids and masses of this result's cells.

        Parameters
        ----------
        density : (ny, nx) array_like, optional
            Non-negative density per grid cell (uniform when omitted).

        Returns
        -------
        centroids, mass : (n, 2) and (n,) float64
            As :func:`diskpack_cl.labels.cell_centroids` computes them; on
            devices with 64-bit atomics the sums are reduced on the device
            (fixed point, 2^-24), and the label map never leaves it.

        Raises
        ------
        RuntimeError
            A later compute() of the raster overwrote the labels, and they
            were not read before.
        """
        lab = self._maps["label"]
        if isinstance(lab, np.ndarray) or self._owner._k_sums is None or density is None:
            return cell_centroids(self.labels, self._sites, density, self._owner.domain)
        self._fetch_check("label")
        return self._owner._device_centroids(lab[0], self._sites, density)

    @property
    def labels(self):
        """(ny, nx) int32 owning site of each grid cell."""
        return self._fetch("label")

    @property
    def dist(self):
        """(ny, nx) float32 distance from each grid-cell centre to its cell's boundary."""
        return self._fetch("dist")

    @property
    def neighbor(self):
        """(ny, nx) int32 site across the nearest boundary line (-1: domain edge)."""
        if "nbr" not in self._maps:
            raise RuntimeError("no neighbour map: ask compute(..., neighbors=True) for it")
        return self._fetch("nbr")

    def adjacency(self):
        """Sorted unique pairs ``(i, j)``, i < j, of sites whose raster cells touch."""
        lab = self.labels
        pairs = [np.stack([lab[:, :-1].ravel(), lab[:, 1:].ravel()], 1),
                 np.stack([lab[:-1, :].ravel(), lab[1:, :].ravel()], 1)]
        if self._owner.domain.periodic:
            pairs += [np.stack([lab[:, -1], lab[:, 0]], 1), np.stack([lab[-1, :], lab[0, :]], 1)]
        p = np.concatenate(pairs)
        p = np.sort(p[p[:, 0] != p[:, 1]], axis=1)
        return np.unique(p, axis=0)


class PowerRaster(DeviceStage):
    """OpenCL processing object for the discrete power diagram of one grid.

    Parameters
    ----------
    domain : Domain
        Unit torus or image rectangle.
    shape : tuple of int
        Raster size ``(ny, nx)``.
    device : str or pyopencl.Context, optional
        See :func:`diskpack_cl.get_context`.
    profile : bool
        Profile the kernels with OpenCL events: device seconds per kernel
        accumulate in `timings` as ``kernel_<name>`` and ``kernel`` (off by default).
    timings : Stopwatch, optional
        Where the seconds of ``raster_labels``, ``mic_estimate`` and the
        profiled kernels go (default: a new one,
        :attr:`timings`); an engine passes its own.
    max_groups : int
        Grid cells per enqueue of the labelling kernel, in units of 8 x 8:
        the raster is labelled in bands of tile rows, each waited for in a
        way that lets Ctrl-C through, so that stage timings are exact and an
        interrupt is answered between bands, even on huge rasters.
    layout : {None, "tile", "item"}
        Labels-only layout: vector tiles (CPUs, the default there) or one
        work item per grid cell (elsewhere).
    lanes : {None, 8, 16}
        Vector lanes of the tile layout (:attr:`DeviceStage.lanes` when None:
        16 where the device checks trusted 512-bit vectors); the labels are the same either way.

    Notes
    -----
    Work-group sizes come from the device and the kernels
    (:func:`diskpack_cl.device.context.group_size`): ``power_labels`` runs in
    square tiles of 8 x 8 grid cells where the kernel may run 64 work items
    in a group, else 4 x 4, 2 x 2 or 1 (:attr:`tile`), with the same labels
    and distances; the reductions run in groups of up to 256, launches
    padded to whole groups.

    Examples
    --------
    >>> import numpy as np
    >>> from diskpack_cl.domain import Domain
    >>> pr = PowerRaster(Domain.torus(), (64, 64))
    >>> est = pr.compute(np.random.default_rng(0).random((50, 2)))
    >>> est.radii.shape, bool(np.all(est.radii > 0))
    ((50,), True)
    """

    def __init__(self, domain: Domain, shape, device=None, *, max_groups=MAX_GROUPS, layout=None,
                 lanes=None, profile=False, timings=None):
        self.domain = domain
        self.shape = (int(shape[0]), int(shape[1]))
        if min(self.shape) < 1:
            raise ValueError(f"raster shape must be positive, got {shape}")
        super().__init__(device, profile=profile, timings=timings)
        self.max_groups = int(max_groups)
        if self.max_groups < 1:
            raise ValueError(f"max_groups must be at least 1, got {max_groups}")
        periodic = int(domain.periodic)
        if lanes is not None:
            if int(lanes) not in (8, 16):
                raise ValueError(f"lanes must be 8 or 16, got {lanes!r}")
            if int(lanes) == 16 and not self.verdict.wide:   # trust, not the default's choice
                raise ValueError(f"{lanes} lanes take 512-bit vectors, which {self.device_name} "
                                 "was not trusted with (diskpack devices --check)")
            self.lanes = int(lanes)
        prg, self.tile = self._labels_program(periodic)
        self._k_labels, self._k_tile = prg["power_labels"], prg["power_labels_tile"]
        # labels-only layout: vector tiles on CPUs, one work item per grid cell elsewhere
        if layout is None:
            layout = "tile" if self.is_cpu else "item"
        if layout not in ("tile", "item"):
            raise ValueError(f"layout must be 'tile' or 'item', got {layout!r}")
        self.layout = layout
        # centroids reduced on the device where it has 64-bit integer atomics
        dev = self.ctx.devices[0]
        self._k_sums = self._k_fused = None
        if "cl_khr_int64_base_atomics" in dev.extensions:
            fp64 = int("cl_khr_fp64" in dev.extensions)
            sums = self.program("raster_sums", {"PERIODIC": periodic, "USE_FP64": fp64,
                                                  "TW": self.lanes, "NEAR_RINGS": NEAR_RINGS})
            self._k_sums = sums["cell_sums"]
            # labels and sums in one pass where labels come in tiles
            self._k_fused = sums["power_sums_tile"] if layout == "tile" else None
            self._real = np.float64 if fp64 else np.float32
        self._density = None
        self._bucket_order = None   # the sites' last bucket order (_buckets)
        k = self.program("raster_mic", {"PERIODIC": periodic})
        self._k_max, self._k_argmax = k["cell_max"], k["cell_argmax"]
        self._groups = {name: group_size(k[name], dev, REDUCE_GROUP) for name in k}
        if self._k_sums is not None:
            # cell_sums runs (segments, rows) with groups along the rows
            self._groups["cell_sums"] = min(group_size(self._k_sums, dev, REDUCE_GROUP),
                                            dev.max_work_item_sizes[1])
        self._maps = {}
        self._generation = 0
        self._uploads = 0   # uploads of sites or sums buffers: a pending pass checks it
        self._warm()

    def _labels_program(self, periodic):
        """The labelling program with the widest tile the device and kernel allow.

        Returns the program and its tile side: 8, or a smaller power of two
        where the device's or ``power_labels``' work-group limit is below
        8 x 8 (the kernel requires a square group of the tile's size).
        """
        dev = self.ctx.devices[0]
        tile = TILE
        while True:
            if tile * tile <= dev.max_work_group_size and tile <= min(dev.max_work_item_sizes[:2]):
                prg = self.program("raster_labels", {"PERIODIC": periodic, "TILE": tile,
                                                     "TW": self.lanes, "NEAR_RINGS": NEAR_RINGS})
                if tile == 1 or tile * tile <= _device.kernel_group_limit(prg["power_labels"], dev):
                    return prg, tile
            tile //= 2

    def _warm(self):
        """Run every kernel once on one grid cell, so that PoCL's lazy
        compilation is not charged to the first real iteration."""
        shape, self.shape = self.shape, (1, 1)
        try:
            with self.timings.discarded():
                site = np.full((1, 2), 0.5 * self.domain.width)
                self.compute(site)
                if self._k_fused is not None:
                    self.centroids(site, density=np.ones((1, 1)))
        finally:
            self.shape = shape

    # -- buffers -----------------------------------------------------------
    def _map_buffer(self, name, nbytes):
        buf = self._maps.get(name)
        if buf is None or buf.size != nbytes:
            buf = cl.Buffer(self.ctx, cl.mem_flags.READ_WRITE, nbytes)
            self._maps[name] = buf
        return buf

    def _buckets(self, pts, w):
        dom = self.domain
        n = len(pts)
        # about two sites per bucket keeps both ring searches short
        nbx = max(1, int(np.sqrt(n / 2.0 * dom.width / dom.height)))
        nby = max(1, int(np.sqrt(n / 2.0 * dom.height / dom.width)))
        bw, bh = dom.width / nbx, dom.height / nby
        if not dom.periodic:
            # Square buckets: a ring search widens by the smaller bucket side
            # per ring, so on an elongated image (1 x N, 2 x 50000) buckets
            # as thin as the image would make it take N / 2 rings.  Buckets
            # may overhang a rectangle (not a torus, whose wrap needs the
            # exact period), so a side shorter than one bucket gets one.
            bw = bh = max(bw, bh)
            nbx = max(1, int(np.ceil(dom.width / bw)))
            nby = max(1, int(np.ceil(dom.height / bh)))
        bid = np.clip((pts[:, 1] / bh).astype(np.int64), 0, nby - 1)
        bid *= nbx
        bid += np.clip((pts[:, 0] / bw).astype(np.int64), 0, nbx - 1)
        # the last order is a hint (the same answer, found faster where the sites moved little)
        order = self._bucket_order = bucket_order(bid, hint=self._bucket_order)
        counts = np.bincount(bid, minlength=nbx * nby)
        start = np.zeros(nbx * nby + 1, np.int32)
        np.cumsum(counts, out=start[1:])
        # the weights are at most 0 (shifted by their maximum): an empty bucket's 0 is above
        # them all, as the kernels expect; maximum.at is several times faster than reduceat
        # over a bucket grid of about two sites a bucket
        wmax = np.full(nbx * nby, -np.inf, np.float32)
        with np.errstate(invalid="ignore"):   # NaN only where a test bypassed check_sites
            np.maximum.at(wmax, bid, w)
        # the largest weight within NEAR_RINGS buckets of each (-inf: no site there)
        near = near_max(wmax.reshape(nby, nbx), NEAR_RINGS, dom.periodic)
        wmax[counts == 0] = 0.0
        return order, start, wmax, near.reshape(-1), (nbx, nby, bw, bh)

    # -- work --------------------------------------------------------------
    def _run_tiles(self, kernel, name, bufs, grid, wmax, *args):
        """A kernel of the CPU layout (``LABEL_ARGS`` then `args`; TW x TH grid cells
        a work item) over the raster, in bands of tile rows of about `max_groups` * 64
        grid cells, waited for one at a time."""
        for ev in self._tile_bands(kernel, bufs, grid, wmax, *args):
            self.wait(ev, name)

    def _tile_bands(self, kernel, bufs, grid, wmax, *args):
        """Enqueue the bands of :meth:`_run_tiles` one by one (a generator of their events)."""
        nbx, nby, bw, bh = grid
        ny, nx = self.shape
        dom = self.domain
        tw, th = self.lanes, TILE_ROWS
        tx, ty = -(-nx // tw), -(-ny // th)
        band = max(1, (self.max_groups * TILE * TILE) // (tx * tw * th))
        for y0 in range(0, ty, band):
            yield kernel(
                self.queue, (tx, min(band, ty - y0)), (1, 1), *bufs,
                np.int32(nbx), np.int32(nby), np.float32(bw), np.float32(bh),
                np.float32(dom.width), np.float32(dom.height), np.float32(wmax),
                np.int32(nx), np.int32(ny), *args, global_offset=(0, y0))

    def compute(self, points, weights=None, distance=True, neighbors=False):
        """Label the raster and estimate every power cell's inscribed circle.

        Parameters
        ----------
        points : (n, 2) array_like
            Sites inside the domain (wrapped into it on a torus).
        weights : (n,) array_like, optional
            Power weights (squared radii); zeros give the Voronoi diagram.
        distance : bool
            False: labels only (about half the work; enough for centroids).
            The result then has no distance map and no MIC estimates
            (``radii`` all -1, ``centers`` the sites).
        neighbors : bool
            Also keep, per grid cell, the site across the nearest boundary
            line (:attr:`RasterResult.neighbor`; with ``distance`` only).

        Returns
        -------
        RasterResult

        Raises
        ------
        ValueError
            No sites, or sites or weights that
            :func:`diskpack_cl._checks.check_sites` refuses (the kernels
            would leave grid cells without an owner).
        RuntimeError
            The labelling kernel reported a ring search at its limit or a
            grid cell without an owner (:data:`STATUS`).
        """
        t0 = time.perf_counter()
        pts, bufs, grid, wmax = self._upload_sites(points, weights)
        n = len(pts)
        ny, nx = self.shape
        dom = self.domain
        maps = self._map_buffers(nx * ny)
        self._generation += 1
        self._label(distance, bufs, grid, wmax, maps)
        self.release_lent()   # the labels are done: the site arrays are read
        t1 = time.perf_counter()
        self.timings.add("raster_labels", t1 - t0)
        if not (distance and neighbors):
            del maps["nbr"]     # the kernel writes it with the distances; kept on request
        if not distance:
            del maps["dist"]
            return RasterResult(pts.copy(), np.full(n, -1.0), self.shape,
                                      (dom.width / nx, dom.height / ny), self, maps,
                                      self._generation, pts)
        rbits, argpix = self._cell_maxima(maps, n)
        has = rbits >= 0
        radii = np.full(n, -1.0)
        radii[has] = rbits[has].view(np.float32)
        hx, hy = dom.width / nx, dom.height / ny
        centers = pts.copy()
        iy, ix = np.divmod(argpix[has].astype(np.int64), nx)
        centers[has, 0] = (ix + 0.5) * hx
        centers[has, 1] = (iy + 0.5) * hy
        t2 = time.perf_counter()
        self.timings.add("mic_estimate", t2 - t1)
        return RasterResult(centers, radii, self.shape, (hx, hy), self, maps,
                                  self._generation, pts)

    def _upload_sites(self, points, weights):
        """Check the sites, sort them into buckets and upload them: ``(points,
        buffers, bucket grid, largest weight)`` for the labelling kernels."""
        pts, w = check_sites(points, weights, self.domain)
        self._uploads += 1
        # Float32 kernels: only relative power distances matter, and the
        # largest weight shifts all of them equally, so subtract it.
        w32 = (w - w.max()).astype(np.float32)
        order, start, wmax_b, near, grid = self._buckets(pts, w32)
        host = {"site": np.take(pts.astype(np.float32), order, axis=0), "weight": w32[order],
                "id": order.astype(np.int32), "start": start, "wmax": wmax_b, "near": near}
        bufs = tuple(self.lend(name, a) for name, a in host.items())   # no copies on a CPU
        return pts, bufs, grid, float(wmax_b.max())

    def centroids(self, points, weights=None, density=None):
        """Density-weighted centroids and masses of the power cells of `points`.

        As ``compute(points, weights, distance=False).centroids(density)``;
        on a CPU device with 64-bit atomics (the ``tile`` layout) in one
        pass that labels the grid cells and sums them without a label map
        (``power_sums_tile`` in ``diskpack_cl/device/kernels/raster_sums.cl``).

        Returns
        -------
        centroids, mass : (n, 2) and (n,) float64
            NaN centroids where a cell holds no mass.

        Examples
        --------
        >>> pr = PowerRaster(Domain.rect(64, 32), (32, 64))
        >>> c, mass = pr.centroids([[16.0, 16.0], [48.0, 16.0]])
        >>> c.round(6).tolist(), mass.tolist()
        ([[16.0, 16.0], [48.0, 16.0]], [1024.0, 1024.0])
        """
        return self.start_centroids(points, weights, density)()

    def start_centroids(self, points, weights=None, density=None):
        """:meth:`centroids`, begun: the returned function gives its ``(centroids, mass)``.

        Where :meth:`centroids` takes one pass (``power_sums_tile``), the
        pass is queued here and the function waits for it, so that the host
        can drive another stage (the MICs' kernel and host work) meanwhile;
        elsewhere the centroids are computed here.  The answers are those of
        :meth:`centroids`.

        Raises
        ------
        RuntimeError
            (from the function) a later :meth:`compute` or :meth:`start_centroids`
            reused the pass's buffers before it was read.

        Examples
        --------
        >>> pr = PowerRaster(Domain.rect(64, 32), (32, 64))
        >>> done = pr.start_centroids([[16.0, 16.0], [48.0, 16.0]], density=np.ones((32, 64)))
        >>> c, mass = done()
        >>> mass.tolist()
        [1024.0, 1024.0]
        """
        if self._k_fused is None or density is None:
            est = self.compute(points, weights, distance=False)
            with self.timings("centroids"):
                answer = est.centroids(density)
            return lambda: answer
        t0 = time.perf_counter()
        pts, bufs, grid, wmax = self._upload_sites(points, weights)
        b_density, b_pts, acc, b_acc = self._sums_buffers(pts, density)
        b_status = self.zeros("status", 4)
        uploads = self._uploads
        # every band queued now: the device works through them while the host goes on
        events = list(self._tile_bands(self._k_fused, bufs, grid, wmax, b_density, b_pts,
                                       np.int32(len(pts)), b_status, b_acc))
        self.timings.add("raster_labels", time.perf_counter() - t0)

        def finish():
            t1 = time.perf_counter()
            for ev in events:   # one at a time: Ctrl-C gets through between bands
                self.wait(ev, "power_sums_tile")
            if self._uploads != uploads:
                raise RuntimeError("the centroids' pass was overwritten by a later pass of this "
                                   "raster (it reuses its device buffers): read it first")
            self.release_lent()
            self._check_status(b_status)
            self.timings.add("raster_labels", time.perf_counter() - t1)
            with self.timings("centroids"):
                return self._sums_to_centroids(acc, b_acc, pts)
        return finish

    def _map_buffers(self, npix):
        """The label, distance and neighbour maps (buffer, dtype).

        They are allocated once and reused (a fresh buffer of a large raster
        costs its page faults every call); an earlier result's maps are read
        before the next compute or not at all.
        """
        return {"label": (self._map_buffer("label", 4 * npix), np.int32),
                "dist": (self._map_buffer("dist", 4 * npix), np.float32),
                "nbr": (self._map_buffer("nbr", 4 * npix), np.int32)}

    def _cell_maxima(self, maps, n):
        """Per cell: the largest distance (float bits, -1: no pixel) and its first pixel."""
        npix = self.shape[0] * self.shape[1]
        rbits = np.full(n, -1, np.int32)
        argpix = np.full(n, INT_MAX, np.int32)
        b_r = self.upload("rbits", rbits)
        b_a = self.upload("argpix", argpix)
        lab, dist = maps["label"][0], maps["dist"][0]
        g = self._groups
        self._k_max(self.queue, (padded(npix, g["cell_max"]),), (g["cell_max"],), lab, dist,
                    np.int32(npix), np.int32(n), b_r)
        self._k_argmax(self.queue, (padded(npix, g["cell_argmax"]),), (g["cell_argmax"],), lab,
                       dist, np.int32(npix), np.int32(n), b_r, b_a)
        cl.enqueue_copy(self.queue, rbits, b_r)
        cl.enqueue_copy(self.queue, argpix, b_a)
        return rbits, argpix

    def _label(self, distance, bufs, grid, wmax, maps):
        """Run the labelling kernel in bands (see `max_groups`) into `maps`,
        and refuse the result if the kernel set a status bit."""
        ny, nx = self.shape
        dom = self.domain
        b_status = self.zeros("status", 4)
        if not distance and self.layout == "tile":
            self._run_tiles(self._k_tile, "power_labels_tile", bufs, grid, wmax,
                            maps["label"][0], b_status)
        t = self.tile
        gx, gy = padded(nx, t), padded(ny, t)
        # bands of tile rows, at most max_groups * 64 grid cells each, one at
        # a time: a signal (Ctrl-C, SIGTERM) is answered between them
        band = max(1, self.max_groups * TILE * TILE // (gx * t)) * t
        for y0 in range(0, gy if distance or self.layout == "item" else 0, band):
            ev = self._k_labels(
                self.queue, (gx, min(band, gy - y0)), (t, t), *bufs, np.int32(grid[0]),
                np.int32(grid[1]), np.float32(grid[2]), np.float32(grid[3]),
                np.float32(dom.width), np.float32(dom.height), np.float32(wmax), np.int32(nx),
                np.int32(ny), np.int32(bool(distance)), maps["label"][0], maps["dist"][0],
                maps["nbr"][0], b_status, global_offset=(0, y0))
            self.wait(ev, "power_labels")
        self._check_status(b_status)

    def _check_status(self, b_status):
        """Refuse a labelling whose kernel set a status bit (:data:`STATUS`)."""
        status = np.zeros(1, np.int32)
        cl.enqueue_copy(self.queue, status, b_status)
        if status[0]:
            why = [name for name, bit in STATUS.items() if status[0] & bit]
            raise RuntimeError(f"the labelling kernel refused its result ({', '.join(why)}): "
                               "sites the host checks should have refused")

    def _device_centroids(self, label_buf, sites, density):
        """Centroids from the device reduction (diskpack_cl/device/kernels/raster_sums.cl): the label
        map never leaves the device; the density is uploaded once per array.
        The sums are fixed point (2^-24), so masses and centroids agree with a
        float64 host reduction to about 1e-7 relative."""
        ny, nx = self.shape
        n = len(sites)
        b_density, b_pts, acc, b_acc = self._sums_buffers(sites, density)
        seg = -(-nx // CELL_SUMS_SEG)
        g = self._groups["cell_sums"]
        # whole groups of rows per band, so that only the last band's padding
        # passes the raster (those work items return); bands never overlap
        band = padded(max(1, (self.max_groups * TILE * TILE) // (seg * CELL_SUMS_SEG)), g)
        for y0 in range(0, ny, band):
            self.wait(self._k_sums(self.queue, (seg, padded(min(band, ny - y0), g)), (1, g),
                                    label_buf, b_density, b_pts, np.int32(n),
                                    np.int32(nx), np.int32(ny), np.int32(y0), b_acc), "cell_sums")
        self.release_lent()
        return self._sums_to_centroids(acc, b_acc, sites)

    def _sums_buffers(self, sites, density):
        """Buffers of the device sums: the density (uploaded once per array), the
        sites in grid-cell units, and the zeroed sums (host array and buffer)."""
        ny, nx = self.shape
        self._uploads += 1
        if self._density is None or self._density[0] is not density:
            d = np.ascontiguousarray(density, np.float32)   # summed in `real` on the device
            if d.shape != self.shape:
                raise ValueError(f"density must have the raster shape {self.shape}")
            if self.is_cpu:
                # the device reads the host's array where it is: no second copy of a
                # whole raster (512 MiB at 8192 x 8192) and no upload; d is kept with it
                buf = cl.Buffer(self.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR,
                                hostbuf=d)
            else:
                buf = self.upload("density", d)
            self._density = (density, buf, d)
        cell = (self.domain.width / nx, self.domain.height / ny)
        b_pts = self.lend("grid_sites", np.ascontiguousarray(sites / cell, self._real))
        acc = np.empty((len(sites), 3), np.int64)   # the sums come back into it
        return self._density[1], b_pts, acc, self.zeros("sums", acc.nbytes)

    def _sums_to_centroids(self, acc, b_acc, sites):
        """``(centroids, mass)`` from the device's fixed-point sums."""
        ny, nx = self.shape
        dom = self.domain
        hx, hy = dom.width / nx, dom.height / ny
        cl.enqueue_copy(self.queue, acc, b_acc)
        # FIX is a power of two: (sum / FIX) / (mass / FIX) is sum / mass exactly, the
        # values of dividing every sum by FIX first, with fewer whole-set temporaries; the
        # moments are cast to float64 inside the division (as astype casts them), not
        # copied whole first (1M sites: 8 against 18 ms)
        mass = acc[:, 0].astype(np.float64)
        c = np.empty_like(sites)
        with np.errstate(invalid="ignore", divide="ignore"):
            for k, h in enumerate((hx, hy)):
                np.divide(acc[:, k + 1], mass, out=c[:, k])
                c[:, k] *= h
        mass /= CELL_SUMS_FIX
        c += sites
        if dom.periodic:
            c = dom.wrap(c)
        return c, mass

