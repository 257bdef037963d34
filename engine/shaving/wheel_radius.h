// engine/shaving/wheel_radius.h: is the flat wheel large enough for the cutter?
// The closed-form minimum wheel radii of SHAVING.md §5 (Jiang 2015, §2.2) and,
// separately, the exact reach of a chosen radius on the MODEL.md §4 grid, taken
// from the grinding model itself.
//
//   const WheelRadiusCheck check = ComputeWheelRadiusCheck(cutter,
//   /*h_s_mm=*/2.0);
//   // check.wheel_radius_min_fixed_mm = 355.78 for the published cutter
//   const WheelReach reach = ComputeWheelReach(cutter, Flank::kRight,
//   GridOptions(), /*R_w=*/350.0);
//   // reach.status[i] == PointStatus::kNotReached where the rim does not reach
//   grid point i
//
// The flat wheel touches the flank along a straight line. q is the angle
// between the rack's contact line and the lead, cos q = cos(alpha_t) /
// cos(alpha_n); h_s is the infeed allowance of the rim below the form line
// [mm].
//   fixed wheel (C_s = 0):   l_s = B cos(beta),  R_w >= (B cos beta)^2 / (8
//   h_s) + h_s / 2 traversing (C_s != 0):   l_s = (sqrt(r_a^2 - r_b^2) -
//   sqrt(max(r_f^2 - r_b^2, 0))) / |tan beta_b|,
//                            at most B cos(beta);  R_w >= (l_s + h_s)^2 / (2
//                            (l_s sin q + h_s))
// Neither formula contains C_s: the published 320 mm and 230 mm (Jiang 2015,
// §3) do not follow from them. The formulas are sufficient conditions of the
// paper's own making; whether the rim of a given R_w reaches each grid point is
// the question ComputeWheelReach answers exactly (MODEL.md §4: a contact with
// u_w < 0 lies beyond the rim).
#ifndef GEARLOOP_ENGINE_SHAVING_WHEEL_RADIUS_H_
#define GEARLOOP_ENGINE_SHAVING_WHEEL_RADIUS_H_

#include <vector>

#include "engine/core/machine_model.h"
#include "engine/grinder/grinding_setup.h"

namespace gearloop {

struct WheelRadiusCheck {
  double contact_angle_rad = 0.0;      // q
  double contact_line_fixed_mm = 0.0;  // l_s = B cos(beta)
  double contact_line_traversing_mm =
      0.0;  // l_s of the traversing formula, at most B cos(beta)
  double wheel_radius_min_fixed_mm = 0.0;       // fixed-wheel formula
  double wheel_radius_min_traversing_mm = 0.0;  // traversing formula
};

// The formulas of SHAVING.md §5 for `gear` (usually the cutter) and allowance
// h_s > 0 [mm]. `gear` must pass ValidateGear.
WheelRadiusCheck ComputeWheelRadiusCheck(const GearData& gear, double h_s_mm);

// Which grid points a flat wheel of radius R_w reaches with nominal settings
// (no profile modification), by the envelope of engine/grinder's
// FlatWheelGrinder.
struct WheelReach {
  double wheel_radius_mm = 0.0;
  // Per grid point, row-major: kOk (reached), kNotReached (beyond the rim),
  // kNotConverged.
  std::vector<PointStatus> status;
  int rows = 0;
  int columns = 0;
  int NumReached() const;
};

// `gear`, `flank`, `grid` and `machine` with R_w must form a setup that passes
// ValidateSetup (check it first: ValidateSetup names the field at fault).
WheelReach ComputeWheelReach(
    const GearData& gear,
    Flank flank,
    const GridOptions& grid,
    double wheel_radius_mm,
    const MachineConstants& machine = MachineConstants());

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SHAVING_WHEEL_RADIUS_H_
