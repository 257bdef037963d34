#include "engine/bevel/freeform_generator.h"

#include <ceres/jet.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "engine/bevel/kinematics.h"
#include "engine/core/damped_newton.h"

namespace gearloop {
namespace {

using bevel_internal::CutterConstants;
using bevel_internal::FreeFormLocal;
using bevel_internal::Vec3;

constexpr double kMmToUm = 1000.0;

// Values and rates (d/dt) of the five axes at roll t, any scalar type.
template <typename T>
void MotionState(const FreeFormMotion& m, const T& t, T* value, T* rate) {
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    const Eigen::VectorXd& c = m.coefficients[i];
    T v(0.0), r(0.0);
    for (int k = static_cast<int>(c.size()) - 1; k >= 0; --k) {
      v = v * t + c(k);
      if (k >= 1) r = r * t + double(k) * c(k);
    }
    value[i] = v;
    rate[i] = r;
  }
}

double Acceleration(const FreeFormMotion& m, int axis, double t) {
  const Eigen::VectorXd& c = m.coefficients[axis];
  double a = 0.0;
  for (int k = static_cast<int>(c.size()) - 1; k >= 2; --k)
    a = a * t + double(k) * (k - 1) * c(k);
  return a;
}

}  // namespace

BevelFreeFormGenerator::BevelFreeFormGenerator(
    const BevelPinionJob& job,
    const BevelFlankGrid& grid,
    const FreeFormMotion& nominal,
    const BevelEnvelopeOptions& options)
    : job_(job), grid_(grid), nominal_(nominal), options_(options) {}

std::vector<ParameterBlock> BevelFreeFormGenerator::ParameterBlocks() const {
  double radius_sum = 0.0, distance_sum = 0.0;
  for (const BevelGridPoint& p : grid_.points) {
    radius_sum += std::hypot(p.position_mm.y(), p.position_mm.z());
    distance_sum += p.position_mm.norm();
  }
  const double n = std::max<double>(1.0, grid_.points.size());
  const double mean_radius = std::max(1.0, radius_sum / n);
  const double mean_distance = std::max(1.0, distance_sum / n);
  const double one_um_mm = 1e-3;
  std::vector<ParameterBlock> blocks;
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    const FreeFormAxis axis = static_cast<FreeFormAxis>(i);
    ParameterBlock b;
    b.name = FreeFormAxisName(axis);
    b.unit = FreeFormAxisUnit(axis);
    b.first_index = i * (nominal_.degree + 1);
    b.num_coefficients = nominal_.degree + 1;
    b.is_polynomial = true;
    if (axis == FreeFormAxis::kA) {
      b.default_scale = one_um_mm / mean_radius;
    } else if (axis == FreeFormAxis::kB) {
      b.default_scale = one_um_mm / mean_distance;
    } else {
      b.default_scale = one_um_mm;
    }
    blocks.push_back(b);
  }
  return blocks;
}

Eigen::Vector3d BevelFreeFormGenerator::SurfacePoint(
    const FreeFormMotion& motion,
    double blade_u_mm,
    double cutter_theta_rad,
    double roll_rad,
    Eigen::Vector3d* normal,
    double* meshing) const {
  const CutterConstants c = bevel_internal::MakeCutterConstants(job_.cutter);
  double value[kNumFreeFormAxes], rate[kNumFreeFormAxes];
  MotionState(motion, roll_rad, value, rate);
  Vec3<double> r1, n1;
  double f = 0.0;
  FreeFormLocal<double>(
      c, blade_u_mm, cutter_theta_rad, value, rate, &r1, &n1, &f);
  if (normal != nullptr) *normal = n1;
  if (meshing != nullptr) *meshing = f;
  return r1;
}

