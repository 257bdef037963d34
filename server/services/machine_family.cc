#include "server/services/machine_family.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "engine/bevel/conversion.h"
#include "engine/bevel/freeform_generator.h"
#include "engine/core/units.h"
#include "engine/grinder/flank_grid.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/grinder_settings.h"
#include "server/codec/bevel_codec.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/simulation_codec.h"
#include "server/services/measurement_service.h"

namespace gearloop {
namespace {

// One machine family: how its requests name the machine and how its parameters
// look in JSON.
class MachineFamily {
 public:
  virtual ~MachineFamily() = default;
  virtual bool Correction(const nlohmann::json& body,
                          CorrectionProblem* problem,
                          ApiError* error) const = 0;
  virtual bool Simulation(const nlohmann::json& body,
                          SimulationProblem* simulation,
                          ApiError* error) const = 0;

  // The one switch on the machine kind (ReadMachineKind reads it).
  static std::unique_ptr<MachineFamily> Create(MachineKind kind);
};

// --- The flat-wheel grinder
// ----------------------------------------------------------------

nlohmann::json GrinderParametersToJson(const Eigen::VectorXd& parameters) {
  return MachineSettingsToJson(MachineSettings::FromVector(parameters));
}

// A shaving target's cutter and grid against the setup being ground (see
// CorrectionProblem::fit_shaving_target).
bool FitShavingTargetToSetup(const GrindingSetup& setup,
                             bool grid_given,
                             ShavingInput* input,
                             ApiError* error) {
  if (setup.flank != Flank::kRight) {
    *error = InvalidValue("flank",
                          "a shaving target is the cutter's right flank "
                          "(SHAVING.md); grind the right flank with it");
    return false;
  }
  const GearData& gear = setup.gear;
  const GearData& cutter = input->cutter;
  const struct {
    const char* name;
    double cutter;
    double gear;
  } fields[] = {
      {"teeth",
       static_cast<double>(cutter.teeth),
       static_cast<double>(gear.teeth)},
      {"normal_module_mm", cutter.normal_module_mm, gear.normal_module_mm},
      {"normal_pressure_angle_deg",
       cutter.normal_pressure_angle_rad,
       gear.normal_pressure_angle_rad},
      {"helix_angle_deg", cutter.helix_angle_rad, gear.helix_angle_rad},
      {"face_width_mm", cutter.face_width_mm, gear.face_width_mm},
      {"tip_radius_mm", cutter.tip_radius_mm, gear.tip_radius_mm},
      {"root_radius_mm", cutter.root_radius_mm, gear.root_radius_mm},
  };
  for (const auto& f : fields) {
    if (std::abs(f.cutter - f.gear) > 1e-9 * std::max(1.0, std::abs(f.gear))) {
      *error = InvalidValue(
          std::string("target.shaving.cutter.") + f.name,
          std::string("the shaving cutter must be the gear being ground: "
                      "target.shaving.cutter.") +
              f.name + " differs from gear." + f.name);
      return false;
    }
  }
  if (!grid_given) {
    input->grid = setup.grid;
    return true;
  }
  const GridOptions& a = input->grid;
  const GridOptions& b = setup.grid;
  if (a.profile_points != b.profile_points || a.lead_points != b.lead_points ||
      a.profile_begin != b.profile_begin || a.profile_end != b.profile_end ||
      a.lead_begin != b.lead_begin || a.lead_end != b.lead_end) {
    *error = InvalidValue("target.shaving.grid",
                          "target.shaving.grid must be the correction's grid "
                          "(leave it out to use it)");
    return false;
  }
  return true;
}

// The grinder's model and renderings for `setup`, ground with `settings`.
void FillGrinderProblem(const nlohmann::json& body,
                        const GrindingSetup& setup,
                        const MachineSettings& settings,
                        CorrectionProblem* problem) {
  problem->model = std::make_unique<FlatWheelGrinder>(setup);
  problem->current_parameters = settings.ToVector();
  problem->rows = setup.grid.profile_points;
  problem->columns = setup.grid.lead_points;
  problem->parameters_key = "settings";
  problem->parameters_to_json = GrinderParametersToJson;
  problem->delta_to_json = GrinderParametersToJson;
  problem->result_header = [](const Eigen::VectorXd&) {
    return nlohmann::json::object();
  };
  nlohmann::json setup_keys = nlohmann::json::object();
  for (const char* key : {"gear", "wheel", "machine", "grid", "flank"}) {
    if (body.contains(key)) setup_keys[key] = body.at(key);
  }
  problem->request_setup_json = [setup_keys](const Eigen::VectorXd& commanded) {
    nlohmann::json request = setup_keys;
    request["settings"] = GrinderParametersToJson(commanded);
    return request;
  };
  problem->job_summary_columns = [setup](JobRecord* job) {
    job->gear_teeth = setup.gear.teeth;
    job->gear_normal_module_mm = setup.gear.normal_module_mm;
    job->gear_helix_angle_deg =
        RoundTo1e9(std::fabs(setup.gear.helix_angle_rad) * kDegPerRad);
    job->gear_hand = HandName(setup.gear);
    job->flank = FlankName(setup.flank);
    job->machine_kind = kFlatWheelGrinderKind;
  };
  problem->evaluate_modifications =
      [setup](const std::vector<TargetModification>& modifications) {
        return EvaluateTargetModifications(
            modifications, BuildFlankGrid(setup), setup.gear, setup.flank);
      };
  problem->flank_quality_json = [setup](const Eigen::VectorXd& deviations_um,
                                        const Eigen::VectorXd& target_um,
                                        double profile_evaluation_length_mm) {
    return FlankQualityJson(setup.gear,
                            setup.grid,
                            deviations_um,
                            target_um,
                            profile_evaluation_length_mm);
  };
  problem->fit_shaving_target =
      [setup](bool grid_given, ShavingInput* input, ApiError* error) {
        return FitShavingTargetToSetup(setup, grid_given, input, error);
      };
}

// The setup and the settings (default nominal) of a grinder request.
bool ParseGrinderSetup(const nlohmann::json& body,
                       GrindingSetup* setup,
                       MachineSettings* settings,
                       ApiError* error) {
  if (!ParseGrindingSetup(body, setup, error)) return false;
  if (body.contains("settings") && !body.at("settings").is_null()) {
    return ParseMachineSettings(
        body.at("settings"), "settings", settings, error);
  }
  *settings = NominalSettings(*setup);
  return true;
}

class FlatWheelGrinderFamily : public MachineFamily {
 public:
  bool Correction(const nlohmann::json& body,
                  CorrectionProblem* problem,
                  ApiError* error) const override {
    GrindingSetup setup;
    MachineSettings settings;
    if (!ParseGrinderSetup(body, &setup, &settings, error)) return false;
    FillGrinderProblem(body, setup, settings, problem);
    return true;
  }

