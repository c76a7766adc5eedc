/* Discrete power diagram on a grid, with each grid cell's distance to the
 * boundary of its power cell.
 *
 * Sites are sorted into a uniform bucket grid (nbx x nby buckets of size
 * bw x bh, CSR layout in bucket_start).  Each work item is one grid cell; it
 * searches the buckets in square rings around its own bucket, skipping a
 * bucket when a lower bound of its power distance cannot beat the best so
 * far, and stops when the next ring cannot.  The label is therefore exact
 * for the grid-cell centre (up to float32 rounding), not a flood-fill
 * approximation.
 *
 * The distance to the boundary is analytic: a power cell is the
 * intersection of half-planes, so the distance from an interior point to its
 * boundary is the smallest distance to the bounding lines
 *   d_j(p) = ((|p-x_j|^2 - w_j) - (|p-x_i|^2 - w_i)) / (2 |x_j - x_i|),
 * and, in a rectangle, to its four edges.  A site j can only give the minimum
 * D if |p - x_j| <= D + sqrt((D + |p - x_i|)^2 + w_j - w_i), which bounds the
 * second ring search.
 *
 * On a torus, ring offsets beyond the bucket grid wrap with a shift of one
 * period, so every periodic image of a site (the cell's own images
 * included) is a separate candidate.
 */
#include "common.h"

/* Distance from p to the outside of the block of buckets within ring r-1
 * of p's bucket: a lower bound on the distance to any site in ring >= r. */
inline float ring_gap(float px, float py, int bx, int by, int r, float bw, float bh)
{
    return fmin(fmin(px - (bx - r + 1) * bw, (bx + r) * bw - px),
                fmin(py - (by - r + 1) * bh, (by + r) * bh - py));
}

__kernel void power_labels(
    __global const float2 *site,        /* sites sorted by bucket */
    __global const float *weight,       /* their weights (squared radii) */
    __global const int *site_id,        /* sorted position -> caller's index */
    __global const int *bucket_start,   /* nbx*nby + 1 offsets into site[] */
    __global const float *bucket_wmax,  /* largest weight in each bucket */
    const int nbx, const int nby,       /* bucket grid size */
    const float bw, const float bh,     /* bucket size */
    const float W, const float H,       /* domain size */
    const float wmax,                   /* largest weight overall */
    const int nx, const int ny,         /* raster size */
    const int with_dist,                /* 0: labels only (Lloyd needs no distances) */
    __global int *label,                /* out: caller's index of the owning site */
    __global float *dist,               /* out: distance to the power cell boundary */
    __global int *nbr)                  /* out: site of the nearest boundary line, -1 = domain edge */
{
    const int ix = get_global_id(0), iy = get_global_id(1);
    if (ix >= nx || iy >= ny) return;
    const float px = (ix + 0.5f) * (W / nx), py = (iy + 0.5f) * (H / ny);
    const int bx = min((int)(px / bw), nbx - 1), by = min((int)(py / bh), nby - 1);
    const int rmax = PERIODIC ? 1 << 20 : max(nbx, nby);

    /* pass 1: owner of p */
    float best = INFINITY, second = INFINITY;
    int best_k = -1, second_k = -1;
    float bsx = 0.0f, bsy = 0.0f;           /* period shift of the best image */
    float ssx = 0.0f, ssy = 0.0f;           /* ... and of the runner-up */
    for (int r = 0; r <= rmax; ++r) {
        if (r > 0) {
            const float lb = ring_gap(px, py, bx, by, r, bw, bh);
            if (lb > 0.0f && lb * lb - wmax >= best) break;
        }
        for (int dy = -r; dy <= r; ++dy) {
            const int step = (dy == -r || dy == r) ? 1 : 2 * r;
            for (int dx = -r; dx <= r; dx += (step ? step : 1)) {
                int cx = bx + dx, cy = by + dy;
                float sx = 0.0f, sy = 0.0f;
#if PERIODIC
                int qx = floordiv(cx, nbx), qy = floordiv(cy, nby);
                sx = qx * W; sy = qy * H;
                cx -= qx * nbx; cy -= qy * nby;
#else
                if (cx < 0 || cy < 0 || cx >= nbx || cy >= nby) continue;
#endif
                const int b = cy * nbx + cx;
                const float x0 = cx * bw + sx, y0 = cy * bh + sy;
                const float d = box_dist(px, py, x0, y0, x0 + bw, y0 + bh);
                if (d * d - bucket_wmax[b] >= best) continue;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float2 s = site[k];
                    const float pw = len2(px - s.x - sx, py - s.y - sy) - weight[k];
                    if (pw < best || (pw == best && site_id[k] < site_id[best_k])) {
                        second = best; second_k = best_k; ssx = bsx; ssy = bsy;
                        best = pw; best_k = k; bsx = sx; bsy = sy;
                    } else if (pw < second) {
                        second = pw; second_k = k; ssx = sx; ssy = sy;
                    }
                }
            }
        }
    }

    const int pix = iy * nx + ix;
    label[pix] = site_id[best_k];
    if (!with_dist) return;

    /* pass 2: distance to the nearest bounding line of the owner's cell */
    const float xi = site[best_k].x + bsx, yi = site[best_k].y + bsy;
    const float wi = weight[best_k];
    const float pi_pow = len2(px - xi, py - yi) - wi;
    const float ri = sqrt(len2(px - xi, py - yi));
    float D = INFINITY;
    int D_id = -1;
