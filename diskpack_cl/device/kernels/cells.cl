/* Maximal inscribed circle of every power cell, or of a list of them, one work item
 * per cell, float64.
 *
 * The MIC of cell i is the Chebyshev centre of its power cell: the linear
 * program  max R  s.t.  n_k . q + R <= beta_k  over the half-planes that
 * bound the cell (q = centre - x_i).  Site j at offset a = x_j + shift - x_i,
 * L = |a|, gives n = a / L and beta = (L^2 - w_j + w_i) / (2 L); on a
 * rectangle the four edges add q.x >= -x_i, q.x <= W - x_i, ...
 *
 * Each work item
 *   1. gathers the sites of the bucket rings around its own bucket until it
 *      holds at least KMIN of them (or RMAX rings), into a private list, and
 *      more rings while the cell is unbounded by them;
 *   2. solves the LP on the list by the dual simplex method, starting from
 *      the cell's optimal basis of the previous call where the host asks for
 *      it (warm) and it is in the list and dual feasible (a relaxation's step:
 *      the optimum's basis in most cells), else from the nearest half-planes
 *      of three sectors of directions where they bound a triangle (dual
 *      feasible; the optimum's basis, or a pivot or two from it, in most
 *      cells), else from three artificial half-planes that bound a large
 *      triangle (dual feasible by construction), and pivoting in the most
 *      violated constraint each step;
 *   3. proves the answer for *all* sites: a site can only violate the
 *      solution if it lies within the cutter radius of the centre (derived
 *      from the power distance; per-bucket weight maxima prune the scan).
 *      When that ball lies inside the gathered rings, nothing is left to
 *      check; otherwise the buckets it touches are scanned (outside the
 *      gathered rings, whose sites the list already holds), and violated or
 *      near-tight sites join the list and the solve continues (warm start).
 *      The scan covers at most a box that doubles each round it finds
 *      nothing: a cell that its gathered sites left unbounded on one side
 *      has a huge cutter radius at first, which the first sites found there
 *      shrink, so scanning that whole ball at once would cost thousands of
 *      buckets;
 *   4. writes, in the order of the list of cells (sorted positions, ascending
 *      for sequential writes), the centre, the radius, the three basic (active)
 *      constraints, the other near-tight ones, the nearest-neighbour distance
 *      of the site and a flag word, non-zero where it could not prove its answer;
 *      where the host asks for it, the basis again by sorted position, for the
 *      next call's warm start.
 *
 * Constraint codes: 9 * j + 3 * (sx + 1) + (sy + 1) for sorted site j shifted by
 * (sx, sy) periods (|sx|, |sy| <= 1); -1..-4 for the left, right, top and
 * bottom edges; artificial constraints never leave the kernel unflagged.
 *
 * Build-time switches: PERIODIC (see common.h), MAXC (list capacity),
 * MAXNEAR (near-tight constraints reported besides the basis).
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#include "common.h"

#ifndef MAXC
#error "define MAXC (constraint list capacity)"
#endif
#ifndef MAXNEAR
#error "define MAXNEAR (near-tight constraints reported per cell)"
#endif

#define KMIN 14          /* sites gathered before the first solve */
#define RMAX 6           /* most bucket rings gathered up front */
#define RMAX_GROW 12     /* most rings gathered while the cell reaches past them */
#define MAX_PIVOTS 96
#define MAX_ROUNDS 32     /* scan rounds: solves plus doublings of the scan box */
#define MAX_SCAN 256     /* widest verification scan on a torus, in buckets per side */
#define GATHER_CAP (MAXC - 16)  /* list room kept for the sites step 3 adds */

/* flag bits, mirrored in diskpack_cl/cells.py */
#define F_LIST_FULL   1
#define F_PIVOTS      2
#define F_UNBOUNDED   4
#define F_SCAN_WIDE   8
#define F_NEAR_FULL  16
#define F_ROUNDS     32
#define F_SHIFT      64
#define F_NN        128

typedef struct {
    double nx[MAXC], ny[MAXC], be[MAXC];
    double d[MAXC];      /* distance of the site from x_i (0 for edges) */
    int code[MAXC];
    int m;
    int raw;             /* entries raw .. m-1 still hold (a.x, a.y, len^2 - w_j + w_i, len^2) */
} clist;

/* Inverse of the 3x3 matrix with rows (ax_k, ay_k, 1); returns 0 if singular.
 * The rows come as scalars, not arrays: arrays filled element by element and
 * read back as vectors stalled on store forwarding (sector_basis, which filled
 * them, held a tenth of the kernel's profile). */
