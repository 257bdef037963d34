#include "server/services/reach_service.h"

#include <cmath>
#include <string>

#include "server/codec/request_keys.h"
#include "server/services/correction_service.h"
#include "server/services/machine_family.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

// The highest order any axis polynomial has (correction options).
constexpr int kHighestOrder = 6;

nlohmann::json FiniteOrNullJson(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

// The reach of one target from a perfect flank: target rms, the rms the model
// cannot make, the share of the target's square it can make, and the
// predicted residual of the solve.
nlohmann::json ReachJson(const CorrectionSummary& s) {
  const double target = s.initial_rms_um;
  const double left = s.best_reachable_rms_um;
  double share = std::nan("");
  if (target > 0.0 && std::isfinite(left))
    share = std::max(0.0, 1.0 - (left * left) / (target * target));
  return {{"target_rms_um", FiniteOrNullJson(target)},
          {"target_max_um", FiniteOrNullJson(s.initial_max_um)},
          {"unreachable_rms_um", FiniteOrNullJson(left)},
          {"reachable_share", FiniteOrNullJson(share)},
          {"predicted_residual_rms_um", FiniteOrNullJson(s.residual_rms_um)},
          {"predicted_residual_max_um", FiniteOrNullJson(s.residual_max_um)},
          {"rank", s.rank}};
}

// Solves `body` with `target` from a perfect flank; false with the error.
bool SolveReach(const ServiceContext& context,
                nlohmann::json body,
                const nlohmann::json& target,
                const nlohmann::json& zero_grid,
                CorrectionSummary* summary,
                ApiError* error) {
  body["target"] = target;
  body["measurement"] = {{"deviations_um", zero_grid}};
  CorrectionRun run;
  if (!RunCorrection(context, body, &run, error)) return false;
  *summary = run.result.summary;
  return true;
}

// The request without what a reach does not take, checked: a grinder setup
// with target.modifications. False with the refusal.
bool ReadReachRequest(const nlohmann::json& body,
                      nlohmann::json* zero_grid,
                      ApiError* error) {
  for (const char* key : {"measurement", "trace", "tolerance"}) {
    if (body.contains(key)) {
      *error = InvalidRequest(key,
                              std::string(key) +
                                  " is not taken here: a reach starts from a "
                                  "perfect flank, before anything is ground");
      return false;
    }
  }
  CorrectionProblem problem;
  if (!CorrectionProblemFor(body, &problem, error)) return false;
  if (!problem.evaluate_modifications) {
    *error = InvalidValue("target.modifications",
                          "a reach is computed for target modifications of "
                          "the flat-wheel grinder");
    return false;
  }
  const nlohmann::json target = body.value("target", nlohmann::json());
  if (!target.is_object() || !target.contains("modifications") ||
      !target["modifications"].is_array() || target["modifications"].empty()) {
    *error = InvalidRequest("target.modifications",
                            "target.modifications must be a non-empty array "
                            "of modifications");
    return false;
  }
  *zero_grid = nlohmann::json::array();
  for (int r = 0; r < problem.rows; ++r)
    zero_grid->push_back(std::vector<double>(problem.columns, 0.0));
  return true;
}

}  // namespace

void ReachTarget(const ServiceContext& context,
                 const httplib::Request& req,
                 httplib::Response& res) {
  nlohmann::json body;
  nlohmann::json zero_grid;
  ApiError error;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kTargetReach, body, "", &error) ||
      !ReadReachRequest(body, &zero_grid, &error))
    return RespondError(res, error);
  const nlohmann::json& modifications = body["target"]["modifications"];
  // All together first: it validates every modification with its own index.
  CorrectionSummary combined;
  if (!SolveReach(context, body, body["target"], zero_grid, &combined, &error))
    return RespondError(res, error);
  nlohmann::json components = nlohmann::json::array();
  for (size_t i = 0; i < modifications.size(); ++i) {
    CorrectionSummary one;
    if (!SolveReach(context,
                    body,
                    {{"modifications", {modifications[i]}}},
                    zero_grid,
                    &one,
                    &error))
      return RespondError(res, error);
    nlohmann::json reach = ReachJson(one);
    reach["index"] = i;
    reach["modification"] = modifications[i];
    components.push_back(reach);
  }
  // What higher orders would make: every axis polynomial free to order 6.
  nlohmann::json all_orders = body;
  all_orders["options"]["default_max_order"] = kHighestOrder;
  CorrectionSummary highest;
  nlohmann::json with_highest_orders;
  if (SolveReach(
          context, all_orders, body["target"], zero_grid, &highest, &error)) {
    with_highest_orders = ReachJson(highest);
    with_highest_orders["default_max_order"] = kHighestOrder;
  }
  RespondJson(res,
              200,
              {{"combined", ReachJson(combined)},
               {"components", components},
               {"with_highest_orders", with_highest_orders},
               {"status", CorrectionStatusName(combined.status)}});
}

}  // namespace gearloop
