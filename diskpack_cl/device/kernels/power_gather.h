/* Candidate gathering of the labelling kernels (raster_labels.cl) and of the
 * fused labels-and-sums kernel (raster_sums.cl): the bucket ring walks, the
 * tile bound U, and the CPU layout's owner scan of a TW x TH tile.  See
 * raster_labels.cl for the bounds.
 *
 * Build-time switches: PERIODIC (common.h); TW, the CPU tile's lanes (8 or
 * 16, see tile_owners); CAP, power_labels' local candidate list
 * (default 256; longer lists are streamed in chunks; the CPU tiles scan
 * their candidates as they find them and keep no list); NEAR_RINGS, the
 * rings of the host's near_wmax (0: the CPU tiles' walks bound the weights
 * of the rings left by wmax alone, see gather).
 */
#ifndef DISKPACK_POWER_GATHER_H
#define DISKPACK_POWER_GATHER_H

#include "common.h"
#include "wide.h"

#ifndef CAP
#define CAP 256
#endif

#ifndef NEAR_RINGS
#define NEAR_RINGS 0
#endif

#define GATHER_OWNER 0
#define GATHER_DIST 1
#define GATHER_SCAN 2

/* The CPU layout: one work item per TW x TH tile of grid cells, no
 * barriers, and the candidate scan written with explicit TW-wide vectors
 * (a row of the tile at a time), which PoCL turns into packed SIMD
 * instructions where it would not vectorize the scalar scan of
 * power_labels.  The arithmetic is that of power_labels' pass 1, and the
 * candidates are its candidates but for those that cannot own a grid cell
 * of the tile, so both give the same labels.  (GPUs want the opposite
 * layout: one work item per grid cell, power_labels.) */
/* TW lanes (build-time: 8 fills AVX2 registers; 16 fills AVX-512 ones and
 * would change the call ABI of the builtins on CPUs without it), TH = 16
 * rows: the bucket walk of a tile is paid once for 128 or 256 grid cells
 * (tiles of 16 x 32 rows spill registers and are slower). */
#ifndef TW
#define TW 8
#endif
#if TW == 16 && !WIDE_BUILTINS
#error "TW 16 takes 512-bit vectors through builtins: WIDE_BUILTINS must be 1"
#endif
#define TH 16
#if TW == 16
#define intT int16
#define floatT float16
#define vstoreT vstore16
#define vloadT vload16
#define convert_floatT convert_float16
#define LANES ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#elif TW == 8
#define intT int8
#define floatT float8
#define vstoreT vstore8
#define vloadT vload8
#define convert_floatT convert_float8
#define LANES ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#else
#error "TW must be 8 or 16"
#endif

/* Candidates between two updates of tile_owners' reach (a power of two). */
#define REACH_EVERY 8

/* The largest best power over the tile, padded as tile_bound pads U: no
 * candidate whose power exceeds it over the whole tile can own a grid cell. */
inline float tile_reach(const floatT *best, float pad)
{
    /* select, not fmax: no builtin call on a 512-bit vector (wide.h) */
    floatT v = best[0];
    for (int r = 1; r < TH; ++r) v = select(v, best[r], best[r] > v);
#if TW == 16
    const float8 a = select(v.lo, v.hi, v.hi > v.lo);
#else
    const float8 a = v;
#endif
    const float4 b = select(a.lo, a.hi, a.hi > a.lo);
    const float2 c = select(b.lo, b.hi, b.hi > b.lo);
    const float M = FMAX(c.lo, c.hi);
    return M + pad + 1e-5f * FABS(M);
}

/* The tile layout's scan (GATHER_SCAN): its grid-cell centres, each cell's
 * best power and owner so far, and the reach beyond which no candidate can
 * own a grid cell of the tile (tile_reach). */
struct tile_scan {
    floatT px;            /* the tile's columns */
    float py[TH];         /* and rows */
    floatT best[TH];      /* least power distance so far, per row */
    intT best_id[TH];     /* its site (caller's index; ties to the lowest) */
    float pad;            /* rounding pad of the bounds (tile_bound's) */
    float reach;          /* candidates with boxdist^2 - w above it own no grid cell */
    int seen;             /* candidates scanned */
    __global const float *near_wmax;   /* largest weight within NEAR_RINGS buckets of each */
};

