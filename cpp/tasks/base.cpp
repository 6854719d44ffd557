#include "tasks/base.hpp"

namespace lab {

void Task::reset(const RobotModel& robot, Eigen::Index n) {
  A.setZero(n, robot.nx);  // no allocation while n stays the same
  b.setZero(n);
}

void contact_rows(const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                  std::vector<Eigen::Index>& rows) {
  rows.clear();
  for (std::size_t i = 0; i < robot.contacts.size(); ++i)
    if (flags[i])
      for (int k = 0; k < robot.contacts[i].force_dim(); ++k)
        rows.push_back(robot.force_starts[i] + k);
}

void write_jacobian_rows(const RobotModel& robot, const std::vector<Eigen::Index>& index,
                         Eigen::MatrixXd& A) {
  for (std::size_t r = 0; r < index.size(); ++r) A.row(r).head(robot.nv) = robot.Jc.row(index[r]);
}

}  // namespace lab
