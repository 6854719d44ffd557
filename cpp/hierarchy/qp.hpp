// The dense QP backend of the native kernel (mirrors lab/controller/qp.py): DAQP, the dual
// active-set solver the Python kernel calls through qpsolvers, compiled from the C sources its
// sdist ships (cpp/third_party/daqp), with the same settings. Every solve is bounded: DAQP
// stops after its iteration limit, or on a cycle, and says why in its exit flag.
#pragma once

#include <Eigen/Dense>

namespace lab {

/// How a QP solve ended: DAQP's exit flag (> 0: x is a solution) and its iteration count.
struct QpReport {
  int exitflag = 0;
  int iterations = 0;
};

/// DAQP's name for an exit flag ("optimal", "infeasible", "iteration limit", ...).
const char* qp_exit_name(int exitflag);

/// The iteration limit of every solve (DAQP's default, which the Python kernel runs with too).
int qp_iteration_limit();

/// min 1/2 x^T P x + q^T x  s.t.  G x <= h, A x = b (P positive definite). Returns false when
/// the solver finds no solution (infeasible, cycling, iteration limit); x is then unspecified.
/// `report`, when given, receives the exit flag and the iteration count. `eta_prox` is DAQP's
/// stopping tolerance of its own proximal loop on a semi-definite P (qp.py solve_qp's); negative:
/// DAQP's automatic one.
bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
              Eigen::VectorXd& x, QpReport* report = nullptr, double eta_prox = -1.0);

/// The same without equality rows.
bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, Eigen::VectorXd& x, QpReport* report = nullptr,
              double eta_prox = -1.0);

/// The same without equality rows, on a DAQP workspace kept from call to call (one per thread)
/// while the sizes stay, for a QP posed every tick (the weighted method's): DAQP's setup
/// allocates a dozen buffers per solve otherwise. Each call starts cold, as a fresh workspace
/// does (no working set carried over), so it finds what `solve_qp` finds.
bool solve_qp_kept(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
                   const Eigen::VectorXd& h, Eigen::VectorXd& x, QpReport* report = nullptr);

}  // namespace lab
