#include "server/services/shaving_service.h"

#include <chrono>

#include "engine/grinder/flank_grid.h"
#include "engine/shaving/diagonal_modification.h"
#include "server/codec/request_keys.h"
#include "server/codec/shaving_codec.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {

bool ResolveShavingTarget(const ShavingInput& input,
                          const std::string& path,
                          ShavingResult* result,
                          ApiError* error) {
  *result = ComputeShavingCutterTarget(ShavingOptions(), input);
  return CheckShavingResult(*result, path, error);
}

Eigen::VectorXd WorkModificationGrid(const ShavingInput& input) {
  GrindingSetup work;
  work.gear = input.work_gear;
  work.grid = input.grid;
  work.flank = Flank::kRight;
  const FlankGrid grid = BuildFlankGrid(work);
  const DiagonallyModifiedFlank flank(input.work_gear,
                                      input.diagonal_modification);
  Eigen::VectorXd relief_um(static_cast<int>(grid.points.size()));
  for (size_t i = 0; i < grid.points.size(); ++i) {
    relief_um(static_cast<int>(i)) =
        flank.Relief(grid.points[i].roll_length_mm, grid.points[i].x_mm)
            .value_um;
  }
  return relief_um;
}

void ShavingCutterTarget(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  ShavingInput input;
  ApiError error;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(
          RequestSchema::kShavingCutterTarget, body, "", &error) ||
      !ParseShavingInput(body, "", &input, &error))
    return RespondError(res, error);
  const auto start = std::chrono::steady_clock::now();
  ShavingResult result;
  if (!ResolveShavingTarget(input, "", &result, &error))
    return RespondError(res, error);
  const double elapsed_ms = std::chrono::duration<double, std::milli>(
                                std::chrono::steady_clock::now() - start)
                                .count();
  nlohmann::json answer = ShavingResultToJson(result, elapsed_ms);
  answer["work_modification_um"] =
      GridToJson(WorkModificationGrid(input), {}, result.rows, result.columns);
  RespondJson(res, 200, answer);
}

}  // namespace gearloop
