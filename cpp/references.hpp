// What the behaviour asks of the tasks this tick (mirrors lab/controller/references.py: its
// References, WalkReferences and SoleReferences). The behaviour owns them in Python;
// the bindings read the fields `kReferenceFields` lists, the one layout both sides check
// (tests/kernel/test_kernel.py compares it with the dataclasses' fields). A walking field left
// empty means what the Python side does for a plain References: flat ground, no swing trajectories,
// no force interpolation, zero posture velocity, full postural weight.
#pragma once

#include <Eigen/Dense>
#include <array>

namespace lab {

struct References {
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::VectorXd posture;  // actuated joint positions, pinocchio order
  double base_height = 0.0;
  Eigen::Matrix3d base_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d com_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d com_acceleration = Eigen::Vector3d::Zero();  // fed forward by momentum (eq. 22)
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();  // world axes
  Eigen::Array<bool, Eigen::Dynamic, 1> contact_active;
  Eigen::VectorXd normal_force_max;  // per contact (N); empty: the robot-wide bound
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();  // world axes
  // The hands task's targets, per hand (h, 3) and (h, 3, 3) row-major flat, or empty (no rows):
  // position, its velocity and acceleration, rotation; in world axes, or in the trunk's heading
  // frame for a hand whose hand_heading flag is set (empty flags: all in the world).
  Eigen::VectorXd hand_position;
  Eigen::VectorXd hand_velocity;
  Eigen::VectorXd hand_acceleration;
  Eigen::VectorXd hand_rotation;
  Eigen::Array<bool, Eigen::Dynamic, 1> hand_heading;

  // WalkReferences: per-contact rows (n_contacts, 3) stored row-major flat, or empty.
  Eigen::VectorXd foot_position;
  Eigen::VectorXd foot_velocity;
  Eigen::VectorXd foot_acceleration;
  Eigen::VectorXd surface_normal;
  Eigen::VectorXd force_weight;      // per contact; NaN: not changing
  Eigen::VectorXd posture_velocity;  // per actuated joint
  Eigen::VectorXd posture_weight;    // per contact's leg
  // Feet the swing_feet task moves, per contact; empty: those out of contact. A foot in a
  // contact transition (Kim 2016 §III-F) keeps tracking its reference while its force ramps.
  Eigen::Array<bool, Eigen::Dynamic, 1> swing_tracked;

