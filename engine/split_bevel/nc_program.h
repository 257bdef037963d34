// engine/split_bevel/nc_program.h: the NC listing of a split-bevel trajectory
// (SPLIT_BEVEL.md §8) as one string. The engine only builds the text; writing
// it anywhere is the caller's business.
//
//   SplitBevelResult result = ComputeSplitTrajectory(request);
//   const std::string nc = FormatSplitBevelNcProgram(request, result);
//
// Layout (every line ends in "\n"):
//   %
//   (GEARLOOP SPLIT-BEVEL 1)
//   (GEAR Z=75 DELTA=70.000000 RE=... B=... BETAM=... HAND=RIGHT
//   ALPHA=20.000000) (DERIVED RB=... MN=... ZC=... RI=... RM=... RE=...
//   BETAI=... BETAM=... BETAE=... HA=... HF=... W=...) (TOOL R0=... S=...)
//   (MACHINE P=... AMIN=... AMAX=... BMIN=... BMAX=...)
//   (SETUP APEXX=... APEXY=... APEXZ=... PSIMID=... SEGMENT=...)
//   G90 G21 G94
//   per pass i = 1, 2, ...:
//     (PASS i SLOT k FLANK CONVEX LEVEL j POINTS n)
//     G00 X... Y... Z... A... B...          approach: the first pivot moved 5
//     mm back along the axis G01 X... Y... Z... A... B... F200.0   n lines, F
//     on the first G00 X... Y... Z... A... B...          retract: the last
//     pivot moved 5 mm back along the axis
//   M30
//   %
// Lengths mm and angles deg in the header with 6 decimals; axis words with 4
// decimals, the value times 10^4 rounded half away from zero (-0.0000 is
// written 0.0000). The KEY=value header lines are comments for the operator; a
// reader needs only the G words.
#ifndef GEARLOOP_ENGINE_SPLIT_BEVEL_NC_PROGRAM_H_
#define GEARLOOP_ENGINE_SPLIT_BEVEL_NC_PROGRAM_H_

#include <string>

#include "engine/split_bevel/trajectory.h"

namespace gearloop {

// Distance the approach and retract lines stand back along the tool axis [mm].
constexpr double kSplitBevelClearanceMm = 5.0;

// `result` must be ok (an empty string otherwise).
std::string FormatSplitBevelNcProgram(const SplitBevelRequest& request,
                                      const SplitBevelResult& result);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SPLIT_BEVEL_NC_PROGRAM_H_
