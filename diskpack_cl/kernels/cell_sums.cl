/* Density integrals of every cell of a grid labelling, reduced on the device:
 * per site the mass  sum d  and the first moments  sum d (p - x_i)  about
 * the site (in grid-cell units), from which the host forms centroids.
 *
 * One work item per SEG grid cells of a row.  Runs of equal labels are summed
 * in `real` (double where the device has cl_khr_fp64), and each run is added
 * to its site's totals with 64-bit integer atomics in fixed point (FIX units
 * per unit), which are exact and order-independent: the sums do not depend
 * on the schedule, so results are reproducible.  On a torus, offsets take
 * the nearest periodic image, so a cell crossing the seam averages its own
 * contiguous piece.  A grid cell whose label names no site (only possible
 * for sites the host refuses) adds nothing and reads no site.
 *
 * power_sums_tile labels and sums in one pass, in the CPU layout of
 * power_labels_tile: each work item sums its tile's grid cells per owner in
 * local memory and adds each owner's sums once, so no label map is written
 * or read, and a tile costs a few atomics instead of three per run of each
 * row.  Its totals are cell_sums' of power_labels_tile's labels, but for
 * where the fixed point rounds (per tile and owner, not per run).
 *
 * Build-time switches: PERIODIC (see common.h), USE_FP64 (0 or 1), CAP
 * (power_gather.h).
 */
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#include "power_gather.h"

#if USE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
#else
typedef float real;
#endif

#define SEG 32
#define FIX 16777216.0f   /* 2^24: totals stay below 2^63 for densities <= 1 and
                             compact cells of up to about 2^26 grid cells */

inline void add_run(__global long *acc, int l, int nsite, real m, real mx, real my)
{
    if (!owned(l, nsite)) return;
    atom_add(&acc[3 * l], (long)RINT(m * FIX));
    atom_add(&acc[3 * l + 1], (long)RINT(mx * FIX));
    atom_add(&acc[3 * l + 2], (long)RINT(my * FIX));
}

/* Offsets of site l's x and grid row py (periodic: the nearest image);
 * zero for a label that names no site. */
inline void site_origin(__global const real *site, int l, int nsite, int ny, real py,
                        real *sx, real *dy)
{
    const int ok = owned(l, nsite);
    *sx = ok ? site[2 * l] : 0;
    *dy = ok ? py - site[2 * l + 1] : 0;
#if PERIODIC
    *dy -= ny * rint(*dy / ny);
#endif
}

__kernel void cell_sums(
    __global const int *label,       /* owning site of each grid cell */
    __global const float *density,   /* density of each grid cell (float: read, not summed) */
    __global const real *site,       /* site positions in grid-cell units, x then y */
    const int nsite,                 /* sites: labels in [0, nsite) */
    const int nx, const int ny,      /* raster size */
    const int row0,                  /* first row of this enqueue */
    __global long *acc)              /* in/out: per site mass, x moment, y moment (init 0) */
{
    const int iy = row0 + get_global_id(1);
    const int ix0 = get_global_id(0) * SEG;
    if (iy >= ny || ix0 >= nx) return;
    const int ix1 = imin(ix0 + SEG, nx);
    const size_t base = (size_t)iy * nx;
    const real py = iy + (real)0.5;
    int cur = label[base + ix0];
    real m = 0, mx = 0, my = 0, sx, dy;
    site_origin(site, cur, nsite, ny, py, &sx, &dy);
    for (int ix = ix0; ix < ix1; ++ix) {
        const int l = label[base + ix];
        if (l != cur) {
            add_run(acc, cur, nsite, m, mx, my);
            cur = l;
            m = mx = my = 0;
            site_origin(site, cur, nsite, ny, py, &sx, &dy);
        }
        const real d = density[base + ix];
        real dx = (ix + (real)0.5) - sx;
#if PERIODIC
        dx -= nx * RINT(dx / nx);
#endif
        m += d;
        mx += d * dx;
        my += d * dy;
    }
    add_run(acc, cur, nsite, m, mx, my);
}

/* Add a run of owner l's sums to its slot in the tile's table of `k` owners
 * (a new slot for a new owner); returns the owners now in the table. */
inline int add_to_slot(__local int *own, __local real *sum, int k, int l, real m, real mx, real my)
{
    int t = 0;
    while (t < k && own[t] != l) ++t;
    if (t == k) {
        own[k++] = l;
        sum[3 * t] = sum[3 * t + 1] = sum[3 * t + 2] = 0;
    }
    sum[3 * t] += m;
    sum[3 * t + 1] += mx;
    sum[3 * t + 2] += my;
    return k;
}

/* Labels (as power_labels_tile) and density sums (as cell_sums) of one tile:
 * runs of equal owners are summed in registers, as in cell_sums, then per
 * owner in local memory, and each owner's totals get one atomic add each. */
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void power_sums_tile(
    LABEL_ARGS,
    __global const float *density,   /* density of each grid cell (float: read, not summed) */
    __global const real *gsite,      /* site positions in grid-cell units, x then y, by caller's index */
    const int nsite,                 /* sites */
    __global int *status,            /* in/out: ST_* bits (common.h), init 0 */
    __global long *acc)              /* in/out: per site mass, x moment, y moment (init 0) */
{
    __local float2 cpos[CAP];
    __local float cw[CAP];
    __local int cid[CAP];
    __local int own[TW * TH];        /* the tile's owners so far */
    __local real sum[3 * TW * TH];   /* and their sums */
    const int gx0 = get_global_id(0) * TW, gy0 = get_global_id(1) * TH;
    if (gx0 >= nx || gy0 >= ny) return;
    intT best_id[TH];
    tile_owners(gx0, gy0, LABEL_PASS, cpos, cw, cid, status, best_id);
    int k = 0, cur = -1;             /* owners in the table; the run's owner (-1: none yet) */
    real m = 0, mx = 0, my = 0, sx = 0, sy = 0;
    for (int r = 0; r < TH && gy0 + r < ny; ++r) {
        int ids[TW];
        vstoreT(best_id[r], 0, ids);
        const size_t base = (size_t)(gy0 + r) * nx;
        const real py = gy0 + r + (real)0.5;
        for (int c = 0; c < TW && gx0 + c < nx; ++c) {
            const int l = ids[c];
            if (l != cur) {
                if (owned(cur, nsite)) k = add_to_slot(own, sum, k, cur, m, mx, my);
                cur = l;
                m = mx = my = 0;
                sx = owned(l, nsite) ? gsite[2 * l] : 0;
                sy = owned(l, nsite) ? gsite[2 * l + 1] : 0;
            }
            const real d = density[base + gx0 + c];
            real dx = (gx0 + c + (real)0.5) - sx, dy = py - sy;
#if PERIODIC
            dx -= nx * RINT(dx / nx);
            dy -= ny * RINT(dy / ny);
#endif
            m += d;
            mx += d * dx;
            my += d * dy;
        }
    }
    if (owned(cur, nsite)) k = add_to_slot(own, sum, k, cur, m, mx, my);
    for (int t = 0; t < k; ++t)
        add_run(acc, own[t], nsite, sum[3 * t], sum[3 * t + 1], sum[3 * t + 2]);
}
