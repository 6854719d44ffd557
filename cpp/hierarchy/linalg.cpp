#include "hierarchy/linalg.hpp"

#include <algorithm>
#include <cmath>

namespace lab {

bool solution_and_null_space_of_leading_block(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                              Eigen::MatrixXd& Z, Eigen::VectorXd& x) {
  const Eigen::Index k = A.rows(), n = A.cols();
  Eigen::PartialPivLU<Eigen::MatrixXd> lu(A.leftCols(k));
  if (!(std::abs(lu.determinant()) > 0.0)) return false;
  Z.setZero(n, n - k);
  Z.topRows(k).noalias() = -lu.solve(A.rightCols(n - k));
  Z.bottomRows(n - k).setIdentity();
  x.setZero(n);
  x.head(k) = lu.solve(b);
  return Z.allFinite() && x.allFinite();
}

void RowSpaceQR::compute(const Eigen::MatrixXd& A) {
  rows_ = static_cast<int>(A.rows());
  rank_ = 0;
  if (rows_ == 0) {
    qr_ = Eigen::ColPivHouseholderQR<Eigen::MatrixXd>();
    return;
  }
  qr_.compute(A.transpose());
  // Column pivoting makes |R00| >= |R11| >= ...: the rank is the count above the threshold.
  const auto diagonal = qr_.matrixQR().diagonal().cwiseAbs();
  const double threshold = kRankRtol * std::max(1.0, diagonal.size() ? diagonal(0) : 0.0);
  for (Eigen::Index i = 0; i < diagonal.size(); ++i) rank_ += diagonal(i) > threshold ? 1 : 0;
}

Eigen::VectorXd RowSpaceQR::solve(const Eigen::VectorXd& b) const {
  if (rank_ == 0) return Eigen::VectorXd::Zero(0);
  const Eigen::VectorXd rhs = qr_.colsPermutation().transpose() * b;  // P^T b
  const auto& R = qr_.matrixQR();
  if (rank_ == rows_) {  // R1^T is square and lower triangular
    return R.topLeftCorner(rank_, rank_).triangularView<Eigen::Upper>().transpose().solve(rhs);
  }
  // More rows than freedom: least squares of the full-column-rank R1^T (m x rank).
  const Eigen::MatrixXd R1t =
      R.topRows(rank_).triangularView<Eigen::Upper>().toDenseMatrix().transpose();
  return R1t.householderQr().solve(rhs);
}

void RowSpaceQR::apply_q_on_the_right(Eigen::MatrixXd& M) const {
  if (rows_ == 0) return;
  qr_.householderQ().applyThisOnTheRight(M);
}

void least_squares_and_null_space(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                  Eigen::VectorXd& u, Eigen::MatrixXd& N) {
  const Eigen::Index n = A.cols();
  Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(n, n);
  if (A.rows() == 0) {
    u.setZero(n);
    N = Q;
    return;
  }
  RowSpaceQR qr;
  qr.compute(A);
  qr.apply_q_on_the_right(Q);
  const int rank = qr.rank();
  u = rank ? (Q.leftCols(rank) * qr.solve(b)).eval() : Eigen::VectorXd::Zero(n);
  N = Q.rightCols(n - rank);
}

void least_squares_step(Eigen::MatrixXd& Z, Eigen::VectorXd& x, const Eigen::MatrixXd& A,
                        const Eigen::VectorXd& b) {
  const Eigen::MatrixXd AZ = A * Z;
  RowSpaceQR qr;
  qr.compute(AZ);
  const int rank = qr.rank();
  if (rank == 0) return;
  const Eigen::VectorXd y = qr.solve(b - A * x);
  qr.apply_q_on_the_right(Z);  // Z Q: the first `rank` columns step, the rest stay free
  x.noalias() += Z.leftCols(rank) * y;
  Z = Z.rightCols(Z.cols() - rank).eval();
}

}  // namespace lab
