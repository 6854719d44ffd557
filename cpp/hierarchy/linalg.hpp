// The small dense-algebra steps of the cascade (mirrors lab/controller/hierarchy/linalg.py):
// everything comes from one column-pivoted QR per level.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace lab {

/// Diagonal entries of R below this fraction of max(1, |R00|) do not count towards the rank.
constexpr double kRankRtol = 1e-9;

/// Safety factor on full_rank_by_margin's sufficient condition (rounding is ~1e-16 of it).
constexpr double kRankMargin = 1e3;

/// Rows of the Newton-Euler equations: the free-flyer base's six (model.hpp's BASE_DOF).
constexpr Eigen::Index kBaseRows = 6;
/// The LU of the base block of M, fixed-size: its factorization and solves are unrolled, a
/// third of the dynamic-size ones' instructions.
using BaseBlockLU = Eigen::PartialPivLU<Eigen::Matrix<double, kBaseRows, kBaseRows>>;

/// x solves A x = b and Z spans null(A), for A = [A1 A2] with A1 square and invertible:
/// x = [A1^-1 b; 0], Z = [-A1^-1 A2; I]. The Newton-Euler rows have this form, A1 being the
/// base block of M (Herzog §2.4, footnote 3). Z is not orthonormal; it spans the null space.
/// A has kBaseRows rows. Returns false when A1 is singular. `lu` is the factorization's storage.
bool solution_and_null_space_of_leading_block(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                              Eigen::MatrixXd& Z, Eigen::VectorXd& x,
                                              BaseBlockLU& lu);

/// out = A Z, row by row where A's rows are sparse: a row with at most a quarter of its entries
/// nonzero (the posture and force tasks' selection rows, the friction and CoP rows) sums only
/// those entries' rows of Z, any other row is a dense row-times-matrix product; with no sparse
/// row it is one dense product. A selection row's product is then a copy of a row of Z, the
/// dense product's value exactly (its other terms are exact zeros). `out` must not alias Z.
/// SparseRows' `compute` then `product` (one scan of A's rows, which keeps their nonzero columns).
void sparse_rows_product(const Eigen::MatrixXd& A, const Eigen::Ref<const Eigen::MatrixXd>& Z,
                         Eigen::MatrixXd& out);

/// sparse_rows_product for a matrix that many products read (a nullspace search's levels, in
/// each of its hierarchy solves): which rows are sparse, and their nonzero columns, found once
/// by `compute`; `product` then forms the same sums in the same order without looking again.
/// Its storage is kept from call to call: no allocation once it has held the largest matrix.
class SparseRows {
 public:
  void compute(const Eigen::MatrixXd& A);

  /// out = A Z, A the matrix last given to `compute`: equal to sparse_rows_product(A, Z, out).
  void product(const Eigen::MatrixXd& A, const Eigen::Ref<const Eigen::MatrixXd>& Z,
               Eigen::MatrixXd& out) const;

 private:
  bool any_sparse_ = false;
  std::vector<Eigen::Index> start_;    // row i's nonzero columns: columns_[start_[i], start_[i+1])
  std::vector<Eigen::Index> columns_;  // (none for a dense row: start_[i] == start_[i+1])
  std::vector<bool> dense_;
};

/// Whether B (rows >= cols, factorized as `qr`, B = Q R) has full column rank by a margin that
/// the rank rule of RowSpaceQR, applied to B^T, cannot miss. That rule's pivoted QR of B^T keeps at
/// each step a column at least sigma_min(B) / sqrt(rows) long (projected off the columns chosen
/// before, the others still span with sigma_min(B)), so every diagonal entry is at least that;
/// its threshold is at most kRankRtol max(1, ||B||_F); and sigma_min(B) = sigma_min(R) >=
/// 1 / ||R^-1||_F. So sigma_min / sqrt(rows) above kRankMargin times the threshold means rank =
/// cols there too. `R_inverse` is scratch (it holds R^-1 after a true answer).
bool full_rank_by_margin(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, double frobenius,
                         Eigen::MatrixXd& R_inverse);

/// A column-pivoted QR of the transpose of a level's rows A (m x n): A^T P = Q [R1; 0], with
/// R1 the `rank` rows whose diagonal exceeds kRankRtol * max(1, |R00|). Then A ~ P R1^T Q1^T.
/// One object per level keeps its storage from tick to tick: no allocation while the level's
/// shape stays the same.
class RowSpaceQR {
 public:
  /// Factorizes A^T (A may have no rows).
  void compute(const Eigen::Ref<const Eigen::MatrixXd>& A);

  int rank() const { return rank_; }

  /// y with R1^T y = P^T b, in the least-squares sense when A has more rows than rank, so that
  /// u = Q1 y is the minimum-norm minimiser of ||A u - b||.
  void solve(const Eigen::Ref<const Eigen::VectorXd>& b, Eigen::VectorXd& y);
  Eigen::VectorXd solve(const Eigen::VectorXd& b) {
    Eigen::VectorXd y;
    solve(b, y);
    return y;
  }

  /// solve's y and g = b - P R1^T y, the part of b outside A's range as the rank rule keeps it
  /// (linalg.py least_squares_with_residual); g = b at rank 0. Reuses the factorization of R1^T
  /// that the last `solve` formed.
  void solve_with_residual(const Eigen::Ref<const Eigen::VectorXd>& b, Eigen::VectorXd& y,
                           Eigen::VectorXd& g);

  /// ||A||_F, from R (Q is orthogonal).
  double frobenius() const;

  /// Whether A has full row rank with its last diagonal entry of R kRankMargin times above the
  /// rank rule's threshold (linalg.py rank_by_margin).
  bool rank_by_margin() const;