static int inv3(double ax0, double ax1, double ax2, double ay0, double ay1, double ay2,
                double *inv)
{
    const double c0 = ay1 - ay2, c1 = ay2 - ay0, c2 = ay0 - ay1;
    const double det = ax0 * c0 + ax1 * c1 + ax2 * c2;
    if (FABS(det) < 1e-14) return 0;
    const double id = 1.0 / det;
    /* columns of the inverse follow the rows of the matrix */
    inv[0] = c0 * id;                inv[1] = c1 * id;                inv[2] = c2 * id;
    inv[3] = (ax2 - ax1) * id;       inv[4] = (ax0 - ax2) * id;       inv[5] = (ax1 - ax0) * id;
    inv[6] = (ax1 * ay2 - ax2 * ay1) * id;
    inv[7] = (ax2 * ay0 - ax0 * ay2) * id;
    inv[8] = (ax0 * ay1 - ax1 * ay0) * id;
    return 1;
}

/* Slack of constraint k of the list at z = (qx, qy, R). */
static double slack(const clist *L, int k, const double *z)
{
    return L->be[k] - L->nx[k] * z[0] - L->ny[k] * z[1] - z[2];
}

/* How many constraints have slack below `lim` at z, of the positions
 * first.. other than b[0..2] (b: NULL for none); without branches. */
static int count_tight(const clist *L, const double *z, double lim, int first, const int *b)
{
    const int b0 = b ? b[0] : -1, b1 = b ? b[1] : -1, b2 = b ? b[2] : -1;
    int c = 0;
    for (int k = first; k < L->m; ++k)
        c += (slack(L, k, z) < lim) & (k != b0) & (k != b1) & (k != b2);
    return c;
}

/* The most violated constraint at z (slack below -tol; the lowest index on
 * ties), -1 for none.  Even and odd positions kept apart and merged at the
 * end: one running minimum made each constraint wait for the last one's
 * comparison. */
static int most_violated(const clist *L, const double *z, double tol)
{
    int e0 = -1, e1 = -1;
    double w0 = -tol, w1 = -tol;
    int k = 0;
    for (; k + 1 < L->m; k += 2) {
        const double s0 = slack(L, k, z), s1 = slack(L, k + 1, z);
        if (s0 < w0) { w0 = s0; e0 = k; }
        if (s1 < w1) { w1 = s1; e1 = k + 1; }
    }
    if (k < L->m) {
        const double s0 = slack(L, k, z);
        if (s0 < w0) { w0 = s0; e0 = k; }
    }
    /* e1 >= 0 whenever w1 < -tol; on a tie the lower index (e0 >= 0 there) */
    return w1 < w0 || (w1 == w0 && e1 >= 0 && e1 < e0) ? e1 : e0;
}

/* Dual simplex on the list from basis b[3]; z = (qx, qy, R). Returns flag bits.
 * inv0: the basis' inverse where the caller has it (start_basis computed it
 * to check the basis), else NULL. */
static int dual_simplex(const clist *L, int *b, double *z, double tol, const double *inv0)
{
    double own[9];
    for (int it = 0; it < MAX_PIVOTS; ++it) {
        const double be0 = L->be[b[0]], be1 = L->be[b[1]], be2 = L->be[b[2]];
        /* the start's inverse read where it is: copied, its scalar stores were
         * read back as vectors, which stalled on store forwarding */
        const double *inv = it == 0 && inv0 ? inv0 : own;
        if (inv == own && !inv3(L->nx[b[0]], L->nx[b[1]], L->nx[b[2]],
                                L->ny[b[0]], L->ny[b[1]], L->ny[b[2]], own)) {
            return F_PIVOTS;
        }
        z[0] = inv[0] * be0 + inv[1] * be1 + inv[2] * be2;
        z[1] = inv[3] * be0 + inv[4] * be1 + inv[5] * be2;
        z[2] = inv[6] * be0 + inv[7] * be1 + inv[8] * be2;
        /* most calls end at a basis that is already optimal: a count first, which
         * the compiler vectorizes, and the search only where something is violated */
        if (!count_tight(L, z, -tol, 0, NULL)) return 0;
        const int e = most_violated(L, z, tol);
        if (e < 0) return 0;
        /* ratio test: dual multipliers l = third row of inv, direction u = a_e^T inv */
        int out = -1;
        double best = INFINITY;
        for (int k = 0; k < 3; ++k) {
            const double u = L->nx[e] * inv[k] + L->ny[e] * inv[3 + k] + inv[6 + k];
            if (u > 1e-12) {
                const double r = FMAX(inv[6 + k], 0.0) / u;
                if (r < best) { best = r; out = k; }
            }
        }
        if (out < 0) return F_PIVOTS;
        b[out] = e;
    }
    return F_PIVOTS;
}

