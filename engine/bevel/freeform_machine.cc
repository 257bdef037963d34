#include "engine/bevel/freeform_machine.h"

#include "engine/bevel/kinematics.h"

namespace gearloop {

const char* FreeFormAxisName(FreeFormAxis axis) {
  static const char* const kNames[kNumFreeFormAxes] = {"A", "B", "X", "Y", "Z"};
  return kNames[static_cast<int>(axis)];
}

const char* FreeFormAxisUnit(FreeFormAxis axis) {
  return axis == FreeFormAxis::kA || axis == FreeFormAxis::kB ? "rad" : "mm";
}

double FreeFormAxisValues::Get(FreeFormAxis axis) const {
  switch (axis) {
    case FreeFormAxis::kA:
      return a_rad;
    case FreeFormAxis::kB:
      return b_rad;
    case FreeFormAxis::kX:
      return x_mm;
    case FreeFormAxis::kY:
      return y_mm;
    case FreeFormAxis::kZ:
      return z_mm;
  }
  return 0.0;
}

void FreeFormAxisValues::Set(FreeFormAxis axis, double value) {
  switch (axis) {
    case FreeFormAxis::kA:
      a_rad = value;
      break;
    case FreeFormAxis::kB:
      b_rad = value;
      break;
    case FreeFormAxis::kX:
      x_mm = value;
      break;
    case FreeFormAxis::kY:
      y_mm = value;
      break;
    case FreeFormAxis::kZ:
      z_mm = value;
      break;
  }
}

RigidTransform FreeFormWorkFromCutter(const FreeFormAxisValues& axes) {
  const Eigen::Matrix3d swing =
      bevel_internal::RotX(-axes.a_rad) * bevel_internal::RotY(axes.b_rad);
  RigidTransform t;
  t.rotation = swing * bevel_internal::RotZ(axes.c_rad);
  t.translation_mm = swing * Eigen::Vector3d(axes.x_mm, axes.y_mm, -axes.z_mm);
  return t;
}

FreeFormMotion FreeFormMotion::Zero(int degree) {
  FreeFormMotion m;
  m.degree = degree;
  for (auto& c : m.coefficients) c = Eigen::VectorXd::Zero(degree + 1);
  return m;
}

double FreeFormMotion::Value(FreeFormAxis axis, double roll_rad) const {
  const Eigen::VectorXd& c = coefficients[static_cast<int>(axis)];
  double v = 0.0;
  for (int k = static_cast<int>(c.size()) - 1; k >= 0; --k)
    v = v * roll_rad + c(k);
  return v;
}

double FreeFormMotion::Rate(FreeFormAxis axis, double roll_rad) const {
  const Eigen::VectorXd& c = coefficients[static_cast<int>(axis)];
  double r = 0.0;
  for (int k = static_cast<int>(c.size()) - 1; k >= 1; --k)
    r = r * roll_rad + k * c(k);
  return r;
}

FreeFormAxisValues FreeFormMotion::At(double roll_rad) const {
  FreeFormAxisValues v;
  for (int i = 0; i < kNumFreeFormAxes; ++i)
    v.Set(static_cast<FreeFormAxis>(i),
          Value(static_cast<FreeFormAxis>(i), roll_rad));
  double c = 0.0;
  for (int k = static_cast<int>(c_coefficients.size()) - 1; k >= 0; --k)
    c = c * roll_rad + c_coefficients(k);
  v.c_rad = c;
  return v;
}

Eigen::VectorXd FreeFormMotion::ToVector() const {
  Eigen::VectorXd p(NumParameters());
  for (int i = 0; i < kNumFreeFormAxes; ++i)
    p.segment(i * (degree + 1), degree + 1) = coefficients[i];
  return p;
}

FreeFormMotion FreeFormMotion::FromVector(int degree,
                                          const Eigen::VectorXd& parameters) {
  FreeFormMotion m;
  m.degree = degree;
  for (int i = 0; i < kNumFreeFormAxes; ++i)
    m.coefficients[i] = parameters.segment(i * (degree + 1), degree + 1);
  return m;
}

std::string FreeFormParameterName(int index, int degree) {
  const int axis = index / (degree + 1);
  const int order = index % (degree + 1);
  return std::string(FreeFormAxisName(static_cast<FreeFormAxis>(axis))) +
         std::to_string(order);
}

}  // namespace gearloop
