#include "engine/bevel/conversion.h"

#include <ceres/ceres.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "engine/bevel/freeform_generator.h"
#include "engine/bevel/kinematics.h"
#include "engine/core/units.h"

namespace gearloop {
namespace {

// Residual of RotX(-A) RotY(B) RotZ(C) - L, row-major; parameters (A, B, C).
struct OrientationResidual {
  explicit OrientationResidual(const Eigen::Matrix3d& target)
      : target_(target) {}
  template <typename T>
  bool operator()(const T* const angles, T* residual) const {
    const bevel_internal::Mat3<T> r = bevel_internal::RotX<T>(-angles[0]) *
                                      bevel_internal::RotY<T>(angles[1]) *
                                      bevel_internal::RotZ<T>(angles[2]);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) residual[3 * i + j] = r(i, j) - target_(i, j);
    }
    return true;
  }
  Eigen::Matrix3d target_;
};

double OrientationError(double a,
                        double b,
                        double c,
                        const Eigen::Matrix3d& target) {
  const Eigen::Matrix3d r = bevel_internal::RotX(-a) * bevel_internal::RotY(b) *
                            bevel_internal::RotZ(c);
  return (r - target).norm();
}

double NearestBranch(double angle, double reference) {
  return angle + 2.0 * kPi * std::round((reference - angle) / (2.0 * kPi));
}

// Least-squares polynomial of `degree` through (t_i, y_i) in s = (t - centre) /
// half, returned as monomial coefficients in t.
Eigen::VectorXd FitMonomials(const std::vector<double>& t,
                             const std::vector<double>& y,
                             int degree,
                             double centre,
                             double half) {
  const int n = static_cast<int>(t.size());
  Eigen::MatrixXd v(n, degree + 1);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const double s = (t[i] - centre) / half;
    double p = 1.0;
    for (int k = 0; k <= degree; ++k) {
      v(i, k) = p;
      p *= s;
    }
    b(i) = y[i];
  }
  const Eigen::VectorXd a = v.colPivHouseholderQr().solve(b);
  // sum_k a_k ((t - c)/h)^k = sum_k a_k h^-k sum_j binom(k, j) t^j (-c)^(k-j).
  Eigen::VectorXd m = Eigen::VectorXd::Zero(degree + 1);
  for (int k = 0; k <= degree; ++k) {
    const double ak = a(k) / std::pow(half, k);
    double binom = 1.0;  // binom(k, j)
    for (int j = 0; j <= k; ++j) {
      m(j) += ak * binom * std::pow(-centre, k - j);
      binom = binom * (k - j) / (j + 1);
    }
  }
  return m;
}

}  // namespace

InstantConversion ConvertInstant(const CradleMachineSettings& machine,
                                 double roll_rad,
                                 double a_reference_rad,
                                 double c_reference_rad,
                                 bool polish) {
  const RigidTransform cradle = CradleWorkFromCutter(machine, roll_rad);
  const Eigen::Matrix3d& l = cradle.rotation;
  double angles[3];
  angles[1] = std::atan2(l(0, 2), std::hypot(l(0, 0), l(0, 1)));
  angles[0] = NearestBranch(std::atan2(l(1, 2), l(2, 2)), a_reference_rad);
  angles[2] = NearestBranch(std::atan2(-l(0, 1), l(0, 0)), c_reference_rad);
  InstantConversion out;
  out.closed_form_residual =
      OrientationError(angles[0], angles[1], angles[2], l);
  if (polish) {
    ceres::Problem problem;
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<OrientationResidual, 9, 3>(
            new OrientationResidual(l)),
        nullptr,
        angles);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_QR;
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    options.function_tolerance = 1e-20;
    options.gradient_tolerance = 1e-20;
    options.parameter_tolerance = 1e-20;
    options.max_num_iterations = 20;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
  }
  out.polished_residual = OrientationError(angles[0], angles[1], angles[2], l);
  out.axes.a_rad = angles[0];
  out.axes.b_rad = angles[1];
  out.axes.c_rad = angles[2];
  const Eigen::Matrix3d swing =
      bevel_internal::RotX(-angles[0]) * bevel_internal::RotY(angles[1]);
  const Eigen::Vector3d d =
      swing.colPivHouseholderQr().solve(cradle.translation_mm);
  out.axes.x_mm = d.x();
  out.axes.y_mm = d.y();
  out.axes.z_mm = -d.z();
  return out;
}

