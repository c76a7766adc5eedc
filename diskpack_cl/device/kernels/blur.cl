/* Separable Gaussian blur of a float64 image, as scipy.ndimage.gaussian_filter1d
 * makes it along each axis in "reflect" mode (d c b a | a b c d | d c b a):
 * blur_columns along the rows' direction (axis 0), then blur_rows (axis 1),
 * each from its own input buffer.
 *
 * The weights w[0..2r] are symmetric about w[r], and every output is summed
 * as scipy's correlate1d sums a symmetric kernel:
 *     w[r] * in[i]  +  sum over j = r, r-1, ..., 1 of  w[r - j] * (in[i - j] + in[i + j]),
 * with contraction into fused multiply-adds switched off, so that the sums
 * round as scipy's do.  A work item makes 8 neighbouring outputs of a row
 * with double8 vectors (blur_columns: of ROWS rows); taps past the image's
 * ends take the reflected index.  Build-time switches: WIDE_BUILTINS
 * (wide.h), ROWS.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#include "wide.h"
#pragma OPENCL FP_CONTRACT OFF

/* Index i of a line of n samples under scipy's "reflect" mode (period 2n). */
inline int reflect(int i, int n)
{
    const int p = 2 * n;
    i %= p;
    if (i < 0) i += p;
    return i < n ? i : p - 1 - i;
}

/* Sample i of a line of n samples `stride` apart, blurred, each tap reflected. */
inline double line_blur(__global const double *line, size_t stride, int i, int n,
                        __global const double *w, int r)
{
    double acc = w[r] * line[(size_t)i * stride];
    for (int j = r; j >= 1; --j)
        acc += w[r - j] * (line[(size_t)reflect(i - j, n) * stride] + line[(size_t)reflect(i + j, n) * stride]);
    return acc;
}

/* out[y, x] for x = 8 g .. 8 g + 7 and y = ROWS h .. ROWS h + ROWS - 1 from the
 * rows y - r .. y + r of `in`.  Neighbouring outputs of a column share most of
 * their taps: tap j of output o reads rows o - j and o + j, which are taps j + 1
 * of output o + 1 and j - 1 of output o - 1, so the ROWS outputs keep the rows
 * of one j in windows that slide by a row per j, and load two rows a j instead
 * of 2 ROWS (the pass had been bound by those loads).  Each output still sums
 * its taps in scipy's order. */
#ifndef ROWS
#define ROWS 8
#endif
__kernel void blur_columns(__global const double *in, __global double *out,
                           __global const double *w, const int r, const int nx, const int ny)
{
    const int x0 = get_global_id(0) * 8, y0 = get_global_id(1) * ROWS;
    if (x0 >= nx || y0 >= ny) return;
    if (x0 + 8 > nx) {
        for (int y = y0; y < min(y0 + ROWS, ny); ++y)
            for (int x = x0; x < nx; ++x)
                out[(size_t)y * nx + x] = line_blur(in + x, nx, y, ny, w, r);
        return;
    }
    in += x0;
    double8 acc[ROWS], lo[ROWS], hi[ROWS];   /* lo[o], hi[o]: rows y0 + o - j, y0 + o + j */
#pragma unroll
    for (int o = 0; o < ROWS; ++o) {
        acc[o] = w[r] * VLOAD_D8(in + (size_t)reflect(y0 + o, ny) * nx);
        lo[o] = VLOAD_D8(in + (size_t)reflect(y0 + o - r, ny) * nx);
        hi[o] = VLOAD_D8(in + (size_t)reflect(y0 + o + r, ny) * nx);
    }
    for (int j = r; j >= 1; --j) {
        const double wj = w[r - j];
#pragma unroll
        for (int o = 0; o < ROWS; ++o) acc[o] += wj * (lo[o] + hi[o]);
        if (j == 1) break;
        /* to j - 1: lo moves down a row, hi up a row, each taking one new row */
#pragma unroll
        for (int o = 0; o < ROWS - 1; ++o) {
            lo[o] = lo[o + 1];
            hi[ROWS - 1 - o] = hi[ROWS - 2 - o];
        }
        lo[ROWS - 1] = VLOAD_D8(in + (size_t)reflect(y0 + ROWS - j, ny) * nx);
        hi[0] = VLOAD_D8(in + (size_t)reflect(y0 + j - 1, ny) * nx);
    }
#pragma unroll
    for (int o = 0; o < ROWS; ++o)
        if (y0 + o < ny) VSTORE_D8(acc[o], out + (size_t)(y0 + o) * nx + x0);
}

/* out[y, x] for x = 8 g .. 8 g + 7 from the columns x - r .. x + 7 + r of row y of `in`. */
__kernel void blur_rows(__global const double *in, __global double *out,
                        __global const double *w, const int r, const int nx, const int ny)
{
    const int x0 = get_global_id(0) * 8, y = get_global_id(1);
    if (x0 >= nx || y >= ny) return;
    __global const double *row = in + (size_t)y * nx;
    if (x0 - r >= 0 && x0 + 8 + r <= nx) {
        double8 acc = w[r] * VLOAD_D8(row + x0);
        for (int j = r; j >= 1; --j)
            acc += w[r - j] * (VLOAD_D8(row + x0 - j) + VLOAD_D8(row + x0 + j));
        VSTORE_D8(acc, out + (size_t)y * nx + x0);
        return;
    }
    for (int x = x0; x < min(x0 + 8, nx); ++x)
        out[(size_t)y * nx + x] = line_blur(row, 1, x, nx, w, r);
}