  // SoleReferences (references.py), or empty: each sole's pose target (world position (n, 3) and
  // rotation (n, 3, 3), row-major flat), the legs swinging in joint space and their trajectory
  // (actuated joints, pinocchio order).
  Eigen::VectorXd sole_position;
  Eigen::VectorXd sole_rotation;
  Eigen::Array<bool, Eigen::Dynamic, 1> leg_swinging;
  Eigen::VectorXd leg_position;
  Eigen::VectorXd leg_velocity;
  Eigen::VectorXd leg_acceleration;
};

/// How Python holds a field: a float, a float64 array or a bool array.
enum class FieldType { number, doubles, flags };

/// One field of the references' dataclasses as the kernel reads it: its name, the class that
/// declares it, its type and its shape in the robot's sizes ("n" contacts, "na" actuated
/// joints, "h" hands, comma-separated dimensions, "" for a number; a field whose dataclass default
/// is empty may be empty), and the setter that stores `size` values into References (false: not a
/// size the field can have).
struct ReferenceField {
  const char* name;
  const char* declared_by;
  FieldType type;
  const char* shape;
  bool (*set_doubles)(References&, const double*, Eigen::Index);  // number and doubles
  bool (*set_flags)(References&, const bool*, Eigen::Index);      // flags
};

namespace reference_setters {
template <Eigen::VectorXd References::* field>
bool doubles(References& refs, const double* data, Eigen::Index size) {
  refs.*field = Eigen::Map<const Eigen::VectorXd>(data, size);
  return true;
}
template <Eigen::Vector3d References::* field>
bool vector3(References& refs, const double* data, Eigen::Index size) {
  if (size != 3) return false;
  refs.*field = Eigen::Map<const Eigen::Vector3d>(data);
  return true;
}
inline bool base_height(References& refs, const double* data, Eigen::Index size) {
  refs.base_height = *data;
  return size == 1;
}
inline bool base_rotation(References& refs, const double* data, Eigen::Index size) {
  if (size != 9) return false;
  refs.base_rotation = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(data);
  return true;
}
template <Eigen::Array<bool, Eigen::Dynamic, 1> References::* field>
bool flags(References& refs, const bool* data, Eigen::Index size) {
  refs.*field = Eigen::Map<const Eigen::Array<bool, Eigen::Dynamic, 1>>(data, size);
  return true;
}
}  // namespace reference_setters

/// Every field of References, WalkReferences and SoleReferences, in their declaration order.
inline const std::array<ReferenceField, 29> kReferenceFields = [] {
  namespace set = reference_setters;
  using R = References;
  constexpr auto doubles = FieldType::doubles;
  constexpr auto flags = FieldType::flags;
  constexpr const char* walk = "WalkReferences";
  constexpr const char* sole = "SoleReferences";
  return std::array<ReferenceField, 29>{{
      {"com", "References", doubles, "3", set::vector3<&R::com>, nullptr},
      {"posture", "References", doubles, "na", set::doubles<&R::posture>, nullptr},
      {"base_height", "References", FieldType::number, "", set::base_height, nullptr},
      {"base_rotation", "References", doubles, "3,3", set::base_rotation, nullptr},
      {"com_velocity", "References", doubles, "3", set::vector3<&R::com_velocity>, nullptr},
      {"com_acceleration", "References", doubles, "3", set::vector3<&R::com_acceleration>, nullptr},
      {"base_angular_velocity", "References", doubles, "3", set::vector3<&R::base_angular_velocity>,
       nullptr},
      {"contact_active", "References", flags, "n", nullptr, set::flags<&R::contact_active>},
      {"normal_force_max", "References", doubles, "n", set::doubles<&R::normal_force_max>, nullptr},
      {"base_linear_velocity", "References", doubles, "3", set::vector3<&R::base_linear_velocity>,
       nullptr},
      {"hand_position", "References", doubles, "h,3", set::doubles<&R::hand_position>, nullptr},
      {"hand_velocity", "References", doubles, "h,3", set::doubles<&R::hand_velocity>, nullptr},
      {"hand_acceleration", "References", doubles, "h,3", set::doubles<&R::hand_acceleration>,
       nullptr},
      {"hand_rotation", "References", doubles, "h,3,3", set::doubles<&R::hand_rotation>, nullptr},
      {"hand_heading", "References", flags, "h", nullptr, set::flags<&R::hand_heading>},
      {"foot_position", walk, doubles, "n,3", set::doubles<&R::foot_position>, nullptr},
      {"foot_velocity", walk, doubles, "n,3", set::doubles<&R::foot_velocity>, nullptr},
      {"foot_acceleration", walk, doubles, "n,3", set::doubles<&R::foot_acceleration>, nullptr},
      {"surface_normal", walk, doubles, "n,3", set::doubles<&R::surface_normal>, nullptr},
      {"force_weight", walk, doubles, "n", set::doubles<&R::force_weight>, nullptr},
      {"posture_velocity", walk, doubles, "na", set::doubles<&R::posture_velocity>, nullptr},
      {"swing_tracked", walk, flags, "n", nullptr, set::flags<&R::swing_tracked>},
      {"posture_weight", walk, doubles, "n", set::doubles<&R::posture_weight>, nullptr},
      {"sole_position", sole, doubles, "n,3", set::doubles<&R::sole_position>, nullptr},
      {"sole_rotation", sole, doubles, "n,3,3", set::doubles<&R::sole_rotation>, nullptr},
      {"leg_swinging", sole, flags, "n", nullptr, set::flags<&R::leg_swinging>},
      {"leg_position", sole, doubles, "na", set::doubles<&R::leg_position>, nullptr},
      {"leg_velocity", sole, doubles, "na", set::doubles<&R::leg_velocity>, nullptr},
      {"leg_acceleration", sole, doubles, "na", set::doubles<&R::leg_acceleration>, nullptr},
  }};
}();

}  // namespace lab