BevelContact BevelFreeFormGenerator::SolveContact(const FreeFormMotion& motion,
                                                  int index) const {
  using Jet3 = ceres::Jet<double, 3>;
  const CutterConstants c = bevel_internal::MakeCutterConstants(job_.cutter);
  const BevelGridPoint& point = grid_.points[index];
  const double lever_mm = 0.5 * (job_.blank.inner_cone_distance_mm +
                                 job_.blank.outer_cone_distance_mm);
  const Eigen::Vector4d step_scale(
      1.0, job_.cutter.point_radius_mm, lever_mm, 1.0);
  // Start from the cradle contact. The free-form chain leaves the cutter
  // spindle C out (the cutter is a surface of revolution), so the cutter angle
  // is re-measured in its frame: the grid point carried into the cutter frame
  // of `motion` at the contact's roll.
  double theta0 = point.contact.cutter_theta_rad;
  {
    double value[kNumFreeFormAxes], rate[kNumFreeFormAxes];
    MotionState(motion, point.contact.roll_rad, value, rate);
    const Eigen::Matrix3d swing =
        bevel_internal::RotX(-value[bevel_internal::kFreeFormA]) *
        bevel_internal::RotY(value[bevel_internal::kFreeFormB]);
    const Eigen::Vector3d d(value[bevel_internal::kFreeFormX],
                            value[bevel_internal::kFreeFormY],
                            -value[bevel_internal::kFreeFormZ]);
    const Eigen::Vector3d r_t = swing.transpose() * point.position_mm - d;
    theta0 = std::atan2(r_t.y(), r_t.x());
  }
  Eigen::Vector4d x(
      point.contact.blade_u_mm, theta0, point.contact.roll_rad, 0.0);
  BevelContact contact;
  // Unknowns (u, theta, t, lambda): the cutter point at (u, theta, t) lies on
  // the normal line of the grid point at lambda and satisfies the meshing
  // equation.
  const engine_internal::DampedNewtonSummary newton =
      engine_internal::DampedNewton<4>(
          engine_internal::DampedNewtonOptions{options_.max_iterations,
                                               options_.step_tolerance_mm,
                                               options_.max_step_mm},
          step_scale,
          [&](const Eigen::Vector4d& x,
              Eigen::Vector4d* g,
              Eigen::Matrix4d* jacobian) {
            const Jet3 u(x(0), 0), theta(x(1), 1), t(x(2), 2);
            Jet3 value[kNumFreeFormAxes], rate[kNumFreeFormAxes];
            MotionState(motion, t, value, rate);
            Vec3<Jet3> r1, n1;
            Jet3 f;
            FreeFormLocal<Jet3>(c, u, theta, value, rate, &r1, &n1, &f);
            for (int i = 0; i < 3; ++i) {
              (*g)(i) = r1(i).a - point.position_mm(i) - x(3) * point.normal(i);
              jacobian->block<1, 3>(i, 0) = r1(i).v.transpose();
              (*jacobian)(i, 3) = -point.normal(i);
            }
            (*g)(3) = f.a;
            jacobian->block<1, 3>(3, 0) = f.v.transpose();
            (*jacobian)(3, 3) = 0.0;
          },
          &x);
  const bool converged = newton.converged;
  contact.iterations = newton.num_iterations;
  contact.blade_u_mm = x(0);
  contact.cutter_theta_rad = x(1);
  contact.roll_rad = x(2);
  contact.deviation_mm = x(3);
  if (!converged || !x.allFinite()) {
    contact.status = PointStatus::kNotConverged;
  } else if (x(0) < bevel_internal::EdgeRadiusEndU(job_.cutter)) {
    contact.status = PointStatus::kNotReached;  // beyond the edge radius: the
                                                // tip plane, not the blade
  } else {
    contact.status = PointStatus::kOk;
  }
  return contact;
}

Eigen::RowVectorXd BevelFreeFormGenerator::ContactSensitivity(
    const FreeFormMotion& motion,
    int index,
    const BevelContact& contact) const {
  // Local variables: u, theta, the five axis values and the five axis rates at
  // the contact.
  constexpr int kLocalU = 0, kLocalTheta = 1, kLocalValue = 2, kLocalRate = 7,
                kNumLocal = 12;
  using JetN = ceres::Jet<double, kNumLocal>;
  const CutterConstants c = bevel_internal::MakeCutterConstants(job_.cutter);
  const BevelGridPoint& point = grid_.points[index];
  const double t = contact.roll_rad;
  double value_d[kNumFreeFormAxes], rate_d[kNumFreeFormAxes],
      accel_d[kNumFreeFormAxes];
  MotionState(motion, t, value_d, rate_d);
  for (int i = 0; i < kNumFreeFormAxes; ++i)
    accel_d[i] = Acceleration(motion, i, t);
  JetN value[kNumFreeFormAxes], rate[kNumFreeFormAxes];
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    value[i] = JetN(value_d[i], kLocalValue + i);
    rate[i] = JetN(rate_d[i], kLocalRate + i);
  }
  Vec3<JetN> r1, n1;
  JetN f;
  FreeFormLocal<JetN>(c,
                      JetN(contact.blade_u_mm, kLocalU),
                      JetN(contact.cutter_theta_rad, kLocalTheta),
                      value,
                      rate,
                      &r1,
                      &n1,
                      &f);
  Eigen::Matrix<double, 4, kNumLocal> local;
  for (int i = 0; i < 3; ++i) local.row(i) = r1(i).v.transpose();
  local.row(3) = f.v.transpose();

  Eigen::Matrix4d dg_dx;
  dg_dx.col(0) = local.col(kLocalU);
  dg_dx.col(1) = local.col(kLocalTheta);
  dg_dx.col(2).setZero();
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    dg_dx.col(2) += local.col(kLocalValue + i) * rate_d[i] +
                    local.col(kLocalRate + i) * accel_d[i];
  }
  dg_dx.col(3) << -point.normal, 0.0;
  // d lambda / d zeta = -e_4^T (dG/dx)^-1 dG/dzeta = -y^T dG/dzeta, (dG/dx)^T y
  // = e_4.
  const Eigen::Vector4d y =
      dg_dx.transpose().partialPivLu().solve(Eigen::Vector4d::UnitW());
  const Eigen::Matrix<double, 1, kNumLocal> y_local = -y.transpose() * local;

  const int n = motion.degree + 1;
  Eigen::RowVectorXd s(motion.NumParameters());
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    double power = 1.0, power_below = 0.0;
    for (int k = 0; k < n; ++k) {
      s(i * n + k) = y_local(kLocalValue + i) * power +
                     y_local(kLocalRate + i) * k * power_below;
      power_below = power;
      power *= t;
    }
  }
  return s;
}

