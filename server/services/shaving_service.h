// server/services/shaving_service.h: POST /api/v1/shaving/cutter-target
// (SHAVING.md §6): parse (codec/shaving_codec.h) -> ShavingInput::IsValid ->
// ComputeShavingCutterTarget (engine/shaving) -> answer. Points whose contact
// lies outside the work flank, or whose Newton fails, are null in the grids
// and listed; only a grid with no generated point is refused (422, "grid").
// ResolveShavingTarget is the same computation for a correction whose target
// is {"shaving": ...} (server/services/correction_service.cc).
//
//   ShavingCutterTarget(req, res);   // 200 {crossed_axes_angle_deg,
//                                    // stock_target_um, ...}
#ifndef GEARLOOP_SERVER_SERVICES_SHAVING_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_SHAVING_SERVICE_H_

#include <Eigen/Core>
#include <string>

#include "engine/shaving/cutter_target.h"
#include "server/respond.h"

namespace gearloop {

// The cutter target of a valid `input`; a grid with no generated point is a
// 422 whose field is `path` + ".grid".
bool ResolveShavingTarget(const ShavingInput& input,
                          const std::string& path,
                          ShavingResult* result,
                          ApiError* error);

// delta1 [um] of the work gear's diagonal modification (SHAVING.md §2,
// negative = relief) on the work gear's own MODEL.md §4 grid with the options
// of input.grid (fractions of its roll-length range and face width),
// row-major: what the designer drew, beside the cutter target it needs.
Eigen::VectorXd WorkModificationGrid(const ShavingInput& input);

// 200 with ShavingResultToJson plus "work_modification_um"
// (WorkModificationGrid).
void ShavingCutterTarget(const httplib::Request& req, httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_SHAVING_SERVICE_H_
