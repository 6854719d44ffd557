// The contact task (lab/controller/tasks/contact.py): feet in support do not accelerate.
#include "tasks/base.hpp"

namespace lab {
namespace {

/// Feet in contact do not accelerate: J_c q̈ = −J̇_c v − kd J_c v (Raiola eq. 7).
class ContactTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    contact_rows(robot, refs.contact_active, index_);
    const auto n = static_cast<Eigen::Index>(index_.size());
    reset(robot, n);
    write_jacobian_rows(robot, index_, A);
    error.noalias() = A.leftCols(robot.nv) * robot.v;
    for (Eigen::Index r = 0; r < n; ++r) b[r] = -robot.Jc_dot_v[index_[r]];
    if (gains.kd != 0.0) b -= gains.kd * error;
  }

 private:
  std::vector<Eigen::Index> index_;
};

}  // namespace

void add_contact_tasks(TaskRegistry& tasks) { tasks["contact"] = std::make_unique<ContactTask>(); }

}  // namespace lab
