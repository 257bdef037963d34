#include "server/codec/machine_kind.h"

#include <string>

namespace gearloop {
namespace {

// The words of the refusal are the grinder's, as before the server knew other
// families: an unknown kind, or a bevel kind on a grinder endpoint.
ApiError UnknownKind(const std::string& kind) {
  return InvalidValue("machine.kind",
                      "machine.kind \"" + kind +
                          "\" is not known; this server has \"" +
                          kFlatWheelGrinderKind + "\"");
}

}  // namespace

const char* MachineKindName(MachineKind kind) {
  return kind == MachineKind::kFreeFormBevelGenerator
             ? kFreeFormBevelGeneratorKind
             : kFlatWheelGrinderKind;
}

bool ReadMachineKind(const nlohmann::json& body,
                     MachineKind* kind,
                     ApiError* error) {
  *kind = MachineKind::kFlatWheelGrinder;
  const nlohmann::json* machine = nullptr;
  if (!RequireObject(body, "", "machine", false, &machine, error)) return false;
  if (machine == nullptr) return true;
  std::string name;
  bool found = false;
  if (!ReadString(*machine, "machine", "kind", false, &name, error, &found))
    return false;
  if (!found || name == kFlatWheelGrinderKind) return true;
  if (name == kFreeFormBevelGeneratorKind) {
    *kind = MachineKind::kFreeFormBevelGenerator;
    return true;
  }
  *error = UnknownKind(name);
  return false;
}

bool RequireFlatWheelGrinder(const nlohmann::json& body, ApiError* error) {
  MachineKind kind;
  if (!ReadMachineKind(body, &kind, error)) return false;
  if (kind == MachineKind::kFlatWheelGrinder) return true;
  *error = UnknownKind(MachineKindName(kind));
  return false;
}

}  // namespace gearloop
