#include "behaviours/swing.hpp"

#include <cmath>

namespace lab {

Eigen::Matrix3d swing_reference(const Eigen::Vector3d& start, const Eigen::Vector2d& target_xy,
                                double height, double t, double duration) {
  const double step_x = target_xy.x() - start.x(), step_y = target_xy.y() - start.y();
  const double length = std::hypot(step_x, step_y);
  double hx = 0.0, hy = 0.0;  // heading ψ_s
  if (length > 1e-9) {
    hx = step_x / length;
    hy = step_y / length;
  }
  const double w = M_PI / duration;
  double x, dx, ddx, z, dz, ddz;
  if (t <= duration) {
    const double u = t / duration;
    const double warped = duration * (u * u * u) * (6.0 - 8.0 * u + 3.0 * (u * u));  // t'
    const double rate = (u * u) * (18.0 - 32.0 * u + 15.0 * (u * u));                // dt'/dt
    const double rate_dot = u * (36.0 - 96.0 * u + 60.0 * (u * u)) / duration;       // d²t'/dt²
    const double s = std::sin(w * warped), c = std::cos(w * warped);
    x = 0.5 * length * (1.0 - c);  // eq. 26 in the swing frame
    dx = 0.5 * length * w * s;
    ddx = 0.5 * length * w * w * c;
    z = height * s;
    dz = height * w * c;
    ddz = -height * w * w * s;
    ddx = ddx * (rate * rate) + dx * rate_dot;
    ddz = ddz * (rate * rate) + dz * rate_dot;
    dx = dx * rate;
    dz = dz * rate;
  } else {  // reaching: keep descending at the touchdown speed
    x = length;
    dx = 0.0;
    ddx = 0.0;
    z = -height * w * (t - duration);
    dz = -height * w;
    ddz = 0.0;
  }
  Eigen::Matrix3d out;
  out << start.x() + x * hx, start.y() + x * hy, start.z() + z,  // position (eq. 27: turned by ψ_s)
      dx * hx, dx * hy, dz,                                      // velocity
      ddx * hx, ddx * hy, ddz;                                   // acceleration
  return out;
}

}  // namespace lab
