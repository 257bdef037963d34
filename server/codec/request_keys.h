// server/codec/request_keys.h: strict input where a client's body enters. The
// top-level keys each request body of the API may carry (api/openapi.yaml);
// an unknown one is a 422 naming it as sent and the nearest known key
// (CheckKeys), before anything else of the body is read.
//
//   if (!ParseJsonBody(req.body, &body, &error) ||
//       !CheckRequestKeys(RequestSchema::kCorrection, body, "", &error))
//     return RespondError(res, error);
//
// Only the HTTP handlers call this, on the body as the client sent it. A stored
// request read back for replay, show or lineage is not checked again: requests
// stored by older versions may carry keys this check now refuses, and they
// replay as they were stored.
#ifndef GEARLOOP_SERVER_CODEC_REQUEST_KEYS_H_
#define GEARLOOP_SERVER_CODEC_REQUEST_KEYS_H_

#include <nlohmann/json.hpp>
#include <string>

#include "server/codec/json_read.h"

namespace gearloop {

// The request bodies of the API, by their schema in api/openapi.yaml.
enum class RequestSchema {
  kGrinderSetup,           // POST nominal, evaluate, sensitivity
  kCorrection,             // POST corrections (either family), batch items
  kMeasurementSimulation,  // POST simulations/measurement (either family)
  kClosedLoop,             // POST simulations/closed-loop (either family)
  kTargetReach,            // POST targets/reach
  kBevelConversion,        // POST bevel/conversions
  kBevelMotion,            // POST bevel/evaluate
  kBevelAxisSensitivity,   // POST bevel/axis-sensitivity
  kSplitTrajectory,        // POST bevel/split-trajectory
  kShavingCutterTarget,    // POST shaving/cutter-target
  kMeasurementImport,      // POST measurements/import
  kBatch,                  // POST batches (the items: kCorrection)
  kReplay,                 // POST corrections/{id}/replay
};

// Every top-level key of `body` (named under `path`: "" or "items[3]") must
// be one of `schema`'s. Where the keys depend on the machine family
// (corrections, simulations) the family is read from machine.kind; a body
// whose machine.kind cannot be read passes here and is refused by its parser
// with the reason.
bool CheckRequestKeys(RequestSchema schema,
                      const nlohmann::json& body,
                      const std::string& path,
                      ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_REQUEST_KEYS_H_
