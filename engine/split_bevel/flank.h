// engine/split_bevel/flank.h: one flank of one slot of a split
// equal-base-circle bevel wheel as a ruled surface in the blank frame Si
// (SPLIT_BEVEL.md §4-§5), its normal with the analytic derivative along the
// face, and the flank point nearest a given point.
//
//   const SplitBevelFlankSurface flank(data, /*slot=*/0,
//   SplitBevelFlank::kConcave); const FlankSection section =
//   flank.Section(/*cone_distance_mm=*/1400.0); const Eigen::Vector3d q =
//   section.Point(/*height_mm=*/-5.0);    // F(R, y) const Eigen::Vector3d n =
//   section.Normal(-5.0);                 // N(R, y), into the slot
//
// The flank is the crown-gear flank laid on the cone at each station: with h =
// y / cos(alpha),
//   F(R, y) = p_f(R) + h g(R),   g = cos(alpha) k - sin(alpha) n_s   (all at
//   psi_f(R)),
// y the height above the pitch cone, n_s the unit vector tangent to the cone,
// normal to the pitch line, into the slot: n_s = -c on the convex flank, +c on
// the concave, c = -sin b e_R + sigma cos b e_psi pointing to the line's centre
// of curvature. g is a unit vector (k and n_s are orthonormal): the ruling of
// the flank and the axis of the end mill that side-mills it. The flank normal
// is N = unit(dF/dR x g), oriented so that N . n_s > 0.
#ifndef GEARLOOP_ENGINE_SPLIT_BEVEL_FLANK_H_
#define GEARLOOP_ENGINE_SPLIT_BEVEL_FLANK_H_

#include <Eigen/Core>

#include "engine/split_bevel/gear.h"

namespace gearloop {

// The flank along its ruling at one cone distance R, with the first and second
// derivatives in R in closed form (dpsi/dR = sigma tan b / (R sin d), db/dR =
// cos b / (R sin b)). Vectors in Si.
struct FlankSection {
  double cone_distance_mm = 0.0;  // R
  double spiral_angle_rad = 0.0;  // beta(R)
  double azimuth_rad = 0.0;       // psi_f(R)
  double cos_pressure_angle = 1.0;
  Eigen::Vector3d pitch_point_mm = Eigen::Vector3d::Zero();  // p_f(R) = R e_R
  Eigen::Vector3d d_pitch_point =
      Eigen::Vector3d::Zero();  // dp_f/dR = e_R + sigma tan b e_psi
  Eigen::Vector3d d2_pitch_point = Eigen::Vector3d::Zero();  // d2p_f/dR2 [1/mm]
  Eigen::Vector3d tangent =
      Eigen::Vector3d::Zero();  // t = cos b e_R + sigma sin b e_psi
  Eigen::Vector3d slot_side = Eigen::Vector3d::Zero();  // n_s
  Eigen::Vector3d ruling = Eigen::Vector3d::Zero();     // g (unit)
  Eigen::Vector3d d_ruling = Eigen::Vector3d::Zero();   // dg/dR [1/mm]
  Eigen::Vector3d d2_ruling = Eigen::Vector3d::Zero();  // d2g/dR2 [1/mm^2]

  // F(R, y) [mm] and dF/dR (dimensionless) at height y [mm] above the pitch
  // cone.
  Eigen::Vector3d Point(double height_mm) const {
    return pitch_point_mm + (height_mm / cos_pressure_angle) * ruling;
  }
  Eigen::Vector3d DPointDR(double height_mm) const {
    return d_pitch_point + (height_mm / cos_pressure_angle) * d_ruling;
  }
  // N(R, y): unit(dF/dR x g), N . n_s > 0.
  Eigen::Vector3d Normal(double height_mm) const;
};

class FlankAnchors;

class SplitBevelFlankSurface {
 public:
  SplitBevelFlankSurface(const SplitBevelGearData& gear,
                         int slot,
                         SplitBevelFlank flank);

  const SplitBevelGearData& gear() const { return gear_; }
  int slot() const { return slot_; }
  SplitBevelFlank flank() const { return flank_; }

  // The section at cone distance R (r_b < R; the face is [Ri, Re] but any R >
  // r_b evaluates).
  FlankSection Section(double cone_distance_mm) const;
  Eigen::Vector3d Point(double cone_distance_mm, double height_mm) const {
    return Section(cone_distance_mm).Point(height_mm);
  }
  Eigen::Vector3d Normal(double cone_distance_mm, double height_mm) const {
    return Section(cone_distance_mm).Normal(height_mm);
  }

