#include "server/codec/request_keys.h"

#include <vector>

#include "server/codec/machine_kind.h"

namespace gearloop {
namespace {

using Keys = std::vector<std::string>;

Keys Join(Keys a, const Keys& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// SetupRequest: the flat-wheel grinder and the part's flank.
const Keys& GrinderSetupKeys() {
  static const Keys keys = {
      "gear", "wheel", "machine", "grid", "flank", "settings"};
  return keys;
}

// What a correction adds to its machine's keys (CorrectionRequest,
// BevelCorrectionRequest).
const Keys& CorrectionKeys() {
  static const Keys keys = {"measurement",
                            "target",
                            "options",
                            "settings_source_job_id",
                            "allow_large_deviations",
                            "trace",
                            "tolerance"};
  return keys;
}

// The free-form bevel generator's machine keys of a correction or simulation.
const Keys& BevelMachineKeys() {
  static const Keys keys = {"machine", "job", "motion"};
  return keys;
}

// The simulated measuring machine (MeasurementSimulationRequest,
// BevelMeasurementSimulationRequest).
Keys SimulationKeys(bool grinder) {
  Keys keys = {"hidden_errors",
               "noise_um",
               "seed",
               "outlier_probability",
               "outlier_size_um",
               "missing_probability",
               "teeth"};
  if (grinder) {
    keys = Join(keys,
                {"random_hidden_errors", "outlier_points", "missing_points"});
  }
  return keys;
}

// A closed loop adds the target, the loop and the solver.
const Keys& ClosedLoopKeys() {
  static const Keys keys = {
      "target", "corrections", "options", "store", "allow_large_deviations"};
  return keys;
}

// The keys of a schema whose keys depend on the machine family.
Keys FamilyKeys(RequestSchema schema, bool grinder) {
  const Keys machine = grinder ? GrinderSetupKeys() : BevelMachineKeys();
  switch (schema) {
    case RequestSchema::kCorrection:
      return Join(machine, CorrectionKeys());
    case RequestSchema::kMeasurementSimulation:
      return Join(machine, SimulationKeys(grinder));
    default:  // kClosedLoop
      return Join(Join(machine, SimulationKeys(grinder)), ClosedLoopKeys());
  }
}

// The keys of a schema of one machine only.
Keys FixedKeys(RequestSchema schema) {
  switch (schema) {
    case RequestSchema::kGrinderSetup:
      return GrinderSetupKeys();
    case RequestSchema::kTargetReach:
      // measurement, trace and tolerance are a correction's: the reach
      // refuses them with the reason (reach_service.cc).
      return Join(GrinderSetupKeys(),
                  {"target", "options", "measurement", "trace", "tolerance"});
    case RequestSchema::kBevelConversion:
      return {"job", "options"};
    case RequestSchema::kBevelMotion:
      return {"job", "motion"};
    case RequestSchema::kBevelAxisSensitivity:
      return {"job", "motion", "errors"};
    case RequestSchema::kSplitTrajectory:
      return {"gear", "tool", "cut", "machine", "setup", "output"};
    case RequestSchema::kShavingCutterTarget:
      return {"work_gear",
              "cutter",
              "centre_distance_mm",
              "diagonal_modification",
              "grid",
              "wheel_check"};
    case RequestSchema::kMeasurementImport:
      return {"format",
              "content",
              "tooth",
              "datum_face",
              "sign_factors",
              "gear",
              "grid",
              "flank"};
    case RequestSchema::kBatch:
      return {"items"};
    case RequestSchema::kReplay:
      return {"options", "target", "tolerance"};
    default:
      return {};
  }
}

bool DependsOnFamily(RequestSchema schema) {
  return schema == RequestSchema::kCorrection ||
         schema == RequestSchema::kMeasurementSimulation ||
         schema == RequestSchema::kClosedLoop;
}

}  // namespace

bool CheckRequestKeys(RequestSchema schema,
                      const nlohmann::json& body,
                      const std::string& path,
                      ApiError* error) {
  if (!DependsOnFamily(schema))
    return CheckKeys(body, path, FixedKeys(schema), error);
  MachineKind kind = MachineKind::kFlatWheelGrinder;
  ApiError kind_error;
  if (!ReadMachineKind(body, &kind, &kind_error))
    return true;  // the parser refuses the machine with the reason
  return CheckKeys(body,
                   path,
                   FamilyKeys(schema, kind == MachineKind::kFlatWheelGrinder),
                   error);
}

}  // namespace gearloop
