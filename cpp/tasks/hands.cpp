// The hands task (lab/controller/tasks/hands.py): each hand frame the kernel was given tracks its
// pose target in the references, 6 rows per hand, in world axes or in the trunk's heading frame,
// with all the robot's joints or only the hand's chain from the trunk ("arm"). References without
// hand targets give no rows.
#include <cmath>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/explog.hpp>
#include <stdexcept>

#include "tasks/registry.hpp"

namespace lab {
namespace {

constexpr auto kFrame = pinocchio::LOCAL_WORLD_ALIGNED;
constexpr pinocchio::JointIndex kBaseJoint = 1;  // the free-flyer joint: the trunk

/// R_ψ: the rotation about world z by the trunk's yaw ψ, the heading of its x axis.
Eigen::Matrix3d heading(const Eigen::Matrix3d& base_rotation) {
  const double yaw = std::atan2(base_rotation(1, 0), base_rotation(0, 0));
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

/// ψ̇ at the trunk's angular velocity ω (world axes): ω_z − x_z (x_x ω_x + x_y ω_y) / (x_x² + x_y²).
double heading_rate(const Eigen::Matrix3d& base_rotation, const Eigen::Vector3d& omega) {
  const Eigen::Vector3d x = base_rotation.col(0);
  return omega.z() - x.z() * (x.x() * omega.x() + x.y() * omega.y()) / x.head<2>().squaredNorm();
}

/// Per hand, J q̈ + J̇v = [p̈_ref + kp (p_ref − p) + kd (ṗ_ref − ṗ); kp log₃(R_ref Rᵀ) + kd (ω_ref −
/// ω)] (Raiola eqs. 7–9, world axes); the error is [p_ref − p; log₃(R_ref Rᵀ)] per hand. A target
/// in the heading frame tracks the hand relative to the base: rows J − J_b, its turning fed forward
/// (hands.py's docstring). An "arm" hand's rows keep only its chain's columns of J.
class HandsTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const auto n = static_cast<Eigen::Index>(frame_ids.size());
    if (n == 0 || refs.hand_position.size() != 3 * n) {
      reset(robot, 0);
      error.resize(0);
      return;
    }
    reset(robot, 6 * n);
    error.resize(6 * n);
    const pinocchio::Model& model = *robot.model;
    pinocchio::Data& data = *robot.data;  // the update's pass: placements of these frames only
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto fid = frame_ids[static_cast<std::size_t>(k)];
      const pinocchio::SE3& placement = pinocchio::updateFramePlacement(model, data, fid);
      jacobian_.setZero(6, robot.nv);  // getFrameJacobian writes the frame's joints' columns only
      pinocchio::getFrameJacobian(model, data, fid, kFrame, jacobian_);
      A.block(6 * k, 0, 6, robot.nv) = jacobian_;
      velocity_.noalias() = jacobian_ * robot.v;
      Eigen::Matrix<double, 6, 1> drift =
          pinocchio::getFrameClassicalAcceleration(model, data, fid, kFrame).toVector();
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> rotation(
          refs.hand_rotation.data() + 9 * k);
      Eigen::Vector3d p_ref = refs.hand_position.segment<3>(3 * k);
      Eigen::Vector3d v_ref = refs.hand_velocity.segment<3>(3 * k);
      Eigen::Vector3d a_ref = refs.hand_acceleration.segment<3>(3 * k);
      Eigen::Matrix3d R_ref = rotation;
      Eigen::Vector3d w_ref = Eigen::Vector3d::Zero();
      if (refs.hand_heading.size() && refs.hand_heading[k]) {  // hands.py's docstring
        const pinocchio::SE3& base = data.oMi[kBaseJoint];
        base_jacobian_.setZero(6, robot.nv);
        pinocchio::getJointJacobian(model, data, kBaseJoint, kFrame, base_jacobian_);
        A.block(6 * k, 0, 3, robot.nv) -= base_jacobian_.topRows<3>();
        drift.head<3>() -=
            pinocchio::getClassicalAcceleration(model, data, kBaseJoint, kFrame).linear();
        base_velocity_.noalias() = base_jacobian_ * robot.v;
        const Eigen::Matrix3d turn = heading(base.rotation());
        const double rate = heading_rate(base.rotation(), base_velocity_.tail<3>());
        const Eigen::Vector3d r_ref = turn * p_ref, v_rel = turn * v_ref;
        p_ref = base.translation() + r_ref;
        v_ref = base_velocity_.head<3>() + rate * up.cross(r_ref) + v_rel;
        a_ref =
            turn * a_ref + 2.0 * rate * up.cross(v_rel) + rate * rate * up.cross(up.cross(r_ref));
        R_ref = turn * R_ref;
        w_ref = rate * up;
      }
      for (const Eigen::Index column : other_columns[static_cast<std::size_t>(k)])
        A.block<6, 1>(6 * k, column).setZero();  // an arm hand: its chain's columns only
      const Eigen::Vector3d e_p = p_ref - placement.translation();
      const Eigen::Vector3d e_r =
          pinocchio::log3(Eigen::Matrix3d(R_ref * placement.rotation().transpose()));
      error.segment<3>(6 * k) = e_p;
      error.segment<3>(6 * k + 3) = e_r;
      b.segment<3>(6 * k) = a_ref + gains.kp * e_p + gains.kd * (v_ref - velocity_.head<3>());
      b.segment<3>(6 * k + 3) = gains.kp * e_r + gains.kd * (w_ref - velocity_.tail<3>());
      b.segment<6>(6 * k) -= drift;
    }
  }

