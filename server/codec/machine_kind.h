// server/codec/machine_kind.h: the machine family a request names in "machine":
// {"kind": ...}, read in this one place. The server's one switch on it is
// MachineFamily::Create (server/services/machine_family.cc); the grinder's own
// endpoints refuse the other families.
//
//   MachineKind kind;
//   if (!ReadMachineKind(body, &kind, &error)) return RespondError(res, error);
#ifndef GEARLOOP_SERVER_CODEC_MACHINE_KIND_H_
#define GEARLOOP_SERVER_CODEC_MACHINE_KIND_H_

#include <nlohmann/json.hpp>

#include "server/codec/json_read.h"

namespace gearloop {

// machine.kind of each family.
constexpr const char* kFlatWheelGrinderKind = "flat-wheel-grinder";
constexpr const char* kFreeFormBevelGeneratorKind = "free-form-bevel-generator";
// The machine of split bevel wheels (SPLIT_BEVEL.md): not a correction family,
// its jobs are trajectories (server/services/split_bevel_service.h).
constexpr const char* kHeadHead5AxisMillKind = "head-head-5-axis-mill";

enum class MachineKind {
  kFlatWheelGrinder,  // "flat-wheel-grinder" (also when machine or machine.kind
                      // is absent)
  kFreeFormBevelGenerator,  // "free-form-bevel-generator"
};
const char* MachineKindName(MachineKind kind);

// Reads body.machine.kind: 400 when machine is not an object or kind not a
// string, 422 naming machine.kind for a kind this server does not know.
bool ReadMachineKind(const nlohmann::json& body,
                     MachineKind* kind,
                     ApiError* error);

// ReadMachineKind, and a 422 naming machine.kind for any family but the
// flat-wheel grinder (the grinder's own endpoints: nominal, evaluate,
// sensitivity).
bool RequireFlatWheelGrinder(const nlohmann::json& body, ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_MACHINE_KIND_H_