/* Make b the basis of constraints c0, c1, c2 (-1 for none), the nearest
 * half-planes of three 120-degree sectors of normal directions, when the three
 * bound a triangle: their normals span the plane positively, the dual
 * multipliers (third row of the basis inverse) are > 0.  Returns whether it
 * did; the basis' inverse (inv3) is then in `inv`. */
static int sector_basis(const clist *L, int c0, int c1, int c2, int *b, double *inv)
{
    if (c0 < 0 || c1 < 0 || c2 < 0) return 0;
    if (!inv3(L->nx[c0], L->nx[c1], L->nx[c2], L->ny[c0], L->ny[c1], L->ny[c2], inv)
        || !(inv[6] > 0.0 && inv[7] > 0.0 && inv[8] > 0.0)) return 0;
    b[0] = c0; b[1] = c1; b[2] = c2;
    return 1;
}

/* The nearer of the sextants' constraints u and v (betas bu, bv); u on a tie. */
static int nearer(int u, double bu, int v, double bv)
{
    return bv < bu ? v : u;
}

/* A dual feasible start basis for the dual simplex from the list's constraints
 * `first`.. : the nearest half-plane in each of three 120-degree sectors of
 * normal directions ([0, 120), [120, 240), [240, 360) degrees, or, where those
 * three do not bound a triangle, the sectors turned by 60 degrees); else `b` is
 * left as it is (the artificial triangle).  A relaxed cell's optimal basis is
 * mostly its nearest neighbours': from there the simplex needs about a third of
 * the pivots it needs from the artificial triangle, which it must pivot out first.
 * Returns whether it found one; its inverse is then in `inv`. */
static int start_basis(const clist *L, int first, int *b, double *inv)
{
    /* the nearest constraint (-1: none) and its beta (INFINITY: none) in each
     * 60-degree sextant: sextants 0-3 in the lanes of a (4), 4-5 in those of c (2) */
    long4 near_a = (long4)(-1);
    long2 near_c = (long2)(-1);
    double4 nbe_a = (double4)(INFINITY);
    double2 nbe_c = (double2)(INFINITY);
    for (int k = first; k < L->m; ++k) {
        /* sextants 0 1 2 above the x axis from the right, 3 4 5 below from the left;
         * computed and kept without branches: the directions are random, and
         * mispredicted branches here cost more than the simplex.  Every sextant's
         * minimum is updated, in two vectors of lanes (scalars unrolled took
         * three 2-lane ones; indexing near[s] made the compiler branch on each
         * comparison and keep the minima in memory) */
        const double x = L->nx[k], be = L->be[k];
        const int up = L->ny[k] >= 0.0;
        const long s = up * (2 - (x > 0.5) - (x > -0.5)) + (1 - up) * (3 + (x >= -0.5) + (x >= 0.5));
        /* (vector ?: rather than select: PoCL 3.0 calls its library for select) */
        const double4 cand_a = (long4)(s) == (long4)(0, 1, 2, 3) ? (double4)(be) : (double4)(INFINITY);
        const double2 cand_c = (long2)(s) == (long2)(4, 5) ? (double2)(be) : (double2)(INFINITY);
        const long4 take_a = cand_a < nbe_a;
        const long2 take_c = cand_c < nbe_c;
        near_a = take_a ? (long4)(k) : near_a;
        near_c = take_c ? (long2)(k) : near_c;
        nbe_a = take_a ? cand_a : nbe_a;
        nbe_c = take_c ? cand_c : nbe_c;
    }
    const int near[6] = {near_a.s0, near_a.s1, near_a.s2, near_a.s3, near_c.s0, near_c.s1};
    const double nbe[6] = {nbe_a.s0, nbe_a.s1, nbe_a.s2, nbe_a.s3, nbe_c.s0, nbe_c.s1};
    /* sectors of sextants (0, 1), (2, 3), (4, 5), else turned: (1, 2), (3, 4), (5, 0) */
    return sector_basis(L, nearer(near[0], nbe[0], near[1], nbe[1]),
                        nearer(near[2], nbe[2], near[3], nbe[3]),
                        nearer(near[4], nbe[4], near[5], nbe[5]), b, inv)
        || sector_basis(L, nearer(near[1], nbe[1], near[2], nbe[2]),
                        nearer(near[3], nbe[3], near[4], nbe[4]),
                        nearer(near[5], nbe[5], near[0], nbe[0]), b, inv);
}

/* The previous step's optimal basis of this cell as a start basis: `prev` its three
 * constraint codes (9 * j + shift with j a sorted position of the previous step, an
 * edge's code as it is), `newpos` the sorted position now of each previous one.
 * Where all three are in the list and bound a triangle (dual feasible:
 * sector_basis' check), b holds their list positions and `binv` their inverse;
 * returns whether.  The dots of a stippling step move by a fraction of their
 * spacing: most cells keep their basis, or lie a pivot from it, and finding it
 * costs three comparisons a site, not start_basis' sextants. */
