// What the kernel's Python face shares between its files: the TickOutcome a native tick reports
// (bindings.cpp's tick_into, server_tick.cpp's ServerTick), the reading of a Python References
// object, and the server tick's binding.
#pragma once

#include <nanobind/nanobind.h>

#include <string>
#include <utility>
#include <vector>

#include "controller.hpp"

namespace lab {

/// What a native tick reports besides τ and x, copied out of the kernel so that it stays that
/// tick's after the next one: NativeOutput (native.py) builds its HierarchySolution and task
/// errors from it only when they are read (telemetry reads them at 100 Hz, the loop runs at 1 kHz).
struct TickOutcome {
  bool ok = false;
  std::string message;
  std::vector<LevelStatus> levels;
  std::vector<double> residuals, level_seconds;
  int qp_solves = 0;
  std::vector<std::pair<std::string, double>> task_errors;
  std::vector<std::string> violations;
  Eigen::VectorXd internal_force_sensed, internal_force_command;
  bool capped = false;  // nullspace: its active set stopped at the cap (message says where)
  int projections = 0;  // nullspace: hierarchy solves
  std::vector<ActiveSet> active_sets;

  TickOutcome() = default;
  TickOutcome(const Kernel& kernel, const TickResult& result) { record(kernel, result); }

  /// This report made `kernel`'s last tick's (`result`), in the storage it has: the server tick
  /// records one every tick, which allocates nothing once the sizes have settled (copy
  /// assignment keeps a vector's and a string's capacity).
  void record(const Kernel& kernel, const TickResult& result) {
    const HierarchySolution& solution = result.solution;
    ok = solution.ok;
    message = solution.message;
    levels = solution.levels;
    residuals = solution.residuals;
    level_seconds = solution.level_seconds;
    qp_solves = solution.qp_solves;
    violations = solution.violations;
    internal_force_sensed = kernel.internal_force_feedback().first;
    internal_force_command = kernel.internal_force_feedback().second;
    capped = solution.capped;
    projections = solution.projections;
    active_sets = solution.active_sets;
    std::size_t n = 0;
    kernel.visit_task_errors([&](const std::string& name, double error) {
      if (n < task_errors.size()) {
        task_errors[n].first = name;  // in its string's capacity
        task_errors[n].second = error;
      } else {
        task_errors.emplace_back(name, error);
      }
      ++n;
    });
    task_errors.resize(n);
    if (ok && !result.tau.allFinite()) {
      ok = false;
      message = "non-finite torques";
    }
  }
};

/// Copy the fields of the Python References object `refs` into the kernel's references (the
/// kernel's ReferenceReader, bindings.cpp); raises ValueError naming a field of the wrong type or
/// size.
void read_references(Kernel& kernel, nanobind::handle refs);

/// `ServerTick` (server_tick.cpp), into module m; built only with MuJoCo's headers and library.
void bind_server_tick(nanobind::module_& m);

}  // namespace lab
