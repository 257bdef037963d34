// engine/grinder/flank_grid.h: the theoretical involute helicoid and the
// measurement grid on it (MODEL.md §3 and §4).
//
//   FlankGrid grid = BuildFlankGrid(setup);
//   const FlankGridPoint& p = grid.At(/*row=*/2, /*column=*/4);   //
//   p.position_mm, p.normal
//
// Points are in the work frame S1: x along the gear axis (origin at mid face
// width), a point on the flank is (x, r cos theta, r sin theta). The right
// flank of the tooth centred on polar angle 0 is theta(r, x) = pi/(2z) + inv
// alpha_t - inv(acos(r_b/r)) - x tan(beta)/r_j; the left flank is its mirror
// image (z -> -z) for the gear of helix -beta.
#ifndef GEARLOOP_ENGINE_GRINDER_FLANK_GRID_H_
#define GEARLOOP_ENGINE_GRINDER_FLANK_GRID_H_

#include <Eigen/Core>
#include <vector>

#include "engine/grinder/grinding_setup.h"

namespace gearloop {

struct FlankGridPoint {
  int row = 0;                  // profile index, 0 at the root side
  int column = 0;               // lead index, 0 at x < 0
  double roll_length_mm = 0.0;  // L = sqrt(r^2 - r_b^2)
  double radius_mm = 0.0;       // r
  double x_mm = 0.0;            // axial position
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // in S1
  Eigen::Vector3d normal =
      Eigen::Vector3d::Zero();  // unit, out of the material
};

struct FlankGrid {
  int rows = 0;
  int columns = 0;
  double form_roll_length_mm = 0.0;  // L_form
  double tip_roll_length_mm = 0.0;   // L_a
  std::vector<FlankGridPoint>
      points;  // row-major: index = row * columns + column

  int NumPoints() const { return rows * columns; }
  const FlankGridPoint& At(int row, int column) const {
    return points[row * columns + column];
  }
};

// The point of the theoretical flank at roll length L [mm] and axial position x
// [mm], with its outward unit normal. Works for either flank.
FlankGridPoint InvoluteFlankPoint(const GearData& gear,
                                  Flank flank,
                                  double roll_length_mm,
                                  double x_mm);

// The grid of MODEL.md §4 for a valid setup.
FlankGrid BuildFlankGrid(const GrindingSetup& setup);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_GRINDER_FLANK_GRID_H_
