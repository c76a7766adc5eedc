/* Shared definitions for the diskpack_cl kernels.
 *
 * Build-time switches (pass with -D):
 *   PERIODIC  1: the domain is a torus of size W x H (sites repeat with period W, H)
 *             0: the domain is the closed rectangle [0,W] x [0,H]
 */
#ifndef DISKPACK_COMMON_H
#define DISKPACK_COMMON_H

#ifndef PERIODIC
#error "define PERIODIC to 0 or 1"
#endif

/* Scalar math without calls where the compiler is PoCL's.
 *
 * PoCL links its builtin library into a kernel after optimizing the kernel, so
 * every sqrt, fmin, fmax, fabs, floor, clamp, min, max or abs stays a call, and
 * around each call every live floating-point value is spilled (x86-64 keeps
 * none across calls).  The host's build_program sets INLINE_MATH for PoCL's CPU device:
 * these are then clang's builtins, one instruction each; other compilers need
 * not know those (Oclgrind's interpreter knows no llvm.abs, for one) and get
 * the OpenCL builtins.  Either gives the same IEEE results. */
#if INLINE_MATH
#define MATH1(F, B) \
    inline __attribute__((overloadable)) float F(float x) { return B##f(x); } \
    inline __attribute__((overloadable)) double F(double x) { return B(x); }
#define MATH2(F, B) \
    inline __attribute__((overloadable)) float F(float x, float y) { return B##f(x, y); } \
    inline __attribute__((overloadable)) double F(double x, double y) { return B(x, y); }
MATH1(SQRT, __builtin_sqrt)
MATH1(FABS, __builtin_fabs)
MATH1(FLOOR, __builtin_floor)
MATH1(RINT, __builtin_rint)
MATH2(FMIN, __builtin_fmin)
MATH2(FMAX, __builtin_fmax)
inline int imin(int a, int b) { return a < b ? a : b; }
inline int imax(int a, int b) { return a > b ? a : b; }
inline int iabs(int a) { return a < 0 ? -a : a; }
inline int iclamp(int a, int lo, int hi) { return a < lo ? lo : a > hi ? hi : a; }
#else
#define SQRT(x) sqrt(x)
#define FABS(x) fabs(x)
#define FLOOR(x) floor(x)
#define RINT(x) rint(x)
#define FMIN(a, b) fmin(a, b)
#define FMAX(a, b) fmax(a, b)
#define imin(a, b) min(a, b)
#define imax(a, b) max(a, b)
#define iabs(a) abs(a)
#define iclamp(a, lo, hi) clamp(a, lo, hi)
#endif

/* Bits of a kernel's status word (atomic_or), mirrored in diskpack_cl/raster.py:
 * the host refuses a result that has any. */
#define ST_RING_LIMIT 1   /* a bucket ring search reached its limit */
#define ST_NO_OWNER   2   /* a grid cell found no owning site */

/* An index into the per-site buffers: a grid cell that found no owner
 * (label INT_MAX) must not index them. */
inline int owned(int label, int nsite) { return label >= 0 && label < nsite; }

/* Squared length of a 2-vector. */
inline float len2(float dx, float dy) { return dx * dx + dy * dy; }

/* Squared distance from point (px,py) to the axis-aligned box [x0,x1] x [y0,y1]. */
inline float box_dist2(float px, float py, float x0, float y0, float x1, float y1)
{
    float dx = FMAX(FMAX(x0 - px, px - x1), 0.0f);
    float dy = FMAX(FMAX(y0 - py, py - y1), 0.0f);
    return dx * dx + dy * dy;
}

/* Floor division for bucket indices that may leave the grid on a torus. */
inline int floordiv(int a, int b) { return (a >= 0) ? a / b : -((-a + b - 1) / b); }

/* Bucket (cx, cy) of the unbounded bucket lattice: on a torus, wrap it onto
 * the grid and give the period shift (sx, sy) of its sites; on a rectangle,
 * return 0 when it lies outside the grid. */
inline int locate_bucket(int *cx, int *cy, float *sx, float *sy,
                         int nbx, int nby, float W, float H)
{
#if PERIODIC
    const int qx = floordiv(*cx, nbx), qy = floordiv(*cy, nby);
    *sx = qx * W; *sy = qy * H;
    *cx -= qx * nbx; *cy -= qy * nby;
    return 1;
#else
    *sx = 0.0f; *sy = 0.0f;
    return *cx >= 0 && *cy >= 0 && *cx < nbx && *cy < nby;
#endif
}

/* Bucket (cx, cy) of the unbounded bucket lattice: on a torus, wrap it onto
 * the grid and give its period shift (qx, qy); on a rectangle, 0 when it
 * lies outside the grid.  (locate_bucket with integer shifts, for the float64
 * kernels.) */
inline int wrap_bucket(int *cx, int *cy, int *qx, int *qy, int nbx, int nby)
{
#if PERIODIC
    *qx = floordiv(*cx, nbx); *qy = floordiv(*cy, nby);
    *cx -= *qx * nbx; *cy -= *qy * nby;
    return 1;
#else
    *qx = 0; *qy = 0;
    return *cx >= 0 && *cy >= 0 && *cx < nbx && *cy < nby;
#endif
}

#endif
