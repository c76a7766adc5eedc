/* Parallel dart throwing on the unit torus (diskpack_cl/parallel_darts.py), one work
 * item per live cell (or per cell of a list).
 *
 * The torus is a g x g grid of cells of side c <= d / sqrt(2): a cell holds at most
 * one point, and a point can be closer than d only to the points of the 24 cells
 * around its own.  Points and darts are stored one per cell in grids that stay on
 * the device between rounds (an empty cell holds a point far off, at 1e9, which no
 * distance test can find near); a neighbour past an edge is the
 * cell on the far side, shifted by one period.  The kernels take lists of cells, so
 * that a round costs its live cells and not the whole grid.
 *
 * The host draws three 64-bit keys a round and does the bookkeeping; the darts' uniforms
 * and priorities are a hash of a key and the cell (uniform(), which numpy computes the
 * same, so that a seed gives the same set with or without a device, and nothing is
 * uploaded but lists of cells).  These kernels place the darts and do the distance
 * tests, in the same float64 operations as the numpy path (no contraction):
 *   dart_place   a live cell's dart, into the dart grid;
 *   set_prio     the priorities of the free darts (or -1 again, after the round);
 *   dart_free    a dart is free when no point lies within d;
 *   dart_keep    a free dart is kept when no free dart of higher priority lies within d;
 *   cell_covered a live cell is covered when its corners and centre all lie within d
 *                of a point of the 8 cells around it;
 *   put_pair     writes points (or given darts) into grid cells;
 *   fill         sets every double of a grid to one value (empty cells, no priority).
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

/* Cell (r, c) of the unbounded cell lattice, one period at most off the grid, wrapped
 * onto it: its row-major index, and in `shift` the periods it was wrapped over.
 * Conditional adds, not `%`: an integer division per neighbour was most of a round. */
static int wrap_cell(int r, int c, int g, double2 *shift)
{
    *shift = (double2)(0.0, 0.0);
    if (r < 0) { r += g; shift->y = -1.0; } else if (r >= g) { r -= g; shift->y = 1.0; }
    if (c < 0) { c += g; shift->x = -1.0; } else if (c >= g) { c -= g; shift->x = 1.0; }
    return r * g + c;
}

/* The entry of cell (r, c) of the unbounded cell lattice: wrapped onto the grid and
 * shifted by the periods it was wrapped over (by 0.0 on the grid: x + 0.0 is x, as no
 * coordinate is -0.0, so the numpy path's unshifted values come out bit for bit). */
static double2 at_cell(__global const double2 *a, int r, int c, int g)
{
    double2 shift;
    const int at = wrap_cell(r, c, g, &shift);
    return a[at] + shift;
}

/* The 24 cells around a cell, as a branch-free OR of `test(dy, dx)` over them: the 8
 * nearest first (most rejected darts meet their conflict there, and a test stops at
 * the end of the block of its first conflict), then the 16 others.  Offsets written
 * out: indexed from a __constant table, the inner cells' tests took 1.1 to 1.5 times
 * as long on PoCL. */
#define NEAR_8(test) (test(-1, -1) | test(-1, 0) | test(-1, 1) | test(0, -1) | test(0, 1) \
                      | test(1, -1) | test(1, 0) | test(1, 1))
#define FAR_16(test) (test(-2, -2) | test(-2, -1) | test(-2, 0) | test(-2, 1) | test(-2, 2) \
                      | test(-1, -2) | test(-1, 2) | test(0, -2) | test(0, 2) | test(1, -2) \
                      | test(1, 2) | test(2, -2) | test(2, -1) | test(2, 0) | test(2, 1) \
                      | test(2, 2))

/* Is cell (r, c) two cells or more from every edge?  Then its 24 neighbours are plain
 * offsets in the grid, with no wrap (most cells: all but 8 g of the g * g). */
static int inner(int r, int c, int g)
{
    return r >= 2 && r < g - 2 && c >= 2 && c < g - 2;
}

/* Is p closer than sqrt(d2) to q? */
static int closer(double2 p, double2 q, double d2)
{
    const double dx = p.x - q.x, dy = p.y - q.y;
    return dx * dx + dy * dy < d2;
}

