/* 512-bit vectors through builtins, or through two 256-bit halves.
 *
 * Build-time switch WIDE_BUILTINS (the host's device checks choose it, see
 * diskpack_cl/device_checks.py):
 *   1  builtins (vload8, vstore8, convert_double8, rint, ...) take 512-bit
 *      vectors as they are;
 *   0  every builtin call on a double8 goes through its two double4 halves.
 * Some drivers compile a kernel for a CPU without AVX-512 but link a builtin
 * library built with it (pip's PoCL 3.0 with LLVM 14 on AMD Zen 4): a
 * double8 crossing such a call is passed in the wrong registers, and the
 * kernel returns garbage or crashes.  Arithmetic on double8 needs no call
 * and is right either way; the halves give the same bits. */
#ifndef DISKPACK_WIDE_H
#define DISKPACK_WIDE_H

#ifndef WIDE_BUILTINS
#error "define WIDE_BUILTINS to 0 or 1"
#endif

#if WIDE_BUILTINS
#define VLOAD_D8(p) vload8(0, (p))
#define VSTORE_D8(v, p) vstore8((v), 0, (p))
#define CONVERT_D8(v) convert_double8(v)
#define RINT_D8(v) rint(v)
#else
#define VLOAD_D8(p) ((double8)(vload4(0, (p)), vload4(0, (p) + 4)))
#define VSTORE_D8(v, p) do { vstore4((v).lo, 0, (p)); vstore4((v).hi, 0, (p) + 4); } while (0)
#define CONVERT_D8(v) ((double8)(convert_double4((v).lo), convert_double4((v).hi)))
#define RINT_D8(v) ((double8)(rint((v).lo), rint((v).hi)))
#endif

#endif
