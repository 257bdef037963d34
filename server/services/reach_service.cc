#include "server/services/reach_service.h"

#include <cmath>
#include <string>

#include "server/codec/request_keys.h"
#include "server/services/correction_service.h"
#include "server/services/machine_family.h"
#include "server/services/reach_remedy.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

// The highest order any axis polynomial has (correction options).
constexpr int kHighestOrder = 6;

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

// The reach answer of a checked request: all together, each modification
// with its remedy, and all together with every axis free to order 6. False
// with the error of a modification the solve refuses.
bool ComputeReach(const ServiceContext& context,
                  const nlohmann::json& body,
                  const nlohmann::json& zero_grid,
                  nlohmann::json* answer,
                  ApiError* error) {
  const nlohmann::json& modifications = body["target"]["modifications"];
  // All together first: it validates every modification with its own index.
  CorrectionSummary combined;
  if (!SolveReach(context, body, body["target"], zero_grid, &combined, error))
    return false;
  nlohmann::json components = nlohmann::json::array();
  for (size_t i = 0; i < modifications.size(); ++i) {
    CorrectionSummary one;
    if (!SolveReach(context,
                    body,
                    {{"modifications", {modifications[i]}}},
                    zero_grid,
                    &one,
                    error))
      return false;
    nlohmann::json reach = ReachJson(one);
    reach["index"] = i;
    reach["modification"] = modifications[i];
    const nlohmann::json& share = reach["reachable_share"];
    reach["remedy"] =
        ReachRemedyJson(context,
                        body,
                        modifications[i],
                        zero_grid,
                        share.is_number() ? share.get<double>() : std::nan(""));
    components.push_back(reach);
  }
  // What higher orders would make: every axis polynomial free to order 6
  // (the combined solve itself where the options already open them all, the
  // default).
  const bool raised = combined.axis_orders_held_below_highest;
  CorrectionSummary highest;
  nlohmann::json with_highest_orders;
  ApiError ignored;
  const nlohmann::json combined_json = ReachJson(combined);
  if (!raised) {
    with_highest_orders = combined_json;
  } else {
    nlohmann::json all_orders = body;
    all_orders["options"] =
        WithEveryAxisAtHighestOrder(body.value("options", nlohmann::json()));
    if (SolveReach(
            context, all_orders, body["target"], zero_grid, &highest, &ignored))
      with_highest_orders = ReachJson(highest);
  }
  if (with_highest_orders.is_object()) {
    with_highest_orders["default_max_order"] = kHighestOrder;
    with_highest_orders["same_as_combined"] = !raised;
  }
  *answer = {{"combined", combined_json},
             {"components", components},
             {"with_highest_orders", with_highest_orders},
             {"status", CorrectionStatusName(combined.status)}};
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
  nlohmann::json answer;
  if (!ComputeReach(context, body, zero_grid, &answer, &error))
    return RespondError(res, error);
  RespondJson(res, 200, answer);
}

nlohmann::json CorrectionReachJson(const ServiceContext& context,
                                   const nlohmann::json& body) {
  nlohmann::json reach = body;
  for (const char* key :
       {"measurement", "trace", "tolerance", "settings_source_job_id"})
    reach.erase(key);
  nlohmann::json zero_grid;
  nlohmann::json answer;
  ApiError ignored;
  if (!ReadReachRequest(reach, &zero_grid, &ignored) ||
      !ComputeReach(context, reach, zero_grid, &answer, &ignored))
    return nullptr;
  return answer;
}

}  // namespace gearloop
