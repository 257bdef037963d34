// server/bevel_codec.h: the spiral-bevel pinion endpoints (issue 6, docs/bevel-machines.md):
// the cradle summary and the free-form axis motions read from JSON, the engine run, the answer
// written back. Handlers stay thin:
//
//   nlohmann::json body, answer;
//   ApiError error;
//   if (!ParseJsonBody(req.body, &body, &error) || !BevelConversion(body, &answer, &error)) {
//     return RespondError(res, error);
//   }
//   RespondJson(res, 200, answer);
//
// Request pieces (API names; angles in DEGREES, the engine takes radians):
//   job     {"side": "convex" | "concave", "published": true}  the pinion of Tang 2011 Table 1,
//           or the whole summary: "cutter" {point_radius_mm, blade_angle_deg, edge_radius_mm},
//           "machine" {blank_offset_mm, horizontal_offset_mm, sliding_base_mm,
//           machine_root_angle_deg, eccentric_angle_deg, eccentric_mm, cradle_angle_deg,
//           tilt_rotation_deg, tilt_axis_inclination_deg, tilt_axis_mounting_deg, ratio_of_roll},
//           "blank" {outer_cone_distance_mm, inner_cone_distance_mm, face_angle_deg,
//           root_angle_deg}, "grid" {profile_points, lengthwise_points, profile_min_fraction,
//           profile_max_fraction, lengthwise_min_fraction, lengthwise_max_fraction}. With
//           "published": true every given field overrides the published value.
//   motion  {"A_rad": [...], "B_rad": [...], "X_mm": [...], "Y_mm": [...], "Z_mm": [...],
//           "C_rad": [...] (optional)}: free-form axis polynomials, coefficient k multiplies
//           t^k (t the cradle roll [rad]); A, B, X, Y, Z of one length (degree + 1, 1..13).
//           Absent: the motions converted from the cradle summary (default options).
#ifndef GEARLOOP_SERVER_BEVEL_CODEC_H_
#define GEARLOOP_SERVER_BEVEL_CODEC_H_

#include <string>

#include <nlohmann/json.hpp>

#include "engine/bevel/cradle_machine.h"
#include "engine/bevel/freeform_machine.h"
#include "server/correction_codec.h"
#include "server/codec/grinder_codec.h"
#include "server/simulation_handlers.h"

namespace gearloop {

// The machine kind of a bevel correction request ("machine": {"kind": ...}).
constexpr const char* kFreeFormBevelGeneratorKind = "free-form-bevel-generator";

// Reads body["job"] and validates it (BevelPinionJob::IsValid, fields mapped to API names).
bool ParseBevelJob(const nlohmann::json& body, BevelPinionJob* job, ApiError* error);
// The job in the API's shape (degrees).
nlohmann::json BevelJobToJson(const BevelPinionJob& job);
// Reads a motion object at `path`.
bool ParseFreeFormMotion(const nlohmann::json& value, const std::string& path, FreeFormMotion* motion,
                         ApiError* error);
nlohmann::json FreeFormMotionToJson(const FreeFormMotion& motion);

// POST /api/v1/bevel/conversions: job, options {polynomial_degree | max_flank_distance_um,
// num_samples, num_check_samples, roll_margin_fraction} -> motions, fit residuals, transform
// differences, flank distance on the grid, the grid.
bool BevelConversion(const nlohmann::json& body, nlohmann::json* answer, ApiError* error);
// POST /api/v1/bevel/evaluate: job, motion -> deviations_um (null where not reached), points.
bool BevelEvaluate(const nlohmann::json& body, nlohmann::json* answer, ApiError* error);
// POST /api/v1/bevel/axis-sensitivity: job, motion, errors {linear_error_mm, angular_error_deg,
// exact} -> offsets and coefficients tables, rankings.
bool BevelAxisSensitivity(const nlohmann::json& body, nlohmann::json* answer, ApiError* error);

// POST /api/v1/simulations/measurement with machine.kind "free-form-bevel-generator": job,
// motion (commanded; default converted), hidden_errors (a motion of coefficient errors, any of
// A_rad .. Z_mm, shorter arrays padded with 0), noise_um, seed, teeth, outlier_probability,
// outlier_size_um, missing_probability -> the simulated CMM grid and the true one.
bool BevelSimulateMeasurement(const nlohmann::json& body, nlohmann::json* answer, ApiError* error);

// POST /api/v1/simulations/closed-loop with the bevel machine kind: the scenario above plus
// target {deviations_um}, corrections (1..20), options -> iterations of cut, measure, correct
// (each with the commanded motion and the true error) and one replayable job per correction.
bool BevelSimulateClosedLoop(const nlohmann::json& body, ClosedLoopRun* run, ApiError* error);

// True when body.machine.kind is kFreeFormBevelGeneratorKind.
bool IsBevelCorrectionRequest(const nlohmann::json& body);
// A bevel correction (POST /api/v1/corrections): job, motion (the commanded motions the
// measured pinion was cut with; default converted), measurement, target {deviations_um},
// options (as the grinder's). Fills `run` like RunCorrection; false with a 4xx in `error`.
bool RunBevelCorrection(const nlohmann::json& body, CorrectionRun* run, ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_BEVEL_CODEC_H_
