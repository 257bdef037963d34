#include "server/services/shaving_service.h"

#include <chrono>

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

void ShavingCutterTarget(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  ShavingInput input;
  ApiError error;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !ParseShavingInput(body, "", &input, &error))
    return RespondError(res, error);
  const auto start = std::chrono::steady_clock::now();
  ShavingResult result;
  if (!ResolveShavingTarget(input, "", &result, &error))
    return RespondError(res, error);
  const double elapsed_ms = std::chrono::duration<double, std::milli>(
                                std::chrono::steady_clock::now() - start)
                                .count();
  RespondJson(res, 200, ShavingResultToJson(result, elapsed_ms));
}

}  // namespace gearloop
