// tests/fuzz/split_bevel_request_fuzzer.cc: libFuzzer target for the request
// of POST /api/v1/bevel/split-trajectory (issue 14, server/codec/
// split_bevel_codec.h). The input is an HTTP body; it runs through the codec
// and the engine's validation as the service does:
//
//   ParseJsonBody -> ParseSplitBevelRequest -> CheckSplitBevelRequest
//     [-> ComputeSplitTrajectory -> SplitBevelResultJsonText, the NC listing]
//
// Besides the sanitizers' own findings it checks the contract: a refusal is a
// 400 or a 422 with a code of the closed list that names a field (every 422 of
// SPLIT_BEVEL.md §8 does); a small accepted request (at most 2 000 points, so
// that an input cannot make a slow run) computes, or is refused by the two
// limits only the computation finds, and its answer is JSON whose passes match
// the result and its listing starts with "%".
//
//   build-fuzz/tests/fuzz/split_bevel_request_fuzzer -max_total_time=60
//   tests/fuzz/corpus/split_bevel_request
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/split_bevel/nc_program.h"
#include "engine/split_bevel/trajectory.h"
#include "server/codec/split_bevel_codec.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gearloop::fuzz::Check;

void CheckRefusal(const gearloop::ApiError& error) {
  Check(error.status == 400 || error.status == 422,
        "a refusal is a 400 or a 422");
  Check(error.code == "invalid_json" || error.code == "invalid_request" ||
            error.code == "invalid_value",
        "the error code is one of the codec's");
  Check(!error.message.empty(), "a refusal says why");
  Check(error.status == 400 || !error.field.empty(), "a 422 names its field");
  const std::string rendered = gearloop::ErrorBody(error).dump(
      -1, ' ', false, nlohmann::json::error_handler_t::replace);
  Check(!rendered.empty(), "the error body renders");
}

// Points the request asks for, when it says (steps), or a bound for a chord
// tolerance (which may need up to 20 001 stations per pass).
long long Points(const gearloop::SplitBevelRequest& r) {
  const long long passes =
      static_cast<long long>(r.cut.flanks.size()) * r.cut.depth_levels;
  const long long stations =
      r.cut.chord_tolerance_mm
          ? gearloop::kSplitBevelMaxSteps
          : r.cut.steps.value_or(gearloop::kSplitBevelDefaultSteps);
  return passes * stations;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json body;
  gearloop::ApiError error;
  gearloop::SplitBevelRequest request;
  if (!gearloop::ParseJsonBody(text, &body, &error) ||
      !gearloop::ParseSplitBevelRequest(body, &request, &error) ||
      !gearloop::CheckSplitBevelRequest(request, &error)) {
    CheckRefusal(error);
    return 0;
  }
  if (Points(request) > 2000) return 0;
  request.nc_program = true;
  const gearloop::SplitBevelResult result =
      gearloop::ComputeSplitTrajectory(request);
  if (!result.ok) {
    Check(result.field == "machine.a_limits_deg" ||
              result.field == "cut.chord_tolerance_mm",
          "only the axis limits or the chord tolerance refuse a valid request");
    CheckRefusal(gearloop::SplitBevelResultError(result));
    return 0;
  }
  const nlohmann::json answer = nlohmann::json::parse(
      gearloop::SplitBevelResultJsonText(result), nullptr, false);
  Check(answer.is_object(), "the answer is JSON");
  Check(answer["passes"].size() == result.passes.size(),
        "one answer pass per pass");
  Check(
      result.passes.size() == request.cut.flanks.size() *
                                  static_cast<size_t>(request.cut.depth_levels),
      "a pass per flank and level");
  Check(result.nc_program.rfind("%\n(GEARLOOP SPLIT-BEVEL 1)\n", 0) == 0,
        "the listing starts with its header");
  return 0;
}
