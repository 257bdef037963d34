#include "server/services/grinder_service.h"

#include <limits>

#include "engine/core/sensitivity.h"
#include "engine/core/units.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/grinder_settings.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/request_keys.h"
#include "server/services/measurement_service.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

// Reads the body, the setup and (optionally) the settings common to
// nominal/evaluate/sensitivity.
bool ParseSetupAndSettings(const httplib::Request& req,
                           GrindingSetup* setup,
                           MachineSettings* settings,
                           ApiError* error) {
  nlohmann::json body;
  if (!ParseJsonBody(req.body, &body, error) ||
      !CheckRequestKeys(RequestSchema::kGrinderSetup, body, "", error) ||
      !ParseGrindingSetup(body, setup, error))
    return false;
  if (body.contains("settings") && !body.at("settings").is_null()) {
    return ParseMachineSettings(
        body.at("settings"), "settings", settings, error);
  }
  *settings = NominalSettings(*setup);
  return true;
}

}  // namespace

void GrinderNominal(const httplib::Request& req, httplib::Response& res) {
  GrindingSetup setup;
  MachineSettings settings;
  ApiError error;
  if (!ParseSetupAndSettings(req, &setup, &settings, &error))
    return RespondError(res, error);
  const FlatWheelGrinder grinder(setup);
  RespondJson(res,
              200,
              NominalToJson(setup,
                            grinder.nominal(),
                            grinder.roll_min_rad(),
                            grinder.roll_max_rad()));
}

void GrinderEvaluate(const httplib::Request& req, httplib::Response& res) {
  GrindingSetup setup;
  MachineSettings settings;
  ApiError error;
  if (!ParseSetupAndSettings(req, &setup, &settings, &error))
    return RespondError(res, error);
  const FlatWheelGrinder grinder(setup);
  ModelEvaluation evaluation;
  grinder.Evaluate(settings.ToVector(), /*with_jacobian=*/false, &evaluation);
  nlohmann::json answer = EvaluationToJson(grinder.grid(), evaluation);
  // The ISO 1328-1 figures of the ground flank, without the points not reached.
  Eigen::VectorXd deviations_um = evaluation.deviations_um;
  for (int i = 0; i < deviations_um.size(); ++i) {
    if (evaluation.status[i] != PointStatus::kOk)
      deviations_um[i] = std::numeric_limits<double>::quiet_NaN();
  }
  answer["iso1328"] =
      FlankQualityJson(setup.gear, setup.grid, deviations_um, {}, 0.0);
  RespondJson(res, 200, answer);
}

void GrinderSensitivity(const httplib::Request& req, httplib::Response& res) {
  GrindingSetup setup;
  MachineSettings settings;
  ApiError error;
  if (!ParseSetupAndSettings(req, &setup, &settings, &error))
    return RespondError(res, error);
  const FlatWheelGrinder grinder(setup);
  ModelEvaluation evaluation;
  grinder.Evaluate(settings.ToVector(), /*with_jacobian=*/true, &evaluation);
  // The API quotes the cone-angle column per degree (API.md); the engine per
  // radian.
  Eigen::MatrixXd matrix = evaluation.jacobian_um;
  matrix.col(kConeAngleIndex) /= kDegPerRad;
  const SensitivitySummary raw = AnalyzeSensitivity(matrix, Eigen::VectorXd());
  const SensitivitySummary normalised =
      AnalyzeSensitivity(matrix, UnitColumnScales(matrix));
  RespondJson(
      res,
      200,
      SensitivityToJson(matrix, raw, normalised, grinder.grid(), evaluation));
}

}  // namespace gearloop