static int warm_basis(const clist *L, __global const int *newpos, const int *prev, int *b,
                      double *binv)
{
    int c[3], f[3] = {-1, -1, -1};
    for (int k = 0; k < 3; ++k) {
        if (prev[k] < -4) return 0;   /* none, or an artificial half-plane */
        c[k] = prev[k] < 0 ? prev[k] : 9 * newpos[prev[k] / 9] + prev[k] % 9;
    }
    /* codes are unique in the list: the last match is the only one (no branches) */
    for (int k = 3; k < L->m; ++k) {
        const int code = L->code[k];
        f[0] = code == c[0] ? k : f[0];
        f[1] = code == c[1] ? k : f[1];
        f[2] = code == c[2] ? k : f[2];
    }
    return sector_basis(L, f[0], f[1], f[2], b, binv);
}

/* Normalise the raw entries of the list (gather_run stores the offsets):
 * n = a / |a|, beta = (|a|^2 - w_j + w_i) / (2 |a|), d = |a|, as set_site
 * does one by one, with the same operations.  A loop of its own, without
 * branches, so that the compiler can vectorize the square roots and
 * divisions that cost most of the gather when done site by site. */
static void normalise(clist *L)
{
    for (int k = L->raw; k < L->m; ++k) {
        const double len = SQRT(L->d[k]), il = 1.0 / len;
        L->nx[k] *= il;
        L->ny[k] *= il;
        L->be[k] = 0.5 * L->be[k] * il;
        L->d[k] = len;
    }
    L->raw = L->m;
}

static void set_site(clist *L, int k, double ax, double ay, double len2, double wj, double wi,
                     int code)
{
    const double len = SQRT(len2), il = 1.0 / len;
    L->nx[k] = ax * il;
    L->ny[k] = ay * il;
    L->be[k] = 0.5 * (len2 - wj + wi) * il;
    L->d[k] = len;
    L->code[k] = code;
}

/* The list is full: the new constraint (slack `sl` at the vertex z) takes
 * the place of the non-basic one with the most slack, when that has more;
 * returns whether it found a place.
 * A constraint pushed out this way comes back if it is ever violated, in a
 * later round. */
static int replace_slackest(clist *L, const int *b, const double *z, double sl,
                            double ax, double ay, double len2, double wj, double wi, int code)
{
    int worst = -1;
    double most = sl;
    for (int k = 3; k < L->m; ++k) {
        if (k == b[0] || k == b[1] || k == b[2] || L->code[k] < 0) continue;
        const double sk = L->be[k] - L->nx[k] * z[0] - L->ny[k] * z[1] - z[2];
        if (sk > most) { most = sk; worst = k; }
    }
    if (worst < 0) return 0;
    set_site(L, worst, ax, ay, len2, wj, wi, code);
    return 1;
}

/* Radius around the centre beyond which no site can have slack below near_tol:
 * slack < near_tol  <=>  (d_j - Rp)^2 < (|q| + Rp)^2 + w_j - w_i, Rp = R + near_tol,
 * with w_j <= wmax. Also returns Rp, |q| and (|q| + Rp)^2 - w_i. */
static double cutter_reach(const double *z, double wi, double wmax, double near_tol,
                           double *Rp, double *qn, double *reach2)
{
    *Rp = FMAX(z[2], 0.0) + near_tol;
    *qn = SQRT(z[0] * z[0] + z[1] * z[1]);
    *reach2 = (*qn + *Rp) * (*qn + *Rp) - wi;
    return *Rp + SQRT(FMAX(*reach2 + wmax, 0.0));
}

/* The cutter radius `rad` (from the global weight maximum) narrowed to the
 * weight maximum `wloc` of the window of buckets around the home bucket
 * (corners `win`, unbounded lattice coordinates), when the ball of radius
 * `rad` around the centre (cx, cy) lies inside the window: no site outside
 * it can then reach, and none inside is heavier than `wloc`. */
static double local_reach(double rad, double Rp, double reach2, double wloc,
                          double cx, double cy, double4 win)
{
    const double inside = FMIN(FMIN(cx - win.x, win.z - cx), FMIN(cy - win.y, win.w - cy));
    return rad <= inside ? FMIN(rad, Rp + SQRT(FMAX(reach2 + wloc, 0.0))) : rad;
}

/* The bucket of lattice coordinate v (in bucket widths), clamped to +-1e8 on both
 * sides before the conversion: the centre of an empty power cell can lie 1e10
 * widths away, and a conversion out of int's range (undefined; INT_MIN on x86)
 * made a scan from INT_MIN that never ended. */
