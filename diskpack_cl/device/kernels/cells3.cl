/* Maximal inscribed sphere of every 3D Voronoi cell, one work item per site, float64.
 *
 * The sphere of cell i is the Chebyshev centre of the cell: the linear
 * program  max R  s.t.  n_k . q + R <= beta_k  over the planes that bound
 * the cell (q = centre - x_i).  Site j at offset a = x_j + shift - x_i,
 * L = |a|, gives n = a / L and beta = L / 2; in a box the six walls add
 * -q.x <= x_i.x, q.x <= W - x_i.x, ...
 *
 * Each work item solves the LP by the dual simplex method, starting from
 * four artificial planes that bound a large regular tetrahedron around the
 * site (dual feasible: their multipliers are all 1/4), and pivots in the
 * most violated constraint each step.  Candidates come from a scan of the
 * bucket grid: while the vertex is the artificial one, or the cutter ball
 * (below) is wider than the scan, the buckets within RING of the site's
 * bucket (RING grows up to RMAX); then the buckets the cutter ball touches.
 * A site j can violate the sphere (c, R), c = x_i + q, only if
 * |c - x_j| < |c - x_i| + 2 R (the bisector lies at least half the
 * difference of the two distances from c), so a scan of that ball that
 * finds nothing violated proves the vertex optimal for all sites.
 *
 * Outputs, per site in sorted order: (qx, qy, qz, R), the four constraint
 * codes of the optimal basis and a flag word (non-zero: unproven, the host
 * solves that cell again).  Codes: 125 j + 25 (sx + 2) + 5 (sy + 2) + (sz + 2)
 * for sorted site j shifted by (sx, sy, sz) periods (|s| <= 2; a scan that
 * reaches farther images flags the cell); -1..-6 for the walls
 * x = 0, x = W, y = 0, y = H, z = 0, z = D; -7..-10 artificial.
 *
 * Build-time switch: PERIODIC (see common.h).
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#include "common.h"

#define RMAX 4           /* widest scan ring while the cell is not yet bounded */
#define MAX_PIVOTS 200
#define MAX_SCAN 10      /* widest scan, in buckets from the centre's bucket */

/* flag bits, mirrored in diskpack_cl/cells3.py */
#define F_PIVOTS     1
#define F_UNBOUNDED  2
#define F_SCAN_WIDE  4
#define F_SINGULAR   8
#define F_SHIFT     16

typedef struct { double n[4][3]; double be[4]; int code[4]; } basis;

/* Solve M z = r for the 4 x 4 matrix with rows (n_k, 1) (transposed when
 * `tr`), by Gauss-Jordan elimination with partial pivoting; 0 if singular. */
static int solve4(const basis *B, int tr, const double *r, double *z)
{
    double a[4][5];
    for (int k = 0; k < 4; k++)
        for (int c = 0; c < 4; c++) {
            const double v = (c < 3) ? B->n[k][c] : 1.0;
            if (tr) a[c][k] = v; else a[k][c] = v;
        }
    for (int k = 0; k < 4; k++) a[k][4] = r[k];
    for (int c = 0; c < 4; c++) {
        int p = c;
        for (int k = c + 1; k < 4; k++) if (FABS(a[k][c]) > FABS(a[p][c])) p = k;
        if (FABS(a[p][c]) < 1e-13) return 0;
        for (int t = 0; t < 5; t++) { const double s = a[c][t]; a[c][t] = a[p][t]; a[p][t] = s; }
        for (int k = 0; k < 4; k++) {
            if (k == c) continue;
            const double f = a[k][c] / a[c][c];
            for (int t = c; t < 5; t++) a[k][t] -= f * a[c][t];
        }
    }
    for (int k = 0; k < 4; k++) z[k] = a[k][4] / a[k][k];
    return 1;
}

