// The dense QP backend of the native kernel (mirrors lab/controller/qp.py): eiquadprog, the
// Goldfarb-Idnani active-set solver TSID uses.
#pragma once

#include <Eigen/Dense>

namespace lab {

/// min 1/2 x^T P x + q^T x  s.t.  G x <= h, A x = b (P positive definite). Returns false when
/// the solver finds no solution (infeasible, or it gave up); x is then unspecified.
bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
              Eigen::VectorXd& x);

/// The same without equality rows.
bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, Eigen::VectorXd& x);

}  // namespace lab
