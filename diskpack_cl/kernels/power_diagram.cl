/* Discrete power diagram on a grid, with each grid cell's distance to the
 * boundary of its power cell.
 *
 * Sites are sorted into a uniform bucket grid (nbx x nby buckets of size
 * bw x bh, CSR layout in bucket_start).  A work-group is a tile of
 * TILE x TILE grid cells.  One work item gathers, into local memory, every
 * site that can matter anywhere in the tile; then each work item scans that
 * short list for its own grid cell.  The scans have the same length for all
 * work items, which lets PoCL vectorize them across the tile, and the
 * bucket walk is paid once per tile instead of once per grid cell.
 *
 * Pass 1 (owner).  U is an upper bound of the least power distance over the
 * tile: for any site j and any p in the tile, pow_j(p) <= max over the
 * tile's corners of pow_j (power distance is convex).  A site can own a
 * grid cell of the tile only if  boxdist(x_j, tile)^2 - w_j <= U.
 *
 * Pass 2 (distance).  A power cell is the intersection of half-planes, so
 * the distance from an interior point p to its boundary is the smallest
 * distance to the bounding lines
 *   d_j(p) = ((|p-x_j|^2 - w_j) - (|p-x_i|^2 - w_i)) / (2 |x_j - x_i|),
 * and, in a rectangle, to its four edges.  Site j can give the minimum D
 * only if |p - x_j| <= D + sqrt((D + |p - x_i|)^2 + w_j - w_i).  The
 * runner-up of pass 1 bounds D from above, which bounds the gather radius.
 *
 * Labels are exact for the grid-cell centres (up to float32 rounding), not a
 * flood-fill approximation.  Ties go to the lowest site index, so the
 * output does not depend on the gather order.  When more candidates than
 * CAP exist, they are streamed through local memory in chunks.
 *
 * On a torus, bucket offsets beyond the grid wrap with a shift of one
 * period, so every periodic image of a site (the cell's own images
 * included) is a separate candidate.
 *
 * Every ring search stops at a limit from the bucket grid and, when it
 * reaches it, sets ST_RING_LIMIT in the status word; a grid cell left
 * without an owner sets ST_NO_OWNER (common.h).  Only sites the host
 * refuses (NaN weights, none at all) get there: then no search is bounded
 * by its candidates, and without the limit a torus search would not end.
 */
#include "common.h"

#ifndef TILE
#define TILE 8
#endif
#ifndef CAP
#define CAP 256
#endif

#define GATHER_OWNER 0
#define GATHER_DIST 1

/* Distance between boxes [ax0,ax1]x[ay0,ay1] and [bx0,bx1]x[by0,by1]. */
inline float boxbox(float ax0, float ay0, float ax1, float ay1,
                    float bx0, float by0, float bx1, float by1)
{
    const float dx = fmax(fmax(bx0 - ax1, ax0 - bx1), 0.0f);
    const float dy = fmax(fmax(by0 - ay1, ay0 - by1), 0.0f);
    return sqrt(dx * dx + dy * dy);
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
    return 2 * (max(nbx, nby) + span) + 4;
#else
    return max(nbx, nby) + 1;
#endif
}

/* Walk the buckets in rings around the tile's bucket block and copy the
 * sites that pass the test of `mode` into the local list, skipping the first
 * `skip` that pass.  Returns how many pass in total (may exceed CAP); sets
 * ST_RING_LIMIT in `status` when the rings reach gather_limit.
 *   GATHER_OWNER: boxdist^2 - w <= bound
 *   GATHER_DIST:  boxdist <= bound + sqrt(bound2 + w)   (bound2 >= -w)
 */