static int bucket_index(double v)
{
    return (int)FLOOR(FMIN(FMAX(v, -1e8), 1e8));
}

/* Add site (xj + shift) as a constraint of cell i, unless it coincides with
 * the site (no bisector).  The callers make sure the list has room. */
static void push_site(clist *L, double ax, double ay, double wj, double wi, int code)
{
    const double len2 = ax * ax + ay * ay;
    if (len2 == 0.0) return;
    set_site(L, L->m++, ax, ay, len2, wj, wi, code);
}

static int site_code(int j, int qx, int qy, int *flag)
{
    if (qx < -1 || qx > 1 || qy < -1 || qy > 1) *flag |= F_SHIFT;
    return 9 * j + 3 * (iclamp(qx, -1, 1) + 1) + (iclamp(qy, -1, 1) + 1);
}

/* Does the basis still hold one of the artificial half-planes? */
static int is_artificial(const clist *L, const int *b)
{
    return L->code[b[0]] <= -5 || L->code[b[1]] <= -5 || L->code[b[2]] <= -5;
}

/* Add the sites t0 .. t1-1 (shifted by qx, qy periods) to the list, and track the
 * nearest one; a full list keeps the GATHER_CAP nearest (before the first solve:
 * `replace`; after it the basis indexes the list) and remembers the nearest dropped.
 * Inlined: a call per bucket run, with its many arguments, cost about a tenth
 * of the kernel on the torus. */
static inline __attribute__((always_inline)) void gather_run(__global const double2 *site, __global const double *weight,
                       int s, double2 xi, double wi, int t0, int t1, int qx, int qy,
                       double W, double H, int fixed, int replace, clist *L, double *nn2,
                       double *dropped, int *flag)
{
    /* the nearest distance and the list's length in registers: kept in memory,
     * each site waited on the last one's store */
    double nn = *nn2;
    int m = L->m;
    for (int t = t0; t < t1; ++t) {
        if (t == s && qx == 0 && qy == 0) continue;
        const double ax = site[t].x + qx * W - xi.x, ay = site[t].y + qy * H - xi.y;
        const double len2 = ax * ax + ay * ay;
        nn = len2 < nn ? len2 : nn;   /* fmin: no NaN here (check_sites) */
        if (m < GATHER_CAP) {
            if (len2 == 0.0) continue;   /* coincides with the site: no bisector */
            L->nx[m] = ax; L->ny[m] = ay; L->be[m] = len2 - weight[t] + wi; L->d[m] = len2;
            L->code[m++] = site_code(t, qx, qy, flag);
            continue;
        }
        L->m = m;
        normalise(L);   /* the replacements below compare distances */
        const double len = SQRT(len2);
        if (!replace) { *dropped = FMIN(*dropped, len); continue; }
        int far = fixed;
        for (int k = fixed + 1; k < m; ++k)
            if (L->d[k] > L->d[far]) far = k;
        if (len < L->d[far]) {
            *dropped = FMIN(*dropped, L->d[far]);
            set_site(L, far, ax, ay, len2, weight[t], wi, site_code(t, qx, qy, flag));
        } else {
            *dropped = FMIN(*dropped, len);
        }
    }
    L->m = m;
    *nn2 = nn;
}

/* wrap_bucket, without its integer divisions for a bucket on the grid (on a
 * torus most are: they cost more than the sites of a ring's run). */
static int grid_bucket(int *cx, int *cy, int *qx, int *qy, int nbx, int nby)
{
#if PERIODIC
    if (*cx >= 0 && *cx < nbx && *cy >= 0 && *cy < nby) { *qx = 0; *qy = 0; return 1; }
#endif
    return wrap_bucket(cx, cy, qx, qy, nbx, nby);
}

/* Add the sites of the buckets at Chebyshev distance `ring` from the home
 * bucket (hx, hy) to the list (gather_run), row by row, each row from the left.
 * The top and bottom rows' buckets are one run of sites where the row does not
 * wrap: one loop, not 2 ring + 1 short ones. */
