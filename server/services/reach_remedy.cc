#include "server/services/reach_remedy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace gearloop {
namespace {

// The highest order any axis polynomial has (correction options).
constexpr int kHighestOrder = 6;
// Two shares closer than this are the same (the lower order is named).
constexpr double kSameShare = 1e-4;
const char* const kAxes[] = {"X", "Y", "Z", "A", "B", "C"};

nlohmann::json FiniteOrNullJson(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

// 1 - (unreachable / target)^2, NaN without a target. Unreachable: the larger
// of the linear best reachable and the correction's exact prediction (within
// the motion bound): the per-direction filter follows weak directions whose
// linear reach a bounded move need not make.
double ShareOf(const CorrectionSummary& s) {
  const double target = s.initial_rms_um;
  const double left = std::max(s.best_reachable_rms_um, s.residual_rms_um);
  if (!(target > 0.0) || !std::isfinite(left)) return std::nan("");
  return std::max(0.0, 1.0 - (left * left) / (target * target));
}

std::string Percent(double share) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f %%", 100.0 * share);
  return text;
}

// The order axis block `axis` may change at in `options` (max_order, else
// default_max_order, else the engine's default).
int CurrentOrder(const nlohmann::json& options, const std::string& axis) {
  int order = CorrectionOptions().default_max_order;
  if (options.is_object()) {
    const nlohmann::json& d =
        options.value("default_max_order", nlohmann::json());
    if (d.is_number_integer()) order = d.get<int>();
    const nlohmann::json& named = options.value("max_order", nlohmann::json());
    if (named.is_object() && named.contains(axis) &&
        named[axis].is_number_integer())
      order = named[axis].get<int>();
  }
  return std::min(order, kHighestOrder);
}

}  // namespace

nlohmann::json WithEveryAxisAtHighestOrder(const nlohmann::json& options) {
  nlohmann::json opened =
      options.is_object() ? options : nlohmann::json::object();
  opened["default_max_order"] = kHighestOrder;
  if (opened.contains("max_order") && opened["max_order"].is_object()) {
    for (const char* axis : kAxes) {
      nlohmann::json& named = opened["max_order"];
      if (named.contains(axis) && named[axis].is_number_integer() &&
          named[axis].get<int>() >= 0)
        named[axis] = kHighestOrder;
    }
  }
  return opened;
}

namespace {

// The share of `modification` with each block of `orders` set to its order
// in options.max_order (the rest as sent); NaN when that solve is refused.
double ShareWithOrders(const ServiceContext& context,
                       nlohmann::json body,
                       const nlohmann::json& modification,
                       const nlohmann::json& zero_grid,
                       const std::vector<std::pair<std::string, int>>& orders) {
  for (const auto& [axis, order] : orders)
    body["options"]["max_order"][axis] = order;
  CorrectionSummary summary;
  ApiError ignored;
  if (!SolveReach(context,
                  body,
                  {{"modifications", {modification}}},
                  zero_grid,
                  &summary,
                  &ignored))
    return std::nan("");
  return ShareOf(summary);
}

struct OrderRemedy {
  std::string axis;
  int order = -1;
  double share = std::nan("");
};

// (a): every axis opened one order higher at a time, up to 6.
OrderRemedy BestHigherOrder(const ServiceContext& context,
                            const nlohmann::json& body,
                            const nlohmann::json& modification,
                            const nlohmann::json& zero_grid) {
  OrderRemedy best;
  const nlohmann::json options = body.value("options", nlohmann::json());
  for (const char* axis : kAxes) {
    for (int order = CurrentOrder(options, axis) + 1; order <= kHighestOrder;
         ++order) {
      const double share = ShareWithOrders(
          context, body, modification, zero_grid, {{axis, order}});
      if (!std::isfinite(share)) continue;
      if (best.order < 0 || share > best.share + kSameShare)
        best = {axis, order, share};
    }
  }
  return best;
}

// The wheel's profile freed (cone angle, parabola coefficient and vertex, the
// parabola being fixed by default): a dressed wheel form. NaN when refused.
double ShareWithWheelProfile(const ServiceContext& context,
                             const nlohmann::json& body,
                             const nlohmann::json& modification,
                             const nlohmann::json& zero_grid) {
  return ShareWithOrders(
      context,
      body,
      modification,
      zero_grid,
      {{"cone_angle", 0}, {"parabola_coefficient", 0}, {"parabola_vertex", 0}});
}

bool IsLeadModification(const nlohmann::json& modification) {
  const std::string kind = modification.value("kind", "");
  return kind == "lead_crowning" || kind == "helix_slope" ||
         kind == "end_relief" || kind == "flank_twist";
}

bool IsFixedWheel(const nlohmann::json& body) {
  const nlohmann::json machine = body.value("machine", nlohmann::json());
  const nlohmann::json cs =
      machine.is_object()
          ? machine.value("traverse_mm_per_rad", nlohmann::json())
          : nlohmann::json();
  return !cs.is_number() || cs.get<double>() == 0.0;
}

// (b): C_s freed, i.e. X and Z open to at least order 1 (the file comment of
// reach_remedy.h).
nlohmann::json WheelTraverseJson(const ServiceContext& context,
                                 const nlohmann::json& body,
                                 const nlohmann::json& modification,
                                 const nlohmann::json& zero_grid,
                                 double share) {
  const nlohmann::json options = body.value("options", nlohmann::json());
  const double freed =
      ShareWithOrders(context,
                      body,
                      modification,
                      zero_grid,
                      {{"X", std::max(1, CurrentOrder(options, "X"))},
                       {"Z", std::max(1, CurrentOrder(options, "Z"))}});
  return {{"reachable_share", FiniteOrNullJson(freed)},
          {"share_gain",
           FiniteOrNullJson(std::isfinite(freed) ? freed - share : freed)},
          {"in_model", false}};
}

std::string TraverseMessage(const OrderRemedy& best,
                            double profile,
                            const nlohmann::json& traverse,
                            double share) {
  std::string said =
      "a lead modification on the fixed-wheel setup (traverse_mm_per_rad 0): ";
  if (best.order >= 0)
    said += "no axis up to order 6 helps (best " + best.axis + " to order " +
            std::to_string(best.order) + ": " + Percent(best.share) +
            " against " + Percent(share) + " now), ";
  if (std::isfinite(profile))
    said += "nor the wheel's profile (" + Percent(profile) + "); ";
  said +=
      "the rest needs the wheel to traverse along the lead as a motion of "
      "its own, the axes following the traverse position. The model's "
      "traverse C_s moves the wheel along the lead per radian of roll and "
      "enters only the first-order X and Z coefficients, so freeing it "
      "reaches ";
  const nlohmann::json& freed = traverse["reachable_share"];
  said += freed.is_number() ? Percent(freed.get<double>()) : "-";
  return said +
         " (computed); a machine with its own traverse along the lead is "
         "outside this model";
}

}  // namespace

