// Balance: the standing behaviour (mirrors lab/controller/behaviours/balance.py Balance.update).
// The references at rest are built on the Python side, once; on two point feet (Bolt) each tick
// leans the CoM reference off the foot line (line_balance.cpp); otherwise nothing changes.
#pragma once

#include <Eigen/Dense>

#include "behaviours/behaviour.hpp"
#include "behaviours/line_balance.hpp"

namespace lab {

/// Balance's state between ticks (balance.py Balance; the same names).
class Balance : public NativeBehaviour {
 public:
  bool on_line = false;                                   // two point feet
  Eigen::Vector3d com_on_line = Eigen::Vector3d::Zero();  // the CoM reference on the line
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();      // composite, about the CoM (world)
  LineBalanceGains line_gains;

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
