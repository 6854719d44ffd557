#include "hierarchy/linalg.hpp"

#include <algorithm>
#include <cmath>

namespace lab {

bool solution_and_null_space_of_leading_block(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                              Eigen::MatrixXd& Z, Eigen::VectorXd& x,
                                              BaseBlockLU& lu) {
  constexpr Eigen::Index k = kBaseRows;
  const Eigen::Index n = A.cols();
  if (A.rows() != k || n < k) return false;
  lu.compute(A.leftCols<k>());
  if (!(std::abs(lu.determinant()) > 0.0)) return false;
  // Z's top rows as one product with A1^-1: a fixed-size inverse and a product over its six
  // columns, unrolled (the blocked triangular solves of a dynamic right-hand side, or one fixed
  // solve per column, take 0.6-0.8 us more per tick at ANYmal's size).
  Z.resize(n, n - k);
  const Eigen::Matrix<double, k, k> inverse = lu.inverse();
  Z.topRows<k>().noalias() = -(inverse.lazyProduct(A.rightCols(n - k)));
  Z.bottomRows(n - k).setIdentity();
  x.setZero(n);
  x.head<k>().noalias() = inverse * b;
  return Z.topRows<k>().allFinite() && x.head<k>().allFinite();  // the rest: I and 0
}

void sparse_rows_product(const Eigen::MatrixXd& A, const Eigen::Ref<const Eigen::MatrixXd>& Z,
                         Eigen::MatrixXd& out) {
  thread_local SparseRows rows;  // its storage kept from call to call: no allocation once warm
  rows.compute(A);
  rows.product(A, Z, out);
}

void SparseRows::compute(const Eigen::MatrixXd& A) {
  const Eigen::Index m = A.rows(), n = A.cols();
  // A row is sparse with at most a quarter of its entries nonzero: below that the strided sum
  // over its entries costs less than the vectorised dense product.
  const auto sparse_limit = static_cast<std::size_t>(n / 4);
  any_sparse_ = false;
  start_.assign(1, 0);
  columns_.clear();
  dense_.assign(static_cast<std::size_t>(m), false);
  for (Eigen::Index i = 0; i < m; ++i) {
    const std::size_t begin = columns_.size();
    bool dense = false;
    const double* entry = A.data() + i;  // A(i, j), column-major: m apart
    for (Eigen::Index j = 0; j < n; ++j, entry += m) {
      if (*entry == 0.0) continue;
      dense = columns_.size() - begin == sparse_limit;  // one nonzero more than the limit
      if (dense) break;
      columns_.push_back(j);
    }
    if (dense) columns_.resize(begin);
    dense_[static_cast<std::size_t>(i)] = dense;
    any_sparse_ = any_sparse_ || !dense;
    start_.push_back(static_cast<Eigen::Index>(columns_.size()));
  }
}

void SparseRows::product(const Eigen::MatrixXd& A, const Eigen::Ref<const Eigen::MatrixXd>& Z,
                         Eigen::MatrixXd& out) const {
  out.resize(A.rows(), Z.cols());
  if (!any_sparse_) {
    out.noalias() = A * Z;
    return;
  }
  for (Eigen::Index i = 0; i < A.rows(); ++i) {
    const auto row = static_cast<std::size_t>(i);
    if (dense_[row]) {
      out.row(i).noalias() = A.row(i) * Z;
      continue;
    }
    out.row(i).setZero();
    for (Eigen::Index k = start_[row]; k < start_[row + 1]; ++k) {
      const Eigen::Index j = columns_[static_cast<std::size_t>(k)];
      out.row(i) += A(i, j) * Z.row(j);
    }
  }
}

bool full_rank_by_margin(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, double frobenius,
                         Eigen::MatrixXd& R_inverse) {
  const Eigen::Index rows = qr.rows(), cols = qr.cols();
  // R^-1 column by column, each a back substitution of e_j over its leading j + 1 rows (axpys
  // on R's contiguous columns): n^3 / 6 flops. Eigen's blocked solve with the identity as its
  // right-hand side spent 46k instructions a tick at G1's last level (23 x 23), this 26k.
  const auto& R = qr.matrixQR();
  R_inverse.setZero(cols, cols);
  for (Eigen::Index j = 0; j < cols; ++j) {
    auto x = R_inverse.col(j).head(j + 1);
    x(j) = 1.0;
    for (Eigen::Index k = j; k >= 0; --k) {
      x(k) /= R(k, k);
      x.head(k) -= x(k) * R.col(k).head(k);
    }
  }
  const double sigma_min = 1.0 / R_inverse.norm();  // 0 or NaN when R is singular
  const double threshold = kRankRtol * std::max(1.0, frobenius);
  return sigma_min > kRankMargin * std::sqrt(static_cast<double>(rows)) * threshold;
}

void RowSpaceQR::compute(const Eigen::Ref<const Eigen::MatrixXd>& A) {
  rows_ = static_cast<int>(A.rows());
  rank_ = 0;
  r1t_ready_ = false;
  if (rows_ == 0) return;
  qr_.compute(A.transpose());
  // Column pivoting makes |R00| >= |R11| >= ...: the rank is the count above the threshold.
  const auto diagonal = qr_.matrixQR().diagonal().cwiseAbs();
  const double threshold = kRankRtol * std::max(1.0, diagonal.size() ? diagonal(0) : 0.0);
  for (Eigen::Index i = 0; i < diagonal.size(); ++i) rank_ += diagonal(i) > threshold ? 1 : 0;
}

void RowSpaceQR::solve(const Eigen::Ref<const Eigen::VectorXd>& b, Eigen::VectorXd& y) {
  if (rank_ == 0) {
    y.resize(0);
    return;
  }
  rhs_ = qr_.colsPermutation().transpose() * b;  // P^T b
  const auto& R = qr_.matrixQR();
  if (rank_ == rows_) {  // R1^T is square and lower triangular
    y = rhs_;
    R.topLeftCorner(rank_, rank_).triangularView<Eigen::Upper>().transpose().solveInPlace(y);
    return;
  }
  // More rows than freedom: least squares of the full-column-rank R1^T (m x rank).
  if (!r1t_ready_) {  // R1^T's factorization, once per factorization of A
    r1t_ = R.topRows(rank_).triangularView<Eigen::Upper>().transpose();
    r1t_qr_.compute(r1t_);
    r1t_ready_ = true;
  }
  workspace_.resize(1);
  r1t_qr_.householderQ().setLength(rank_).transpose().applyThisOnTheLeft(rhs_, workspace_);
  y = rhs_.head(rank_);
  r1t_qr_.matrixQR().topLeftCorner(rank_, rank_).triangularView<Eigen::Upper>().solveInPlace(y);
}

void RowSpaceQR::solve_with_residual(const Eigen::Ref<const Eigen::VectorXd>& b, Eigen::VectorXd& y,
                                     Eigen::VectorXd& g) {
  g = b;
  if (rank_ == 0) {
    y.resize(0);
    return;
  }
  solve(b, y);
  // P^T b - R1^T y, R1^T y summed over R1's rows (each zero left of its diagonal), then P back
  rhs_ = qr_.colsPermutation().transpose() * b;
  const auto& R = qr_.matrixQR();
  for (Eigen::Index i = 0; i < rank_; ++i)
    rhs_.tail(rows_ - i) -= y(i) * R.row(i).tail(rows_ - i).transpose();
  g = qr_.colsPermutation() * rhs_;
}

double RowSpaceQR::frobenius() const {
  const auto& R = qr_.matrixQR();
  double sum = 0.0;
  for (Eigen::Index i = 0; i < std::min<Eigen::Index>(R.rows(), rows_); ++i)
    sum += R.row(i).tail(rows_ - i).squaredNorm();
  return std::sqrt(sum);
}

bool RowSpaceQR::rank_by_margin() const {
  if (rows_ == 0 || rank_ != rows_) return false;
  const auto& R = qr_.matrixQR();
  return std::abs(R(rows_ - 1, rows_ - 1)) >
         kRankMargin * kRankRtol * std::max(1.0, std::abs(R(0, 0)));
}

void RowSpaceQR::apply_q_to_vector(Eigen::VectorXd& v) const {
  // Q = H_0 H_1 ... H_(h-1): the last reflector first
  const auto& qr = qr_.matrixQR();
  const auto& tau = qr_.hCoeffs();
  const Eigen::Index n = qr.rows();
  double workspace;  // applyHouseholderOnTheLeft's, one entry per column of v
  for (Eigen::Index k = tau.size() - 1; k >= 0; --k)
    v.tail(n - k).applyHouseholderOnTheLeft(qr.col(k).tail(n - k - 1), tau(k), &workspace);
}

void RowSpaceQR::step_and_null_space(Eigen::Ref<Eigen::MatrixXd> Z, const Eigen::VectorXd& y,
                                     Eigen::VectorXd& x, bool identity_below) {
  const auto& qr = qr_.matrixQR();
  const Eigen::Index n = qr.rows(), k = qr_.hCoeffs().size(), left = n - rank_;
  V_ = qr.leftCols(k).triangularView<Eigen::UnitLower>();  // zeros above the unit diagonal
  T_.setZero(k, k);  // the factor fills its upper triangle: dense products below
  Eigen::internal::make_block_householder_triangular_factor(T_, V_, qr_.hCoeffs());
  ZV_.resize(Z.rows(), k);
  if (identity_below) {
    ZV_.topRows<kBaseRows>().noalias() = Z.topRows<kBaseRows>() * V_;
    ZV_.bottomRows(n) = V_;
  } else {
    ZV_.noalias() = Z * V_;
  }
  // (Z Q) [y; 0] = Z_lead y - (Z V) T V_lead^T y, V_lead V's first `rank` rows
  Vy_.noalias() = V_.topRows(rank_).transpose() * y;
  TVy_.noalias() = T_ * Vy_;
  x.noalias() += Z.leftCols(rank_) * y;
  x.noalias() -= ZV_ * TVy_;
  // (Z Q)'s trailing columns: Z_tail - (Z V) T V_tail^T, from Z V formed before Z_tail changes
  W_.noalias() = T_ * V_.bottomRows(left).transpose();
  Z.rightCols(left).noalias() -= ZV_ * W_;
}

void least_squares_and_null_space(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                  Eigen::VectorXd& u, Eigen::MatrixXd& N) {
  const Eigen::Index n = A.cols();
  if (A.rows() == 0) {
    u.setZero(n);
    N = Eigen::MatrixXd::Identity(n, n);
    return;
  }
  RowSpaceQR qr;
  qr.compute(A);
  Eigen::MatrixXd Q;
  qr.q(Q);  // as dorgqr forms it (linalg.py): accumulated, not applied to a whole identity
  const int rank = qr.rank();
  u = rank ? (Q.leftCols(rank) * qr.solve(b)).eval() : Eigen::VectorXd::Zero(n);
  N = Q.rightCols(n - rank);
}

void apply_qt_to_vector(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, Eigen::VectorXd& v) {
  // Reflector by reflector on v's tail: HouseholderSequence::applyThisOnTheLeft takes a vector
  // as a block of dynamic columns, and each reflector's outer product then evaluates tau * v into
  // a heap temporary (one allocation per reflector, per tick).
  const auto& reflectors = qr.matrixQR();
  const auto& tau = qr.hCoeffs();
  const Eigen::Index m = reflectors.rows();
  double workspace;  // applyHouseholderOnTheLeft's, one entry per column of v
  for (Eigen::Index k = 0; k < tau.size(); ++k)
    v.tail(m - k).applyHouseholderOnTheLeft(reflectors.col(k).tail(m - k - 1), tau(k), &workspace);
}

bool full_rank_step(LeastSquaresStep& step, const Eigen::VectorXd& r, Eigen::VectorXd& u) {
  const Eigen::Index n = step.AZ.cols();
  if (step.AZ.rows() < n) return false;
  step.full_rank_qr.compute(step.AZ);
  if (!full_rank_by_margin(step.full_rank_qr, step.AZ.norm(), step.R_inverse)) return false;
  step.y = r;
  apply_qt_to_vector(step.full_rank_qr, step.y);
  u.noalias() = step.R_inverse * step.y.head(n);
  return true;
}

void least_squares_step(Eigen::MatrixXd& Z_buffer, Eigen::Index& first, Eigen::Index& cols,
                        Eigen::VectorXd& x, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                        LeastSquaresStep& step, bool update_z, bool identity_below) {
  auto Z = Z_buffer.middleCols(first, cols);
  step.AZ.resize(A.rows(), cols);
  if (identity_below) {  // A Z = A_1 Z_top + A_2: a product over kBaseRows only, unrolled
    step.AZ.noalias() = A.leftCols<kBaseRows>().lazyProduct(Z.topRows<kBaseRows>());
    step.AZ += A.rightCols(cols);
  } else {
    sparse_rows_product(A, Z, step.AZ);
  }
  step.r = b;
  step.r.noalias() -= A * x;
  if (!update_z && full_rank_step(step, step.r, step.u)) {  // the last level: only the step
    x.noalias() += Z * step.u;
    return;
  }
  step.qr.compute(step.AZ);
  const int rank = step.qr.rank();
  if (rank == 0) return;
  step.qr.solve(step.r, step.y);
  if (!update_z) {  // the last level: only the step, Z Q [y; 0]
    step.r.setZero(cols);
    step.r.head(rank) = step.y;
    step.qr.apply_q_on_the_left(step.r);
    x.noalias() += Z * step.r;
    return;
  }
  // Z Q: its first `rank` columns step, the rest stay free (the window's tail)
  step.qr.step_and_null_space(Z, step.y, x, identity_below);
  first += rank;
  cols -= rank;
}

}  // namespace lab
