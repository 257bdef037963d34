#include "engine/shaving/wheel_radius.h"

#include <algorithm>
#include <cmath>

#include "engine/grinder/flat_wheel_grinder.h"

namespace gearloop {

WheelRadiusCheck ComputeWheelRadiusCheck(const GearData& gear, double h_s_mm) {
  WheelRadiusCheck check;
  const double alpha_t = gear.TransversePressureAngleRad();
  check.contact_angle_rad = std::acos(std::min(
      1.0, std::cos(alpha_t) / std::cos(gear.normal_pressure_angle_rad)));
  const double normal_face_mm =
      gear.face_width_mm * std::cos(gear.helix_angle_rad);
  check.contact_line_fixed_mm = normal_face_mm;
  check.wheel_radius_min_fixed_mm =
      normal_face_mm * normal_face_mm / (8.0 * h_s_mm) + 0.5 * h_s_mm;

  const double r_b = gear.BaseRadiusMm();
  const double tip_roll = std::sqrt(
      std::max(0.0, gear.tip_radius_mm * gear.tip_radius_mm - r_b * r_b));
  const double root_roll = std::sqrt(
      std::max(0.0, gear.root_radius_mm * gear.root_radius_mm - r_b * r_b));
  const double tan_base_helix = std::abs(gear.TanBaseHelixAngle());
  // A spur gear's contact line runs across the whole face: the face limit
  // applies.
  double line = tan_base_helix > 0.0 ? (tip_roll - root_roll) / tan_base_helix
                                     : normal_face_mm;
  line = std::min(line, normal_face_mm);
  check.contact_line_traversing_mm = line;
  check.wheel_radius_min_traversing_mm =
      (line + h_s_mm) * (line + h_s_mm) /
      (2.0 * (line * std::sin(check.contact_angle_rad) + h_s_mm));
  return check;
}

int WheelReach::NumReached() const {
  return static_cast<int>(
      std::count(status.begin(), status.end(), PointStatus::kOk));
}

WheelReach ComputeWheelReach(const GearData& gear,
                             Flank flank,
                             const GridOptions& grid,
                             double wheel_radius_mm,
                             const MachineConstants& machine) {
  GrindingSetup setup;
  setup.gear = gear;
  setup.wheel.radius_mm = wheel_radius_mm;
  setup.machine = machine;
  setup.flank = flank;
  setup.grid = grid;
  const FlatWheelGrinder grinder(setup);
  ModelEvaluation evaluation;
  grinder.Evaluate(
      grinder.nominal().ToVector(), /*with_jacobian=*/false, &evaluation);
  WheelReach reach;
  reach.wheel_radius_mm = wheel_radius_mm;
  reach.rows = grinder.GridRows();
  reach.columns = grinder.GridColumns();
  reach.status = evaluation.status;
  return reach;
}

}  // namespace gearloop
