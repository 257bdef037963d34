// server/codec/split_bevel_codec.h: the request and answer of POST
// /api/v1/bevel/split-trajectory (issue 14, SPLIT_BEVEL.md §8,
// docs/split-bevel.md): 5-axis flank-milling trajectories of split
// equal-base-circle bevel wheels. Pure mapping: DEGREES in the API, radians in
// the engine (engine/split_bevel/trajectory.h); the conversion is here and
// nowhere else. The engine's IsValid and ComputeSplitTrajectory decide every
// 422; this file decides the 400s (a missing field, a wrong type) and the words
// of the enumerations.
//
//   SplitBevelRequest request;
//   ApiError error;
//   if (!ParseSplitBevelRequest(body, &request, &error)) return ...;  // 400
//   if (!CheckSplitBevelRequest(request, &error)) return ...;         // 422
//   const SplitBevelResult result = ComputeSplitTrajectory(request);
//   if (!result.ok) error = SplitBevelResultError(result);            // 422
//   const std::string text = SplitBevelResultJsonText(result);  // 200 body
//
// Request (API names; required: gear.teeth, gear.pitch_angle_deg,
// gear.face_width_mm, gear.hand, gear.pressure_angle_deg, tool.radius_mm):
//   gear    {teeth, pitch_angle_deg, outer_cone_distance_mm |
//            outer_transverse_module_mm, face_width_mm, mean_spiral_angle_deg |
//            outer_spiral_angle_deg, hand "left"|"right", pressure_angle_deg,
//            addendum_mm, dedendum_mm, slot_width_mm}
//   tool    {radius_mm, stock_mm}
//   cut     {slot_index, flanks ["convex", "concave"], depth_levels, steps |
//            chord_tolerance_mm, from "toe"|"heel", feed_mm_per_min}
//   machine {pivot_length_mm, a_limits_deg [min, max], b_limits_deg}
//   setup   {apex_mm [x, y, z], segment_mid_deg, segment_angle_deg}
//   output  {nc: bool}
// Absent optional fields take the engine's defaults (SPLIT_BEVEL.md §1).
#ifndef GEARLOOP_SERVER_CODEC_SPLIT_BEVEL_CODEC_H_
#define GEARLOOP_SERVER_CODEC_SPLIT_BEVEL_CODEC_H_

#include <nlohmann/json.hpp>
#include <string>

#include "engine/split_bevel/trajectory.h"
#include "server/codec/json_read.h"

namespace gearloop {

// Reads the whole request body (degrees converted to radians). 400
// invalid_request for a missing required field or a wrong type; 422
// invalid_value for a word outside its enumeration (gear.hand, cut.flanks[i],
// cut.from) or an integer beyond the range of an int.
bool ParseSplitBevelRequest(const nlohmann::json& body,
                            SplitBevelRequest* request,
                            ApiError* error);

// SplitBevelRequest::IsValid as a 422 naming the field.
bool CheckSplitBevelRequest(const SplitBevelRequest& request, ApiError* error);

// A result that is not ok (a point out of the axis limits, too many stations
// for the chord tolerance) as a 422 naming its field.
ApiError SplitBevelResultError(const SplitBevelResult& result);

// What SplitBevelResultJsonText writes besides derived, passes and setup.
struct SplitBevelTextOptions {
  // Each pass with its points (the answer), or with "point_count" only (the
  // stored job: server/services/split_bevel_service.h).
  bool points = true;
  // Small members appended after "setup" in their (sorted) order: job_id,
  // location, nc_location, ...
  nlohmann::json members = nlohmann::json::object();
  // Appended last as "nc_program" when not null.
  const std::string* nc_program = nullptr;
};

// The 200 answer of SPLIT_BEVEL.md §8 as JSON text, written straight into one
// string (40 000 points are a million numbers; server/codec/
// split_bevel_answer.cc): derived, passes with their points, setup
// {blank_to_machine, segment_mid_deg} (vectors in the blank frame Si, X Y Z in
// mm, A B and every angle in degrees), then the options' members. Every number
// has 17 significant digits as std::to_chars(..., general, 17) writes them
// (server/codec/decimal17.h): it reads back to the engine's double exactly; a
// non-finite one is null. The same result gives the same bytes.
std::string SplitBevelResultJsonText(const SplitBevelResult& result,
                                     const SplitBevelTextOptions& options = {});

// "both" when the request cuts both flanks, else the one flank's name: the
// job's flank column (storage/job_repository.h).
std::string SplitBevelJobFlank(const SplitBevelRequest& request);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_SPLIT_BEVEL_CODEC_H_
