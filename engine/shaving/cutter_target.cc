#include "engine/shaving/cutter_target.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "engine/core/damped_newton.h"
#include "engine/core/units.h"
#include "engine/grinder/flank_grid.h"
#include "engine/shaving/crossed_axis_mesh.h"

namespace gearloop {
namespace {

constexpr double kMmToUm = 1000.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The §7 checks of one gear that ValidateGear words differently or not at all,
// then ValidateGear with its "gear." prefix replaced by `name`.
bool ValidateShavingGear(const GearData& gear,
                         const std::string& name,
                         ValidationIssue* issue) {
  if (gear.teeth <= 0)
    return FailValidation(
        issue, name + ".teeth", "the number of teeth must be positive");
  if (!(gear.normal_module_mm > 0.0))
    return FailValidation(issue,
                          name + ".normal_module_mm",
                          "the normal module must be positive");
  if (!(gear.face_width_mm > 0.0))
    return FailValidation(
        issue, name + ".face_width_mm", "the face width must be positive");
  if (!(gear.tip_radius_mm > 0.0))
    return FailValidation(
        issue, name + ".tip_radius_mm", "the tip radius must be positive");
  if (!(gear.root_radius_mm > 0.0))
    return FailValidation(
        issue, name + ".root_radius_mm", "the root radius must be positive");
  if (!std::isfinite(gear.helix_angle_rad) ||
      std::abs(gear.helix_angle_rad) * kDegPerRad >= 45.0 - 1e-9) {
    return FailValidation(issue,
                          name + ".helix_angle_rad",
                          "the helix angle must be below 45 degrees, got " +
                              FormatValidationNumber(
                                  std::abs(gear.helix_angle_rad) * kDegPerRad) +
                              " degrees");
  }
  if (gear.tip_radius_mm <= gear.root_radius_mm) {
    return FailValidation(
        issue,
        name + ".tip_radius_mm",
        "the tip radius " + FormatValidationNumber(gear.tip_radius_mm) +
            " mm must exceed the root radius " +
            FormatValidationNumber(gear.root_radius_mm) + " mm");
  }
  ValidationIssue inner;
  if (!ValidateGear(gear, &inner)) {
    const std::string prefix = "gear.";
    std::string field = inner.field;
    if (field.compare(0, prefix.size(), prefix) == 0)
      field = name + "." + field.substr(prefix.size());
    return FailValidation(issue, field, inner.message);
  }
  return true;
}

engine_internal::DampedNewtonOptions NewtonOptions(
    const ShavingOptions& options) {
  return engine_internal::DampedNewtonOptions{
      options.max_iterations, options.step_tolerance, options.max_step};
}

}  // namespace

ConjugatePointSolution RefineConjugatePoint(const ShavingOptions& options,
                                            const CrossedAxisMesh& mesh,
                                            const FlankGridPoint& point,
                                            const Eigen::Vector4d& start) {
  ConjugatePointSolution s;
  s.unknowns = start;
  const engine_internal::DampedNewtonSummary newton =
      engine_internal::DampedNewton<4>(
          NewtonOptions(options),
          Eigen::Vector4d::Ones(),
          [&](const Eigen::Vector4d& u,
              Eigen::Vector4d* g,
              Eigen::Matrix4d* jacobian) {
            ConjugatePointSystem(
                mesh, point.position_mm, point.normal, u, g, jacobian);
          },
          &s.unknowns);
  s.iterations = newton.num_iterations;
  if (newton.converged && s.unknowns.allFinite()) {
    Eigen::Vector4d g;
    ConjugatePointSystem(
        mesh, point.position_mm, point.normal, s.unknowns, &g, nullptr);
    s.converged = g.cwiseAbs().maxCoeff() < options.residual_tolerance;
  }
  return s;
}

bool FindGlobalStart(const ShavingOptions& options,
                     const CrossedAxisMesh& mesh,
                     const FlankGridPoint& point,
                     Eigen::Vector4d* start) {
  const double r_b = mesh.work_flank().gear().BaseRadiusMm();
  const int n = options.num_start_angles;
  const double range = options.start_angle_range_rad;
  bool have_previous = false;
  bool found = false;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  double best_lambda = std::numeric_limits<double>::infinity();
  for (int j = 0; j < n; ++j) {
    const double theta1 = -range + 2.0 * range * j / (n - 1);
    Eigen::Vector3d u;
    if (have_previous) {
      u = previous;
    } else {
      const Eigen::Vector3d p1 = mesh.CutterToWork(point.position_mm, theta1);
      const double r2 = p1.y() * p1.y() + p1.z() * p1.z();
      u = Eigen::Vector3d(
          std::sqrt(std::max(0.0, r2 - r_b * r_b)), p1.x(), 0.0);
    }
    engine_internal::DampedNewtonOptions start_options = NewtonOptions(options);
    start_options.max_iterations = options.max_start_iterations;
    const engine_internal::DampedNewtonSummary newton =
        engine_internal::DampedNewton<3>(
            start_options,
            Eigen::Vector3d::Ones(),
            [&](const Eigen::Vector3d& v,
                Eigen::Vector3d* g,
                Eigen::Matrix3d* jacobian) {
              Eigen::Vector3d p_s;
              Eigen::Matrix<double, 3, 2> d_p_s;
              mesh.CutterPoint(v(0), v(1), theta1, &p_s, &d_p_s);
              *g = p_s - point.position_mm - v(2) * point.normal;
              jacobian->leftCols<2>() = d_p_s;
              jacobian->col(2) = -point.normal;
            },
            &u);
    // A sample counts only where the normal line crosses the work gear's real
    // (active) flank: only material of the work gear can cut the cutter. Far
    // from the mesh the same system has other roots on the analytic
    // continuation of the helicoid (far beyond the face, or behind the cusp at
    // the base circle) with lambda of hundreds of mm either way; they are no
    // part of the work gear, and a warm start from one would follow that
    // branch, so the next sample starts again from Q carried into S1.
    bool ok = newton.converged && u.allFinite() &&
              mesh.work_flank().OnActiveFlank(u(0), u(1));
    if (ok) {
      Eigen::Vector3d p_s;
      Eigen::Matrix<double, 3, 2> d_p_s;
      mesh.CutterPoint(u(0), u(1), theta1, &p_s, &d_p_s);
      ok = (p_s - point.position_mm - u(2) * point.normal)
               .cwiseAbs()
               .maxCoeff() < options.residual_tolerance;
    }
    have_previous = ok;
    if (!ok) continue;
    previous = u;
    if (u(2) < best_lambda) {
      best_lambda = u(2);
      *start = Eigen::Vector4d(u(0), u(1), theta1, u(2));
      found = true;
    }
  }
  return found;
}

bool ShavingOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (num_start_angles < 2 || num_start_angles > 10000)
    return fail("num_start_angles must be in [2, 10000]");
  if (!(start_angle_range_rad > 0.0 && start_angle_range_rad <= kPi)) {
    return fail("start_angle_range_rad must be in (0, pi]");
  }
  if (max_iterations < 1) return fail("max_iterations must be positive");
  if (max_start_iterations < 1) {
    return fail("max_start_iterations must be positive");
  }
  if (!(step_tolerance > 0.0)) return fail("step_tolerance must be positive");
  if (!(residual_tolerance > 0.0))
    return fail("residual_tolerance must be positive");
  if (!(max_step > 0.0)) return fail("max_step must be positive");
  return true;
}