  bool Simulation(const nlohmann::json& body,
                  SimulationProblem* simulation,
                  ApiError* error) const override {
    GrindingSetup setup;
    MachineSettings settings;
    if (!ParseGrinderSetup(body, &setup, &settings, error)) return false;
    CorrectionProblem& problem = simulation->problem;
    FillGrinderProblem(body, setup, settings, &problem);
    simulation->hidden_errors.setZero(kNumGrinderParameters);
    if (body.contains("hidden_errors") &&
        body.contains("random_hidden_errors")) {
      *error = InvalidRequest(
          "random_hidden_errors",
          "give hidden_errors or random_hidden_errors, not both");
      return false;
    }
    if (body.contains("hidden_errors") &&
        !ParseGrinderHiddenErrors(
            body.at("hidden_errors"), &simulation->hidden_errors, error)) {
      return false;
    }
    if (body.contains("random_hidden_errors")) {
      RandomHiddenErrorsRequest random;
      if (!ParseRandomHiddenErrors(
              body.at("random_hidden_errors"), &random, error))
        return false;
      const auto& grinder =
          static_cast<const FlatWheelGrinder&>(*problem.model);
      simulation->hidden_errors = RandomHiddenErrors(grinder,
                                                     grinder.roll_min_rad(),
                                                     grinder.roll_max_rad(),
                                                     random.block_size,
                                                     random.max_order,
                                                     random.wheel_size,
                                                     random.seed,
                                                     random.fixed_blocks);
    }
    return ParseMeasurementSimulation(body,
                                      /*with_point_lists=*/true,
                                      problem.rows,
                                      problem.columns,
                                      &simulation->measurement,
                                      error);
  }
};

// --- The free-form bevel generator
// ---------------------------------------------------------

// The generator's model and renderings for `setup`.
void FillBevelProblem(const nlohmann::json& body,
                      const BevelSetup& setup,
                      CorrectionProblem* problem) {
  problem->model = std::make_unique<BevelFreeFormGenerator>(
      setup.job, setup.grid, setup.nominal);
  problem->current_parameters = setup.motion.ToVector();
  problem->rows = setup.grid.rows;
  problem->columns = setup.grid.columns;
  problem->parameters_key = "motion";
  problem->answer_header = {{"machine_kind", kFreeFormBevelGeneratorKind}};
  const int degree = setup.motion.degree;
  const Eigen::VectorXd c_coefficients = setup.motion.c_coefficients;
  // The C axis is not corrected: a corrected or commanded motion keeps the
  // request's C.
  auto to_json = [degree, c_coefficients](const Eigen::VectorXd& parameters) {
    FreeFormMotion motion = FreeFormMotion::FromVector(degree, parameters);
    motion.c_coefficients = c_coefficients;
    return FreeFormMotionToJson(motion);
  };
  problem->parameters_to_json = to_json;
  problem->delta_to_json = [degree](const Eigen::VectorXd& delta) {
    return FreeFormMotionToJson(FreeFormMotion::FromVector(degree, delta));
  };
  const std::string side = BevelFlankSideName(setup.job.side);
  problem->result_header = [side, to_json](const Eigen::VectorXd& commanded) {
    return nlohmann::json{{"machine_kind", kFreeFormBevelGeneratorKind},
                          {"side", side},
                          {"commanded_motion", to_json(commanded)}};
  };
  const nlohmann::json job = body.at("job");
  problem->request_setup_json = [job,
                                 to_json](const Eigen::VectorXd& commanded) {
    return nlohmann::json{{"machine", {{"kind", kFreeFormBevelGeneratorKind}}},
                          {"job", job},
                          {"motion", to_json(commanded)}};
  };
  problem->job_summary_columns = [side](JobRecord* record) {
    // A pinion flank has no tooth count or module in the summary; the pinion is
    // left-hand (§2.4).
    record->gear_teeth = 0;
    record->gear_normal_module_mm = 0.0;
    record->gear_helix_angle_deg = 0.0;
    record->gear_hand = "left";
    record->flank = side;
    record->machine_kind = kFreeFormBevelGeneratorKind;
  };
}

// The machine of a bevel correction or simulation names its kind alone.
bool CheckBevelMachineKeys(const nlohmann::json& body, ApiError* error) {
  return !body.contains("machine") ||
         CheckKeys(body.at("machine"), "machine", {"kind"}, error);
}

class FreeFormBevelGeneratorFamily : public MachineFamily {
 public:
  bool Correction(const nlohmann::json& body,
                  CorrectionProblem* problem,
                  ApiError* error) const override {
    BevelSetup setup;
    if (!CheckBevelMachineKeys(body, error) ||
        !PrepareBevel(body, &setup, error))
      return false;
    FillBevelProblem(body, setup, problem);
    return true;
  }