static void gather_ring(__global const double2 *site, __global const double *weight,
                        __global const int *bstart,
                        int s, double2 xi, double wi, int hx, int hy, int ring,
                        int nbx, int nby, double W, double H,
                        int fixed, int replace, clist *L, double *nn2, double *dropped, int *flag)
{
    for (int dy = -ring; dy <= ring; ++dy) {
        const int edge = dy == -ring || dy == ring;
        if (edge && hx - ring >= 0 && hx + ring < nbx) {
            int cx = hx, cy = hy + dy, qx, qy;
            if (!grid_bucket(&cx, &cy, &qx, &qy, nbx, nby)) continue;
            const int row = cy * nbx;
            gather_run(site, weight, s, xi, wi, bstart[row + hx - ring], bstart[row + hx + ring + 1],
                       0, qy, W, H, fixed, replace, L, nn2, dropped, flag);
            continue;
        }
        for (int dx = -ring; dx <= ring; dx += edge ? 1 : imax(2 * ring, 1)) {
            int cx = hx + dx, cy = hy + dy, qx, qy;
            if (!grid_bucket(&cx, &cy, &qx, &qy, nbx, nby)) continue;
            const int b = cy * nbx + cx;
            gather_run(site, weight, s, xi, wi, bstart[b], bstart[b + 1], qx, qy, W, H,
                       fixed, replace, L, nn2, dropped, flag);
        }
    }
    normalise(L);
}