GearData WithStandardRadii(const GearData& gear) {
  GearData g = gear;
  const double r_j = g.PitchRadiusMm();
  if (g.tip_radius_mm == 0.0) g.tip_radius_mm = r_j + g.normal_module_mm;
  if (g.root_radius_mm == 0.0)
    g.root_radius_mm = r_j - 1.25 * g.normal_module_mm;
  return g;
}

double CrossedAxesAngleRad(const GearData& work_gear, const GearData& cutter) {
  return work_gear.helix_angle_rad + cutter.helix_angle_rad;
}

bool ShavingInput::IsValid(ValidationIssue* issue) const {
  if (!ValidateShavingGear(work_gear, "work_gear", issue)) return false;
  if (!ValidateShavingGear(cutter, "cutter", issue)) return false;
  if (!std::isfinite(wheel_check.h_s_mm) || wheel_check.h_s_mm <= 0.0) {
    return FailValidation(issue,
                          "wheel_check.h_s_mm",
                          "the infeed allowance h_s must be positive, got " +
                              FormatValidationNumber(wheel_check.h_s_mm));
  }
  if (!std::isfinite(wheel_check.traverse_mm_per_rad)) {
    return FailValidation(issue,
                          "wheel_check.traverse_mm_per_rad",
                          "the wheel traverse must be finite");
  }
  const double pitch_work = work_gear.normal_module_mm *
                            std::cos(work_gear.normal_pressure_angle_rad);
  const double pitch_cutter =
      cutter.normal_module_mm * std::cos(cutter.normal_pressure_angle_rad);
  if (std::abs(pitch_work - pitch_cutter) > 1e-9) {
    return FailValidation(
        issue,
        "cutter.normal_module_mm",
        "not conjugate: the normal base pitches differ (m_n cos alpha_n " +
            FormatValidationNumber(pitch_work) + " mm on the work gear, " +
            FormatValidationNumber(pitch_cutter) + " mm on the cutter)");
  }
  const double gamma = CrossedAxesAngleRad(work_gear, cutter);
  if (std::abs(gamma) * kDegPerRad < 0.1) {
    return FailValidation(
        issue,
        "cutter.helix_angle_rad",
        "crossed-axes angle is zero: not plunge shaving (gamma = beta1 "
        "+ beta_s = " +
            FormatValidationNumber(gamma * kDegPerRad) + " degrees)");
  }
  if (centre_distance_mm.has_value()) {
    const double a = *centre_distance_mm;
    const double outer = work_gear.tip_radius_mm + cutter.tip_radius_mm;
    const double inner = work_gear.BaseRadiusMm() + cutter.BaseRadiusMm();
    if (!std::isfinite(a) || a >= outer || a <= inner) {
      return FailValidation(
          issue,
          "centre_distance_mm",
          "no contact: the centre distance " + FormatValidationNumber(a) +
              " mm must lie between the sum of the base radii " +
              FormatValidationNumber(inner) +
              " mm and the sum of the tip radii " +
              FormatValidationNumber(outer) + " mm");
    }
  }
  ValidationIssue inner;
  if (!ValidateDiagonalModification(diagonal_modification, &inner)) {
    return FailValidation(
        issue, "diagonal_modification." + inner.field, inner.message);
  }
  if (!ValidateGrid(grid, issue)) return false;
  // The grid must lie on the cutter's involute (MODEL.md §4: L_form < L_a).
  if (cutter.FormRollLengthMm() >= cutter.TipRollLengthMm()) {
    return FailValidation(
        issue,
        "cutter.root_radius_mm",
        "the rim at root radius " +
            FormatValidationNumber(cutter.root_radius_mm) +
            " mm leaves no involute below the tip of the cutter");
  }
  return true;
}

