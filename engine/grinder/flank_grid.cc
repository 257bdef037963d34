#include "engine/grinder/flank_grid.h"

#include <cmath>

#include "engine/core/units.h"

namespace gearloop {
namespace {

// Right flank of `gear` (helix `beta_rad`) at roll length L and axial position
// x.
void RightFlankPoint(const GearData& gear,
                     double beta_rad,
                     double roll_length_mm,
                     double x_mm,
                     FlankGridPoint* point) {
  GearData g = gear;
  g.helix_angle_rad = beta_rad;
  const double r_b = g.BaseRadiusMm();
  const double r_j = g.PitchRadiusMm();
  const double tan_beta = std::tan(beta_rad);
  const double r = std::hypot(roll_length_mm, r_b);
  // inv(acos(r_b / r)) with tan(a) = L / r_b.
  const double roll_involute =
      roll_length_mm / r_b - std::atan2(roll_length_mm, r_b);
  const double theta = kPi / (2.0 * g.teeth) +
                       Involute(g.TransversePressureAngleRad()) -
                       roll_involute - x_mm * tan_beta / r_j;
  const double y = r * std::cos(theta);
  const double z = r * std::sin(theta);
  // Gradient of theta(y, z) + inv(acos(r_b / r)) + x tan(beta) / r_j; it grows
  // out of the material.
  const double d_involute_dr = roll_length_mm / (r * r_b);
  Eigen::Vector3d gradient(tan_beta / r_j,
                           -z / (r * r) + d_involute_dr * y / r,
                           y / (r * r) + d_involute_dr * z / r);
  point->roll_length_mm = roll_length_mm;
  point->radius_mm = r;
  point->x_mm = x_mm;
  point->position_mm = Eigen::Vector3d(x_mm, y, z);
  point->normal = gradient.normalized();
}

}  // namespace

FlankGridPoint InvoluteFlankPoint(const GearData& gear,
                                  Flank flank,
                                  double roll_length_mm,
                                  double x_mm) {
  FlankGridPoint point;
  if (flank == Flank::kRight) {
    RightFlankPoint(gear, gear.helix_angle_rad, roll_length_mm, x_mm, &point);
  } else {
    // MODEL.md §3: the left flank of helix beta is the mirror (z -> -z) of the
    // right flank of -beta.
    RightFlankPoint(gear, -gear.helix_angle_rad, roll_length_mm, x_mm, &point);
    point.position_mm.z() = -point.position_mm.z();
    point.normal.z() = -point.normal.z();
  }
  return point;
}

FlankGrid BuildFlankGrid(const GrindingSetup& setup) {
  const GearData& gear = setup.gear;
  const GridOptions& options = setup.grid;
  FlankGrid grid;
  grid.rows = options.profile_points;
  grid.columns = options.lead_points;
  grid.form_roll_length_mm = gear.FormRollLengthMm();
  grid.tip_roll_length_mm = gear.TipRollLengthMm();
  const double span = grid.tip_roll_length_mm - grid.form_roll_length_mm;
  grid.points.reserve(grid.rows * grid.columns);
  for (int row = 0; row < grid.rows; ++row) {
    const double p =
        options.profile_begin +
        (options.profile_end - options.profile_begin) * row / (grid.rows - 1);
    const double roll_length = grid.form_roll_length_mm + p * span;
    for (int column = 0; column < grid.columns; ++column) {
      const double l =
          options.lead_begin +
          (options.lead_end - options.lead_begin) * column / (grid.columns - 1);
      FlankGridPoint point = InvoluteFlankPoint(
          gear, setup.flank, roll_length, l * gear.face_width_mm);
      point.row = row;
      point.column = column;
      grid.points.push_back(point);
    }
  }
  return grid;
}

}  // namespace gearloop
