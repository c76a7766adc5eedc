/* Per-cell reduction of the distance map: each power cell's largest
 * distance to its boundary (the raster estimate of its maximal inscribed
 * circle) and the grid cell where it is reached.
 *
 * Distances are >= 0, so their IEEE bit patterns order like the values and
 * a 32-bit integer atomic_max is exact and order-independent: the result is
 * the same on every run and every device.  Ties go to the lowest grid index.
 * A grid cell whose label names no site (only possible for sites the host
 * refuses) is skipped: it must not index the per-site buffers.
 */
#include "common.h"

__kernel void cell_max(
    __global const int *label,     /* owning site of each grid cell */
    __global const float *dist,    /* distance to the cell boundary */
    const int npix,                /* grid cells (the launch is padded past them) */
    const int nsite,               /* sites: labels in [0, nsite) */
    __global int *rbits)           /* in/out: per site, max distance bits (init -1) */
{
    const int p = get_global_id(0);
    if (p >= npix || !owned(label[p], nsite)) return;
    atomic_max(&rbits[label[p]], as_int(dist[p]));
}

__kernel void cell_argmax(
    __global const int *label,
    __global const float *dist,
    const int npix,
    const int nsite,
    __global const int *rbits,     /* per site, result of cell_max */
    __global int *argpix)          /* in/out: per site, lowest grid index reaching the max (init INT_MAX) */
{
    const int p = get_global_id(0);
    if (p >= npix || !owned(label[p], nsite)) return;
    const int l = label[p];
    if (as_int(dist[p]) == rbits[l]) atomic_min(&argpix[l], p);
}
