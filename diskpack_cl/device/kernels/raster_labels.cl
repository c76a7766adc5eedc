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
#include "power_gather.h"

#ifndef TILE
#define TILE 8
#endif

/* Both passes of power_labels: chunk `chunk` of the candidates into local
 * memory (work item 0 gathers, every work item waits); `total` counts all
 * candidates, `m` those of this chunk. */
#define GATHER_CHUNK(mode, a, b)                                                        \
    if (lid == 0)                                                                       \
        count_l = gather(mode, a, b, chunk * CAP, x0, y0, x1, y1, site, weight,         \
                         site_id, bucket_start, bucket_wmax, nbx, nby, bw, bh, W, H,    \
                         wmax, cpos, cw, cid, status, 0);                               \
    barrier(CLK_LOCAL_MEM_FENCE);                                                       \
    const int total = count_l;                                                          \
    const int m = imin(total - chunk * CAP, CAP)

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
    const float px = (imin(ix, nx - 1) + 0.5f) * hx, py = (imin(iy, ny - 1) + 0.5f) * hy;
    /* the tile's grid-cell centres span this box */
    /* (not get_group_id: the host enqueues bands of tile rows with a global offset) */
    const int gx0 = ix - lx, gy0 = iy - ly;
    const float x0 = (gx0 + 0.5f) * hx, y0 = (gy0 + 0.5f) * hy;
    const float x1 = (imin(gx0 + TILE, nx) - 0.5f) * hx, y1 = (imin(gy0 + TILE, ny) - 0.5f) * hy;
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
    const float ri = SQRT(len2(px - xi, py - yi));
#if PERIODIC
    /* the owner's own images bound its cell to half a period around it */
    float D = 0.5f * FMIN(W, H);
    int D_id = best_id;
#else
    float D = FMIN(FMIN(px, W - px), FMIN(py, H - py));
    int D_id = -1;
#endif
    if (second_id >= 0) {
        const float sep = SQRT(len2(second_x.x - xi, second_x.y - yi));
        if (sep > 0.0f) {
            const float dj = (second - best) / (2.0f * sep);
            if (dj < D) { D = dj; D_id = second_id; }
        }
    }
    /* gather radius for the whole tile: site j matters for p only within
       D + SQRT((D + ri)^2 + w_j - w_i); take the tile's largest D + ri
       and the smallest w_i, and add w_j per site in the gather */
    red[lid] = D + ri;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0) {
        float a = 0.0f;
        for (int t = 0; t < TILE * TILE; ++t) a = FMAX(a, red[t]);
        bound_l = a;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const float A = bound_l;     /* max of D + ri, >= max D */
    barrier(CLK_LOCAL_MEM_FENCE);
    red[lid] = wi;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0) {
        float wlo = INFINITY;
        for (int t = 0; t < TILE * TILE; ++t) wlo = FMIN(wlo, red[t]);
        bound_l = wlo;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const float wlo = bound_l;
    /* |p - x_j| <= A + sqrt(A^2 + w_j - wlo), and boxdist <= |p - x_j| */
    const float g1 = A * (1.0f + 1e-5f) + SQRT(pad), g2 = A * A * (1.0f + 1e-4f) + pad - wlo;
    for (int chunk = 0; ; ++chunk) {
        barrier(CLK_LOCAL_MEM_FENCE);
        GATHER_CHUNK(GATHER_DIST, g1, g2);
        for (int c = 0; c < m; ++c) {
            const float2 s = cpos[c];
            const float sep = SQRT(len2(s.x - xi, s.y - yi));
            if (sep == 0.0f) continue;      /* the owner itself (or a duplicate) */
            const float dj = (len2(px - s.x, py - s.y) - cw[c] - best) / (2.0f * sep);
            if (dj < D || (dj == D && cid[c] < D_id)) { D = dj; D_id = cid[c]; }
        }
        if (total <= (chunk + 1) * CAP) break;
    }
    if (valid) {
        dist[pix] = FMAX(D, 0.0f);
        nbr[pix] = D_id;
    }
}

/* Labels only, in the CPU layout (tile_owners, power_gather.h). */
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void power_labels_tile(
    LABEL_ARGS,
    __global int *label,                /* out: caller's index of the owning site */
    __global int *status)               /* in/out: ST_* bits (common.h), init 0 */
{
    const int gx0 = get_global_id(0) * TW, gy0 = get_global_id(1) * TH;
    if (gx0 >= nx || gy0 >= ny) return;
    intT best_id[TH];
    tile_owners(gx0, gy0, LABEL_PASS, status, best_id);
    const int cols = imin(TW, nx - gx0);
    for (int r = 0; r < TH && gy0 + r < ny; ++r) {
        __global int *row = label + (size_t)(gy0 + r) * nx + gx0;
        if (cols == TW) {
            vstoreT(best_id[r], 0, row);
        } else {
            int tmp[TW];
            vstoreT(best_id[r], 0, tmp);
            for (int k = 0; k < cols; ++k) row[k] = tmp[k];
        }
    }
}