#if !PERIODIC
    D = fmin(fmin(px, W - px), fmin(py, H - py));
#endif
    if (second_k >= 0) {
        /* the runner-up's line bounds D from the start, so the search below
           can stop early; it is found again there, which is harmless */
        const float xj = site[second_k].x + ssx, yj = site[second_k].y + ssy;
        const float sep = sqrt(len2(xj - xi, yj - yi));
        if (sep > 0.0f) {
            const float dj = (second - pi_pow) / (2.0f * sep);
            if (dj < D) { D = dj; D_id = site_id[second_k]; }
        }
    }
    for (int r = 0; r <= rmax; ++r) {
        if (r > 0) {
            const float lb = ring_gap(px, py, bx, by, r, bw, bh);
            if (lb > 0.0f && lb > D + sqrt((D + ri) * (D + ri) + wmax - wi)) break;
        }
        for (int dy = -r; dy <= r; ++dy) {
            const int step = (dy == -r || dy == r) ? 1 : 2 * r;
            for (int dx = -r; dx <= r; dx += (step ? step : 1)) {
                int cx = bx + dx, cy = by + dy;
                float sx = 0.0f, sy = 0.0f;
#if PERIODIC
                int qx = floordiv(cx, nbx), qy = floordiv(cy, nby);
                sx = qx * W; sy = qy * H;
                cx -= qx * nbx; cy -= qy * nby;
#else
                if (cx < 0 || cy < 0 || cx >= nbx || cy >= nby) continue;
#endif
                const int b = cy * nbx + cx;
                const float x0 = cx * bw + sx, y0 = cy * bh + sy;
                const float d = box_dist(px, py, x0, y0, x0 + bw, y0 + bh);
                if (d > D + sqrt((D + ri) * (D + ri) + bucket_wmax[b] - wi)) continue;
                for (int k = bucket_start[b]; k < bucket_start[b + 1]; ++k) {
                    const float xj = site[k].x + sx, yj = site[k].y + sy;
                    const float sep = sqrt(len2(xj - xi, yj - yi));
                    if (sep == 0.0f) continue;      /* the owner itself (or a duplicate) */
                    const float dj = (len2(px - xj, py - yj) - weight[k] - pi_pow) / (2.0f * sep);
                    if (dj < D) { D = dj; D_id = site_id[k]; }
                }
            }
        }
    }
    dist[pix] = fmax(D, 0.0f);
    nbr[pix] = D_id;
}