/* The constraint of site j (sorted) shifted by `shift` periods, seen from x_i. */
static void site_plane(__global const double *site, int j, int3 shift, double3 xi,
                       double3 size, double *nv, double *be)
{
    const double3 a = (double3)(site[3 * j], site[3 * j + 1], site[3 * j + 2])
                      + convert_double3(shift) * size - xi;
    const double L = SQRT(a.x * a.x + a.y * a.y + a.z * a.z);
    nv[0] = a.x / L; nv[1] = a.y / L; nv[2] = a.z / L;
    *be = 0.5 * L;
}

/* The most violated site constraint over the buckets [lo, hi] (per axis). */
static double most_violated(__global const double *site, __global const int *start, int i,
                            double3 xi, const double *x, int3 lo, int3 hi, int3 nb,
                            double3 size, double tol, int *best, int *flag)
{
    double worst = tol;
    for (int bz = lo.z; bz <= hi.z; bz++)
    for (int by = lo.y; by <= hi.y; by++)
    for (int bx = lo.x; bx <= hi.x; bx++) {
        int3 b = (int3)(bx, by, bz), shift = (int3)(0, 0, 0);
#if PERIODIC
        shift = (int3)(floordiv(bx, nb.x), floordiv(by, nb.y), floordiv(bz, nb.z));
        b -= shift * nb;
        if (iabs(shift.x) > 2 || iabs(shift.y) > 2 || iabs(shift.z) > 2) { *flag |= F_SHIFT; continue; }
#else
        if (any(b < 0) || any(b >= nb)) continue;
#endif
        const int id = (b.z * nb.y + b.y) * nb.x + b.x;
        for (int j = start[id]; j < start[id + 1]; j++) {
            if (j == i && all(shift == 0)) continue;
            double nv[3], be;
            site_plane(site, j, shift, xi, size, nv, &be);
            const double v = nv[0] * x[0] + nv[1] * x[1] + nv[2] * x[2] + x[3] - be;
            if (v > worst) {
                worst = v;
                *best = 125 * j + 25 * (shift.x + 2) + 5 * (shift.y + 2) + (shift.z + 2);
            }
        }
    }
    return worst;
}

/* The most violated wall (a box only). */
static double wall_violation(double3 xi, double3 size, const double *x, double tol, int *best)
{
    double worst = tol;
#if !PERIODIC
    const double lim[6] = {xi.x, size.x - xi.x, xi.y, size.y - xi.y, xi.z, size.z - xi.z};
    for (int w = 0; w < 6; w++) {
        const double v = ((w & 1) ? x[w / 2] : -x[w / 2]) + x[3] - lim[w];
        if (v > worst) { worst = v; *best = -1 - w; }
    }
#endif
    return worst;
}

/* Normal and beta of the constraint `code`. */
static void plane(__global const double *site, int code, double3 xi, double3 size,
                  double big, double *nv, double *be)
{
    if (code >= 0) {
        const int r = code % 125;
        site_plane(site, code / 125, (int3)(r / 25 - 2, (r / 5) % 5 - 2, r % 5 - 2), xi, size, nv, be);
        return;
    }
    nv[0] = nv[1] = nv[2] = 0.0;
    if (code >= -6) {
        const int w = -1 - code;
        const double lim[6] = {xi.x, size.x - xi.x, xi.y, size.y - xi.y, xi.z, size.z - xi.z};
        nv[w / 2] = (w & 1) ? 1.0 : -1.0;
        *be = lim[w];
        return;
    }
    const int t = -7 - code;   /* artificial: the corners of a regular tetrahedron */
    const double s = 0.5773502691896258;
    nv[0] = (t == 0 || t == 1) ? s : -s;
    nv[1] = (t == 0 || t == 2) ? s : -s;
    nv[2] = (t == 0 || t == 3) ? s : -s;
    *be = big;
}

