// The preamble of a file with per-target Highway kernels (erosion_*.cpp, hydrology_d8.cpp):
//
//   #undef HWY_TARGET_INCLUDE
//   #define HWY_TARGET_INCLUDE "this_file.cpp"
//   #include "hwy_kernels.hpp"
//
// No include guard on purpose: foreach_target.h reads the .cpp again once per target, and this
// preamble with it. The target list is noise_simd.cpp's (SSSE3 disabled), and floating-point
// contraction is off, so that no target fuses a multiply-add the scalar code rounds twice.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
