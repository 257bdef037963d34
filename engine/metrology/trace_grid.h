// engine/metrology/trace_grid.h: measured traces of a gear measuring machine ->
// the 5 x 9 deviation grid of MODEL.md §4, by the Boolean-sum (Gordon)
// interpolation of METROLOGY.md §2.
//
//   std::vector<MeasuredTrace> traces = ...;          // from formats/ (mka,
//   GDE) or a test TraceGridOptions options;                          // flank,
//   tooth, datum face, sign factors TraceGridResult result =
//   InterpolateTraces(options, gear, grid, traces); if (!result.ok) { /*
//   result.message, result.trace_index */ } result.deviations_um; // row-major,
//   NaN = not measured
//
// Traces come in the file's own coordinates: a profile trace lies at an axial
// position z from the datum (reference) face and runs over diameters; a helix
// trace lies at a diameter d and runs over z. They are converted here, with the
// request's gear, to the grid's roll length L = sqrt(d^2/4 - r_b^2) and axial
// position x (z = x + b/2 with the datum face at x = -b/2, z = b/2 - x with the
// datum face at x = +b/2, which also swaps the file's left and right).
//
// Deviations in um along the flank normal, positive = material above the design
// flank. No I/O; bad input is a result (ok = false with a message), never a
// crash.
#ifndef GEARLOOP_ENGINE_METROLOGY_TRACE_GRID_H_
#define GEARLOOP_ENGINE_METROLOGY_TRACE_GRID_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/grinder/grinding_setup.h"

namespace gearloop {

// A profile trace runs along the involute (a grid column), a helix trace along
// the face (a row).
enum class TraceKind { kProfile, kHelix };

// Where the datum (reference) face lies in the grid's axial coordinate x
// (METROLOGY.md §1).
enum class DatumFace { kXNegative, kXPositive };

// How the abscissa of a trace's values is given.
enum class TraceSpacing {
  // Values at equal steps from begin_mm to end_mm: for a profile in ROLL LENGTH
  // between the
  // diameters begin_mm and end_mm (the P-series convention, METROLOGY.md §2),
  // for a helix in z.
  kEqualSteps,
  // Values at the listed abscissas: diameters for a profile, z for a helix (a
  // GDE net).
  kListed,
};

struct MeasuredTrace {
  TraceKind kind = TraceKind::kProfile;
  int tooth = 1;
  // The flank as the FILE names it (seen from the datum face, tip up).
  Flank flank = Flank::kRight;
  // Profile: axial position z from the datum face [mm]. Helix: diameter d [mm].
  double position_mm = 0.0;
  TraceSpacing spacing = TraceSpacing::kEqualSteps;
  // kEqualSteps: first and last abscissa (profile: diameters [mm]; helix: z
  // [mm]).
  double begin_mm = 0.0;
  double end_mm = 0.0;
  // kListed: one abscissa per value (profile: diameters [mm]; helix: z [mm]).
  std::vector<double> abscissa_mm;
  // Deviations [um]; NaN = undefined point (dropped before use).
  std::vector<double> values_um;
};

// Sign factor applied to the file's values per (kind, flank as the file names
// it). Default +1: the file stores material-positive deviations. One
// machine/software generation is reported to store raw curves whose
// profile-left and helix traces need -1 to match its printout; that is an
// import option, never a guess (METROLOGY.md §2).
struct TraceSignFactors {
  double profile_right = 1.0;
  double profile_left = 1.0;
  double helix_right = 1.0;
  double helix_left = 1.0;
};

struct TraceGridOptions {
  // The grid's flank ("right"/"left" of the request, MODEL.md §1).
  Flank flank = Flank::kRight;
  // The tooth to use; 0 = every tooth of the flank, the grid being their
  // pointwise mean.
  int tooth = 0;
  DatumFace datum_face = DatumFace::kXNegative;
  TraceSignFactors sign;
  // Linear extrapolation across traces reaches at most this fraction beyond the
  // outermost trace: of b across profile traces, of (L_a - L_form) across helix
  // traces (METROLOGY.md §2: 0.1).
  double max_extrapolation_fraction = 0.1;
  // A trace needs at least this many finite values (the local quadratic needs
  // 3).
  int min_trace_points = 3;

  bool IsValid(std::string* error) const;
};

// One grid point that could not be formed.
struct GridPointIndex {
  int row = 0;
  int column = 0;
};

struct TraceGridResult {
  bool ok = false;
  // Why not, in words a metrologist reads; with trace_index >= 0 when about one
  // input trace (index into the `traces` argument), so that a file reader can
  // name its line or element.
  std::string message;
  int trace_index = -1;

  int rows = 0;
  int columns = 0;
  // Row-major grid [um], row 0 at the root, column 0 at x < 0; NaN where it
  // cannot be formed.
  Eigen::VectorXd deviations_um;
  std::vector<GridPointIndex> not_measured;
  // Teeth averaged, and per grid point the spread (max - min) over them [um] (0
  // for one tooth).
  std::vector<int> teeth;
  Eigen::VectorXd tooth_spread_um;
  // Largest |P_m(L_k) - H_k(x_m)| over the crossings of profile and helix
  // traces [um]; NaN when the traces do not cross. More than ~2 um usually
  // means a wrong sign, tooth or flank.
  double max_crossing_mismatch_um = 0.0;
  // Numbers of profile and helix traces used (per tooth).
  int profile_traces = 0;
  int helix_traces = 0;
  std::vector<std::string> warnings;
};

// Roll lengths of the grid rows and axial positions x of the grid columns
// (MODEL.md §4).
std::vector<double> GridRollLengthsMm(const GearData& gear,
                                      const GridOptions& grid);
std::vector<double> GridAxialPositionsMm(const GearData& gear,
                                         const GridOptions& grid);

// Roll length of diameter d: sqrt(d^2/4 - r_b^2) [mm]; NaN inside the base
// circle.
double RollLengthOfDiameterMm(const GearData& gear, double diameter_mm);
// Diameter of roll length L: 2 sqrt(L^2 + r_b^2) [mm].
double DiameterOfRollLengthMm(const GearData& gear, double roll_length_mm);

// Traces -> grid. Uses the traces of options.flank (mapped through the datum
// face) and options.tooth; fails when there is none, when a trace is malformed
// (length mismatch, fewer than min_trace_points finite values, a diameter
// inside the base circle, non-finite numbers), or when a grid row or column
// keeps fewer than 3 points (the ISO figures need 3).
TraceGridResult InterpolateTraces(const TraceGridOptions& options,
                                  const GearData& gear,
                                  const GridOptions& grid,
                                  const std::vector<MeasuredTrace>& traces);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_METROLOGY_TRACE_GRID_H_