__kernel void cell_mic(
    __global const double2 *site,    /* sites sorted by bucket */
    __global const double *weight,   /* their weights, shifted so that min = 0 */
    __global const int *bstart,      /* bucket b holds sorted sites bstart[b] .. bstart[b+1]-1 */
    __global const double *bwmax,    /* largest weight in each bucket */
    __global const double *bwloc,    /* largest weight in the window of +-win buckets around each */
    const int win,
    __global const int *cells,       /* m sorted positions: the cells to solve */
    const int m,                     /* number of cells to solve */
    const int nbx, const int nby,    /* bucket grid */
    const double bw, const double bh,/* bucket size */
    const double W, const double H,  /* domain size */
    const double wmax,               /* largest weight */
    const double tol,                /* feasibility tolerance (length units) */
    const double near_tol,               /* slack below which a constraint is near-tight */
    const int offset,                /* first list position of this enqueue */
    __global double4 *mic,           /* out, by list position: MIC centre x, y, radius
                                        (negative: empty power cell), nearest-neighbour distance */
    __global int *codes,             /* out: NCODES a cell: three basic constraint codes,
                                        the flag word, MAXNEAR near-tight codes (-9 = none) */
    const int warm,                  /* bit 1: start from the basis in basis_in where it is
                                        dual feasible; bit 2: write this one's to basis_out */
    __global const int *prevpos,     /* (warm) the previous sorted position of each one now */
    __global const int *newpos,      /* (warm) the sorted position now of each previous one */
    __global const int *basis_in,    /* (warm) by previous sorted position: three basis codes */
    __global int *basis_out)         /* (warm) by sorted position: this call's, alike */
{
    const int i = offset + get_global_id(0);
    if (i >= m) return;
    const int s = cells[i];
    const double2 xi = site[s];
    const double wi = weight[s];
    const int hx = iclamp((int)(xi.x / bw), 0, nbx - 1), hy = iclamp((int)(xi.y / bh), 0, nby - 1);
    int flag = 0;
    clist L;
    L.m = 0;

    /* 3 artificial half-planes: a triangle of inradius D around the site */
    const double D = 4.0 * (W + H);
    L.nx[0] = 0.0;                 L.ny[0] = 1.0;  L.be[0] = D; L.code[0] = -5;
    L.nx[1] = -0.8660254037844386; L.ny[1] = -0.5; L.be[1] = D; L.code[1] = -6;
    L.nx[2] = 0.8660254037844386;  L.ny[2] = -0.5; L.be[2] = D; L.code[2] = -7;
    L.m = 3;
#if !PERIODIC
    L.nx[3] = -1.0; L.ny[3] = 0.0;  L.be[3] = xi.x;     L.code[3] = -1;
    L.nx[4] = 1.0;  L.ny[4] = 0.0;  L.be[4] = W - xi.x; L.code[4] = -2;
    L.nx[5] = 0.0;  L.ny[5] = -1.0; L.be[5] = xi.y;     L.code[5] = -3;
    L.nx[6] = 0.0;  L.ny[6] = 1.0;  L.be[6] = H - xi.y; L.code[6] = -4;
    L.m = 7;
#endif
    const int fixed = L.m;
    L.raw = L.m;

    /* 1. gather rings of buckets around the home bucket, and more while the
     *    cell is still unbounded by what was gathered */
    double nn2 = INFINITY;
    int ring = 0;
    double dropped = INFINITY;
    for (;; ++ring) {
        gather_ring(site, weight, bstart, s, xi, wi, hx, hy, ring, nbx, nby, W, H,
                    fixed, 1, &L, &nn2, &dropped, &flag);
        if ((L.m - fixed >= KMIN && ring >= 1) || ring == RMAX) break;
    }
    int b[3] = {0, 1, 2};
    double inv0[9], z[3];
    int prev[3] = {-9, -9, -9};
    if (warm & 1) for (int k = 0; k < 3; ++k) prev[k] = basis_in[3 * prevpos[s] + k];
    const int start = ((warm & 1) && warm_basis(&L, newpos, prev, b, inv0)) || start_basis(&L, 3, b, inv0);
    flag |= dual_simplex(&L, b, z, tol, start ? inv0 : NULL);
    /* 2. more rings while the cell is unbounded by the list, or its disk
     *    reaches past what the rings cover; no replacements once solved
     *    (the basis indexes the list), so this stops at the first dropped site */
    double Rp, qn, reach2, G, cut;
    for (;;) {
        /* (at the end, the cutter radius of the z that step 3 starts from) */
        cut = cutter_reach(z, wi, wmax, near_tol, &Rp, &qn, &reach2);
        /* every site within G of x_i is in the list: the rings cover their
         * width, and a full list kept the nearest, none dropped closer */
        G = FMIN(ring * FMIN(bw, bh), dropped);
        /* grown far enough when the disk and its equal-weight neighbours'
         * reach are covered: the scan below then finds a few heavier cutters */
        if (!is_artificial(&L, b) && qn + 2.0 * Rp <= G) break;
        if (ring >= RMAX_GROW || dropped < INFINITY || (flag & F_PIVOTS)) break;
        gather_ring(site, weight, bstart, s, xi, wi, hx, hy, ++ring, nbx, nby, W, H,
                    fixed, 0, &L, &nn2, &dropped, &flag);
        flag |= dual_simplex(&L, b, z, tol, NULL);
    }
    const double Gnn = ring * FMIN(bw, bh);

    /* 3. prove it by scanning the buckets the proof ball touches */
    int round = 0;
    /* the list holds every site of the gathered rings until one is dropped
     * or evicted: the scan can skip those buckets */
    int inner = dropped == INFINITY;
    double box = 2.0 * (ring + 1) * FMAX(bw, bh);   /* half-width of the scan box */
    const double wloc = bwloc[hy * nbx + hx];
    const double4 window = (double4)((hx - win) * bw, (hy - win) * bh,
                                     (hx + win + 1) * bw, (hy + win + 1) * bh);
    for (; round < MAX_ROUNDS && !(flag & (F_PIVOTS | F_LIST_FULL)); ++round) {
        const double cxp = xi.x + z[0], cyp = xi.y + z[1];
        if (round > 0) cut = cutter_reach(z, wi, wmax, near_tol, &Rp, &qn, &reach2);
        const double rad = local_reach(cut, Rp, reach2, wloc, cxp, cyp, window);
        if (qn + rad <= G) break;
        const int partial = rad > box;
        const double reach = partial ? box : rad;
        int x0 = bucket_index((cxp - reach) / bw), x1 = bucket_index((cxp + reach) / bw);
        int y0 = bucket_index((cyp - reach) / bh), y1 = bucket_index((cyp + reach) / bh);
#if PERIODIC
        /* past one period the images repeat: the scan would only grow */
        if (x1 - x0 > MAX_SCAN || y1 - y0 > MAX_SCAN) { flag |= F_SCAN_WIDE; break; }
#else
        /* a rectangle has no buckets outside the grid: the whole grid at most */
        x0 = imax(x0, 0); y0 = imax(y0, 0); x1 = imin(x1, nbx - 1); y1 = imin(y1, nby - 1);
#endif
        int added = 0, waiting = 0;
        for (int by = y0; by <= y1; ++by) {
            for (int bx = x0; bx <= x1; ++bx) {
                if (inner && iabs(bx - hx) <= ring && iabs(by - hy) <= ring) continue;
                int cx = bx, cy = by, qx, qy;
                if (!grid_bucket(&cx, &cy, &qx, &qy, nbx, nby)) continue;
                const int bb = cy * nbx + cx;
                /* distance from the centre to this bucket (with its shift) */
                const double ox = bx * bw, oy = by * bh;
                const double ddx = FMAX(FMAX(ox - cxp, cxp - ox - bw), 0.0);
                const double ddy = FMAX(FMAX(oy - cyp, cyp - oy - bh), 0.0);
                const double bd = SQRT(ddx * ddx + ddy * ddy);
                if (bd > Rp + SQRT(FMAX(reach2 + bwmax[bb], 0.0))) continue;
                for (int t = bstart[bb]; t < bstart[bb + 1]; ++t) {
                    if (t == s && qx == 0 && qy == 0) continue;
                    const double ax = site[t].x + qx * W - xi.x, ay = site[t].y + qy * H - xi.y;
                    const double len2 = ax * ax + ay * ay;
                    if (len2 == 0.0) continue;
                    const double len = SQRT(len2);
                    const double be = (len2 - weight[t] + wi) / (2.0 * len);
                    const double sl = be - (ax * z[0] + ay * z[1]) / len - z[2];
                    if (sl >= near_tol) continue;
                    const int code = site_code(t, qx, qy, &flag);
                    int known = 0;
                    for (int k = fixed; k < L.m; ++k) known |= (L.code[k] == code);
                    if (known) continue;
                    /* a full list takes a violated site in place of a slack one;
                     * one that finds no place waits for the next round */
                    int placed = 1;
                    if (L.m < MAXC) {
                        push_site(&L, ax, ay, weight[t], wi, code);
                    } else {
                        placed = replace_slackest(&L, b, z, sl, ax, ay, len2, weight[t], wi, code);
                        inner = 0;
                    }
                    added += placed && sl < -tol;
                    waiting += !placed && sl < -tol;
                }
            }
        }
        if (!added) {
            if (waiting) flag |= F_LIST_FULL;
            if (waiting || !partial) break;
            box *= 2.0;   /* nothing cuts within the box: look further */
            continue;
        }
        flag |= dual_simplex(&L, b, z, tol, NULL);
    }
    if (round == MAX_ROUNDS) flag |= F_ROUNDS;
    if (is_artificial(&L, b)) flag |= F_UNBOUNDED;

    /* nearest neighbour: exact once a site inside the gathered rings was seen */
    if (!(nn2 <= Gnn * Gnn)) flag |= F_NN;

    /* 4. outputs */
    __global int *out = codes + (size_t)i * (4 + MAXNEAR);
    /* most cells have no near-tight constraint besides the basis: counted first
     * (the count is the loop's, the same slacks) */
    const int ntight = count_tight(&L, z, near_tol, 3, b);
    int nnear = 0;
    for (int k = 3; k < L.m && nnear < ntight; ++k) {
        if (k == b[0] || k == b[1] || k == b[2]) continue;
        if (slack(&L, k, z) < near_tol) {
            if (nnear < MAXNEAR) out[4 + nnear] = L.code[k];
            nnear++;
        }
    }
    if (nnear > MAXNEAR) flag |= F_NEAR_FULL;
    for (int k = nnear; k < MAXNEAR; ++k) out[4 + k] = -9;
    out[0] = L.code[b[0]]; out[1] = L.code[b[1]]; out[2] = L.code[b[2]]; out[3] = flag;
    if (warm & 2)
        for (int k = 0; k < 3; ++k) basis_out[3 * s + k] = out[k] < -4 ? -9 : out[k];
    mic[i] = (double4)(xi.x + z[0], xi.y + z[1], z[2], SQRT(nn2));
}

