// Python bindings of the hierarchy methods (cpp/bindings.cpp calls bind_hierarchy).
#pragma once

#include <nanobind/nanobind.h>

namespace lab {

/// Adds `solve_hierarchy(method, dynamics_A, dynamics_b, levels, support)` to module m.
void bind_hierarchy(nanobind::module_& m);

}  // namespace lab