/* One candidate at (xs, ys) with weight wc and index id, scanned over the
 * tile's grid cells; every REACH_EVERY candidates the reach is tightened
 * (and after each ring of the gather). */
inline void scan_site(struct tile_scan *t, float xs, float ys, float wc, int id)
{
    const intT vid = (intT)(id);
    const floatT dx = t->px - xs;
    const floatT dx2 = dx * dx;
    for (int r = 0; r < TH; ++r) {
        const float dy = t->py[r] - ys;
        const floatT pw = (dx2 + dy * dy) - wc;
        const intT take = (pw < t->best[r]) | ((pw == t->best[r]) & (vid < t->best_id[r]));
        t->best[r] = take ? pw : t->best[r];
        t->best_id[r] = take ? vid : t->best_id[r];
    }
    if ((++t->seen & (REACH_EVERY - 1)) == 0) t->reach = FMIN(t->reach, tile_reach(t->best, t->pad));
}

/* Squared distance between boxes [ax0,ax1]x[ay0,ay1] and [bx0,bx1]x[by0,by1]
 * (squared: the owner tests compare it with powers, and a square root per
 * bucket was a tenth of the labelling pass). */
inline float boxbox2(float ax0, float ay0, float ax1, float ay1,
                     float bx0, float by0, float bx1, float by1)
{
    const float dx = FMAX(FMAX(bx0 - ax1, ax0 - bx1), 0.0f);
    const float dy = FMAX(FMAX(by0 - ay1, ay0 - by1), 0.0f);
    return dx * dx + dy * dy;
}

/* Distance from the tile [x0,x1] x [y0,y1] to the buckets of rings >= r
 * (r > 0) around its bucket block [bx0,bx1] x [by0,by1]; in a rectangle a
 * side past the grid's edge has no buckets left, and no bound. */
inline float ring_gap(int r, int bx0, int by0, int bx1, int by1, float x0, float y0,
                      float x1, float y1, int nbx, int nby, float bw, float bh)
{
    float gl = x0 - (bx0 - r + 1) * bw, gr = (bx1 + r) * bw - x1;
    float gb = y0 - (by0 - r + 1) * bh, gt = (by1 + r) * bh - y1;
#if !PERIODIC
    if (bx0 - r < 0) gl = INFINITY;
    if (bx1 + r >= nbx) gr = INFINITY;
    if (by0 - r < 0) gb = INFINITY;
    if (by1 + r >= nby) gt = INFINITY;
#endif
    return FMIN(FMIN(gl, gr), FMIN(gb, gt));
}

/* Rings a gather walks at most.  A rectangle's rings leave the grid after
 * max(nbx, nby) + 1.  On a torus the bound U (tile_bound) reaches from the
 * tile's far corner to a runner-up found up to half the grid away, and the
 * gather's rings start at the tile's bucket block (`span` buckets wide), so
 * a legitimate search may walk a few more rings than the grid has; twice
 * that leaves room for the weights' spread. */
inline int gather_limit(int nbx, int nby, int span)
{
#if PERIODIC
    return 2 * (imax(nbx, nby) + span) + 4;
#else
    return imax(nbx, nby) + 1;
#endif
}

/* Walk the buckets in rings around the tile's bucket block and copy the
 * sites that pass the test of `mode` into the local list, skipping the first
 * `skip` that pass.  Returns how many pass in total (may exceed CAP); sets
 * ST_RING_LIMIT in `status` when the rings reach gather_limit.
 *   GATHER_OWNER: boxdist^2 - w <= bound
 *   GATHER_DIST:  boxdist <= bound + sqrt(bound2 + w)   (bound2 >= -w)
 *   GATHER_SCAN:  boxdist^2 - w <= scan->reach, each such site scanned at
 *                 once (scan_site) and no list kept: the reach tightens as
 *                 the rings go out (every REACH_EVERY sites and at each
 *                 ring's end), and the walk stops at it.  With NEAR_RINGS,
 *                 the walk also stops at a ring r <= NEAR_RINGS where the
 *                 weights left within NEAR_RINGS rings (near_wmax, at most
 *                 wnear) and those beyond (at most wmax, at ring
 *                 NEAR_RINGS + 1's gap) pass no site: a picture's few
 *                 largest dots set wmax, and made every tile walk the rings
 *                 out to their radius */
