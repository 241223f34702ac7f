#pragma once
// Four doubles side by side in SIMD lanes (GCC/Clang vector extensions): one AVX2 register, or
// two SSE2 ones in the baseline build. Each lane's arithmetic is a plain double's, so code written
// in lanes gives the bits of the same code written per value, in any build without FMA
// (target_clones.h).
#include <cstring>

namespace hdeform::detail {

using Lanes4 = double __attribute__((vector_size(32)));
// Four 64-bit integers: the masks that comparisons of lanes give, and shuffles' lane indices.
using LaneBits4 = long __attribute__((vector_size(32)));

// Unaligned loads and stores of four consecutive doubles (always inlined, so that they take the
// instruction set of the function they are in; vectors pass by reference for the same reason).
[[gnu::always_inline]] inline void load_lanes(const double* from, Lanes4& lanes) { std::memcpy(&lanes, from, sizeof lanes); }
[[gnu::always_inline]] inline void store_lanes(const Lanes4& lanes, double* to) { std::memcpy(to, &lanes, sizeof lanes); }

}  // namespace hdeform::detail