  // The flank point F(R, y) nearest `point_mm`, by Newton on the cone distance
  // R with the height eliminated (for a fixed R the nearest ruling point is h =
  // (X - p_f) . g in closed form), from the first guess `guess_mm`.
  //
  // Each Newton iterate takes its section from `anchors` (below): the
  // second-order Taylor expansion in R (p, p', p'', g, g', g'') of an exactly
  // evaluated section at most kTaylorRadiusMm away. The expansion's error is
  // |d3F/dR3| r^3 / 6 for a step r: below 1e-10 mm for the gears of the tests
  // (|d3F/dR3| < 1e-4 / mm^2 with r = 0.02 mm), far below the micrometres the
  // side deviation reports. Converged when a Newton step in R is below
  // `step_tolerance_mm`; that last step is taken to first order (the result is
  // then within about 1e-13 mm of the exact foot point, flank.cc).
  struct NearestPoint {
    bool converged = false;
    int iterations = 0;
    int exact_sections = 0;  // sections `anchors` evaluated for this search
    double cone_distance_mm = 0.0;
    double height_mm = 0.0;
    Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  };
  static constexpr double kTaylorRadiusMm = 0.02;
  NearestPoint Nearest(const Eigen::Vector3d& point_mm,
                       double guess_mm,
                       FlankAnchors* anchors,
                       double step_tolerance_mm = 1e-5,
                       int max_iterations = 30) const;
  // Nearest(points_mm[i], guesses_mm[i], anchors) into out[i] for i <
  // count, bit for bit, with the searches' first Newton steps side by side
  // (independent work the processor overlaps).
  void NearestOfEach(const Eigen::Vector3d* points_mm,
                     const double* guesses_mm,
                     int count,
                     FlankAnchors* anchors,
                     NearestPoint* out,
                     double step_tolerance_mm = 1e-5,
                     int max_iterations = 30) const;

 private:
  // Nearest's Newton from R = r at iteration `first_iteration` on.
  void Continue(const Eigen::Vector3d& point_mm,
                double r,
                int first_iteration,
                FlankAnchors* anchors,
                double step_tolerance_mm,
                int max_iterations,
                NearestPoint* out) const;

  SplitBevelGearData gear_;
  int slot_ = 0;
  SplitBevelFlank flank_ = SplitBevelFlank::kConvex;
  // psi_f(R) = azimuth_offset_ + sigma inv beta(R) / sin d.
  double azimuth_offset_rad_ = 0.0;
  // +1 on the concave flank (n_s = +c), -1 on the convex (n_s = -c).
  double slot_sign_ = 1.0;
  double sin_delta_ = 0.0, cos_delta_ = 1.0, sin_alpha_ = 0.0, cos_alpha_ = 1.0;
};

// The exactly evaluated sections that the nearest-point searches of one station
// expand from: the grid R_c + 2 i kTaylorRadiusMm (|i| <= kGridSlots) around
// the station's own section R_c, each computed when a search first needs it and
// then shared by every height and depth level of that station (the foot points
// of a station's side line lie within some 0.1 mm of R_c), and farther out one
// more grid point's section, moved as needed. Every R is given the section of
// its nearest grid point, within kTaylorRadiusMm, whatever was asked before.
//
//   FlankAnchors anchors(flank);
//   anchors.Centre(flank.Section(r_station));   // a new station
//   flank.Nearest(x, guess, &anchors);          // any number of searches
class FlankAnchors {
 public:
  static constexpr int kGridSlots = 8;
  explicit FlankAnchors(const SplitBevelFlankSurface& flank) : flank_(flank) {}
  // Starts over around `centre` (copied: the grid's middle slot).
  void Centre(const FlankSection& centre);
  // A section within kTaylorRadiusMm of `cone_distance_mm`; adds 1 to
  // `*exact_sections` when it had to be evaluated.
  const FlankSection& Near(double cone_distance_mm, int* exact_sections);

 private:
  static constexpr int kSlots = 2 * kGridSlots + 1;
  const SplitBevelFlankSurface& flank_;
  double centre_mm_ = 0.0;
  FlankSection grid_[kSlots];
  bool filled_[kSlots] = {};
  FlankSection outside_;  // the grid point farther out last asked for
  double outside_slot_ = 0.0;
  bool outside_filled_ = false;
};

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SPLIT_BEVEL_FLANK_H_