inline int gather(int mode, float bound, float bound2, int skip,
                  float x0, float y0, float x1, float y1,
                  __global const float2 *site, __global const float *weight,
                  __global const int *site_id, __global const int *bucket_start,
                  __global const float *bucket_wmax,
                  int nbx, int nby, float bw, float bh, float W, float H, float wmax,
                  __local float2 *cpos, __local float *cw, __local int *cid,
                  __global int *status, struct tile_scan *scan)
{
    float lim = mode == GATHER_SCAN ? scan->reach : bound;
    const int bx0 = iclamp((int)FLOOR(x0 / bw), -(1 << 20), 1 << 20);
    const int by0 = iclamp((int)FLOOR(y0 / bh), -(1 << 20), 1 << 20);
    const int bx1 = (int)FLOOR(x1 / bw), by1 = (int)FLOOR(y1 / bh);
    const int rmax = gather_limit(nbx, nby, imax(bx1 - bx0, by1 - by0));
#if NEAR_RINGS
    /* the largest weight within NEAR_RINGS rings of the block, and the gap
       to the rings beyond (GATHER_SCAN) */
    float wnear = wmax, gfar = 0.0f;
    if (mode == GATHER_SCAN) {
        wnear = -INFINITY;
        for (int cy0 = by0; cy0 <= by1; ++cy0)
            for (int cx0 = bx0; cx0 <= bx1; ++cx0) {
                int cx = cx0, cy = cy0;
                float sx, sy;
                if (locate_bucket(&cx, &cy, &sx, &sy, nbx, nby, W, H))
                    wnear = FMAX(wnear, scan->near_wmax[cy * nbx + cx]);
            }
        gfar = ring_gap(NEAR_RINGS + 1, bx0, by0, bx1, by1, x0, y0, x1, y1, nbx, nby, bw, bh);
    }
#endif
    int total = 0;
    int r = 0;
    for (; r <= rmax; ++r) {
        if (r > 0) {
            const float gap = ring_gap(r, bx0, by0, bx1, by1, x0, y0, x1, y1, nbx, nby, bw, bh);
            if (gap > 0.0f) {
                if (mode != GATHER_DIST && gap * gap - wmax > lim) break;
#if NEAR_RINGS
                if (mode == GATHER_SCAN && r <= NEAR_RINGS && gap * gap - wnear > lim
                    && gfar * gfar - wmax > lim) break;
#endif
                if (mode == GATHER_DIST && gap > bound + SQRT(FMAX(bound2 + wmax, 0.0f))) break;
            }
#if !PERIODIC
            if (bx0 - r < 0 && by0 - r < 0 && bx1 + r >= nbx && by1 + r >= nby) break;
#endif
        }
        /* the ring's rows; in a rectangle only those inside the grid, and
           in its top and bottom rows only the columns inside the grid, so
           that a ring costs what its existing buckets cost (elongated
           images have rings far longer than the grid is wide) */
        int cy_lo = by0 - r, cy_hi = by1 + r;
#if !PERIODIC
        cy_lo = imax(cy_lo, 0);
        cy_hi = imin(cy_hi, nby - 1);
#endif
        for (int cy0 = cy_lo; cy0 <= cy_hi; ++cy0) {
            const int edge_row = (r == 0 || cy0 == by0 - r || cy0 == by1 + r);
            const int step = edge_row ? 1 : (bx1 - bx0 + 2 * r);
            int cx_lo = bx0 - r, cx_hi = bx1 + r;
#if !PERIODIC
            if (edge_row) { cx_lo = imax(cx_lo, 0); cx_hi = imin(cx_hi, nbx - 1); }
#endif
            for (int cx0 = cx_lo; cx0 <= cx_hi; cx0 += (step > 0 ? step : 1)) {
                int cx = cx0, cy = cy0;
                float sx, sy;
                if (!locate_bucket(&cx, &cy, &sx, &sy, nbx, nby, W, H)) continue;
                const int b = cy * nbx + cx;
                const float ex0 = cx * bw + sx, ey0 = cy * bh + sy;
                const float d2 = boxbox2(x0, y0, x1, y1, ex0, ey0, ex0 + bw, ey0 + bh);
                const float wb = bucket_wmax[b];
                if (mode != GATHER_DIST && d2 - wb > lim) continue;
                if (mode == GATHER_DIST && SQRT(d2) > bound + SQRT(FMAX(bound2 + wb, 0.0f))) continue;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float2 s = site[k];
                    const float xs = s.x + sx, ys = s.y + sy;
                    const float ds2 = box_dist2(xs, ys, x0, y0, x1, y1);
                    const float wk = weight[k];
                    const int pass = (mode != GATHER_DIST) ? (ds2 - wk <= lim)
                                                           : (SQRT(ds2) <= bound + SQRT(FMAX(bound2 + wk, 0.0f)));
                    if (!pass) continue;
                    if (mode == GATHER_SCAN) {
                        scan_site(scan, xs, ys, wk, site_id[k]);
                        lim = scan->reach;
                        continue;
                    }
                    const int slot = total - skip;
                    if (slot >= 0 && slot < CAP) {
                        cpos[slot] = (float2)(xs, ys);
                        cw[slot] = wk;
                        cid[slot] = site_id[k];
                    }
                    ++total;
                }
            }
        }
        if (mode == GATHER_SCAN) {
            /* a ring's sites scanned: the reach they give bounds the rings
               beyond (the first, the tile's own buckets, sets it) */
            scan->reach = FMIN(scan->reach, tile_reach(scan->best, scan->pad));
            lim = scan->reach;
        }
    }
    if (r > rmax) atomic_or(status, ST_RING_LIMIT);
    return total;
}

