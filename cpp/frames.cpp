#include "frames.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <stdexcept>

#include "model.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace lab {

FramePlacements::FramePlacements(const std::string& serialized_model,
                                 std::vector<std::size_t> frames)
    : model_(load_model(serialized_model)), frames_(std::move(frames)) {
  for (const auto frame : frames_)
    if (frame >= model_->frames.size())
      throw std::invalid_argument("frame index " + std::to_string(frame) + " is not in the model");
  data_ = std::make_unique<pinocchio::Data>(*model_);
}

FramePlacements::~FramePlacements() = default;

int FramePlacements::nq() const { return model_->nq; }

void FramePlacements::compute(const Eigen::Ref<const Eigen::VectorXd>& q,
                              Eigen::Ref<PlacementRows> out) {
  if (q.size() != model_->nq)
    throw std::invalid_argument("frame placements: q needs " + std::to_string(model_->nq) +
                                " entries, got " + std::to_string(q.size()));
  if (out.rows() != static_cast<Eigen::Index>(frames_.size()))
    throw std::invalid_argument("frame placements: out needs " + std::to_string(frames_.size()) +
                                " x 7 entries");
  pinocchio::forwardKinematics(*model_, *data_, q);
  for (std::size_t i = 0; i < frames_.size(); ++i) {
    const auto& placement = pinocchio::updateFramePlacement(*model_, *data_, frames_[i]);
    const auto row = static_cast<Eigen::Index>(i);
    out.row(row).head<3>() = placement.translation().transpose();
    out.row(row).tail<4>() = Eigen::Quaterniond(placement.rotation()).coeffs().transpose();
  }
}

void bind_frame_placements(nb::module_& m) {
  nb::class_<FramePlacements>(m, "FramePlacements",
                              "World placements of chosen frames of a model (lab/robot.py).")
      .def(nb::init<const std::string&, std::vector<std::size_t>>(), "model"_a, "frames"_a,
           // pinocchio's deserialization: C++ alone, the loop runs meanwhile (a robot switch)
           nb::call_guard<nb::gil_scoped_release>(),
           "From pinocchio's Model.saveToString() and the frames' indices.")
      .def_prop_ro("size", &FramePlacements::size)
      .def_prop_ro("nq", &FramePlacements::nq)
      .def("compute", &FramePlacements::compute, "q"_a, "out"_a.noconvert(),
           "Each frame's position (m) and quaternion (x, y, z, w) in the world at q, into out "
           "(one row of 7 per frame, C order, float64).");
}

}  // namespace lab
