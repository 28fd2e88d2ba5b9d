#pragma once
// Shared between the module's translation units.
#include <pybind11/pybind11.h>

namespace relief_py {
// relief.noise and the compat kernels (noise_py.cpp).
void init_noise(pybind11::module_& m);
}  // namespace relief_py
