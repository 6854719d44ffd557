// Python bindings of the hierarchy methods alone: tests hand both kernels the same problem.
#include "hierarchy/python.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include "hierarchy/linalg.hpp"
#include "hierarchy/nullspace.hpp"
#include "hierarchy/problem.hpp"
#include "hierarchy/qp.hpp"

namespace nb = nanobind;

namespace lab {
namespace {

using LevelRows =
    std::tuple<Eigen::MatrixXd, Eigen::VectorXd, Eigen::MatrixXd, Eigen::VectorXd, double>;

nb::dict solve_hierarchy(const std::string& method, const Eigen::MatrixXd& dynamics_A,
                         const Eigen::VectorXd& dynamics_b, const std::vector<LevelRows>& levels,
                         const Eigen::Array<bool, Eigen::Dynamic, 1>& support) {
  HierarchyProblem problem{dynamics_A, dynamics_b, {}, support};
  const Eigen::Index nx = dynamics_A.cols();
  if (dynamics_A.rows() != kBaseRows)
    throw nb::value_error("dynamics_A must have the 6 Newton-Euler rows of a free-flyer base");
  if (dynamics_b.size() != dynamics_A.rows())
    throw nb::value_error("dynamics_b must have one entry per row of dynamics_A");
  for (const auto& [A, b, C, d, weight] : levels) {
    if (A.cols() != nx || C.cols() != nx || A.rows() != b.size() || C.rows() != d.size())
      throw nb::value_error("a level's rows do not match x or their right-hand side");
    problem.levels.push_back(Level{A, b, C, d, weight});
  }
  HierarchySolution solution;
  if (method == "cascade")
    solution = solve_cascade(problem);
  else if (method == "weighted")
    solution = solve_weighted(problem);
  else
    throw nb::value_error(
        ("unknown hierarchy method '" + method + "' (native: cascade, weighted)").c_str());
  std::vector<std::string> statuses;
  for (const LevelStatus status : solution.levels) statuses.emplace_back(level_status_name(status));
  nb::dict out;
  out["x"] = solution.x;
  out["ok"] = solution.ok;
  out["message"] = solution.message;
  out["levels"] = statuses;
  out["residuals"] = solution.residuals;
  out["level_seconds"] = solution.level_seconds;
  out["qp_solves"] = solution.qp_solves;
  return out;
}

/// One QP through the kernel's backend: (x, ok, exit flag, its name, iterations).
std::tuple<Eigen::VectorXd, bool, int, std::string, int> solve_one_qp(
    const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
    const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const Eigen::Index n = q.size();
  if (P.rows() != n || P.cols() != n || G.cols() != n || A.cols() != n || G.rows() != h.size() ||
      A.rows() != b.size())
    throw nb::value_error(
        "P, G and A must have one column per entry of q, h and b one entry per row");
  Eigen::VectorXd x;
  QpReport report;
  const bool ok = solve_qp(P, q, G, h, A, b, x, &report);
  return {x, ok, report.exitflag, qp_exit_name(report.exitflag), report.iterations};
}

/// nullspace.py's active_set_least_squares natively: levels are (A, b, C, d) over z ∈ Rⁿ;
/// (z, projections, capped, feasible, active rows per level).
nb::tuple active_set_search(
    const std::vector<
        std::tuple<Eigen::MatrixXd, Eigen::VectorXd, Eigen::MatrixXd, Eigen::VectorXd>>& rows,
    Eigen::Index n, int cap, std::optional<ActiveSet> start, std::optional<Eigen::VectorXd> point) {
  std::vector<Level> levels;
  for (const auto& [A, b, C, d] : rows) {
    if (A.cols() != n || C.cols() != n || A.rows() != b.size() || C.rows() != d.size())
      throw nb::value_error("a level's rows do not match z or their right-hand side");
    levels.push_back(Level{A, b, C, d, 1.0});
  }
  if (cap < 1) throw nb::value_error("cap must be at least 1");
  const ActiveSetSolution out = active_set_least_squares(levels, n, cap, start ? &*start : nullptr,
                                                         point ? &*point : nullptr);
  return nb::make_tuple(out.z, out.projections, out.capped, out.feasible, out.active);
}

/// The minimum-norm least squares of A u = b and an orthonormal basis of null(A), the cascade's
/// rank decision (RowSpaceQR against kRankRtol): (u, N).
std::tuple<Eigen::VectorXd, Eigen::MatrixXd> least_squares_null_space(const Eigen::MatrixXd& A,
                                                                      const Eigen::VectorXd& b) {
  if (A.rows() != b.size()) throw nb::value_error("b must have one entry per row of A");
  Eigen::VectorXd u;
  Eigen::MatrixXd N;
  least_squares_and_null_space(A, b, u, N);
  return {u, N};
}

}  // namespace

void bind_hierarchy(nb::module_& m) {
  m.def("solve_hierarchy", &solve_hierarchy, nb::arg("method"), nb::arg("dynamics_A"),
        nb::arg("dynamics_b"), nb::arg("levels"), nb::arg("support"),
        "Solve one HierarchyProblem with a native method: levels are (A, b, C, d, weight).");
  m.def("solve_qp", &solve_one_qp, nb::arg("P"), nb::arg("q"), nb::arg("G"), nb::arg("h"),
        nb::arg("A"), nb::arg("b"),
        "min 1/2 x'Px + q'x s.t. Gx <= h, Ax = b with the kernel's QP backend (DAQP): "
        "(x, ok, exit flag, its name, iterations).");
  m.def("least_squares_and_null_space", &least_squares_null_space, nb::arg("A"), nb::arg("b"),
        "The cascade's least-squares step and null space of A u = b, with its rank decision "
        "(pivoted QR against rank_rtol): (u, N).");
  m.attr("qp_iteration_limit") = qp_iteration_limit();
  m.def("active_set_search", &active_set_search, nb::arg("levels"), nb::arg("n"),
        nb::arg("cap") = kMaxProjections, nb::arg("start") = nb::none(),
        nb::arg("point") = nb::none(),
        "nullspace's active-set search alone (nullspace.py active_set_least_squares): levels "
        "are (A, b, C, d) over z; returns (z, projections, capped, feasible, active rows).");
  m.attr("rank_rtol") = kRankRtol;
}

}  // namespace lab
