// Python bindings of the native behaviour parts (lab/controller/behaviours).
#pragma once

#include <nanobind/nanobind.h>

namespace lab {

void bind_behaviours(nanobind::module_& m);

/// The behaviours behind NativeBehaviour (behaviour.hpp): python_standing.cpp.
void bind_standing_behaviours(nanobind::module_& m);

}  // namespace lab