bool ConversionOptions::IsValid(std::string* error) const {
  if (polynomial_degree < 1 || polynomial_degree > 12) {
    *error = "polynomial_degree must lie in [1, 12]";
    return false;
  }
  if (num_samples < polynomial_degree + 1 || num_samples > 100000) {
    *error = "num_samples must lie in [polynomial_degree + 1, 100000]";
    return false;
  }
  if (num_check_samples < 2 || num_check_samples > 100000) {
    *error = "num_check_samples must lie in [2, 100000]";
    return false;
  }
  if (!(max_flank_distance_um > 0.0)) {
    *error = "max_flank_distance_um must be > 0";
    return false;
  }
  if (!(roll_margin_fraction >= 0.0 && roll_margin_fraction <= 10.0)) {
    *error = "roll_margin_fraction must lie in [0, 10]";
    return false;
  }
  return true;
}

namespace {

// The exact axes at num_samples instants over the widened roll range, marching
// from the centre outward so that A and C stay on continuous branches; the
// exact transforms are compared.
void SampleExactAxes(const ConversionOptions& options,
                     const BevelPinionJob& job,
                     const InstantConversion& middle,
                     ConversionResult* result) {
  const int n = options.num_samples;
  result->sample_roll_rad.resize(n);
  result->sample_axes.resize(n);
  for (int i = 0; i < n; ++i)
    result->sample_roll_rad[i] =
        result->roll_min_rad +
        (result->roll_max_rad - result->roll_min_rad) * i / (n - 1);
  auto convert_range = [&](int from, int to, int step) {
    double a_ref = middle.axes.a_rad, c_ref = middle.axes.c_rad;
    for (int i = from; i != to; i += step) {
      const InstantConversion s = ConvertInstant(job.machine,
                                                 result->sample_roll_rad[i],
                                                 a_ref,
                                                 c_ref,
                                                 options.polish_with_ceres);
      result->sample_axes[i] = s.axes;
      a_ref = s.axes.a_rad;
      c_ref = s.axes.c_rad;
      result->max_closed_form_residual =
          std::max(result->max_closed_form_residual, s.closed_form_residual);
      result->max_polished_residual =
          std::max(result->max_polished_residual, s.polished_residual);
    }
  };
  convert_range(n / 2, n, 1);
  convert_range(n / 2 - 1, -1, -1);
  for (int i = 0; i < n; ++i) {
    const RigidTransform g =
        CradleWorkFromCutter(job.machine, result->sample_roll_rad[i]);
    const RigidTransform f = FreeFormWorkFromCutter(result->sample_axes[i]);
    result->exact_max_rotation_difference =
        std::max(result->exact_max_rotation_difference,
                 (g.rotation - f.rotation).cwiseAbs().maxCoeff());
    result->exact_max_translation_difference_mm =
        std::max(result->exact_max_translation_difference_mm,
                 (g.translation_mm - f.translation_mm).cwiseAbs().maxCoeff());
  }
}

// Each axis (and C) fitted by monomials of the roll angle about the centre of
// the range.
void FitAxisPolynomials(const ConversionOptions& options,
                        double centre,
                        double half,
                        ConversionResult* result) {
  const int n = options.num_samples;
  result->motion = FreeFormMotion::Zero(options.polynomial_degree);
  std::vector<double> y(n);
  for (int axis = 0; axis <= kNumFreeFormAxes; ++axis) {
    for (int i = 0; i < n; ++i) {
      y[i] = axis < kNumFreeFormAxes
                 ? result->sample_axes[i].Get(static_cast<FreeFormAxis>(axis))
                 : result->sample_axes[i].c_rad;
    }
    const Eigen::VectorXd c = FitMonomials(
        result->sample_roll_rad, y, options.polynomial_degree, centre, half);
    if (axis < kNumFreeFormAxes) {
      result->motion.coefficients[axis] = c;
    } else {
      result->motion.c_coefficients = c;
    }
  }
}

// Checks over num_check_samples dense instants: the fit residual per axis and
// the difference of the fitted transform from the cradle's.
void CheckFitOnDenseInstants(const ConversionOptions& options,
                             const BevelPinionJob& job,
                             const InstantConversion& middle,
                             ConversionResult* result) {
  for (int axis = 0; axis <= kNumFreeFormAxes; ++axis) {
    result->fit[axis].axis =
        axis < kNumFreeFormAxes
            ? FreeFormAxisName(static_cast<FreeFormAxis>(axis))
            : "C";
    result->fit[axis].unit =
        axis < kNumFreeFormAxes
            ? FreeFormAxisUnit(static_cast<FreeFormAxis>(axis))
            : "rad";
  }
  std::array<double, kNumFreeFormAxes + 1> sum_sq{};
  const int m = options.num_check_samples;
  double a_ref = middle.axes.a_rad, c_ref = middle.axes.c_rad;
  for (int i = 0; i < m; ++i) {
    const double t =
        result->roll_min_rad +
        (result->roll_max_rad - result->roll_min_rad) * i / (m - 1);
    const FreeFormAxisValues fitted = result->motion.At(t);
    a_ref = fitted.a_rad;
    c_ref = fitted.c_rad;
    const InstantConversion exact =
        ConvertInstant(job.machine, t, a_ref, c_ref, /*polish=*/false);
    for (int axis = 0; axis <= kNumFreeFormAxes; ++axis) {
      const double e = axis < kNumFreeFormAxes
                           ? fitted.Get(static_cast<FreeFormAxis>(axis)) -
                                 exact.axes.Get(static_cast<FreeFormAxis>(axis))
                           : fitted.c_rad - exact.axes.c_rad;
      result->fit[axis].max_residual =
          std::max(result->fit[axis].max_residual, std::abs(e));
      sum_sq[axis] += e * e;
    }
    const RigidTransform g = CradleWorkFromCutter(job.machine, t);
    const RigidTransform f = FreeFormWorkFromCutter(fitted);
    result->fitted_max_rotation_difference =
        std::max(result->fitted_max_rotation_difference,
                 (g.rotation - f.rotation).cwiseAbs().maxCoeff());
    result->fitted_max_translation_difference_mm =
        std::max(result->fitted_max_translation_difference_mm,
                 (g.translation_mm - f.translation_mm).cwiseAbs().maxCoeff());
  }
  for (int axis = 0; axis <= kNumFreeFormAxes; ++axis)
    result->fit[axis].rms_residual = std::sqrt(sum_sq[axis] / m);
}

// The flank cut by the fitted motions against the cradle flank on the grid.
void CompareFittedFlank(const BevelPinionJob& job, ConversionResult* result) {
  const BevelFreeFormGenerator generator(job, result->grid, result->motion);
  ModelEvaluation eval;
  generator.Evaluate(result->motion.ToVector(), /*with_jacobian=*/false, &eval);
  double sum = 0.0;
  for (int i = 0; i < eval.deviations_um.size(); ++i) {
    if (eval.status[i] != PointStatus::kOk) continue;
    ++result->flank_points_found;
    result->flank_max_distance_um = std::max(result->flank_max_distance_um,
                                             std::abs(eval.deviations_um(i)));
    sum += eval.deviations_um(i) * eval.deviations_um(i);
  }
  result->flank_rms_distance_um =
      result->flank_points_found > 0
          ? std::sqrt(sum / result->flank_points_found)
          : 0.0;
  result->ok = result->flank_points_found == result->grid.NumPoints();
  if (!result->ok)
    result->message =
        "the flank cut by the fitted motions was not found at every grid point";
}

}  // namespace

