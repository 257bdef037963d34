// engine/split_bevel/trajectory.h: 5-axis flank-milling trajectories for split
// equal-base-circle bevel wheels (issue 14, SPLIT_BEVEL.md). Per flank of a
// slot and per depth level: stations along the tooth line, the flank point, the
// tool centre and axis of the side-milling end mill, the machine's X Y Z A B by
// inverse kinematics, and the side deviation the twisted flank leaves.
//
//   SplitBevelRequest request;                     // gear, tool, cut, machine,
//   setup std::string field, message; if (!request.IsValid(&field, &message))
//   ...    // the 422 cases of §8, field as the API names it const
//   SplitBevelResult result = ComputeSplitTrajectory(request); if (!result.ok)
//   ...                            // result.field, result.message (also 422)
//   for (const SplitBevelPass& pass : result.passes) pass.points[i].axes.b_rad
//   ...
//
// Units: mm and rad throughout (the API's degrees are converted by its codec).
// Vectors are in the blank frame Si (engine/split_bevel/gear.h), X Y Z in
// machine coordinates (engine/split_bevel/head_kinematics.h). The NC program
// text is built by engine/split_bevel/nc_program.h.
#ifndef GEARLOOP_ENGINE_SPLIT_BEVEL_TRAJECTORY_H_
#define GEARLOOP_ENGINE_SPLIT_BEVEL_TRAJECTORY_H_

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "engine/split_bevel/gear.h"
#include "engine/split_bevel/head_kinematics.h"

namespace gearloop {

// The cylindrical flat end mill.
struct SplitBevelTool {
  // Radius r0 [mm] (> 0).
  double radius_mm = 0.0;
  // Material left on the flank, along its normal [mm] (> -r0); default 0.
  double stock_mm = 0.0;
};

// Which end of the face each pass starts from: "toe" (Ri -> Re, default) or
// "heel" (Re -> Ri).
enum class SplitBevelStart { kToe, kHeel };

struct SplitBevelCut {
  // Slot k, |k| < z; its centre line passes azimuth 2 pi k / z at Rm.
  int slot_index = 0;
  // Flanks to cut, in this order (a non-empty subset, each at most once).
  std::vector<SplitBevelFlank> flanks = {SplitBevelFlank::kConvex,
                                         SplitBevelFlank::kConcave};
  // Depth levels L, 1..100: level j puts the tool tip at y_j = h_a - (j +
  // 1)(h_a + h_f) / L.
  int depth_levels = 1;
  // Stations per pass n (2..20001), or the chord tolerance [mm] (>= 1e-4) from
  // which n is found per pass; at most one of the two. Neither: n = 41.
  std::optional<int> steps;
  std::optional<double> chord_tolerance_mm;
  SplitBevelStart from = SplitBevelStart::kToe;
  // Feed [mm/min] (> 0), written on the first G01 of each pass.
  double feed_mm_per_min = 200.0;
};

struct SplitBevelMachine {
  // Pivot to tool-centre distance P [mm] (>= 0); 0 = TCP mode.
  double pivot_length_mm = 0.0;
  // Axis limits [rad] (min < max); defaults [-100, 100] deg and [-360, 360]
  // deg.
  HeadLimits limits;
};

struct SplitBevelSetup {
  // Machine coordinates of the pitch-cone apex [mm].
  Eigen::Vector3d apex_mm = Eigen::Vector3d::Zero();
  // psi_mid [rad]: the blank azimuth brought to the machine's +X half-plane;
  // default the slot azimuth 2 pi k / z.
  std::optional<double> segment_mid_rad;
  // Angular extent of the segment centred on psi_mid [rad] (0 < e <= 2 pi);
  // when given, every pitch line of the requested flanks must lie inside it.
  std::optional<double> segment_angle_rad;
};

// Default number of stations per pass when neither steps nor chord_tolerance_mm
// is given.
constexpr int kSplitBevelDefaultSteps = 41;
constexpr int kSplitBevelMaxSteps = 20001;
constexpr int kSplitBevelMaxLevels = 100;
constexpr double kSplitBevelMinChordToleranceMm = 1e-4;
// Heights per station at which the side deviation is evaluated, y_j to h_a
// (§5).
constexpr int kSplitBevelDeviationHeights = 9;

struct SplitBevelRequest {
  SplitBevelGear gear;
  SplitBevelTool tool;
  SplitBevelCut cut;
  SplitBevelMachine machine;
  SplitBevelSetup setup;
  // Build the NC listing into SplitBevelResult::nc_program (the API's
  // output.nc).
  bool nc_program = false;