void BevelFreeFormGenerator::Evaluate(const Eigen::VectorXd& parameters,
                                      bool with_jacobian,
                                      ModelEvaluation* evaluation) const {
  const FreeFormMotion motion =
      FreeFormMotion::FromVector(nominal_.degree, parameters);
  const int n = grid_.NumPoints();
  evaluation->deviations_um.setZero(n);
  evaluation->status.assign(n, PointStatus::kNotConverged);
  evaluation->contact_roll_rad.assign(n,
                                      std::numeric_limits<double>::quiet_NaN());
  if (with_jacobian) {
    evaluation->jacobian_um.setZero(n, NumParameters());
  } else {
    evaluation->jacobian_um.resize(0, 0);
  }
  for (int i = 0; i < n; ++i) {
    const BevelContact contact = SolveContact(motion, i);
    evaluation->status[i] = contact.status;
    if (contact.status != PointStatus::kOk) continue;
    evaluation->deviations_um(i) = contact.deviation_mm * kMmToUm;
    evaluation->contact_roll_rad[i] = contact.roll_rad;
    if (with_jacobian)
      evaluation->jacobian_um.row(i) =
          ContactSensitivity(motion, i, contact) * kMmToUm;
  }
}

bool AxisSensitivityOptions::IsValid(std::string* error) const {
  if (!(linear_error_mm > 0.0) || !std::isfinite(linear_error_mm)) {
    *error = "linear_error_mm must be finite and > 0";
    return false;
  }
  if (!(angular_error_rad > 0.0) || !std::isfinite(angular_error_rad)) {
    *error = "angular_error_rad must be finite and > 0";
    return false;
  }
  return true;
}

AxisSensitivityTable ComputeAxisSensitivity(
    const BevelFreeFormGenerator& generator,
    const Eigen::VectorXd& parameters,
    const AxisSensitivityOptions& options) {
  AxisSensitivityTable table;
  ModelEvaluation base;
  generator.Evaluate(parameters, /*with_jacobian=*/true, &base);
  const int degree = generator.degree();
  const double h = std::max({std::abs(generator.roll_min_rad()),
                             std::abs(generator.roll_max_rad()),
                             1e-6});
  auto summarise = [&](AxisSensitivityEntry* e, const Eigen::VectorXd& grid) {
    e->grid_um = grid;
    double sum_abs = 0.0, sum_sq = 0.0;
    int count = 0;
    e->min_um = std::numeric_limits<double>::infinity();
    e->max_um = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < grid.size(); ++i) {
      if (base.status[i] != PointStatus::kOk) continue;
      sum_abs += std::abs(grid(i));
      sum_sq += grid(i) * grid(i);
      e->min_um = std::min(e->min_um, grid(i));
      e->max_um = std::max(e->max_um, grid(i));
      ++count;
    }
    if (count == 0) {
      e->min_um = e->max_um = 0.0;
      return;
    }
    e->mean_abs_um = sum_abs / count;
    e->rms_um = std::sqrt(sum_sq / count);
    e->max_abs_um = std::max(std::abs(e->min_um), std::abs(e->max_um));
  };
  for (int axis = 0; axis < kNumFreeFormAxes; ++axis) {
    const FreeFormAxis a = static_cast<FreeFormAxis>(axis);
    const double error = (a == FreeFormAxis::kA || a == FreeFormAxis::kB)
                             ? options.angular_error_rad
                             : options.linear_error_mm;
    for (int k = 0; k <= degree; ++k) {
      const int j = FreeFormParameterIndex(a, k, degree);
      AxisSensitivityEntry e;
      e.parameter = generator.ParameterName(j);
      e.axis = FreeFormAxisName(a);
      e.order = k;
      e.error = error / std::pow(h, k);
      summarise(&e, base.jacobian_um.col(j) * e.error);
      if (k == 0) {
        if (options.exact) {
          Eigen::VectorXd p = parameters;
          p(j) += e.error;
          ModelEvaluation moved;
          generator.Evaluate(p, /*with_jacobian=*/false, &moved);
          double worst = 0.0;
          for (int i = 0; i < moved.deviations_um.size(); ++i) {
            if (moved.status[i] == PointStatus::kOk &&
                base.status[i] == PointStatus::kOk) {
              worst = std::max(
                  worst,
                  std::abs(moved.deviations_um(i) - base.deviations_um(i)));
            }
          }
          e.exact_max_abs_um = worst;
        }
        table.offsets.push_back(e);
      }
      table.coefficients.push_back(e);
    }
  }
  auto rank = [](const std::vector<AxisSensitivityEntry>& entries) {
    std::vector<int> order(entries.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return entries[a].rms_um > entries[b].rms_um;
    });
    return order;
  };
  table.offset_ranking = rank(table.offsets);
  table.coefficient_ranking = rank(table.coefficients);
  return table;
}

}  // namespace gearloop
