// tests/fuzz/correction_request_fuzzer.cc: libFuzzer target for the server's
// request parsing and validation (issue 7). The input is an HTTP body as the
// services of POST /api/v1/corrections and POST /api/v1/evaluate receive it; it
// runs through the same codec calls, without the network, the model and the
// solve:
//
//   ParseJsonBody -> ParseShavingInput (shaving/cutter-target)
//   ParseJsonBody -> ParseGrindingSetup -> ParseCorrectionRequest (corrections,
//   replays, batch items) ParseJsonBody -> ParseGrindingSetup ->
//   ParseMachineSettings   (nominal, evaluate, sensitivity)
//   ParseJsonBody -> ParseMeasurementImportRequest, ParseMeasurementFileRequest
//   (measurements/import, a correction's measurement.file)
//
// Besides the sanitizers' own findings it checks the codec's contract: a
// refusal is a 400 or a 422 with a code from the closed list and an error body
// that renders; an accepted request has grids of the grid's size, finite
// targets and options that pass IsValid.
//
//   build-fuzz/tests/fuzz/correction_request_fuzzer -max_total_time=60
//   tests/fuzz/corpus/correction_request
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "server/codec/correction_codec.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/measurement_codec.h"
#include "server/codec/shaving_codec.h"
#include "server/codec/tolerance_codec.h"
#include "server/codec/trace_codec.h"
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
  // As the server renders it (gearloop_server.cc: invalid UTF-8 replaced, never
  // thrown).
  const std::string rendered = gearloop::ErrorBody(error).dump(
      -1, ' ', false, nlohmann::json::error_handler_t::replace);
  Check(!rendered.empty(), "the error body renders");
}

void CheckFileFields(const gearloop::MeasurementFileRequest& file) {
  Check(file.format == "mka" || file.format == "gde", "a known file format");
  Check(file.tooth >= 0, "a tooth number >= 0");
  for (double factor : {file.sign.profile_right,
                        file.sign.profile_left,
                        file.sign.helix_right,
                        file.sign.helix_left})
    Check(factor == 1.0 || factor == -1.0, "sign factors are +1 or -1");
}

// The import body (POST /api/v1/measurements/import) and a correction's
// measurement.file (server/codec/measurement_codec.h).
void CheckMeasurementFile(const nlohmann::json& body) {
  gearloop::MeasurementImportRequest import;
  gearloop::ApiError error;
  if (gearloop::ParseMeasurementImportRequest(body, &import, &error)) {
    CheckFileFields(import.file);
  } else {
    CheckRefusal(error);
  }
  if (!gearloop::HasMeasurementFile(body)) return;
  gearloop::MeasurementFileRequest file;
  error = gearloop::ApiError();
  if (gearloop::ParseMeasurementFileRequest(body.at("measurement").at("file"),
                                            "measurement.file",
                                            &file,
                                            &error)) {
    CheckFileFields(file);
  } else {
    CheckRefusal(error);
  }
}