  // False with the offending field as the API names it ("tool.radius_mm",
  // "cut.chord_tolerance_mm") and a message, for every 422 of SPLIT_BEVEL.md §8
  // that the request alone decides: a value out of its range, both or neither
  // of an either/or pair, r_b >= Ri, the root slot width, the tool too wide for
  // the slot or for the concave flank's curvature, the slot outside the
  // segment. The two that only the computation finds (a point out of the axis
  // limits; more than 20001 stations for the chord tolerance) come back in
  // SplitBevelResult. Checked in that order, first failure wins.
  bool IsValid(std::string* field, std::string* message) const;
};

struct SplitBevelPoint {
  double arc_mm = 0.0;  // S_j, pitch-line arc length from the inner end
  double cone_distance_mm = 0.0;   // R_j
  double spiral_angle_rad = 0.0;   // beta(R_j)
  Eigen::Vector3d pitch_point_mm;  // p_f(R_j), Si
  Eigen::Vector3d flank_point_mm;  // Q = F(R_j, y_j), Si
  Eigen::Vector3d flank_normal;    // N(R_j, y_j), Si, into the slot
  Eigen::Vector3d tool_centre_mm;  // O = Q + (r0 + s) N, Si
  Eigen::Vector3d tool_axis;       // a = g(R_j), Si, tip -> spindle
  HeadAxes axes;                   // X Y Z [mm] (the pivot), A B [rad]
};

struct SplitBevelSideDeviation {
  // gap = (X - F') . N' - r0 [mm] over all stations and 9 heights from y_j to
  // h_a (positive = material left), X on the tool's side line, F' and N' the
  // nearest flank point and its normal.
  double min_mm = 0.0;
  double max_mm = 0.0;
};

struct SplitBevelPass {
  int slot = 0;
  SplitBevelFlank flank = SplitBevelFlank::kConvex;
  int level = 0;
  double tip_height_mm = 0.0;  // y_j
  SplitBevelSideDeviation side_deviation_mm;
  std::vector<SplitBevelPoint> points;
};

struct SplitBevelResult {
  // False when the request is invalid (IsValid's field and message) or a
  // computation limit is hit: "machine.a_limits_deg" (no head position within
  // the axis limits) or "cut.chord_tolerance_mm" (more than 20001 stations
  // needed). Nothing else is filled then except `derived` if known.
  bool ok = false;
  std::string field;
  std::string message;
  SplitBevelGearData derived;
  // Homogeneous blank -> machine transform
  // (engine/split_bevel/head_kinematics.h).
  Eigen::Matrix4d blank_to_machine = Eigen::Matrix4d::Identity();
  double segment_mid_rad = 0.0;
  // Passes: for each flank in the order requested, levels 0..L-1.
  std::vector<SplitBevelPass> passes;
  // The NC listing (nc_program.h) when the request asked for it.
  std::string nc_program;
};

SplitBevelResult ComputeSplitTrajectory(const SplitBevelRequest& request);

// The tool centre O(R) at height y of a pass, for any R (stations,
// mid-stations): F(R, y) + (r0 + s) N(R, y). Exposed for the chord-tolerance
// check and its tests.
class SplitBevelFlankSurface;
Eigen::Vector3d SplitBevelToolCentre(const SplitBevelFlankSurface& flank,
                                     const SplitBevelTool& tool,
                                     double cone_distance_mm,
                                     double height_mm);

// Largest distance of the exact tool-centre path at the mid-stations from the
// chords between neighbouring stations, for n stations uniform in arc length
// over the face (§5, §7 g) [mm].
double SplitBevelChordDeviation(const SplitBevelFlankSurface& flank,
                                const SplitBevelTool& tool,
                                double height_mm,
                                int stations);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SPLIT_BEVEL_TRAJECTORY_H_