/* Bound U: the second best "worst corner" power distance over the tile
 * [x0,x1] x [y0,y1] among the sites of the nearest bucket rings.  Two sites
 * have pow <= U everywhere in the tile, so every grid cell finds its owner
 * and a runner-up among the sites with  boxdist^2 - w <= U.  By ring
 * max(nbx, nby) + 1 every bucket was seen (on a torus, with its images one
 * period away); U is infinite only when no two candidates exist (no sites,
 * NaN weights), and then the grid cells find no owner (ST_NO_OWNER). */
inline float tile_bound(float x0, float y0, float x1, float y1, float pad,
                        __global const float2 *site, __global const float *weight,
                        __global const int *bucket_start,
                        int nbx, int nby, float bw, float bh, float W, float H)
{
    const int bx = iclamp((int)(0.5f * (x0 + x1) / bw), 0, nbx - 1);
    const int by = iclamp((int)(0.5f * (y0 + y1) / bh), 0, nby - 1);
    float U1 = INFINITY, U2 = INFINITY;
    const int rmax = imax(nbx, nby) + 1;
    for (int r = 0; (U2 == INFINITY || r <= 1) && r <= rmax; ++r) {
        /* ring r only (its perimeter), clipped to the grid in a rectangle */
        int dy_lo = -r, dy_hi = r;
#if !PERIODIC
        dy_lo = imax(dy_lo, -by);
        dy_hi = imin(dy_hi, nby - 1 - by);
#endif
        for (int dy = dy_lo; dy <= dy_hi; ++dy) {
            const int edge = (dy == -r || dy == r);
            int dx_lo = -r, dx_hi = r;
#if !PERIODIC
            if (edge) { dx_lo = imax(dx_lo, -bx); dx_hi = imin(dx_hi, nbx - 1 - bx); }
#endif
            for (int dx = dx_lo; dx <= dx_hi; dx += (edge ? 1 : 2 * r)) {
                int cx = bx + dx, cy = by + dy;
                float sx, sy;
                if (!locate_bucket(&cx, &cy, &sx, &sy, nbx, nby, W, H)) continue;
                const int b = cy * nbx + cx;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float xs = site[k].x + sx, ys = site[k].y + sy;
                    const float fx = FMAX(FABS(x0 - xs), FABS(x1 - xs));
                    const float fy = FMAX(FABS(y0 - ys), FABS(y1 - ys));
                    const float u = fx * fx + fy * fy - weight[k];
                    if (u < U1) { U2 = U1; U1 = u; } else if (u < U2) { U2 = u; }
                }
            }
        }
    }
    return U2 + pad + 1e-5f * FABS(U2);
}