ConversionResult ConvertCradleToFreeForm(const ConversionOptions& options,
                                         const BevelPinionJob& job) {
  if (options.choose_degree) {
    ConversionOptions fixed = options;
    fixed.choose_degree = false;
    ConversionResult best;
    for (int degree = 2; degree <= 12; ++degree) {
      fixed.polynomial_degree = degree;
      fixed.num_samples = std::max(options.num_samples, degree + 1);
      best = ConvertCradleToFreeForm(fixed, job);
      if (!best.grid.ok || (best.ok && best.flank_max_distance_um <
                                           options.max_flank_distance_um))
        break;
    }
    return best;
  }
  ConversionResult result;
  std::string error, field;
  if (!options.IsValid(&error)) {
    result.message = "options: " + error;
    return result;
  }
  if (!job.IsValid(&field, &error)) {
    result.message = field + ": " + error;
    return result;
  }
  CradleGenerator cradle(job);
  result.grid = cradle.BuildGrid();
  if (!result.grid.ok) {
    result.message = "cradle flank grid: " + result.grid.message;
    return result;
  }
  const double span = result.grid.roll_max_rad - result.grid.roll_min_rad;
  result.roll_min_rad =
      result.grid.roll_min_rad - options.roll_margin_fraction * span;
  result.roll_max_rad =
      result.grid.roll_max_rad + options.roll_margin_fraction * span;
  const double centre = 0.5 * (result.roll_min_rad + result.roll_max_rad);
  const double half =
      std::max(1e-9, 0.5 * (result.roll_max_rad - result.roll_min_rad));

  const InstantConversion middle =
      ConvertInstant(job.machine, centre, 0.0, 0.0, options.polish_with_ceres);
  SampleExactAxes(options, job, middle, &result);
  FitAxisPolynomials(options, centre, half, &result);
  CheckFitOnDenseInstants(options, job, middle, &result);
  CompareFittedFlank(job, &result);
  return result;
}

}  // namespace gearloop
