/* Parallel dart throwing on the unit torus (diskpack_cl/parallel_darts.py), one work
 * item per grid cell or live cell.
 *
 * The torus is a g x g grid of cells of side c <= d / sqrt(2): a cell holds at most
 * one point, and a point can be closer than d only to the points of the 24 cells
 * around its own.  Points and darts are stored one per cell (x >= EMPTY: none); a
 * neighbour past an edge is the cell on the far side, shifted by one period.
 *
 * The host draws the darts and their priorities (numpy, so that a seed gives the
 * same set with or without a device) and does the bookkeeping; these kernels do the
 * distance tests, in the same float64 operations as the numpy path (no contraction):
 *   dart_free    a dart is free when no point lies within d;
 *   dart_keep    a free dart is kept when no free dart of higher priority lies within d;
 *   cell_covered a live cell is covered when its corners and centre all lie within d
 *                of a point of the 8 cells around it.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

#define EMPTY 1e8

/* The entry of cell (r, c) of the unbounded cell lattice: wrapped onto the grid and
 * shifted by the periods it was wrapped over. */
static double2 at_cell(__global const double2 *a, int r, int c, int g)
{
    double sx = 0.0, sy = 0.0;
    if (r < 0) { r += g; sy = -1.0; } else if (r >= g) { r -= g; sy = 1.0; }
    if (c < 0) { c += g; sx = -1.0; } else if (c >= g) { c -= g; sx = 1.0; }
    const double2 p = a[r * g + c];
    return (double2)(p.x + sx, p.y + sy);
}

/* Is a point of the cells within `reach` rings of (r, c) (not (r, c) itself) closer
 * than sqrt(d2) to q? */
static int near_point(__global const double2 *pt, int r, int c, int g, double2 q, double d2,
                      int reach)
{
    for (int oy = -reach; oy <= reach; ++oy) {
        for (int ox = -reach; ox <= reach; ++ox) {
            if (oy == 0 && ox == 0) continue;
            const double2 p = at_cell(pt, r + oy, c + ox, g);
            const double dx = p.x - q.x, dy = p.y - q.y;
            if (dx * dx + dy * dy < d2) return 1;
        }
    }
    return 0;
}

__kernel void dart_free(
    __global const double2 *pt,     /* g*g: the point of each cell (x >= EMPTY: none) */
    __global const double2 *dart,   /* g*g: this round's dart of each cell (x >= EMPTY: none) */
    const int g,                    /* grid side */
    const double d2,                /* squared minimum distance */
    __global char *free_out)        /* out, g*g: 1 where the dart is free of the points */
{
    const int i = get_global_id(0);
    if (i >= g * g) return;
    const double2 q = dart[i];
    free_out[i] = q.x < EMPTY && !near_point(pt, i / g, i % g, g, q, d2, 2);
}

__kernel void dart_keep(
    __global const double2 *dart,   /* g*g: this round's darts */
    __global const double *prio,    /* g*g: priority of each free dart (-1: none) */
    const int g,                    /* grid side */
    const double d2,                /* squared minimum distance */
    __global char *keep)            /* out, g*g: 1 where the dart is kept */
{
    const int i = get_global_id(0);
    if (i >= g * g) return;
    const double mine = prio[i];
    int ok = mine >= 0.0;
    const double2 q = dart[i];
    const int r = i / g, c = i % g;
    for (int oy = -2; oy <= 2 && ok; ++oy) {
        for (int ox = -2; ox <= 2; ++ox) {
            if (oy == 0 && ox == 0) continue;
            const int rr = (r + oy + g) % g, cc = (c + ox + g) % g;
            if (!(prio[rr * g + cc] > mine)) continue;
            const double2 p = at_cell(dart, r + oy, c + ox, g);
            const double dx = p.x - q.x, dy = p.y - q.y;
            if (dx * dx + dy * dy < d2) { ok = 0; break; }
        }
    }
    keep[i] = ok;
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
    const double sx[5] = {0.0, 1.0, 0.0, 1.0, 0.5}, sy[5] = {0.0, 0.0, 1.0, 1.0, 0.5};
    int all = 1;
    for (int k = 0; k < 5 && all; ++k)
        all = near_point(pt, r, col, g, (double2)((col + sx[k]) * c, (r + sy[k]) * c), d2, 1);
    covered[i] = all;
}
