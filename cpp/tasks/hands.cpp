// The hands task (lab/controller/tasks/hands.py): each hand frame the kernel was given tracks its
// pose target in the references, 6 rows per hand. References without hand targets give no rows.
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/explog.hpp>
#include <stdexcept>

#include "tasks/registry.hpp"

namespace lab {
namespace {

constexpr auto kFrame = pinocchio::LOCAL_WORLD_ALIGNED;

/// Per hand, J q̈ + J̇v = [p̈_ref + kp (p_ref − p) + kd (ṗ_ref − ṗ); kp log₃(R_ref Rᵀ) − kd ω]
/// (Raiola eqs. 7–9, world axes); the error is [p_ref − p; log₃(R_ref Rᵀ)] per hand.
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
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto fid = frame_ids[static_cast<std::size_t>(k)];
      const pinocchio::SE3& placement = pinocchio::updateFramePlacement(model, data, fid);
      jacobian_.setZero(6, robot.nv);  // getFrameJacobian writes the frame's joints' columns only
      pinocchio::getFrameJacobian(model, data, fid, kFrame, jacobian_);
      A.block(6 * k, 0, 6, robot.nv) = jacobian_;
      velocity_.noalias() = jacobian_ * robot.v;
      const Eigen::Matrix<double, 6, 1> drift =
          pinocchio::getFrameClassicalAcceleration(model, data, fid, kFrame).toVector();
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> target(
          refs.hand_rotation.data() + 9 * k);
      const Eigen::Vector3d e_p = refs.hand_position.segment<3>(3 * k) - placement.translation();
      const Eigen::Vector3d e_r =
          pinocchio::log3(Eigen::Matrix3d(target * placement.rotation().transpose()));
      error.segment<3>(6 * k) = e_p;
      error.segment<3>(6 * k + 3) = e_r;
      b.segment<3>(6 * k) = refs.hand_acceleration.segment<3>(3 * k) + gains.kp * e_p +
                            gains.kd * (refs.hand_velocity.segment<3>(3 * k) - velocity_.head<3>());
      b.segment<3>(6 * k + 3) = gains.kp * e_r - gains.kd * velocity_.tail<3>();
      b.segment<6>(6 * k) -= drift;
    }
  }

  std::vector<pinocchio::FrameIndex> frame_ids;

 private:
  Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian_;
  Eigen::Matrix<double, 6, 1> velocity_;
};

}  // namespace

void add_hands_tasks(TaskRegistry& tasks) { tasks["hands"] = std::make_unique<HandsTask>(); }

void set_hand_frames(Task& hands, const RobotModel& robot, const std::vector<std::string>& frames) {
  std::vector<pinocchio::FrameIndex> ids;
  for (const auto& frame : frames) {
    // the body frame: a URDF's fixed joint and its child link share a name (hands.py)
    if (!robot.model->existFrame(frame, pinocchio::BODY))
      throw std::invalid_argument("no frame '" + frame + "' in the robot's model");
    ids.push_back(robot.model->getFrameId(frame, pinocchio::BODY));
  }
  dynamic_cast<HandsTask&>(hands).frame_ids = std::move(ids);
}

}  // namespace lab
