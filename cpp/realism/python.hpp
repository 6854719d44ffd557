// Python bindings of the realism layer (cpp/bindings.cpp calls bind_realism).
#pragma once

#include <nanobind/nanobind.h>

namespace lab {

/// Adds `RealismLayer(knobs: dict, na, dt)` (reset, measure, actuate, ideal, tick) to module m.
void bind_realism(nanobind::module_& m);

}  // namespace lab
