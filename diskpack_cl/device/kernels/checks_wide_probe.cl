/* The builtins the wide build passes 512-bit vectors to (wide.h, power_gather.h's
 * 16 lanes), on 16 known inputs: the device checks run this before the programs
 * themselves, so that a driver whose builtins take such vectors in the wrong
 * registers is found in a kernel that cannot run away.
 *
 * out[0..7]   = rint(vload8(in) * 1.5)           (double8: vload8, rint, vstore8)
 * out[8..15]  = convert_double8(vload8(fin))     (float8 -> double8)
 * fout[0..15] = select(vload16(fin), 0, mask)    (float16, int16: vload16, select, min, vstore16)
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

__kernel void wide_probe(__global const double *in, __global const float *fin,
                         __global double *out, __global float *fout)
{
    if (get_global_id(0) != 0) return;
    vstore8(rint(vload8(0, in) * 1.5), 0, out);
    vstore8(convert_double8(vload8(0, fin)), 0, out + 8);
    const int16 idx = (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const int16 mask = min(idx, (int16)(7)) == (int16)(7);
    vstore16(select(vload16(0, fin), (float16)(0.0f), mask), 0, fout);
}