/* A coordinate wrapped into [0, s) as numpy's np.mod wraps it, bit for bit
 * (fmod is exact; -0.0 becomes 0.0; a sum that rounds up to s becomes 0.0):
 * the host's Domain.wrap gives the same centres. */
inline double wrap_coord(double v, double s)
{
    if (v >= 0.0 && v < s) return v + 0.0;   /* most: no call to PoCL's fmod */
    double m = fmod(v, s);
    if (m < 0.0) m += s;
    return m >= s ? 0.0 : m + 0.0;
}

/* cell_mic's answers in the caller's order, as CellMIC.solve returns them:
 * one work item per cell of the list, which writes row rows[i] of the centres
 * (wrapped on a torus; the site itself for an empty cell), the radii and the
 * nearest-neighbour distances, and copies its flag word to flags[i] (list
 * order).  The host then reads back these alone, not the constraint codes,
 * and needs no pass over the cells of its own but over the few flagged ones. */
__kernel void mic_rows(
    __global const double2 *site,    /* sites sorted by bucket */
    __global const int *cells,       /* m sorted positions, as cell_mic had them */
    __global const int *rows,        /* m result rows: cell i's answer goes to row rows[i] */
    const int m,
    const double W, const double H,  /* domain size */
    __global const double4 *mic,     /* cell_mic's answers */
    __global const int *codes,       /* cell_mic's codes (flag word at 3) */
    __global double2 *center,        /* out, by row */
    __global double *radius,         /* out, by row */
    __global double *nn,             /* out, by row */
    __global int *flags)             /* out, by list position */
{
    const int i = get_global_id(0);
    if (i >= m) return;
    const double4 c = mic[i];
    const int r = rows[i];
    double2 p = c.z < 0.0 ? site[cells[i]] : c.xy;
#if PERIODIC
    p = (double2)(wrap_coord(p.x, W), wrap_coord(p.y, H));
#endif
    center[r] = p;
    radius[r] = c.z;
    nn[r] = c.w;
    flags[i] = codes[(size_t)i * (4 + MAXNEAR) + 3];
}
