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
 * power_labels_tile: each work item takes its tile's owners one by one and
 * sums each owner's grid cells with TW-wide vectors masked by the label
 * (lanes, then a fixed reduction order), so no label map is written or read
 * and a tile costs one atomic add per owner and total.  Its totals are
 * cell_sums' of power_labels_tile's labels, but for where the fixed point
 * rounds (per tile and owner, not per run).
 *
 * Build-time switches: PERIODIC (see common.h), USE_FP64 (0 or 1), TW
 * (power_gather.h), WIDE_BUILTINS (wide.h).
 */
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#include "power_gather.h"

#if USE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double8 real8;
typedef double4 real4;
typedef double2 real2;
#else
typedef float real;
typedef float8 real8;
typedef float4 real4;
typedef float2 real2;
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

/* Vectors of `real` as wide as the tile's rows, and their reductions in a
 * fixed order (so the sums do not depend on the compiler's choices). */
#if USE_FP64 && TW == 16
#define realT double16
#define convert_realT convert_double16
#elif USE_FP64
#define realT double8
#define convert_realT CONVERT_D8
#elif TW == 16
#define realT float16
#define convert_realT convert_float16
#else
#define realT float8
#define convert_realT convert_float8
#endif
#if USE_FP64 && TW == 8
#define RINT_realT RINT_D8   /* a builtin on a 512-bit vector: wide.h */
#else
#define RINT_realT rint
#endif

inline real hsum(realT v)
{
#if TW == 16
    const real8 a = v.lo + v.hi;
#else
    const real8 a = v;
#endif
    const real4 b = a.lo + a.hi;
    const real2 c = b.lo + b.hi;
    return c.lo + c.hi;
}

inline int hmin(intT v)
{
#if TW == 16
    const int8 a = min(v.lo, v.hi);
#else
    const int8 a = v;
#endif
    const int4 b = min(a.lo, a.hi);
    const int2 c = min(b.lo, b.hi);
    return min(c.lo, c.hi);
}

/* Row `row` of the density from column gx0, TW wide; zero past the raster. */
inline floatT density_row(__global const float *density, size_t row, int gx0, int nx)
{
    if (gx0 + TW <= nx) return vloadT(0, density + row * nx + gx0);
    float part[TW];
    for (int c = 0; c < TW; ++c) part[c] = gx0 + c < nx ? density[row * nx + gx0 + c] : 0.0f;
    return vloadT(0, part);
}

/* Labels (as power_labels_tile) and density sums (as cell_sums) of one tile.
 * The tile's owners are taken in increasing index; each owner's sums are
 * formed lane by lane over the tile's rows, masked by its label, then
 * reduced across the lanes, and added with one atomic add each. */
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void power_sums_tile(
    LABEL_ARGS,
    __global const float *density,   /* density of each grid cell (float: read, not summed) */
    __global const real *gsite,      /* site positions in grid-cell units, x then y, by caller's index */
    const int nsite,                 /* sites */
    __global int *status,            /* in/out: ST_* bits (common.h), init 0 */
    __global long *acc)              /* in/out: per site mass, x moment, y moment (init 0) */
{
    const int gx0 = get_global_id(0) * TW, gy0 = get_global_id(1) * TH;
    if (gx0 >= nx || gy0 >= ny) return;
    intT best_id[TH];
    tile_owners(gx0, gy0, LABEL_PASS, status, best_id);
    const int rows = imin(TH, ny - gy0);
    /* lanes past the raster repeat its last column's owner and read no
       density (density_row), so they add nothing */
    /* the least owner first: a vector min over the rows, then across the lanes */
    intT first = best_id[0];
    for (int r = 1; r < rows; ++r) first = min(first, best_id[r]);
    int l = hmin(first);
    const realT cx = convert_realT(gx0 + LANES) + (real)0.5;
    while (l != INT_MAX) {
        const int ok = owned(l, nsite);
        const real sx = ok ? gsite[2 * l] : 0, sy = ok ? gsite[2 * l + 1] : 0;
        realT dx = cx - sx;
#if PERIODIC
        dx -= nx * RINT_realT(dx / nx);
#endif
        realT m = 0, mx = 0, my = 0;
        intT after = (intT)(INT_MAX);
        for (int r = 0; r < rows; ++r) {
            const floatT d = density_row(density, gy0 + r, gx0, nx);
            const realT dd = convert_realT(select((floatT)(0.0f), d, best_id[r] == l));
            real dy = gy0 + r + (real)0.5 - sy;
#if PERIODIC
            dy -= ny * RINT(dy / ny);   /* (dx above is a vector: RINT takes scalars) */
#endif
            m += dd;
            mx += dd * dx;
            my += dd * dy;
            after = min(after, select((intT)(INT_MAX), best_id[r], best_id[r] > l));
        }
        add_run(acc, l, nsite, hsum(m), hsum(mx), hsum(my));
        l = hmin(after);
    }
}
