#include "hierarchy/qp.hpp"

#include <eiquadprog/eiquadprog-fast.hpp>

namespace lab {

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
              Eigen::VectorXd& x) {
  // One solver per thread keeps its buffers from call to call (it resizes when sizes change).
  thread_local eiquadprog::solvers::EiquadprogFast solver;
  thread_local Eigen::MatrixXd CI;
  thread_local Eigen::VectorXd ce0;
  // eiquadprog's form: CE x + ce0 = 0, CI x + ci0 >= 0.
  CI = -G;
  ce0 = -b;
  const auto status = solver.solve_quadprog(P, q, A, ce0, CI, h, x);
  return status == eiquadprog::solvers::EIQUADPROG_FAST_OPTIMAL && x.allFinite();
}

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, Eigen::VectorXd& x) {
  thread_local Eigen::MatrixXd A;
  thread_local Eigen::VectorXd b;
  A.resize(0, q.size());
  b.resize(0);
  return solve_qp(P, q, G, h, A, b, x);
}

}  // namespace lab