// The job's trace and tolerance (trace_codec.h, tolerance_codec.h): what is
// accepted lies within the documented limits, what is not is a named refusal.
void CheckTraceAndTolerance(const nlohmann::json& body) {
  gearloop::JobRecord job;
  gearloop::ApiError error;
  if (gearloop::ParseJobTrace(body, &job, &error)) {
    for (const std::string* text : {&job.part_number,
                                    &job.serial,
                                    &job.measured_at,
                                    &job.file_name,
                                    &job.machine_id}) {
      Check(text->size() <= gearloop::kMaxTraceTextLength,
            "trace texts within their length");
    }
    Check(
        job.measured_at.empty() || gearloop::IsIso8601DateTime(job.measured_at),
        "an accepted measuring time is ISO 8601");
    Check(job.tooth_numbers.size() <= gearloop::kMaxTraceTeeth,
          "at most the documented number of teeth");
    for (int tooth : job.tooth_numbers) Check(tooth >= 1, "teeth count from 1");
  } else {
    CheckRefusal(error);
  }
  std::optional<gearloop::Tolerance> tolerance;
  error = gearloop::ApiError();
  if (gearloop::ParseTolerance(body, &tolerance, &error)) {
    if (!tolerance) return;
    Check(tolerance->rms_um || tolerance->max_um || tolerance->iso_class,
          "an accepted tolerance has a limit");
    Check(!tolerance->rms_um || *tolerance->rms_um > 0.0,
          "a positive rms limit");
    Check(!tolerance->max_um || *tolerance->max_um > 0.0,
          "a positive max limit");
    Check(!tolerance->iso_class ||
              (*tolerance->iso_class >= 1 && *tolerance->iso_class <= 11),
          "an ISO 1328-1 class 1..11");
  } else {
    CheckRefusal(error);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json body;
  gearloop::ApiError error;
  if (!gearloop::ParseJsonBody(text, &body, &error)) {
    CheckRefusal(error);
    return 0;
  }
  Check(body.is_object(), "an accepted body is an object");

  gearloop::GrindingSetup correction_setup;
  gearloop::CorrectionRequest request;
  error = gearloop::ApiError();
  if (gearloop::ParseGrindingSetup(body, &correction_setup, &error) &&
      gearloop::ParseCorrectionRequest(body,
                                       correction_setup.grid.profile_points,
                                       correction_setup.grid.lead_points,
                                       /*target_modifications_allowed=*/true,
                                       &request,
                                       &error)) {
    const int rows = correction_setup.grid.profile_points;
    const int columns = correction_setup.grid.lead_points;
    const Eigen::Index points = static_cast<Eigen::Index>(rows) * columns;
    Check(rows > 0 && columns > 0, "a positive grid");
    Check(request.measured_teeth_um.empty()
              ? request.measured_um.size() == points
              : request.measured_um.size() == 0,
          "one measured grid of the grid's size, or teeth");
    for (const Eigen::VectorXd& tooth : request.measured_teeth_um)
      Check(tooth.size() == points, "teeth of the grid's size");
    Check(request.target_um.size() == points, "target of the grid's size");
    Check(request.target_um.allFinite(), "a finite target");
    for (Eigen::Index i = 0; i < request.measured_um.size(); ++i) {
      Check(!std::isinf(request.measured_um[i]),
            "no infinite measured point (NaN marks a missing one)");
    }
    std::string message;
    Check(request.options.IsValid(&message), "accepted options are valid");
  } else {
    CheckRefusal(error);
  }

  CheckMeasurementFile(body);
  CheckTraceAndTolerance(body);
  // The body as a plunge-shaving cutter target (POST
  // /api/v1/shaving/cutter-target): an accepted one passes the engine's own
  // check, with its radii filled in.
  gearloop::ShavingInput shaving;
  error = gearloop::ApiError();
  if (gearloop::ParseShavingInput(body, "", &shaving, &error)) {
    gearloop::ValidationIssue issue;
    Check(shaving.IsValid(&issue), "an accepted shaving request is valid");
    Check(shaving.work_gear.tip_radius_mm > 0.0 &&
              shaving.cutter.root_radius_mm > 0.0,
          "the radii are set");
  } else {
    CheckRefusal(error);
  }
  // A shaving target of a correction: read whole or refused.
  if (request.target_shaving) {
    Check(request.target_um.size() ==
              static_cast<Eigen::Index>(correction_setup.grid.profile_points) *
                  correction_setup.grid.lead_points,
          "a shaving target leaves a target of the grid's size");
    if (request.target_shaving_resolved_um) {
      Check(request.target_shaving_generated.size() ==
                static_cast<size_t>(request.target_shaving_resolved_um->size()),
            "the stored grid marks every point generated or not");
    }
  }

  gearloop::GrindingSetup setup;
  gearloop::MachineSettings settings;
  error = gearloop::ApiError();
  if (gearloop::ParseGrindingSetup(body, &setup, &error)) {
    if (body.contains("settings") && !body.at("settings").is_null() &&
        !gearloop::ParseMachineSettings(
            body.at("settings"), "settings", &settings, &error)) {
      CheckRefusal(error);
    }
  } else {
    CheckRefusal(error);
  }
  return 0;
}
