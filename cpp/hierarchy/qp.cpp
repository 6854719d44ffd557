#include "hierarchy/qp.hpp"

#include <algorithm>

#include "third_party/daqp/include/api.h"    // DAQP; declares its C API extern "C"
#include "third_party/daqp/include/utils.h"  // daqp_update_ldp: refill a kept workspace

namespace lab {
namespace {

// lab/controller/qp.py SOLVER_OPTIONS["daqp"]: at DAQP's default 1e-6 a Talos sole's CoP row
// ended 1.02e-6 outside after the cascade's repeated level solves.
constexpr double kPrimalTol = 1e-9;
// qpsolvers' sense of an equality row for DAQP (DAQP_ACTIVE + DAQP_IMMUTABLE).
constexpr int kEqualitySense = 5;

/// DAQP's problem in its own layout (row-major constraints, bounds on both sides), kept from
/// call to call (one set per thread).
struct DaqpBuffers {
  Eigen::MatrixXd H;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> A;
  Eigen::VectorXd f, upper, lower, lambda;
  Eigen::VectorXi sense;
};

/// DAQP's view of the buffers: n variables, m rows.
DAQPProblem problem_of(DaqpBuffers& buffer, Eigen::Index n, Eigen::Index m) {
  return DAQPProblem{static_cast<int>(n),
                     static_cast<int>(m),
                     0,  // no simple bounds: every row is in A, as qpsolvers passes them
                     buffer.H.data(),
                     buffer.f.data(),
                     m ? buffer.A.data() : nullptr,
                     m ? buffer.upper.data() : nullptr,
                     m ? buffer.lower.data() : nullptr,
                     m ? buffer.sense.data() : nullptr,
                     nullptr,
                     0,
                     0};
}

/// A DAQP workspace for one size of inequality-only QP, set up once and refilled per call.
struct KeptWorkspace {
  DaqpBuffers buffer;
  DAQPSettings settings{};
  DAQPProblem problem{};
  DAQPWorkspace work{};
  int n = -1, m = -1;  // the sizes it is set up for (-1: none)

  ~KeptWorkspace() { release(); }

  void release() {
    if (n < 0) return;
    work.settings = nullptr;  // ours: DAQP frees only settings it allocated
    free_daqp_workspace(&work);
    free_daqp_ldp(&work);
    n = m = -1;
  }

