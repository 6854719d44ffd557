#include "hierarchy/qp.hpp"

#include <eiquadprog/eiquadprog-fast.hpp>

namespace lab {

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
              Eigen::VectorXd& x) {
  // One solver per thread keeps its buffers from call to call (it resizes when sizes change).
  thread_local eiquadprog::solvers::EiquadprogFast solver;
  // eiquadprog's form: CE x + ce0 = 0, CI x + ci0 >= 0.
  const auto status = solver.solve_quadprog(P, q, A, -b, -G, h, x);
  return status == eiquadprog::solvers::EIQUADPROG_FAST_OPTIMAL && x.allFinite();
}

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, Eigen::VectorXd& x) {
  return solve_qp(P, q, G, h, Eigen::MatrixXd(0, q.size()), Eigen::VectorXd(0), x);
}

}  // namespace lab