  /// Q v for one vector of n entries, reflector by reflector (no workspace sized by columns):
  /// apply_q_on_the_left gives the same v, but Eigen's HouseholderSequence around it cost G1's
  /// unload ticks 3 % more instructions where nullspace's release prediction calls it per step.
  void apply_q_to_vector(Eigen::VectorXd& v) const;

  /// M Q (Q of the factorization, n x n), applied as reflectors without forming Q.
  template <typename Matrix>
  void apply_q_on_the_right(Matrix&& M) {
    if (rows_ == 0) return;
    workspace_.resize(M.rows());
    qr_.householderQ().applyThisOnTheRight(M, workspace_);
  }

  /// One level's step and the null space it leaves, for Z (rows x n) spanning the space A was
  /// written in: x += (Z Q) [y; 0], and Z's trailing n - rank columns become Z Q's, the null space
  /// of A in Z's coordinates (Z's leading `rank` columns are left as they were). Q = I - V T V^T,
  /// the reflectors' compact WY form (V their unit lower trapezoid, T Eigen's block reflector
  /// factor): two matrix products over the k reflectors instead of k rank-one updates of all of
  /// Z, and only the columns of Z Q that are kept are formed, the others only times y. Equal to
  /// apply_q_on_the_right's Z Q up to rounding (the same reflectors, grouped). `identity_below`:
  /// Z = [Z_top; I] with Z_top its first kBaseRows rows, whose Z V is [Z_top V; V].
  void step_and_null_space(Eigen::Ref<Eigen::MatrixXd> Z, const Eigen::VectorXd& y,
                           Eigen::VectorXd& x, bool identity_below);

  /// Q itself (n x n), formed from the reflectors (Eigen's accumulation, which skips the
  /// identity's untouched corner): I Q without applying the reflectors to a whole identity.
  void q(Eigen::MatrixXd& out) {
    if (rows_ == 0) return;
    workspace_.resize(qr_.rows());
    out.resize(qr_.rows(), qr_.rows());
    qr_.householderQ().evalTo(out, workspace_);
  }

  /// Q M (M a vector or a matrix of n rows), applied as reflectors.
  template <typename Matrix>
  void apply_q_on_the_left(Matrix& M) {
    if (rows_ == 0) return;
    qr_.householderQ().applyThisOnTheLeft(M, left_workspace_);
  }

 private:
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_;
  Eigen::HouseholderQR<Eigen::MatrixXd> r1t_qr_;  // R1^T when A has more rows than rank
  Eigen::MatrixXd r1t_;
  Eigen::VectorXd rhs_, workspace_;
  Eigen::VectorXd left_workspace_;  // apply_q_on_the_left's: one entry per column of M
  // step_and_null_space's: V, T (row-major, as Eigen's own block reflector), Z V, T V_tail^T
  Eigen::MatrixXd V_, ZV_, W_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> T_;
  Eigen::VectorXd Vy_, TVy_;
  int rows_ = 0;
  int rank_ = 0;
  bool r1t_ready_ = false;  // r1t_qr_ holds R1^T of this factorization
};

/// The minimum-norm minimiser u of ||A u - b|| and an orthonormal basis N of null(A). Rows that
/// are zero up to round-off (a level with no freedom left) count as locked and give u = 0.
void least_squares_and_null_space(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                  Eigen::VectorXd& u, Eigen::MatrixXd& N);

/// Buffers of one equality level of the cascade, kept from tick to tick.
struct LeastSquaresStep {
  RowSpaceQR qr;
  Eigen::HouseholderQR<Eigen::MatrixXd> full_rank_qr;  // the last level's, see linalg.cpp
  Eigen::MatrixXd AZ, R_inverse;
  Eigen::VectorXd r, y, u;  // u: a last level's step, apart from r (no resize between them)
};

/// Q^T v for the unpivoted QR `qr` of a matrix of v.size() rows (rows >= cols), its reflectors
/// applied one by one, without a heap temporary.
void apply_qt_to_vector(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, Eigen::VectorXd& v);

/// The step u of a last level (no level below needs its null space) where its A Z, in
/// `step.AZ` (rows >= cols), has full column rank by a margin (full_rank_by_margin): the minimiser
/// of ||A Z u - r|| is then unique, and an unpivoted QR of A Z finds it for less than the pivoted
/// QR of the wide (A Z)^T, whose column norms are downdated over every row of A Z at each step.
/// False otherwise (u then unspecified). `r` and `u` may be the same vector.
bool full_rank_step(LeastSquaresStep& step, const Eigen::VectorXd& r, Eigen::VectorXd& u);

/// One equality level of the cascade: x <- x + Z u and Z <- Z N with u and N those of
/// least_squares_and_null_space(A Z, b - A x) (Herzog eq. 8), without forming Q or N. Z is the
/// `cols` columns of `Z_buffer` from `first` on; the level's step uses the leading columns of
/// Z Q, so the null space left is the window's tail: `first` moves right by the rank, `cols`
/// shrinks by it. `update_z` false (the last level) leaves Z as it is. `identity_below` says that
/// Z is [Z_top; I] with Z_top its first kBaseRows rows (the dynamics' null space as
/// solution_and_null_space_of_leading_block gives it): A Z is then formed from Z_top alone.
void least_squares_step(Eigen::MatrixXd& Z_buffer, Eigen::Index& first, Eigen::Index& cols,
                        Eigen::VectorXd& x, const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                        LeastSquaresStep& step, bool update_z = true, bool identity_below = false);

}  // namespace lab