/* The first arguments of both labelling kernels (power_labels and
 * power_labels_tile): the sorted sites, their bucket grid and the raster. */
#define LABEL_ARGS \
    __global const float2 *site,        /* sites sorted by bucket */ \
    __global const float *weight,       /* their weights (squared radii) */ \
    __global const int *site_id,        /* sorted position -> caller's index */ \
    __global const int *bucket_start,   /* nbx*nby + 1 offsets into site[] */ \
    __global const float *bucket_wmax,  /* largest weight in each bucket */ \
    __global const float *near_wmax,    /* largest within NEAR_RINGS buckets of each (-inf: none) */ \
    const int nbx, const int nby,       /* bucket grid size */ \
    const float bw, const float bh,     /* bucket size */ \
    const float W, const float H,       /* domain size */ \
    const float wmax,                   /* largest weight overall */ \
    const int nx, const int ny          /* raster size */

/* The arguments of LABEL_ARGS, passed on. */
#define LABEL_PASS site, weight, site_id, bucket_start, bucket_wmax, near_wmax, nbx, nby, bw, bh, W, H, wmax, nx, ny

/* Owners of the tile whose first grid cell is (gx0, gy0): best_id[r] holds
 * row r's, caller's indices (lanes past the raster repeat its last column).
 * The candidates are those of power_labels' pass 1 but for the ones that
 * cannot own a grid cell of the tile (GATHER_SCAN), so both give the same
 * labels.  The reach starts infinite: the tile's own buckets (ring 0) set it
 * (a seed from tile_bound, its walk of 3 x 3 buckets, cost a tenth of the
 * pass and pruned little more).  A grid cell of the raster left without an
 * owner sets ST_NO_OWNER. */
inline void tile_owners(int gx0, int gy0, LABEL_ARGS, __global int *status, intT *best_id)
{
    const float hx = W / nx, hy = H / ny;
    const float x0 = (gx0 + 0.5f) * hx, y0 = (gy0 + 0.5f) * hy;
    const float x1 = (imin(gx0 + TW, nx) - 0.5f) * hx, y1 = (imin(gy0 + TH, ny) - 0.5f) * hy;
    struct tile_scan t;
    t.pad = 1e-4f * (hx * hx + hy * hy);
    t.reach = INFINITY;
    t.seen = 0;
    t.near_wmax = near_wmax;
    /* columns past the raster shadow its last column */
    t.px = (convert_floatT(min(gx0 + LANES, (intT)(nx - 1))) + 0.5f) * hx;
    for (int r = 0; r < TH; ++r) {
        t.py[r] = (imin(gy0 + r, ny - 1) + 0.5f) * hy;
        t.best[r] = (floatT)(INFINITY);
        t.best_id[r] = (intT)(INT_MAX);
    }
    /* (no local list: the candidates are scanned as they are found) */
    gather(GATHER_SCAN, t.reach, 0.0f, 0, x0, y0, x1, y1, site, weight, site_id, bucket_start,
           bucket_wmax, nbx, nby, bw, bh, W, H, wmax, 0, 0, 0, status, &t);
    /* the largest owner over the raster's rows: INT_MAX where a cell has none
       (one test a tile: any() is a chain of shuffles a row) */
    intT last = (intT)(INT_MIN);
    for (int r = 0; r < TH; ++r) {
        best_id[r] = t.best_id[r];
        if (gy0 + r < ny) last = max(last, best_id[r]);
    }
    if (any(last == (intT)(INT_MAX))) atomic_or(status, ST_NO_OWNER);
}

#endif
