// Stance: a biped stands on both soles or on one, switching as Herzog 2016 §5.4 does (shift,
// unload, lift and back), the lifted leg swinging on request (Fig. 11); mirrors
// lab/controller/behaviours/stance.py (Stance.update, _to_single, _to_double, _update_swing),
// whose docstring describes each phase.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "behaviours/balance.hpp"

namespace lab {

constexpr double kShiftS = 1.0;        // s, CoG over the stance sole (or back to the middle)
constexpr double kUnloadS = 0.5;       // s, the leaving sole's normal-force bound to zero
constexpr double kLiftS = 1.0;         // s, the sole up by kLiftHeight (or down)
constexpr double kLiftHeight = 0.10;   // m, Herzog §5.4
constexpr double kNormalMax = 5000.0;  // N, the bound of a sole that carries load freely
constexpr double kSwingAmplitude[2] = {0.4, 0.6};  // rad, hip and knee flexion's excursion
constexpr int kDoubleSupport = -1;                 // a stance: both soles, else a contact index

/// 0 → 1 with zero slope at both ends (a cosine ramp) for s in [0, 1], clamped outside.
double smooth(double s);

/// Stance's state between ticks (stance.py Stance; the same names, a stance as the index of
/// its sole's contact or kDoubleSupport, an optional as a flag and its value).
class Stance : public Balance {
 public:
  int stance = kDoubleSupport, from = kDoubleSupport;  // where the robot is (going), from where
  bool started = false;                                // a transition runs (`_started`)
  double started_at = 0.0;                             // s
  bool pending = false;                                // a request waits (`_pending`)
  int pending_stance = kDoubleSupport;
  double swing_hz = 0.0;  // asked for; 0: hold the lifted sole
  bool swinging = false;  // a swing runs (`_swing`): its start time and frequency
  double swing_start = 0.0, swing_frequency = 0.0;
  Eigen::VectorXd lifted;  // the posture a swing starts and ends in (na)
  long periods_done = 0;
  std::vector<std::vector<int>> flexion;  // each sole's leg's hip and knee flexion joints
  Eigen::VectorXd bend;                   // the side each joint bends to in the crouch (±1)
  double weight = 0.0;                    // N
  Eigen::Vector3d middle = Eigen::Vector3d::Zero();  // the CoG reference in double support
  RowMatrixX3 ground;                                // each sole where it stood (n x 3)

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;

 private:
  bool to_single(double elapsed, References& refs);
  bool to_double(double elapsed, int on, References& refs);
  void update_swing(double t, const BehaviourModel& robot, References& refs);
};

}  // namespace lab