__kernel void cell_mic3(
    __global const double *site,    /* 3 n coordinates, sorted by bucket */
    __global const int *start,      /* nbx nby nbz + 1 bucket offsets into site */
    const int n,                    /* number of sites */
    const int nbx, const int nby, const int nbz,   /* bucket grid */
    const double W, const double H, const double D,  /* domain size */
    const double tol,               /* violation tolerance (absolute) */
    const int offset,               /* first site of this enqueue */
    __global double *out_mic,       /* 4 per site: qx, qy, qz, R */
    __global int *out_code)         /* 5 per site: four basis codes, flag word */
{
    const int i = offset + get_global_id(0);
    if (i >= n) return;
    const double3 size = (double3)(W, H, D);
    const int3 nb = (int3)(nbx, nby, nbz);
    const double3 bs = size / convert_double3(nb);
    const double3 xi = (double3)(site[3 * i], site[3 * i + 1], site[3 * i + 2]);
    const double big = 4.0 * (W + H + D);
    basis B;
    for (int k = 0; k < 4; k++) {
        B.code[k] = -7 - k;
        plane(site, B.code[k], xi, size, big, B.n[k], &B.be[k]);
    }
    const double c4[4] = {0.0, 0.0, 0.0, 1.0};
    double x[4], lam[4];
    int flag = 0, ring = 1, pivots = 0;
    const int3 own = clamp(convert_int3(floor(xi / bs)), (int3)(0), nb - 1);
    for (;;) {
        if (!solve4(&B, 0, B.be, x) || !solve4(&B, 1, c4, lam)) { flag |= F_SINGULAR; break; }
        int artificial = 0;
        for (int k = 0; k < 4; k++) artificial |= B.code[k] <= -7;
        const double3 q = (double3)(x[0], x[1], x[2]);
        const double cut = length(q) + 2.0 * x[3];
        const double3 c = xi + q;
        int3 lo = own - ring, hi = own + ring;
        int clipped = 0;
        const int covered = !artificial && all(c - cut >= convert_double3(lo) * bs)
                            && all(c + cut <= convert_double3(hi + 1) * bs);
        if (!artificial && !covered) {
            lo = convert_int3(floor((c - cut) / bs));
            hi = convert_int3(floor((c + cut) / bs));
            const int3 cb = convert_int3(floor(c / bs));
#if !PERIODIC
            lo = max(lo, (int3)(0)); hi = min(hi, nb - 1);   /* no sites outside the box */
#endif
            if (any(hi - cb > MAX_SCAN) || any(cb - lo > MAX_SCAN)) {
                lo = max(lo, cb - MAX_SCAN); hi = min(hi, cb + MAX_SCAN);
                clipped = 1;   /* the scan may pivot, but proves nothing */
            }
        }
        int best = 0;
        double worst = most_violated(site, start, i, xi, x, lo, hi, nb, size, tol, &best, &flag);
        worst = wall_violation(xi, size, x, worst, &best);
        if (worst <= tol) {
            if (!artificial) {               /* proven: nothing in the cutter ball cuts */
                if (clipped) flag |= F_SCAN_WIDE;
                break;
            }
            if (ring++ >= RMAX) { flag |= F_UNBOUNDED; break; }
            continue;
        }
        if (++pivots > MAX_PIVOTS) { flag |= F_PIVOTS; break; }
        double nv[3], be, mu[4];
        plane(site, best, xi, size, big, nv, &be);
        const double row[4] = {nv[0], nv[1], nv[2], 1.0};
        if (!solve4(&B, 1, row, mu)) { flag |= F_SINGULAR; break; }
        int leave = -1;
        double ratio = 0.0;
        for (int k = 0; k < 4; k++) {
            if (mu[k] <= 1e-12) continue;
            const double t = lam[k] / mu[k];
            if (leave < 0 || t < ratio) { leave = k; ratio = t; }
        }
        if (leave < 0) { flag |= F_UNBOUNDED; break; }
        for (int t = 0; t < 3; t++) B.n[leave][t] = nv[t];
        B.be[leave] = be;
        B.code[leave] = best;
    }
    for (int k = 0; k < 4; k++) {
        out_mic[4 * i + k] = x[k];
        out_code[5 * i + k] = B.code[k];
    }
    out_code[5 * i + 4] = flag;
}
