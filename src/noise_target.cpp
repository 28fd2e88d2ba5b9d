// relief::noise_simd_target (relief/noise.hpp): the public name of the dispatched noise target.
#include "noise_simd.hpp"
#include "relief/noise.hpp"

namespace relief {

std::string noise_simd_target() { return detail::noise_simd_current_target(); }

}  // namespace relief