  std::vector<pinocchio::FrameIndex> frame_ids;
  std::vector<std::vector<Eigen::Index>> other_columns;  // zeroed per hand (empty: all joints)

 private:
  Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian_, base_jacobian_;
  Eigen::Matrix<double, 6, 1> velocity_, base_velocity_;
};

}  // namespace

void add_hands_tasks(TaskRegistry& tasks) { tasks["hands"] = std::make_unique<HandsTask>(); }

void set_hand_frames(Task& hands, const RobotModel& robot, const std::vector<std::string>& frames,
                     const std::vector<std::string>& joints) {
  const pinocchio::Model& model = *robot.model;
  if (!joints.empty() && joints.size() != frames.size())
    throw std::invalid_argument(std::to_string(joints.size()) + " hand joints options for " +
                                std::to_string(frames.size()) + " hands");
  for (const auto& option : joints)
    if (option != "all" && option != "arm")
      throw std::invalid_argument("hand joints must be 'all' or 'arm', got '" + option + "'");
  std::vector<pinocchio::FrameIndex> ids;
  for (const auto& frame : frames) {
    // the body frame: a URDF's fixed joint and its child link share a name (hands.py)
    if (!model.existFrame(frame, pinocchio::BODY))
      throw std::invalid_argument("no frame '" + frame + "' in the robot's model");
    ids.push_back(model.getFrameId(frame, pinocchio::BODY));
  }
  std::vector<std::vector<Eigen::Index>> others(ids.size());
  for (std::size_t k = 0; k < joints.size(); ++k) {
    if (joints[k] != "arm") continue;
    // the chain from the trunk: the supports of the frame's joint past the free flyer (hands.py)
    std::vector<bool> arm(static_cast<std::size_t>(model.nv), false);
    for (const auto joint : model.supports[model.frames[ids[k]].parentJoint]) {
      if (joint <= kBaseJoint) continue;
      for (int i = 0; i < model.joints[joint].nv(); ++i)
        arm[static_cast<std::size_t>(model.joints[joint].idx_v() + i)] = true;
    }
    for (Eigen::Index column = 0; column < model.nv; ++column)
      if (!arm[static_cast<std::size_t>(column)]) others[k].push_back(column);
  }
  auto& task = dynamic_cast<HandsTask&>(hands);
  task.frame_ids = std::move(ids);
  task.other_columns = std::move(others);
}

}  // namespace lab
