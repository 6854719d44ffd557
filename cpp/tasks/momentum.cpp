// The centroidal momentum task of Herzog 2016 (lab/controller/tasks/momentum.py): momentum.
// K_h, the 6 × 9 feedback gain, is designed in Python (lab/controller/momentum.py: PD of eq. 22,
// LQR of eqs. 23–26 and its interpolation across a contact switch) and set here when it changes.
#include <stdexcept>

#include "tasks/registry.hpp"

namespace lab {
namespace {

/// A_G q̈ = ḣ_des − Ȧ_G v with ḣ_des = −K_h s + ḣ_ref (eqs. 20, 22, 24), s = [c − c_ref;
/// h_lin − m ċ_ref; h_ang] (world axes, about the CoM), ḣ_ref = [m c̈_ref; 0] fed forward; the
/// error is s.
class MomentumTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    if (!gain_set) throw std::logic_error("momentum: no K_h was set (Kernel.set_momentum_gain)");
    const Eigen::Matrix<double, 6, 1> h = robot.centroidal_map * robot.v;
    reset(robot, 6);
    A.leftCols(robot.nv) = robot.centroidal_map;
    error.resize(9);
    error << robot.com - refs.com, h.head<3>() - robot.mass * refs.com_velocity, h.tail<3>();
    b.noalias() = -gain * error;
    b -= robot.centroidal_drift();
    b.head<3>() += robot.mass * refs.com_acceleration;
  }

  Eigen::Matrix<double, 6, 9> gain = Eigen::Matrix<double, 6, 9>::Zero();
  bool gain_set = false;
};

}  // namespace

void set_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& gain) {
  if (gain.rows() != 6 || gain.cols() != 9)
    throw std::invalid_argument("momentum: K_h needs 6 x 9 entries, got " +
                                std::to_string(gain.rows()) + " x " + std::to_string(gain.cols()));
  if (!gain.allFinite()) throw std::invalid_argument("momentum: K_h has non-finite entries");
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  task.gain = gain;
  task.gain_set = true;
}

void add_momentum_tasks(TaskRegistry& tasks) {
  tasks["momentum"] = std::make_unique<MomentumTask>();
}

}  // namespace lab
