// server/services/reach_remedy.h: what would make the rest of a target
// component the machine configuration cannot make whole (issue 16 item 1),
// computed by solving the reach projection again, never guessed:
//
//   (a) a higher order on one axis: each axis block X..C in turn is opened one
//       order higher at a time, up to 6, the rest of the options as sent; the
//       axis and order whose share is highest is named (the lowest order of
//       the best, on a tie);
//   (b) the wheel's profile freed (cone angle, parabola coefficient and
//       vertex; the parabola is fixed by default): a dressed wheel form;
//   (c) for a lead modification (lead crowning, helix slope, end relief, flank
//       twist: they vary along the face width) on the fixed-wheel setup
//       (machine.traverse_mm_per_rad = 0), the wheel traverse along the lead.
//       The model's only traverse is C_s, the wheel's travel along the lead
//       per radian of ROLL (MODEL.md §1-2): it enters nothing but the
//       first-order X and Z coefficients (X1 = C_s cos b, Z1 = -C_s sin b), so
//       freeing it is computed as opening X and Z to at least order 1, and it
//       gains nothing the axes do not already have. A lead form needs the
//       wheel to travel along the lead as a motion of its own, which this
//       model does not describe: the remedy says so (in_model false).
//
// The remedy's kind is the one of (a), (b) that helps most, else (c) when it
// applies, else "outside_model".
//
//   nlohmann::json remedy = ReachRemedyJson(context, body, modification,
//                                           zero_grid, share);
//   // null when share >= kWholeReachShare
#ifndef GEARLOOP_SERVER_SERVICES_REACH_REMEDY_H_
#define GEARLOOP_SERVER_SERVICES_REACH_REMEDY_H_

#include <nlohmann/json.hpp>

#include "server/services/correction_service.h"
#include "server/services/service_context.h"

namespace gearloop {

// A component whose reachable share is at least this is made whole (the CLI's
// `gearloop reach` exits 0 only when every component is).
constexpr double kWholeReachShare = 0.99;
// A remedy "helps" when it raises the share by at least kUsefulShareGain, or
// closes at least kUsefulGapShare of what is missing (1 - share), or makes the
// component whole.
constexpr double kUsefulShareGain = 0.05;
constexpr double kUsefulGapShare = 0.5;

// The reach of one target from a perfect flank: target rms and max, the rms
// the model cannot make, the reachable share 1 - (unreachable / target)^2, the
// predicted residual and the rank.
nlohmann::json ReachJson(const CorrectionSummary& summary);

// `options` (a request's correction options, null or an object) with every
// axis block X..C that moves opened to order 6: default_max_order 6, and
// every max_order entry of an axis at 0-5 raised to 6 (an axis held fixed,
// max_order < 0, stays fixed). Whether that opens anything is the engine's
// decision (CorrectionSummary::axis_orders_held_below_highest).
nlohmann::json WithEveryAxisAtHighestOrder(const nlohmann::json& options);

// Solves the correction `body` (a grinder request without measurement) for
// `target` from a perfect flank (`zero_grid` measured); false with the error.
bool SolveReach(const ServiceContext& context,
                nlohmann::json body,
                const nlohmann::json& target,
                const nlohmann::json& zero_grid,
                CorrectionSummary* summary,
                ApiError* error);

// The remedy of the target modification `modification` of request `body`
// whose reachable share is `share` (see the file comment): {"kind":
// "higher_order" | "wheel_profile" | "wheel_traverse" | "outside_model",
// "message", "higher_order": {axis, order, reachable_share, share_gain} | null,
// "wheel_profile": {reachable_share, share_gain}, "wheel_traverse":
// {reachable_share, share_gain, in_model: false} | null (not a lead
// modification on the fixed wheel)};
// null when share >= kWholeReachShare or is not a number.
nlohmann::json ReachRemedyJson(const ServiceContext& context,
                               const nlohmann::json& body,
                               const nlohmann::json& modification,
                               const nlohmann::json& zero_grid,
                               double share);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_REACH_REMEDY_H_
