// The optimization vectors of Hutter 2014 §4 (mirrors lab/controller/hierarchy/formulations.py).

#include "hierarchy/formulations.hpp"

#include <algorithm>

#include "hierarchy/linalg.hpp"

namespace lab {
namespace {

/// Rows F_j = 0 for every force row out of support, F starting at column `offset` of z, written
/// into `eom` from row `row` on (formulations.py unsupported_forces_rows).
void unsupported_forces_rows(const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                             Eigen::Index offset, Eigen::Index row, Level& eom) {
  for (Eigen::Index i = 0; i < support.size(); ++i) {
    if (support(i)) continue;
    eom.A.row(row).setZero();
    eom.A(row, offset + i) = 1.0;
    eom.b(row++) = 0.0;
  }
}

/// The rows of J_c in support, into `Js`.
void support_rows(const Eigen::MatrixXd& Jc, const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                  Eigen::MatrixXd& Js) {
  Js.resize(support.count(), Jc.cols());
  Eigen::Index row = 0;
  for (Eigen::Index i = 0; i < support.size(); ++i)
    if (support(i)) Js.row(row++) = Jc.row(i);
}

/// Empty inequality rows over `n` variables.
void no_inequalities(Level& level, Eigen::Index n) {
  level.C.resize(0, n);
  level.d.resize(0);
}

}  // namespace

bool is_formulation(const std::string& name) {
  return name == "qdd_force" || name == "full" || name == "qdd_tau" || name == "sequential";
}

void Reparametrization::level(const Level& in, Level& out) const {
  out.A.noalias() = in.A * T;
  out.b = in.b;
  out.b.noalias() -= in.A * t;
  out.C.noalias() = in.C * T;
  out.d = in.d;
  out.d.noalias() -= in.C * t;
}

void Reparametrization::x_of(const Eigen::VectorXd& z, Eigen::VectorXd& x) const {
  if (identity) {
    x = z;
    return;
  }
  x = t;
  x.noalias() += T * z;
}

void support_qr(const DynamicsTerms& terms, const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                SupportQR& out) {
  const Eigen::MatrixXd& Jc = *terms.Jc;
  const Eigen::Index nv = terms.M->rows(), nf = Jc.rows();
  support_rows(Jc, support, out.Js);
  const Eigen::Index k = out.Js.rows();
  out.force_map.setZero(nf, nv);
  out.Q.setIdentity(nv, nv);
  if (k) {
    out.qr.compute(out.Js.transpose());
    out.workspace.resize(nv);
    out.qr.householderQ().applyThisOnTheLeft(out.Q, out.workspace);
    const auto diagonal = out.qr.matrixQR().diagonal().head(k).cwiseAbs();
    if (diagonal.minCoeff() <= kRankRtol * std::max(1.0, diagonal.maxCoeff()))
      throw SingularSystem("the support Jacobian is singular (feet in a singular stance)");
  }
  out.Qc = out.Q.leftCols(k);
  out.Qu = out.Q.rightCols(nv - k);
  if (!k) return;
  // K[support] = R⁻¹ Q_cᵀ (eq. 28)
  out.K_support = out.Qc.transpose();  // k × nv: the rows of K in support, solved in place
  out.qr.matrixQR().topLeftCorner(k, k).triangularView<Eigen::Upper>().solveInPlace(out.K_support);
  Eigen::Index row = 0;
  for (Eigen::Index i = 0; i < support.size(); ++i)
    if (support(i)) out.force_map.row(i) = out.K_support.row(row++);
}

void reparametrize(const HierarchyProblem& problem, SupportQR& qr, Reparametrization& out) {
  const Eigen::Index nx = problem.dynamics_A.cols();
  const DynamicsTerms& terms = problem.terms;
  const Eigen::Index free = (!problem.support).count();
  Level& eom = out.eom;
  if (problem.formulation == "qdd_force") {
    out.identity = true;
    const Eigen::Index rows = problem.dynamics_A.rows(), extra = terms.M ? free : 0;
    eom.A.resize(rows + extra, nx);
    eom.b.resize(rows + extra);
    eom.A.topRows(rows) = problem.dynamics_A;
    eom.b.head(rows) = problem.dynamics_b;
    if (terms.M) unsupported_forces_rows(problem.support, terms.M->rows(), rows, eom);
    no_inequalities(eom, nx);
    return;
  }
  if (!terms.M)
    throw std::invalid_argument("formulation '" + problem.formulation +
                                "' needs the model terms of the problem");
  const Eigen::MatrixXd &M = *terms.M, &Jc = *terms.Jc;
  const Eigen::VectorXd& h = *terms.h;
  const Eigen::Index nv = M.rows(), nf = Jc.rows(), na = nv - kBaseRows;
  out.identity = false;
  if (problem.formulation == "full") {
    const Eigen::Index nz = nv + na + nf;
    eom.A.setZero(nv + free, nz);
    eom.A.topLeftCorner(nv, nv) = M;
    eom.A.block(kBaseRows, nv, na, na).diagonal().setConstant(-1.0);  // −Sᵀ
    eom.A.block(0, nv + na, nv, nf) = -Jc.transpose();
    eom.b.resize(nv + free);
    eom.b.head(nv) = -h;
    unsupported_forces_rows(problem.support, nv + na, nv, eom);
    no_inequalities(eom, nz);
    out.T.setZero(nx, nz);
    out.T.topLeftCorner(nv, nv).setIdentity();
    out.T.bottomRightCorner(nf, nf).setIdentity();
    out.t.setZero(nx);
    return;
  }
  if (problem.formulation == "qdd_tau") {
    support_qr(terms, problem.support, qr);
    Eigen::MatrixXd& MS = out.MS;  // [M, −Sᵀ]
    MS.setZero(nv, nv + na);
    MS.leftCols(nv) = M;
    MS.block(kBaseRows, nv, na, na).diagonal().setConstant(-1.0);
    eom.A.noalias() = qr.Qu.transpose() * MS;
    eom.b.noalias() = -(qr.Qu.transpose() * h);
    no_inequalities(eom, nv + na);
    out.T.setZero(nx, nv + na);
    out.T.topLeftCorner(nv, nv).setIdentity();
    out.T.bottomRows(nf).noalias() = qr.force_map * MS;
    out.t.setZero(nx);
    out.t.tail(nf).noalias() = qr.force_map * h;
    return;
  }
  throw std::invalid_argument("unknown formulation '" + problem.formulation +
                              "' (formulations: qdd_force, full, qdd_tau, sequential)");
}

void torque_step(const DynamicsTerms& terms, const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                 const Eigen::VectorXd& qdd, SupportQR& qr, Reparametrization& out) {
  const Eigen::MatrixXd& M = *terms.M;
  const Eigen::Index nv = M.rows(), nf = terms.Jc->rows(), na = nv - kBaseRows;
  support_qr(terms, support, qr);
  Eigen::VectorXd& bias = out.bias;  // M q̈ + h
  bias = *terms.h;
  bias.noalias() += M * qdd;
  out.identity = false;
  // Q_uᵀ Sᵀ: the rows of Q_u at the actuated coordinates, transposed
  out.eom.A = qr.Qu.bottomRows(na).transpose();
  out.eom.b.noalias() = qr.Qu.transpose() * bias;
  no_inequalities(out.eom, na);
  out.T.setZero(nv + nf, na);
  out.T.bottomRows(nf) = -qr.force_map.rightCols(na);
  out.t.resize(nv + nf);
  out.t.head(nv) = qdd;
  out.t.tail(nf).noalias() = qr.force_map * bias;
}

void constrained_forward_dynamics(const DynamicsTerms& terms,
                                  const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                                  const Eigen::VectorXd& tau,
                                  const Eigen::VectorXd& contact_acceleration,
                                  ForwardDynamics& scratch, Eigen::VectorXd& x) {
  const Eigen::MatrixXd& M = *terms.M;
  const Eigen::Index nv = M.rows(), nf = terms.Jc->rows();
  support_rows(*terms.Jc, support, scratch.Js);
  const Eigen::Index k = scratch.Js.rows();
  scratch.K.setZero(nv + k, nv + k);
  scratch.K.topLeftCorner(nv, nv) = M;
  scratch.K.topRightCorner(nv, k) = -scratch.Js.transpose();
  scratch.K.bottomLeftCorner(k, nv) = scratch.Js;
  scratch.rhs.resize(nv + k);
  scratch.rhs.head(nv) = -*terms.h;
  scratch.rhs.tail(k) = contact_acceleration;
  scratch.rhs.segment(kBaseRows, nv - kBaseRows) += tau;
  scratch.lu.compute(scratch.K);
  scratch.solution = scratch.lu.solve(scratch.rhs);
  if (!scratch.solution.allFinite())
    throw SingularSystem("the constrained forward dynamics are singular");
  x.setZero(nv + nf);
  x.head(nv) = scratch.solution.head(nv);
  Eigen::Index row = nv;
  for (Eigen::Index i = 0; i < support.size(); ++i)
    if (support(i)) x(nv + i) = scratch.solution(row++);
}

}  // namespace lab
