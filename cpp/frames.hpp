// The world placements of the frames the UI draws with (lab/robot.py FramePlacements): the
// `frames` of a `lab/state` message in one call, pinocchio's forward kinematics and frame
// placements, each rotation as Eigen's quaternion.
#pragma once

#include <nanobind/nanobind.h>

#include <Eigen/Dense>
#include <memory>
#include <pinocchio/multibody/fwd.hpp>
#include <string>
#include <vector>

namespace lab {

/// One row per frame: position (m) then quaternion (x, y, z, w), world axes.
using PlacementRows = Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor>;

class FramePlacements {
 public:
  /// From pinocchio's Model.saveToString() and the indices of the frames to place.
  FramePlacements(const std::string& serialized_model, std::vector<std::size_t> frames);
  ~FramePlacements();

  std::size_t size() const { return frames_.size(); }
  int nq() const;

  /// The frames' placements at configuration q, into out (size() x 7).
  void compute(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<PlacementRows> out);

 private:
  std::unique_ptr<pinocchio::Model> model_;
  std::unique_ptr<pinocchio::Data> data_;
  std::vector<std::size_t> frames_;
};

void bind_frame_placements(nanobind::module_& m);

}  // namespace lab
