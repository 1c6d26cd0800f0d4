// The SEM kernels at 8 doubles per vector (kernels_impl.inc), compiled with AVX-512F and
// without FMA contraction (host/CMakeLists.txt), so each lane's arithmetic is the 4-wide
// kernels' to the bit. kernels.cpp uses them (w8::kKernels) only where the CPU has AVX-512F.
// Everything here but that table has internal linkage: no AVX-512 code can stand in for another
// translation unit's copy of an inline function.
#include <cstring>

#include "sem/engine/kernels.hpp"

#if defined(__AVX512F__)
#define MRD_MULTIVERSION
#define MRD_KERNEL_W 8
#define MRD_KERNEL_NS w8
#include "sem/engine/kernels_impl.inc"
#endif
