// Python bindings of the state estimator (cpp/bindings.cpp calls bind_estimation).
#pragma once

#include <nanobind/nanobind.h>

namespace lab {

/// Adds `EkfEstimator` (lab/world/estimator.py's BaseEstimator under "ekf") to module m.
void bind_estimation(nanobind::module_& m);

}  // namespace lab