inline int gather(int mode, float bound, float bound2, int skip,
                  float x0, float y0, float x1, float y1,
                  __global const float2 *site, __global const float *weight,
                  __global const int *site_id, __global const int *bucket_start,
                  __global const float *bucket_wmax,
                  int nbx, int nby, float bw, float bh, float W, float H, float wmax,
                  __local float2 *cpos, __local float *cw, __local int *cid,
                  __global int *status)
{
    const int bx0 = clamp((int)floor(x0 / bw), -(1 << 20), 1 << 20);
    const int by0 = clamp((int)floor(y0 / bh), -(1 << 20), 1 << 20);
    const int bx1 = (int)floor(x1 / bw), by1 = (int)floor(y1 / bh);
    const int rmax = gather_limit(nbx, nby, max(bx1 - bx0, by1 - by0));
    int total = 0;
    int r = 0;
    for (; r <= rmax; ++r) {
        if (r > 0) {
            /* distance from the tile to buckets of ring >= r */
            float gl = x0 - (bx0 - r + 1) * bw, gr = (bx1 + r) * bw - x1;
            float gb = y0 - (by0 - r + 1) * bh, gt = (by1 + r) * bh - y1;
#if !PERIODIC
            /* a side past the grid's edge has no buckets left: no bound */
            if (bx0 - r < 0) gl = INFINITY;
            if (bx1 + r >= nbx) gr = INFINITY;
            if (by0 - r < 0) gb = INFINITY;
            if (by1 + r >= nby) gt = INFINITY;
#endif
            const float gap = fmin(fmin(gl, gr), fmin(gb, gt));
            if (gap > 0.0f) {
                if (mode == GATHER_OWNER && gap * gap - wmax > bound) break;
                if (mode == GATHER_DIST && gap > bound + sqrt(fmax(bound2 + wmax, 0.0f))) break;
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
        cy_lo = max(cy_lo, 0);
        cy_hi = min(cy_hi, nby - 1);
#endif
        for (int cy0 = cy_lo; cy0 <= cy_hi; ++cy0) {
            const int edge_row = (r == 0 || cy0 == by0 - r || cy0 == by1 + r);
            const int step = edge_row ? 1 : (bx1 - bx0 + 2 * r);
            int cx_lo = bx0 - r, cx_hi = bx1 + r;
#if !PERIODIC
            if (edge_row) { cx_lo = max(cx_lo, 0); cx_hi = min(cx_hi, nbx - 1); }
#endif
            for (int cx0 = cx_lo; cx0 <= cx_hi; cx0 += (step > 0 ? step : 1)) {
                int cx = cx0, cy = cy0;
                float sx, sy;
                if (!locate_bucket(&cx, &cy, &sx, &sy, nbx, nby, W, H)) continue;
                const int b = cy * nbx + cx;
                const float ex0 = cx * bw + sx, ey0 = cy * bh + sy;
                const float d = boxbox(x0, y0, x1, y1, ex0, ey0, ex0 + bw, ey0 + bh);
                const float wb = bucket_wmax[b];
                if (mode == GATHER_OWNER && d * d - wb > bound) continue;
                if (mode == GATHER_DIST && d > bound + sqrt(fmax(bound2 + wb, 0.0f))) continue;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float2 s = site[k];
                    const float xs = s.x + sx, ys = s.y + sy;
                    const float ds = box_dist(xs, ys, x0, y0, x1, y1);
                    const float wk = weight[k];
                    const int pass = (mode == GATHER_OWNER) ? (ds * ds - wk <= bound)
                                                            : (ds <= bound + sqrt(fmax(bound2 + wk, 0.0f)));
                    if (!pass) continue;
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
    const int bx = clamp((int)(0.5f * (x0 + x1) / bw), 0, nbx - 1);
    const int by = clamp((int)(0.5f * (y0 + y1) / bh), 0, nby - 1);
    float U1 = INFINITY, U2 = INFINITY;
    const int rmax = max(nbx, nby) + 1;
    for (int r = 0; (U2 == INFINITY || r <= 1) && r <= rmax; ++r) {
        /* ring r only (its perimeter), clipped to the grid in a rectangle */
        int dy_lo = -r, dy_hi = r;
#if !PERIODIC
        dy_lo = max(dy_lo, -by);
        dy_hi = min(dy_hi, nby - 1 - by);
#endif
        for (int dy = dy_lo; dy <= dy_hi; ++dy) {
            const int edge = (dy == -r || dy == r);
            int dx_lo = -r, dx_hi = r;
#if !PERIODIC
            if (edge) { dx_lo = max(dx_lo, -bx); dx_hi = min(dx_hi, nbx - 1 - bx); }
#endif
            for (int dx = dx_lo; dx <= dx_hi; dx += (edge ? 1 : 2 * r)) {
                int cx = bx + dx, cy = by + dy;
                float sx, sy;
                if (!locate_bucket(&cx, &cy, &sx, &sy, nbx, nby, W, H)) continue;
                const int b = cy * nbx + cx;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float xs = site[k].x + sx, ys = site[k].y + sy;
                    const float fx = fmax(fabs(x0 - xs), fabs(x1 - xs));
                    const float fy = fmax(fabs(y0 - ys), fabs(y1 - ys));
                    const float u = fx * fx + fy * fy - weight[k];
                    if (u < U1) { U2 = U1; U1 = u; } else if (u < U2) { U2 = u; }
                }
            }
        }
    }
    return U2 + pad + 1e-5f * fabs(U2);
}

/* The first arguments of both labelling kernels (power_labels and
 * power_labels_tile): the sorted sites, their bucket grid and the raster. */
#define LABEL_ARGS \
    __global const float2 *site,        /* sites sorted by bucket */ \
    __global const float *weight,       /* their weights (squared radii) */ \
    __global const int *site_id,        /* sorted position -> caller's index */ \
    __global const int *bucket_start,   /* nbx*nby + 1 offsets into site[] */ \
    __global const float *bucket_wmax,  /* largest weight in each bucket */ \
    const int nbx, const int nby,       /* bucket grid size */ \
    const float bw, const float bh,     /* bucket size */ \
    const float W, const float H,       /* domain size */ \
    const float wmax,                   /* largest weight overall */ \
    const int nx, const int ny          /* raster size */

/* Both passes of power_labels: chunk `chunk` of the candidates into local
 * memory (work item 0 gathers, every work item waits); `total` counts all
 * candidates, `m` those of this chunk. */
#define GATHER_CHUNK(mode, a, b)                                                        \
    if (lid == 0)                                                                       \
        count_l = gather(mode, a, b, chunk * CAP, x0, y0, x1, y1, site, weight,         \
                         site_id, bucket_start, bucket_wmax, nbx, nby, bw, bh, W, H,    \
                         wmax, cpos, cw, cid, status);                                  \
    barrier(CLK_LOCAL_MEM_FENCE);                                                       \
    const int total = count_l;                                                          \
    const int m = min(total - chunk * CAP, CAP)

__kernel __attribute__((reqd_work_group_size(TILE, TILE, 1)))
void power_labels(
    LABEL_ARGS,
    const int with_dist,                /* 0: labels only (Lloyd needs no distances) */
    __global int *label,                /* out: caller's index of the owning site */
    __global float *dist,               /* out: distance to the power cell boundary */
    __global int *nbr,                  /* out: site of the nearest boundary line, -1 = domain edge */
    __global int *status)               /* in/out: ST_* bits (common.h), init 0 */
{
    __local float2 cpos[CAP];
    __local float cw[CAP];
    __local int cid[CAP];
    __local float red[TILE * TILE];
    __local float bound_l;
    __local int count_l;

    const int lx = get_local_id(0), ly = get_local_id(1), lid = ly * TILE + lx;
    const int ix = get_global_id(0), iy = get_global_id(1);
    const int valid = ix < nx && iy < ny;
    const float hx = W / nx, hy = H / ny;
    /* out-of-range work items shadow a real grid cell so that every work
       item runs the same loops (they write nothing) */
    const float px = (min(ix, nx - 1) + 0.5f) * hx, py = (min(iy, ny - 1) + 0.5f) * hy;
    /* the tile's grid-cell centres span this box */
    /* (not get_group_id: the host enqueues bands of tile rows with a global offset) */
    const int gx0 = ix - lx, gy0 = iy - ly;
    const float x0 = (gx0 + 0.5f) * hx, y0 = (gy0 + 0.5f) * hy;
    const float x1 = (min(gx0 + TILE, nx) - 0.5f) * hx, y1 = (min(gy0 + TILE, ny) - 0.5f) * hy;
    /* float rounding must never drop a needed site: pad the bounds */
    const float pad = 1e-4f * (hx * hx + hy * hy);

    /* bound U: the second best "worst corner" power distance among the
       sites of the nearest rings.  Two sites have pow <= U everywhere in the
       tile, so every grid cell finds its owner and a runner-up among the
       sites with  boxdist^2 - w <= U, and the runner-up bounds pass 2. */
    if (lid == 0)
        bound_l = tile_bound(x0, y0, x1, y1, pad, site, weight, bucket_start, nbx, nby, bw, bh, W, H);
    barrier(CLK_LOCAL_MEM_FENCE);
    const float U = bound_l;

    /* pass 1: owner (and runner-up) of p, streaming the candidates */
    float best = INFINITY, second = INFINITY;
    int best_id = INT_MAX, second_id = -1;
    float2 best_x = (float2)(0.0f), second_x = (float2)(0.0f);
    float best_w = 0.0f, second_w = 0.0f;
    for (int chunk = 0; ; ++chunk) {
        GATHER_CHUNK(GATHER_OWNER, U, 0.0f);
        for (int c = 0; c < m; ++c) {
            const float2 s = cpos[c];
            const float pw = len2(px - s.x, py - s.y) - cw[c];
            const int id = cid[c];
            if (pw < best || (pw == best && id < best_id)) {
                second = best; second_id = best_id; second_x = best_x; second_w = best_w;
                best = pw; best_id = id; best_x = s; best_w = cw[c];
            } else if (pw < second) {
                second = pw; second_id = id; second_x = s; second_w = cw[c];
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        if (total <= (chunk + 1) * CAP) break;
    }
    const int pix = iy * nx + ix;
    if (valid) label[pix] = best_id;
    if (valid && best_id == INT_MAX) atomic_or(status, ST_NO_OWNER);
    if (!with_dist) return;

    /* pass 2: distance to the nearest bounding line of the owner's cell */
    const float xi = best_x.x, yi = best_x.y, wi = best_w;
    const float ri = sqrt(len2(px - xi, py - yi));
#if PERIODIC
    /* the owner's own images bound its cell to half a period around it */
    float D = 0.5f * fmin(W, H);
    int D_id = best_id;
#else
    float D = fmin(fmin(px, W - px), fmin(py, H - py));
    int D_id = -1;
#endif
    if (second_id >= 0) {
        const float sep = sqrt(len2(second_x.x - xi, second_x.y - yi));
        if (sep > 0.0f) {
            const float dj = (second - best) / (2.0f * sep);
            if (dj < D) { D = dj; D_id = second_id; }
        }
    }
    /* gather radius for the whole tile: site j matters for p only within
       D + sqrt((D + ri)^2 + w_j - w_i); take the tile's largest D + ri
       and the smallest w_i, and add w_j per site in the gather */
    red[lid] = D + ri;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0) {
        float a = 0.0f;
        for (int t = 0; t < TILE * TILE; ++t) a = fmax(a, red[t]);
        bound_l = a;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const float A = bound_l;     /* max of D + ri, >= max D */
    barrier(CLK_LOCAL_MEM_FENCE);
    red[lid] = wi;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0) {
        float wlo = INFINITY;
        for (int t = 0; t < TILE * TILE; ++t) wlo = fmin(wlo, red[t]);
        bound_l = wlo;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const float wlo = bound_l;
    /* |p - x_j| <= A + sqrt(A^2 + w_j - wlo), and boxdist <= |p - x_j| */
    const float g1 = A * (1.0f + 1e-5f) + sqrt(pad), g2 = A * A * (1.0f + 1e-4f) + pad - wlo;
    for (int chunk = 0; ; ++chunk) {
        barrier(CLK_LOCAL_MEM_FENCE);
        GATHER_CHUNK(GATHER_DIST, g1, g2);
        for (int c = 0; c < m; ++c) {
            const float2 s = cpos[c];
            const float sep = sqrt(len2(s.x - xi, s.y - yi));
            if (sep == 0.0f) continue;      /* the owner itself (or a duplicate) */
            const float dj = (len2(px - s.x, py - s.y) - cw[c] - best) / (2.0f * sep);
            if (dj < D || (dj == D && cid[c] < D_id)) { D = dj; D_id = cid[c]; }
        }
        if (total <= (chunk + 1) * CAP) break;
    }
    if (valid) {
        dist[pix] = fmax(D, 0.0f);
        nbr[pix] = D_id;
    }
}

/* Labels only, laid out for CPUs: one work item per TW x TH tile of grid
 * cells, no barriers, and the candidate scan written with explicit float8
 * vectors (a row of the tile at a time), which PoCL turns into packed SIMD
 * instructions where it would not vectorize the scalar scan of power_labels.
 * The candidates and the arithmetic are those of power_labels' pass 1, so
 * both give the same labels.  (GPUs want the opposite layout: one work
 * item per grid cell, power_labels.) */
/* (8 lanes: AVX2 registers; 16-wide vectors would change the call ABI of
 * the builtins on CPUs without AVX-512) */
#define TW 8
#define TH 16

__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void power_labels_tile(
    LABEL_ARGS,
    __global int *label,                /* out: caller's index of the owning site */
    __global int *status)               /* in/out: ST_* bits (common.h), init 0 */
{
    __local float2 cpos[CAP];
    __local float cw[CAP];
    __local int cid[CAP];
    const int gx0 = get_global_id(0) * TW, gy0 = get_global_id(1) * TH;
    if (gx0 >= nx || gy0 >= ny) return;
    const float hx = W / nx, hy = H / ny;
    const float x0 = (gx0 + 0.5f) * hx, y0 = (gy0 + 0.5f) * hy;
    const float x1 = (min(gx0 + TW, nx) - 0.5f) * hx, y1 = (min(gy0 + TH, ny) - 0.5f) * hy;
    const float pad = 1e-4f * (hx * hx + hy * hy);
    const float U = tile_bound(x0, y0, x1, y1, pad, site, weight, bucket_start, nbx, nby, bw, bh, W, H);

    const int8 lane = (int8)(0, 1, 2, 3, 4, 5, 6, 7);
    /* columns past the raster shadow its last column (they write nothing) */
    const float8 px = (convert_float8(min(gx0 + lane, (int8)(nx - 1))) + 0.5f) * hx;
    float py[TH];
    float8 best[TH];
    int8 best_id[TH];
    for (int r = 0; r < TH; ++r) {
        py[r] = (min(gy0 + r, ny - 1) + 0.5f) * hy;
        best[r] = (float8)(INFINITY);
        best_id[r] = (int8)(INT_MAX);
    }
    for (int chunk = 0; ; ++chunk) {
        const int total = gather(GATHER_OWNER, U, 0.0f, chunk * CAP, x0, y0, x1, y1, site, weight,
                                 site_id, bucket_start, bucket_wmax, nbx, nby, bw, bh, W, H, wmax,
                                 cpos, cw, cid, status);
        const int m = min(total - chunk * CAP, CAP);
        for (int c = 0; c < m; ++c) {
            const float2 s = cpos[c];
            const float wc = cw[c];
            const int8 id = (int8)(cid[c]);
            const float8 dx = px - s.x;
            const float8 dx2 = dx * dx;
            for (int r = 0; r < TH; ++r) {
                const float dy = py[r] - s.y;
                const float8 pw = (dx2 + dy * dy) - wc;
                const int8 take = (pw < best[r]) | ((pw == best[r]) & (id < best_id[r]));
                best[r] = take ? pw : best[r];
                best_id[r] = take ? id : best_id[r];
            }
        }
        if (total <= (chunk + 1) * CAP) break;
    }
    const int cols = min(TW, nx - gx0);
    for (int r = 0; r < TH && gy0 + r < ny; ++r) {
        /* (lanes past the raster repeat its last column) */
        if (any(best_id[r] == (int8)(INT_MAX))) atomic_or(status, ST_NO_OWNER);
        __global int *row = label + (size_t)(gy0 + r) * nx + gx0;
        if (cols == TW) {
            vstore8(best_id[r], 0, row);
        } else {
            int tmp[TW];
            vstore8(best_id[r], 0, tmp);
            for (int k = 0; k < cols; ++k) row[k] = tmp[k];
        }
    }
}
