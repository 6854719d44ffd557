// lab/realism/knobs.py's RealismKnobs as a plain struct: the values the layer runs with (the
// ranges and presets are checked and loaded in Python, which hands the values over).
#pragma once

#include <cstdint>
#include <string>

namespace lab::realism {

struct Knobs {
  double gyro_noise = 0.0, gyro_bias_walk = 0.0, attitude_noise = 0.0;
  double base_velocity_noise = 0.0, base_position_noise = 0.0;
  int encoder_bits = 0;
  double encoder_noise = 0.0;
  bool velocity_differencing = false;
  double velocity_filter_hz = 0.0;
  int measurement_delay = 0, command_delay = 0;
  std::string actuator = "ideal";  // ideal | bandwidth | sea
  double torque_bandwidth_hz = 1000.0;
  double sea_stiffness = 1000.0, sea_motor_inertia = 0.01, sea_kp = 0.0, sea_kd = 0.0;
  std::uint64_t seed = 0;
};

}  // namespace lab::realism