const char* ShavingPointStatusName(ShavingPointStatus status) {
  switch (status) {
    case ShavingPointStatus::kOk:
      return "ok";
    case ShavingPointStatus::kOutsideWorkFlank:
      return "outside_work_flank";
    case ShavingPointStatus::kNotConverged:
      return "not_converged";
  }
  return "unknown";
}

std::string ShavingSummary::BriefReport() const {
  std::ostringstream out;
  switch (termination) {
    case Termination::kSolved:
      out << "solved: " << num_solved << " of " << num_points
          << " grid points generated, " << num_outside_work_flank
          << " outside the work flank, " << num_not_converged
          << " not converged";
      break;
    case Termination::kInvalidInput:
      out << "invalid input (" << field << "): " << message;
      break;
    case Termination::kNoPointGenerated:
      out << "no grid point generated: " << message;
      break;
  }
  return out.str();
}

namespace {

// Checks the options and the input; on failure sets the summary to
// kInvalidInput with the issue.
bool CheckShavingInputs(const ShavingOptions& options,
                        const ShavingInput& input,
                        ShavingResult* result) {
  std::string error;
  ValidationIssue issue;
  if (!options.IsValid(&error)) {
    result->summary.termination = ShavingSummary::Termination::kInvalidInput;
    result->summary.message = error;
    result->summary.field = "options";
    return false;
  }
  if (!input.IsValid(&issue)) {
    result->summary.termination = ShavingSummary::Termination::kInvalidInput;
    result->summary.message = issue.message;
    result->summary.field = issue.field;
    return false;
  }
  return true;
}

// The crossed axes angle, the centre distance and the wheel radius check.
void SetMeshAndWheel(const ShavingInput& input, ShavingResult* result) {
  const GearData& work = input.work_gear;
  const GearData& cutter = input.cutter;
  result->crossed_axes_angle_rad = CrossedAxesAngleRad(work, cutter);
  result->centre_distance_mm = input.centre_distance_mm.value_or(
      work.PitchRadiusMm() + cutter.PitchRadiusMm());
  result->wheel = ComputeWheelRadiusCheck(cutter, input.wheel_check.h_s_mm);
  result->contact_line_length_mm =
      input.wheel_check.traverse_mm_per_rad == 0.0
          ? result->wheel.contact_line_fixed_mm
          : result->wheel.contact_line_traversing_mm;
}

// Solves grid point i on the unmodified and then the modified work gear and
// records its contact, status and deviations in *result.
void SolveGridPoint(const ShavingOptions& options,
                    const DiagonallyModifiedFlank& base_flank,
                    const DiagonallyModifiedFlank& modified_flank,
                    const CrossedAxisMesh& base_mesh,
                    const CrossedAxisMesh& modified_mesh,
                    const FlankGridPoint& q,
                    int i,
                    ShavingResult* result) {
  Eigen::Vector4d start;
  if (!FindGlobalStart(options, base_mesh, q, &start)) return;
  const ConjugatePointSolution base =
      RefineConjugatePoint(options, base_mesh, q, start);
  if (!base.converged) return;
  const ConjugatePointSolution modified =
      RefineConjugatePoint(options, modified_mesh, q, base.unknowns);
  if (!modified.converged) return;
  const Eigen::Vector4d& u = modified.unknowns;
  ShavingContact& contact = result->contacts[i];
  contact.roll_length_mm = u(0);
  contact.x_mm = u(1);
  contact.work_angle_rad = u(2);
  contact.work_relief_um = modified_flank.Relief(u(0), u(1)).value_um;
  contact.iterations = modified.iterations;
  if (!modified_flank.OnActiveFlank(u(0), u(1)) ||
      !base_flank.OnActiveFlank(base.unknowns(0), base.unknowns(1))) {
    result->status[i] = ShavingPointStatus::kOutsideWorkFlank;
    return;
  }
  result->status[i] = ShavingPointStatus::kOk;
  result->delta_s_um(i) = u(3) * kMmToUm;
  result->base_um(i) = base.unknowns(3) * kMmToUm;
}

// Counts and lists the points by status into the summary; returns the largest
// delta_s of the solved points (-inf when none).
double SummarizePoints(int n, int columns, ShavingResult* result) {
  ShavingSummary& summary = result->summary;
  summary.num_points = n;
  double max_delta = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    const GridIndex index{i / columns, i % columns};
    switch (result->status[i]) {
      case ShavingPointStatus::kOk:
        ++summary.num_solved;
        max_delta = std::max(max_delta, result->delta_s_um(i));
        break;
      case ShavingPointStatus::kOutsideWorkFlank:
        ++summary.num_outside_work_flank;
        result->outside_work_flank.push_back(index);
        break;
      case ShavingPointStatus::kNotConverged:
        ++summary.num_not_converged;
        result->not_converged.push_back(index);
        break;
    }
  }
  return max_delta;
}

}  // namespace