  bool Simulation(const nlohmann::json& body,
                  SimulationProblem* simulation,
                  ApiError* error) const override {
    BevelSetup setup;
    if (!CheckBevelMachineKeys(body, error) ||
        !PrepareBevel(body, &setup, error))
      return false;
    FreeFormMotion hidden;
    if (!ParseBevelHiddenErrors(body, setup.motion.degree, &hidden, error))
      return false;
    FillBevelProblem(body, setup, &simulation->problem);
    simulation->hidden_errors = hidden.ToVector();
    // The bevel simulations take no outlier or missing point lists.
    return ParseMeasurementSimulation(body,
                                      /*with_point_lists=*/false,
                                      /*rows=*/0,
                                      /*columns=*/0,
                                      &simulation->measurement,
                                      error);
  }
};

std::unique_ptr<MachineFamily> MachineFamily::Create(MachineKind kind) {
  switch (kind) {
    case MachineKind::kFreeFormBevelGenerator:
      return std::make_unique<FreeFormBevelGeneratorFamily>();
    case MachineKind::kFlatWheelGrinder:
      break;
  }
  return std::make_unique<FlatWheelGrinderFamily>();
}

}  // namespace

bool CorrectionProblemFor(const nlohmann::json& body,
                          CorrectionProblem* problem,
                          ApiError* error) {
  MachineKind kind;
  return ReadMachineKind(body, &kind, error) &&
         MachineFamily::Create(kind)->Correction(body, problem, error);
}

bool SimulationProblemFor(const nlohmann::json& body,
                          SimulationProblem* simulation,
                          ApiError* error) {
  MachineKind kind;
  return ReadMachineKind(body, &kind, error) &&
         MachineFamily::Create(kind)->Simulation(body, simulation, error);
}

bool PrepareBevel(const nlohmann::json& body,
                  BevelSetup* setup,
                  ApiError* error) {
  if (!ParseBevelJob(body, &setup->job, error)) return false;
  if (body.contains("motion") && !body.at("motion").is_null()) {
    if (!ParseFreeFormMotion(
            body.at("motion"), "motion", &setup->motion, error))
      return false;
    setup->motion_given = true;
    setup->grid = CradleGenerator(setup->job).BuildGrid();
    if (!setup->grid.ok) {
      *error =
          InvalidValue("job",
                       "the flank grid is not found on the cradle flank: " +
                           setup->grid.message);
      return false;
    }
    setup->nominal = setup->motion;
    return true;
  }
  const ConversionResult conversion =
      ConvertCradleToFreeForm(ConversionOptions(), setup->job);
  if (!conversion.ok) {
    *error = InvalidValue(
        "job", "the cradle summary cannot be converted: " + conversion.message);
    return false;
  }
  setup->grid = conversion.grid;
  setup->nominal = conversion.motion;
  setup->motion = conversion.motion;
  return true;
}

}  // namespace gearloop
