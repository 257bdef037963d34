// server/codec/tolerance_codec.h: a job's tolerance ("tolerance": {"rms_um",
// "max_um", "iso_class"}) and the PASS/FAIL verdict of a part against it. The
// figures are those every correction result carries: the deviation from the
// target before (initial_rms_um, initial_max_um) and predicted after
// (residual_rms_um, residual_max_um), and the overall ISO 1328-1 class of
// result.iso1328 (target_relative for the measured part, predicted for the
// next one; METROLOGY.md §4).
//
//   std::optional<Tolerance> tolerance;
//   if (!ParseTolerance(body, &tolerance, &error)) return false;
//   const nlohmann::json verdict = PartVerdictJson(*tolerance, figures);
#ifndef GEARLOOP_SERVER_CODEC_TOLERANCE_CODEC_H_
#define GEARLOOP_SERVER_CODEC_TOLERANCE_CODEC_H_

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "server/codec/json_read.h"

namespace gearloop {

struct Tolerance {
  // Largest allowed rms and largest absolute deviation from the target [um].
  std::optional<double> rms_um;
  std::optional<double> max_um;
  // Worst allowed overall ISO 1328-1 flank tolerance class (1 finest .. 11).
  std::optional<int> iso_class;
};

// Reads body.tolerance (absent: *tolerance stays empty). At least one limit;
// rms_um and max_um > 0 and at most 1000; iso_class an integer in 1..11.
// Errors name "tolerance.<field>".
bool ParseTolerance(const nlohmann::json& body,
                    std::optional<Tolerance>* tolerance,
                    ApiError* error);

nlohmann::json ToleranceToJson(const Tolerance& tolerance);

// A part's figures: rms and max deviation from the target [um] and its overall
// ISO 1328-1 class (null when none was computed or it is coarser than 11).
struct PartFigures {
  double rms_um = 0.0;
  double max_um = 0.0;
  nlohmann::json iso_class;
};

// {"verdict": "PASS"|"FAIL", "rms_um", "max_um", "iso_class", "failed": [the
// limits missed: "rms_um", "max_um", "iso_class"]}. A figure that is not
// finite (or a class that is null) misses its limit.
nlohmann::json PartVerdictJson(const Tolerance& tolerance,
                               const PartFigures& figures);

// "rms 2.70 um > 1.00 um, max 6.90 um > 5.00 um": the limits a verdict
// missed, for a message.
std::string MissedLimitsText(const Tolerance& tolerance,
                             const nlohmann::json& verdict);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_TOLERANCE_CODEC_H_