ShavingResult ComputeShavingCutterTarget(const ShavingOptions& options,
                                         const ShavingInput& input) {
  ShavingResult result;
  if (!CheckShavingInputs(options, input, &result)) return result;
  const GearData& work = input.work_gear;
  const GearData& cutter = input.cutter;
  SetMeshAndWheel(input, &result);

  GrindingSetup cutter_setup;
  cutter_setup.gear = cutter;
  cutter_setup.flank = Flank::kRight;
  cutter_setup.grid = input.grid;
  const FlankGrid grid = BuildFlankGrid(cutter_setup);
  result.rows = grid.rows;
  result.columns = grid.columns;
  const int n = grid.NumPoints();

  const DiagonallyModifiedFlank base_flank(work,
                                           DiagonalModification{0.0, 0.0});
  const DiagonallyModifiedFlank modified_flank(work,
                                               input.diagonal_modification);
  const CrossedAxisMesh base_mesh(base_flank,
                                  cutter.teeth,
                                  result.crossed_axes_angle_rad,
                                  result.centre_distance_mm);
  const CrossedAxisMesh modified_mesh(modified_flank,
                                      cutter.teeth,
                                      result.crossed_axes_angle_rad,
                                      result.centre_distance_mm);

  result.delta_s_um = Eigen::VectorXd::Constant(n, kNaN);
  result.base_um = Eigen::VectorXd::Constant(n, kNaN);
  result.stock_target_um = Eigen::VectorXd::Constant(n, kNaN);
  result.status.assign(n, ShavingPointStatus::kNotConverged);
  result.contacts.assign(n, ShavingContact());
  for (int i = 0; i < n; ++i) {
    SolveGridPoint(options,
                   base_flank,
                   modified_flank,
                   base_mesh,
                   modified_mesh,
                   grid.points[i],
                   i,
                   &result);
  }

  ShavingSummary& summary = result.summary;
  const double max_delta = SummarizePoints(n, grid.columns, &result);
  if (summary.num_solved == 0) {
    summary.termination = ShavingSummary::Termination::kNoPointGenerated;
    summary.field = "grid";
    summary.message =
        "no grid point of the cutter is generated by the work gear (" +
        std::to_string(summary.num_outside_work_flank) +
        " outside its active flank, " +
        std::to_string(summary.num_not_converged) + " not converged)";
    return result;
  }
  for (int i = 0; i < n; ++i) {
    if (result.status[i] == ShavingPointStatus::kOk)
      result.stock_target_um(i) = result.delta_s_um(i) - max_delta;
  }
  summary.termination = ShavingSummary::Termination::kSolved;
  return result;
}

}  // namespace gearloop
