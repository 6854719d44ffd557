// Load-distribution objectives of Hutter 2014 §4–5.1 (lab/controller/tasks/objectives.py):
// forces, sole_forces, torques, force_normal, force_interpolation, internal_wrench.
#include <cmath>

#include "tasks/base.hpp"

namespace lab {
namespace {

/// Contact-force regularization: F → 0.
class ForceTask : public Task {
 public:
  void compute(const RobotModel& robot, const References&) override {
    reset(robot, robot.nf);
    A.rightCols(robot.nf).setIdentity();
  }
};

/// F → 0 with each flat sole's roll and pitch moments in its half-sizes: τ_x / W, τ_y / L (the
/// sole's load times its CoP offset in half-sizes), so that a moment goes first to the load
/// difference between the soles rather than to their ankles (objectives.py SoleForceTask).
class SoleForceTask : public Task {
 public:
  void compute(const RobotModel& robot, const References&) override {
    reset(robot, robot.nf);
    A.rightCols(robot.nf).setIdentity();
    for (std::size_t i = 0; i < robot.contacts.size(); ++i) {
      const ContactSpec& contact = robot.contacts[i];
      if (contact.kind != ContactKind::flat) continue;
      const Eigen::Index at = robot.force_starts[i];
      A(at + 3, robot.nv + at + 3) = 1.0 / contact.half_width;
      A(at + 4, robot.nv + at + 4) = 1.0 / contact.half_length;
    }
  }
};

/// Joint torques → 0 through τ(x) = M_a q̈ + h_a − J_aᵀ F (Table 3, eqs. 44–45).
class TorqueTask : public Task {
 public:
  void compute(const RobotModel& robot, const References&) override {
    reset(robot, robot.na);
    A.leftCols(robot.nv) = robot.M.bottomRows(robot.na);
    A.rightCols(robot.nf) = -robot.Jc.rightCols(robot.na).transpose();
    b = -robot.h.tail(robot.na);
  }
};

/// Two unit tangents (rows) orthogonal to `normal` and to each other.
Eigen::Matrix<double, 2, 3> tangent_basis(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal / normal.norm();
  const Eigen::Vector3d helper =
      std::abs(n[0]) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Vector3d t1 = n.cross(helper);
  t1 /= t1.norm();
  Eigen::Matrix<double, 2, 3> T;
  T.row(0) = t1;
  T.row(1) = n.cross(t1);
  return T;
}

/// Tangential support forces in the local surface tangent plane → 0 (§5.1.5).
class ForceNormalTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const auto n_contacts = static_cast<Eigen::Index>(robot.contacts.size());
    const bool given = refs.surface_normal.size() == 3 * n_contacts;
    reset(robot, 2 * refs.contact_active.count());
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < n_contacts; ++i) {
      if (!refs.contact_active[i]) continue;
      const Eigen::Vector3d normal =
          given ? Eigen::Vector3d(refs.surface_normal.segment<3>(3 * i)) : Eigen::Vector3d::UnitZ();
      Eigen::Matrix<double, 2, 3> tangents = tangent_basis(normal);
      if (robot.contacts[i].kind == ContactKind::flat)  // the wrench is in the sole frame
        tangents = (tangents * robot.contact_rotations[i]).eval();
      A.block<2, 3>(row, robot.nv + robot.force_starts[i]) = tangents;
      row += 2;
    }
  }
};

/// F_j = w F_j^opt for each foot whose interpolation weight w is set (§5.1.6). F^opt is the
/// minimum-norm force of the feet in support that carries the base: J_uᵀ F = h_u.
class ForceInterpolationTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const auto n_contacts = static_cast<Eigen::Index>(robot.contacts.size());
    if (refs.force_weight.size() == 0) return reset(robot, 0);
    Eigen::Array<bool, Eigen::Dynamic, 1> changing(n_contacts);
    for (Eigen::Index i = 0; i < n_contacts; ++i)
      changing[i] = std::isfinite(refs.force_weight[i]) && refs.contact_active[i];
    if (!changing.any()) return reset(robot, 0);
    std::vector<Eigen::Index> support, index;
    contact_rows(robot, refs.contact_active, support);
    Eigen::MatrixXd base(BASE_DOF, static_cast<Eigen::Index>(support.size()));
    for (std::size_t k = 0; k < support.size(); ++k)
      base.col(k) = robot.Jc.row(support[k]).head<BASE_DOF>().transpose();
    // numpy.linalg.lstsq: the minimum-norm least-squares solution.
    const Eigen::VectorXd solved =
        base.completeOrthogonalDecomposition().solve(robot.h.head<BASE_DOF>());
    Eigen::VectorXd optimal = Eigen::VectorXd::Zero(robot.nf);
    for (std::size_t k = 0; k < support.size(); ++k) optimal[support[k]] = solved[k];
    contact_rows(robot, changing, index);
    reset(robot, static_cast<Eigen::Index>(index.size()));
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < n_contacts; ++i) {
      if (!changing[i]) continue;
      for (int k = 0; k < robot.contacts[i].force_dim(); ++k, ++row) {
        const Eigen::Index column = robot.force_starts[i] + k;
        A(row, robot.nv + column) = 1.0;
        b[row] = refs.force_weight[i] * optimal[column];
      }
    }
  }
};

/// The support wrenches' internal part → 0: (I − G⁺G) F = 0 with G = J_uᵀ over the forces of
/// the feet in support (G F is the wrench the base feels; its null space is what the feet exert
/// on each other).
class InternalWrenchTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    contact_rows(robot, refs.contact_active, columns_);
    const auto k = static_cast<Eigen::Index>(columns_.size());
    reset(robot, k);
    if (k == 0) return;
    base_.resize(BASE_DOF, k);
    for (Eigen::Index c = 0; c < k; ++c)
      base_.col(c) = robot.Jc.row(columns_[c]).head<BASE_DOF>().transpose();
    // numpy.linalg.pinv: G⁺G = V_r V_rᵀ over the singular values above 1e-15 of the largest.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(base_, Eigen::ComputeThinV);
    const auto& sigma = svd.singularValues();
    Eigen::Index rank = 0;
    while (rank < sigma.size() && sigma[rank] > 1e-15 * sigma[0]) ++rank;
    const auto V = svd.matrixV().leftCols(rank);
    projector_.noalias() = -V * V.transpose();
    projector_.diagonal().array() += 1.0;
    for (Eigen::Index c = 0; c < k; ++c) A.col(robot.nv + columns_[c]) = projector_.col(c);
  }

 private:
  std::vector<Eigen::Index> columns_;  // rows of F of the feet in support
  Eigen::MatrixXd base_, projector_;   // G (6 × k) and I − G⁺G
};

}  // namespace

void add_objective_tasks(TaskRegistry& tasks) {
  tasks["forces"] = std::make_unique<ForceTask>();
  tasks["sole_forces"] = std::make_unique<SoleForceTask>();
  tasks["torques"] = std::make_unique<TorqueTask>();
  tasks["force_normal"] = std::make_unique<ForceNormalTask>();
  tasks["force_interpolation"] = std::make_unique<ForceInterpolationTask>();
  tasks["internal_wrench"] = std::make_unique<InternalWrenchTask>();
}

}  // namespace lab
