// server/codec/shaving_codec.h: the plunge-shaving cutter target
// (SHAVING.md §6) read from JSON into engine/shaving's ShavingInput, and its
// result written back. Pure mapping: the engine's own validation
// (ShavingInput::IsValid, the 422s of SHAVING.md §7) is called, nothing is
// solved.
//
//   ShavingInput input;
//   ApiError error;
//   if (!ParseShavingInput(body, "", &input, &error)) return RespondError(res,
//   error);
//
// Request (API names; angles in degrees, helix unsigned with a hand as for
// every gear of the API):
//   work_gear, cutter        gear objects; tip_radius_mm and root_radius_mm
//                            may be absent (r_j + m_n and r_j - 1.25 m_n)
//   centre_distance_mm       optional; default the standard r_j1 + r_js
//   diagonal_modification    optional {root_um, tip_um, root_band, tip_band,
//                            exponent, root_slope, tip_slope}; default none
//   grid                     optional, the cutter's MODEL.md §4 grid
//   wheel_check              optional {h_s_mm, traverse_mm_per_rad}
#ifndef GEARLOOP_SERVER_CODEC_SHAVING_CODEC_H_
#define GEARLOOP_SERVER_CODEC_SHAVING_CODEC_H_

#include <nlohmann/json.hpp>
#include <string>

#include "engine/shaving/cutter_target.h"
#include "server/codec/json_read.h"

namespace gearloop {

// Reads the shaving request `body` (found at `path` of the whole request, ""
// for the endpoint, "target.shaving" inside a correction) without validating
// it. Absent gear radii are the standard ones (WithStandardRadii); an absent
// grid leaves input->grid as it was. *grid_given tells whether "grid" was
// there (may be null). Error fields are prefixed with `path`.
bool ReadShavingInput(const nlohmann::json& body,
                      const std::string& path,
                      ShavingInput* input,
                      bool* grid_given,
                      ApiError* error);

// ShavingInput::IsValid as a 422 whose field is the API's name under `path`
// ("work_gear.helix_angle_deg", "target.shaving.diagonal_modification.
// root_band", "grid.profile_range[0]").
bool ValidateShavingInput(const ShavingInput& input,
                          const std::string& path,
                          ApiError* error);

// ReadShavingInput then ValidateShavingInput.
bool ParseShavingInput(const nlohmann::json& body,
                       const std::string& path,
                       ShavingInput* input,
                       ApiError* error);

// A solved result that generated no grid point as a 422 (field `path` +
// "grid"); true when the result is usable.
bool CheckShavingResult(const ShavingResult& result,
                        const std::string& path,
                        ApiError* error);

// The answer of POST /api/v1/shaving/cutter-target (SHAVING.md §6):
// crossed_axes_angle_deg, centre_distance_mm, delta_s_um, base_um,
// stock_target_um (null where not generated), outside_work_flank and
// not_converged [[row, column]], contacts [[{roll_length_mm, x_mm,
// work_angle_rad, work_relief_um}]], contact_line_length_mm,
// wheel_radius_min_mm {fixed, traversing}, contact_angle_deg, summary counts,
// elapsed_ms.
nlohmann::json ShavingResultToJson(const ShavingResult& result,
                                   double elapsed_ms);

// The generated points of a result: true where status is kOk (row-major).
std::vector<bool> ShavingGeneratedPoints(const ShavingResult& result);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_SHAVING_CODEC_H_