nlohmann::json ReachJson(const CorrectionSummary& s) {
  return {{"target_rms_um", FiniteOrNullJson(s.initial_rms_um)},
          {"target_max_um", FiniteOrNullJson(s.initial_max_um)},
          {"unreachable_rms_um", FiniteOrNullJson(s.best_reachable_rms_um)},
          {"reachable_share", FiniteOrNullJson(ShareOf(s))},
          {"predicted_residual_rms_um", FiniteOrNullJson(s.residual_rms_um)},
          {"predicted_residual_max_um", FiniteOrNullJson(s.residual_max_um)},
          {"rank", s.rank}};
}

bool SolveReach(const ServiceContext& context,
                nlohmann::json body,
                const nlohmann::json& target,
                const nlohmann::json& zero_grid,
                CorrectionSummary* summary,
                ApiError* error) {
  body["target"] = target;
  body["measurement"] = {{"deviations_um", zero_grid}};
  body.erase("tolerance");
  CorrectionRun run;
  if (!RunCorrection(context, body, &run, error)) return false;
  *summary = run.result.summary;
  return true;
}

nlohmann::json ReachRemedyJson(const ServiceContext& context,
                               const nlohmann::json& body,
                               const nlohmann::json& modification,
                               const nlohmann::json& zero_grid,
                               double share) {
  if (!std::isfinite(share) || share >= kWholeReachShare) return nullptr;
  const OrderRemedy best =
      BestHigherOrder(context, body, modification, zero_grid);
  nlohmann::json higher = nullptr;
  if (best.order >= 0) {
    higher = {{"axis", best.axis},
              {"order", best.order},
              {"reachable_share", best.share},
              {"share_gain", best.share - share}};
  }
  const double profile =
      ShareWithWheelProfile(context, body, modification, zero_grid);
  const auto helps = [share](double with) {
    return std::isfinite(with) &&
           (with - share >= kUsefulShareGain ||
            with - share >= kUsefulGapShare * (1.0 - share) ||
            with >= kWholeReachShare);
  };
  const bool orders_help = best.order >= 0 && helps(best.share);
  const bool profile_helps =
      helps(profile) && (!orders_help || profile > best.share + kSameShare);
  nlohmann::json remedy = {
      {"higher_order", higher},
      {"wheel_profile",
       {{"reachable_share", FiniteOrNullJson(profile)},
        {"share_gain",
         FiniteOrNullJson(std::isfinite(profile) ? profile - share
                                                 : profile)}}},
      {"wheel_traverse", nullptr}};
  const bool lead_on_fixed_wheel =
      IsLeadModification(modification) && IsFixedWheel(body);
  if (lead_on_fixed_wheel) {
    remedy["wheel_traverse"] =
        WheelTraverseJson(context, body, modification, zero_grid, share);
  }
  if (profile_helps) {
    remedy["kind"] = "wheel_profile";
    remedy["message"] =
        "free the wheel's profile (options.max_order.parabola_coefficient 0 "
        "and parabola_vertex 0: a dressed wheel form; the parabola is fixed "
        "by default): " +
        Percent(profile) + " of it made, against " + Percent(share) + " now";
  } else if (orders_help) {
    remedy["kind"] = "higher_order";
    remedy["message"] = "open axis " + best.axis + " to order " +
                        std::to_string(best.order) + " (options.max_order." +
                        best.axis + "): " + Percent(best.share) +
                        " of it made, against " + Percent(share) + " now";
  } else if (lead_on_fixed_wheel) {
    remedy["kind"] = "wheel_traverse";
    remedy["message"] =
        TraverseMessage(best, profile, remedy["wheel_traverse"], share);
  } else {
    remedy["kind"] = "outside_model";
    remedy["message"] =
        "neither an axis up to order 6 nor the wheel's profile raises the "
        "share by " +
        Percent(kUsefulShareGain) +
        " or closes half of what is missing; the rest needs another motion "
        "than this machine model has";
  }
  return remedy;
}

}  // namespace gearloop
