// server/codec/bevel_codec.h: the spiral-bevel pinion's request pieces (issue
// 6, docs/bevel-machines.md): the cradle summary and the free-form axis motions
// read from JSON, and the answers of the bevel endpoints written back. Pure
// mapping; the engine runs are in server/services/bevel_service.h and
// machine_family.h.
//
//   BevelPinionJob job;
//   ApiError error;
//   if (!ParseBevelJob(body, &job, &error)) return RespondError(res, error);
//
// Request pieces (API names; angles in DEGREES, the engine takes radians):
//   job     {"side": "convex" | "concave", "published": true}  the pinion of
//   Tang 2011 Table 1,
//           or the whole summary: "cutter" {point_radius_mm, blade_angle_deg,
//           edge_radius_mm}, "machine" {blank_offset_mm, horizontal_offset_mm,
//           sliding_base_mm, machine_root_angle_deg, eccentric_angle_deg,
//           eccentric_mm, cradle_angle_deg, tilt_rotation_deg,
//           tilt_axis_inclination_deg, tilt_axis_mounting_deg, ratio_of_roll},
//           "blank" {outer_cone_distance_mm, inner_cone_distance_mm,
//           face_angle_deg, root_angle_deg}, "grid" {profile_points,
//           lengthwise_points, profile_min_fraction, profile_max_fraction,
//           lengthwise_min_fraction, lengthwise_max_fraction}. With
//           "published": true every given field overrides the published value.
//   motion  {"A_rad": [...], "B_rad": [...], "X_mm": [...], "Y_mm": [...],
//   "Z_mm": [...],
//           "C_rad": [...] (optional)}: free-form axis polynomials, coefficient
//           k multiplies t^k (t the cradle roll [rad]); A, B, X, Y, Z of one
//           length (degree + 1, 1..13). Absent: the motions converted from the
//           cradle summary (default options).
#ifndef GEARLOOP_SERVER_CODEC_BEVEL_CODEC_H_
#define GEARLOOP_SERVER_CODEC_BEVEL_CODEC_H_

#include <nlohmann/json.hpp>
#include <string>

#include "engine/bevel/conversion.h"
#include "engine/bevel/cradle_machine.h"
#include "engine/bevel/freeform_generator.h"
#include "engine/bevel/freeform_machine.h"
#include "engine/core/machine_model.h"
#include "server/codec/json_read.h"
#include "server/codec/machine_kind.h"

namespace gearloop {

// Reads body["job"] and validates it (BevelPinionJob::IsValid, fields mapped to
// API names).
bool ParseBevelJob(const nlohmann::json& body,
                   BevelPinionJob* job,
                   ApiError* error);
// The job in the API's shape (degrees).
nlohmann::json BevelJobToJson(const BevelPinionJob& job);
// Reads a motion object at `path`.
bool ParseFreeFormMotion(const nlohmann::json& value,
                         const std::string& path,
                         FreeFormMotion* motion,
                         ApiError* error);
nlohmann::json FreeFormMotionToJson(const FreeFormMotion& motion);

// The grid points on the cradle flank: {row, column, cone_distance_mm,
// polar_angle_deg, roll_deg, blade_u_mm, position_mm [3], normal [3]}.
nlohmann::json GridPointsToJson(const BevelFlankGrid& grid);

// POST /api/v1/bevel/conversions: options {polynomial_degree |
// max_flank_distance_um, num_samples, num_check_samples, roll_margin_fraction}
// (absent: the defaults), checked with ConversionOptions::IsValid.
bool ParseConversionOptions(const nlohmann::json& body,
                            ConversionOptions* options,
                            ApiError* error);
// Its answer: motions, fit residuals, transform differences, flank distance on
// the grid, the grid.
nlohmann::json ConversionToJson(const BevelPinionJob& job,
                                const ConversionResult& conversion);

// POST /api/v1/bevel/evaluate's answer: job, motion, deviations_um (null where
// not reached), not_reached, reached, points.
nlohmann::json BevelEvaluationToJson(const BevelPinionJob& job,
                                     const FreeFormMotion& motion,
                                     const BevelFlankGrid& grid,
                                     const ModelEvaluation& evaluation);

// POST /api/v1/bevel/axis-sensitivity: errors {linear_error_mm,
// angular_error_deg, exact}.
bool ParseAxisSensitivityOptions(const nlohmann::json& body,
                                 AxisSensitivityOptions* options,
                                 ApiError* error);
// Its answer: offsets and coefficients tables, rankings.
nlohmann::json AxisSensitivityToJson(const BevelPinionJob& job,
                                     const FreeFormMotion& motion,
                                     const AxisSensitivityOptions& options,
                                     const AxisSensitivityTable& table,
                                     int rows,
                                     int columns);

// The "hidden_errors" of a bevel simulation: a motion of coefficient errors
// (any of A_rad .. Z_mm, at most degree + 1 coefficients each, shorter arrays
// padded with 0) into a zero motion of `degree`.
bool ParseBevelHiddenErrors(const nlohmann::json& body,
                            int degree,
                            FreeFormMotion* hidden,
                            ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_BEVEL_CODEC_H_