  /// Back to the values a fresh workspace starts from (allocate_daqp_workspace's), then the
  /// LDP formed anew from `problem`, as setup does; DAQP's error flag (< 0) on failure.
  int refill() {
    work.n_prox = 0;
    std::fill_n(work.prox_mask, n, 0);
    work.state = 0;
    work.soft_slack = 0;
    std::fill_n(work.u, n, 0.0);
    work.outer_iter = 1;
    reset_daqp_workspace(&work);
    constexpr int everything = DAQP_UPDATE_Rinv | DAQP_UPDATE_M | DAQP_UPDATE_v | DAQP_UPDATE_d |
                               DAQP_UPDATE_sense | DAQP_UPDATE_unconstrained |
                               DAQP_UPDATE_eliminate;
    return daqp_update_ldp(everything, &work, &problem);
  }
};

}  // namespace

const char* qp_exit_name(int exitflag) {
  switch (exitflag) {
    case DAQP_EXIT_OPTIMAL:
      return "optimal";
    case DAQP_EXIT_SOFT_OPTIMAL:
      return "soft optimal";
    case DAQP_EXIT_OPTIMAL_INEXACT:
      return "optimal (inexact)";
    case DAQP_EXIT_INFEASIBLE:
      return "infeasible";
    case DAQP_EXIT_CYCLE:
      return "cycling";
    case DAQP_EXIT_UNBOUNDED:
      return "unbounded";
    case DAQP_EXIT_ITERLIMIT:
      return "iteration limit";
    case DAQP_EXIT_NONCONVEX:
      return "nonconvex";
    case DAQP_EXIT_OVERDETERMINED_INITIAL:
      return "overdetermined initial active set";
    case DAQP_EXIT_TIMELIMIT:
      return "time limit";
    default:
      return exitflag > 0 ? "solved" : "failed";
  }
}

int qp_iteration_limit() { return DAQP_DEFAULT_ITER_LIMIT; }

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
              Eigen::VectorXd& x, QpReport* report, double eta_prox) {
  thread_local DaqpBuffers buffer;
  const Eigen::Index n = q.size(), mi = G.rows(), m = mi + A.rows();
  // DAQP writes into its inputs' copies only; the caller's matrices stay as they are.
  buffer.H = P;
  buffer.f = q;
  buffer.A.resize(m, n);
  buffer.A.topRows(mi) = G;
  buffer.A.bottomRows(A.rows()) = A;
  buffer.upper.resize(m);
  buffer.upper << h, b;
  buffer.lower.resize(m);
  buffer.lower.head(mi).setConstant(-DAQP_INF);
  buffer.lower.tail(A.rows()) = b;
  buffer.sense.resize(m);
  buffer.sense.head(mi).setZero();
  buffer.sense.tail(A.rows()).setConstant(kEqualitySense);
  buffer.lambda.resize(m);
  x.resize(n);

  DAQPSettings settings;
  daqp_default_settings(&settings);
  settings.primal_tol = kPrimalTol;
  if (eta_prox >= 0.0) settings.eta_prox = eta_prox;
  // DAQP's automatic equality elimination stays on, as in the Python kernel: without it ANYmal's
  // weighted QP took 19 us instead of 25, but on hutter_table7 (level weights down to 1e-18)
  // DAQP then stopped 20 % further from the optimum than the Python kernel's solve.
  DAQPProblem problem = problem_of(buffer, n, m);
  DAQPResult result{};
  result.x = x.data();
  result.lam = m ? buffer.lambda.data() : nullptr;
  daqp_quadprog(&result, &problem, &settings);
  if (report) *report = QpReport{result.exitflag, result.iter};
  return result.exitflag > 0 && x.allFinite();
}

bool solve_qp(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
              const Eigen::VectorXd& h, Eigen::VectorXd& x, QpReport* report, double eta_prox) {
  thread_local Eigen::MatrixXd A;
  thread_local Eigen::VectorXd b;
  A.resize(0, q.size());
  b.resize(0);
  return solve_qp(P, q, G, h, A, b, x, report, eta_prox);
}

bool solve_qp_kept(const Eigen::MatrixXd& P, const Eigen::VectorXd& q, const Eigen::MatrixXd& G,
                   const Eigen::VectorXd& h, Eigen::VectorXd& x, QpReport* report) {
  thread_local KeptWorkspace kept;
  DaqpBuffers& buffer = kept.buffer;
  const Eigen::Index n = q.size(), m = G.rows();
  buffer.H = P;
  buffer.f = q;
  buffer.A = G;
  buffer.upper = h;
  buffer.lower.setConstant(m, -DAQP_INF);
  buffer.sense.setZero(m);
  buffer.lambda.resize(m);
  x.resize(n);
  // The buffers' storage may move when a size changes: point the problem at it every call.
  kept.problem = problem_of(buffer, n, m);
  int flag;
  if (kept.n != n || kept.m != m) {
    kept.release();
    daqp_default_settings(&kept.settings);
    kept.settings.primal_tol = kPrimalTol;
    kept.work = DAQPWorkspace{};
    kept.work.settings = &kept.settings;
    // As daqp_quadprog sets up its one-shot workspace (on failure it frees it itself).
    flag = setup_daqp_main(&kept.problem, &kept.work, nullptr,
                           DAQP_UPDATE_unconstrained | DAQP_UPDATE_eliminate);
    if (flag >= 0) kept.n = static_cast<int>(n), kept.m = static_cast<int>(m);
  } else {
    flag = kept.refill();
    if (flag < 0) kept.release();  // set up anew on the next call
  }
  if (flag < 0) {
    if (report) *report = QpReport{flag, 0};
    return false;
  }
  DAQPResult result{};
  result.x = x.data();
  result.lam = m ? buffer.lambda.data() : nullptr;
  daqp_solve(&result, &kept.work);
  if (report) *report = QpReport{result.exitflag, result.iter};
  return result.exitflag > 0 && x.allFinite();
}

}  // namespace lab
