/* Distance from every site to its nearest other site, one work item per site, float64.
 *
 * The sites come sorted by bucket (the grid of cells.cl).  A work item
 * scans the 3 x 3 buckets around its own; every site nearer than one bucket
 * side lies in them, so a nearest distance up to that side is exact, and a
 * larger one (a site alone in its neighbourhood) is written as -1 for the
 * host to measure.  The distances are computed as cells.cl computes them
 * (offset to the shifted site, sqrt of the smallest squared length): this
 * kernel gives the nearest-neighbour distances of the sets whose MICs are
 * not needed (the iterate where a relaxation goes local) at a small part of
 * that kernel's cost.
 *
 * Build-time switch: PERIODIC (see common.h).
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#include "common.h"

/* Bucket index c, at most one bucket off a row of n, onto the row: on a torus wrapped,
 * with its period shift in q; on a rectangle, 0 when it lies off the row (wrap_bucket
 * without its divisions, for offsets of one bucket). */
inline int step_into(int *c, int *q, int n)
{
#if PERIODIC
    if (*c < 0) { *c += n; *q = -1; } else if (*c >= n) { *c -= n; *q = 1; }
    return 1;
#else
    return *c >= 0 && *c < n;
#endif
}

__kernel void nearest(
    __global const double2 *site,    /* sites sorted by bucket */
    __global const int *bstart,      /* bucket b holds sorted sites bstart[b] .. bstart[b+1]-1 */
    const int n,                     /* number of sites */
    const int nbx, const int nby,    /* bucket grid */
    const double bw, const double bh,/* bucket size */
    const double W, const double H,  /* domain size */
    __global double *nn)             /* out, by sorted position: distance, or -1 (not proven) */
{
    const int s = get_global_id(0);
    if (s >= n) return;
    const double2 xi = site[s];
    const int hx = iclamp((int)(xi.x / bw), 0, nbx - 1), hy = iclamp((int)(xi.y / bh), 0, nby - 1);
    double nn2 = INFINITY;
    for (int dy = -1; dy <= 1; ++dy) {
        int cy = hy + dy, qy = 0;
        if (!step_into(&cy, &qy, nby)) continue;
        const int row = cy * nbx;
        if (hx >= 1 && hx + 1 < nbx) {
            /* the row's three buckets are one run of sites, none shifted: one loop
             * rather than three short ones, whose ends the branches mispredict */
            for (int t = bstart[row + hx - 1]; t < bstart[row + hx + 2]; ++t) {
                if (t == s) continue;
                const double ax = site[t].x - xi.x, ay = site[t].y + qy * H - xi.y;
                nn2 = FMIN(nn2, ax * ax + ay * ay);
            }
            continue;
        }
        for (int dx = -1; dx <= 1; ++dx) {
            int cx = hx + dx, qx = 0;
            if (!step_into(&cx, &qx, nbx)) continue;
            const int b = row + cx;
            for (int t = bstart[b]; t < bstart[b + 1]; ++t) {
                if (t == s) continue;   /* its own periodic images are no other site */
                const double ax = site[t].x + qx * W - xi.x, ay = site[t].y + qy * H - xi.y;
                nn2 = FMIN(nn2, ax * ax + ay * ay);
            }
        }
    }
    const double side = FMIN(bw, bh);
    nn[s] = nn2 <= side * side ? SQRT(nn2) : -1.0;
}