/* Is a point of the 24 cells around (r, c) closer than sqrt(d2) to q? */
static int near_point(__global const double2 *pt, int r, int c, int g, double2 q, double d2)
{
    if (inner(r, c, g)) {   /* the wrap's four tests a neighbour were most of the test */
        const __global double2 *p = pt + r * g + c;
        /* the 8 nearest, then the 16 others, each block without a branch inside (a
         * branch a neighbour cost 1.2 times as much on PoCL) */
#define PT_NEAR(dy, dx) closer(p[(dy) * g + (dx)], q, d2)
        return NEAR_8(PT_NEAR) || FAR_16(PT_NEAR);
#undef PT_NEAR
    }
#define PT_WRAPPED(dy, dx) closer(at_cell(pt, r + (dy), c + (dx), g), q, d2)
    return NEAR_8(PT_WRAPPED) || FAR_16(PT_WRAPPED);
#undef PT_WRAPPED
}

/* A uniform double in [0, 1): the top 53 bits of splitmix64's output number n + 1
 * of the stream `key` (G. L. Steele, D. Lea and C. H. Flood, "Fast splittable
 * pseudorandom number generators", OOPSLA 2014); parallel_darts._uniform in numpy. */
static double uniform(ulong key, ulong n)
{
    ulong z = key + (n + 1) * 0x9E3779B97F4A7C15UL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9UL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBUL;
    return (double)((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

__kernel void dart_place(
    __global double2 *dart,         /* g*g: written at `cells` */
    __global const int *cells,      /* m live cells, row * g + col, no cell twice */
    const int m,                    /* number of live cells */
    const int g,                    /* grid side */
    const double c,                 /* cell side, 1 / g */
    const ulong ku, const ulong kv) /* the round's keys of the uniforms along x and y */
{
    const int i = get_global_id(0);
    if (i >= m) return;
    const int k = cells[i];
    /* ((col + u) c, (row + v) c): numpy's add of the int column and the uniform,
     * then its scaling, rounded as there */
    dart[k] = (double2)(((double)(k % g) + uniform(ku, k)) * c, ((double)(k / g) + uniform(kv, k)) * c);
}

__kernel void set_prio(
    __global double *prio,          /* g*g: written at `cells` */
    __global const int *cells,      /* m cells holding a free dart, no cell twice */
    const int m,                    /* number of those cells */
    const ulong key,                /* the round's key of the priorities */
    const int clear)                /* 1: write -1 (no dart) instead */
{
    const int i = get_global_id(0);
    if (i < m) prio[cells[i]] = clear ? -1.0 : uniform(key, cells[i]);
}

__kernel void dart_free(
    __global const double2 *pt,     /* g*g: the point of each cell (1e9: none) */
    __global const int *cells,      /* m live cells, row * g + col, no cell twice */
    __global const double2 *dart,   /* g*g: the dart of each live cell, at the cell */
    const int m,                    /* number of live cells */
    const int g,                    /* grid side */
    const double d2,                /* squared minimum distance */
    __global char *free_out)        /* out, m: 1 where the dart is free of the points */
{
    const int i = get_global_id(0);
    if (i >= m) return;
    const int k = cells[i];
    free_out[i] = !near_point(pt, k / g, k % g, g, dart[k], d2);
}

/* Does the dart of cell (r, c) of the unbounded cell lattice (one period at most off
 * the grid) have a priority above `mine` and lie closer than sqrt(d2) to q? */
static int beats(__global const double2 *dart, __global const double *prio, int r, int c,
                 int g, double mine, double2 q, double d2)
{
    double2 shift;
    const int at = wrap_cell(r, c, g, &shift);
    return (prio[at] > mine) & closer(dart[at] + shift, q, d2);
}

__kernel void dart_keep(
    __global const double2 *dart,   /* g*g: this round's free darts (counted only where prio >= 0) */
    __global const double *prio,    /* g*g: priority of each free dart (-1: none) */
    __global const int *cells,      /* m cells holding a free dart */
    const int m,                    /* number of those cells */
    const int g,                    /* grid side */
    const double d2,                /* squared minimum distance */
    __global char *keep)            /* out, m: 1 where the dart is kept */
{
    const int i = get_global_id(0);
    if (i >= m) return;
    const int k = cells[i];
    const double mine = prio[k];
    const double2 q = dart[k];
    const int r = k / g, c = k % g;
    int hit = 0;
    if (inner(r, c, g)) {
        /* plain offsets, in two blocks without a branch inside (as near_point): every
         * neighbour's dart is read (an old one, or the fill, where no priority was
         * written this round) and the priority test masks it; one loop selecting
         * between the plain and the wrapped cell took twice as long on PoCL */
        const __global double2 *d = dart + k;
        const __global double *p = prio + k;
#define DART_NEAR(dy, dx) ((p[(dy) * g + (dx)] > mine) & closer(d[(dy) * g + (dx)], q, d2))
        hit = NEAR_8(DART_NEAR) || FAR_16(DART_NEAR);
#undef DART_NEAR
    } else {
#define DART_WRAPPED(dy, dx) beats(dart, prio, r + (dy), c + (dx), g, mine, q, d2)
        hit = NEAR_8(DART_WRAPPED) || FAR_16(DART_WRAPPED);
#undef DART_WRAPPED
    }
    keep[i] = !hit;
}

/* Is one of the points p0 .. p7 closer than sqrt(d2) to q?  All 8 without a branch
 * (0.85 of the time of stopping at the first). */
static int any_of_8(double2 p0, double2 p1, double2 p2, double2 p3, double2 p4, double2 p5,
                    double2 p6, double2 p7, double2 q, double d2)
{
    return closer(p0, q, d2) | closer(p1, q, d2) | closer(p2, q, d2) | closer(p3, q, d2)
         | closer(p4, q, d2) | closer(p5, q, d2) | closer(p6, q, d2) | closer(p7, q, d2);
}

__kernel void cell_covered(
    __global const double2 *pt,     /* g*g: the point of each cell */
    __global const int *cells,      /* m live cells, row * g + col */
    const int m,                    /* number of live cells */
    const int g,                    /* grid side */
    const double c,                 /* cell side, 1 / g */
    const double d2,                /* squared minimum distance */
    __global char *covered)         /* out, m: 1 where every sample point is within d */
{
    const int i = get_global_id(0);
    if (i >= m) return;
    const int r = cells[i] / g, col = cells[i] % g;
    /* the 8 points around, loaded once for the 5 samples, in variables of their own
     * (in a private array filled in a loop over a table of offsets, the kernel took 1.6
     * to 2.9 times as long on PoCL) */
    double2 p0, p1, p2, p3, p4, p5, p6, p7;
    if (inner(r, col, g)) {
        const __global double2 *p = pt + cells[i];
        p0 = p[-g - 1]; p1 = p[-g]; p2 = p[-g + 1]; p3 = p[-1];
        p4 = p[1]; p5 = p[g - 1]; p6 = p[g]; p7 = p[g + 1];
    } else {
        p0 = at_cell(pt, r - 1, col - 1, g); p1 = at_cell(pt, r - 1, col, g);
        p2 = at_cell(pt, r - 1, col + 1, g); p3 = at_cell(pt, r, col - 1, g);
        p4 = at_cell(pt, r, col + 1, g); p5 = at_cell(pt, r + 1, col - 1, g);
        p6 = at_cell(pt, r + 1, col, g); p7 = at_cell(pt, r + 1, col + 1, g);
    }
    /* the corners and the centre, ((col + sx) c, (r + sy) c) as the numpy path has them;
     * all five and all 8 points without a branch */
#define ANY_NEAR(sx, sy) any_of_8(p0, p1, p2, p3, p4, p5, p6, p7, \
                                  (double2)((col + sx) * c, (r + sy) * c), d2)
    covered[i] = ANY_NEAR(0.0, 0.0) & ANY_NEAR(1.0, 0.0) & ANY_NEAR(0.0, 1.0)
               & ANY_NEAR(1.0, 1.0) & ANY_NEAR(0.5, 0.5);
#undef ANY_NEAR
}

__kernel void put_pair(
    __global double2 *grid,         /* g*g: points or darts, written at `cells` */
    __global const int *cells,      /* m cells, no cell twice */
    __global const double2 *value,  /* m: what each cell gets */
    const int m)                    /* number of cells */
{
    const int i = get_global_id(0);
    if (i < m) grid[cells[i]] = value[i];
}

/* One work item a double: the grids' first writes, on every core (a CPU device's
 * buffer pages are fresh, and enqueue_fill_buffer takes their faults on one thread). */
__kernel void fill(
    __global double *a,             /* m: set to `value` */
    const double value,
    const long m)                   /* number of doubles (2 g * g for a grid of pairs) */
{
    const size_t i = get_global_id(0);
    if (i < m) a[i] = value;
}
