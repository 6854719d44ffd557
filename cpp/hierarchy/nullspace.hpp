// The active-set search of the nullspace method alone (mirrors nullspace.py's
// active_set_least_squares), for the tests: solve_nullspace (problem.hpp) is the tick's entry.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "hierarchy/problem.hpp"

namespace lab {

/// z, how many hierarchy solves it took, whether the cap stopped the search (then z is the best
/// point found: `feasible` says whether it satisfies every inequality), and the active rows of
/// each level's C where it stopped (nullspace.py ActiveSetSolution).
struct ActiveSetSolution {
  Eigen::VectorXd z;
  int projections = 0;
  bool capped = false, feasible = true;
  ActiveSet active;
};

/// Strict priorities over z ∈ Rⁿ with inequalities activated when violated (§3.1-3.2), at most
/// `cap` hierarchy solves, from the active rows `start` (ignored unless they match the levels'
/// rows; null: none) and, where those rows' solution violates a row, from `point` (null: none).
ActiveSetSolution active_set_least_squares(const std::vector<Level>& levels, Eigen::Index n,
                                           int cap, const ActiveSet* start,
                                           const Eigen::VectorXd* point);

}  // namespace lab
