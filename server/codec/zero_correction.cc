#include "server/codec/zero_correction.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace gearloop {
namespace {

// An error below this rms [um] is already the target.
constexpr double kOnTargetRmsUm = 1e-6;
// An error whose neighbour ratio (CorrectionSummary::error_neighbour_ratio:
// about 1 for probe scatter alone, near 0 for a smooth shape) is below this is
// a flank shape, not scatter: measuring again would show it again.
constexpr double kSmoothErrorRatio = 0.5;
// When the best reachable rms of a smooth error is at least this share of the
// error's, most of it is out of reach of the free axes: the advice is to free
// more of the machine.
constexpr double kMostlyOutOfReach = 0.9;
// A step or motion factor below this kept nothing of the change.
constexpr double kNothingKeptFraction = 1e-9;

std::string Num(double value, const char* format = "%.3g") {
  if (!std::isfinite(value)) return "-";
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

nlohmann::json Explain(const char* reason, const std::string& message) {
  return {{"reason", reason}, {"message", message}};
}

// The part of the error the linearised machine could make: sqrt(e^2 - best^2).
double ReachableRmsUm(const CorrectionSummary& s) {
  const double e = s.initial_rms_um, best = s.best_reachable_rms_um;
  if (!std::isfinite(e) || !std::isfinite(best)) return std::nan("");
  return std::sqrt(std::max(0.0, e * e - best * best));
}

// Scatter (rough over the grid) is measured again; a smooth shape mostly out
// of reach asks for more of the machine; a smooth shape the axes could make
// was taken for noise by the rule: a smaller stated noise lets the solve act.
// Before the neighbour ratio the advice read the reach alone, and a part
// measured as 0.24 um of noise with 97 % of its rms out of reach of orders 0-3
// was told to free more axes.
std::string NoiseAdvice(const CorrectionSummary& s) {
  const std::string measure_again =
      "Measure again (several teeth average the noise out) or state the "
      "probe noise if it is smaller";
  if (!(s.error_neighbour_ratio < kSmoothErrorRatio)) return measure_again;
  const std::string shape =
      "The error is a smooth shape, not probe scatter (error_neighbour_ratio " +
      Num(s.error_neighbour_ratio, "%.2f") +
      "; independent scatter gives about 1). ";
  if (s.best_reachable_rms_um >= kMostlyOutOfReach * s.initial_rms_um) {
    return shape + "Most of it is out of reach of the free axes: free " +
           (s.axis_orders_held_below_highest ? "higher orders, more axes"
                                             : "more axes") +
           " or the wheel's profile (options.max_order; POST "
           "/api/v1/targets/reach names which makes most of a target), or "
           "accept the part";
  }
  return shape +
         "The free axes could make part of it: state the probe noise if it "
         "is smaller than the rule took it to be, or accept the part";
}

nlohmann::json NothingAboveNoise(const CorrectionSummary& s) {
  const char* rule = RegularisationRuleName(s.rule);
  std::string noise;
  if (s.prediction_band.noise_stated) {
    noise = "the stated probe noise (options.probe_noise_um = " +
            Num(s.prediction_band.noise_sigma_um) + " um)";
  } else if (std::isfinite(s.prediction_band.stated_noise_um)) {
    noise = "the probe noise the measurement shows (" +
            Num(s.prediction_band.noise_sigma_um) +
            " um; the stated options.probe_noise_um = " +
            Num(s.prediction_band.stated_noise_um) +
            " um is contradicted by its scatter)";
  } else {
    noise = std::string("what ") + rule +
            " takes for noise (no options.probe_noise_um stated)";
  }
  return Explain(
      "nothing_above_noise",
      "zero correction: nothing above the noise. The regularisation rule " +
          std::string(rule) + " put the level at " +
          Num(s.regularisation_level) + ", keeping " +
          Num(s.effective_dof, "%.2g") + " effective directions of " +
          std::to_string(s.truncation_rank) +
          ": the part of the measured error the machine can make (rms " +
          Num(ReachableRmsUm(s)) + " um of " + Num(s.initial_rms_um) +
          " um; best reachable " + Num(s.best_reachable_rms_um) +
          " um) is no larger than " + noise + ". " + NoiseAdvice(s));
}

}  // namespace

nlohmann::json ZeroCorrectionExplainJson(const CorrectionSummary& s) {
  if (!s.IsSolutionUsable() || !std::isfinite(s.correction_size) ||
      s.correction_size > kNegligibleCorrectionSize)
    return nullptr;
  if (s.initial_rms_um <= kOnTargetRmsUm) {
    return Explain("already_on_target",
                   "zero correction: the measured flank already is the target "
                   "(error rms " +
                       Num(s.initial_rms_um) + " um)");
  }
  if (s.rank == 0 || s.truncation_rank == 0) {
    return Explain(
        "below_min_flank_effect",
        "zero correction: no direction the free axes can move the flank in "
        "changes it by more than options.min_flank_effect_um (rank " +
            std::to_string(s.rank) + " of " +
            std::to_string(s.num_free_parameters) +
            " free parameters): lower min_flank_effect_um, or free more axes "
            "or orders (options.default_max_order, options.max_order)");
  }
  if (s.status == CorrectionStatus::kNoSafeImprovement ||
      (s.safe_step_checked && s.step_fraction < kNothingKeptFraction)) {
    return Explain(
        "no_safe_improvement",
        "zero correction: no safe improvement. The solve's change (rank " +
            std::to_string(s.rank) + ", " + Num(s.effective_dof, "%.3g") +
            " effective directions) is predicted by the exact model to make "
            "no better part than the current settings (rms " +
            Num(s.safe_step_current_rms_um) +
            " um) at any fraction tried; the current settings are kept");
  }
  if (s.motion_scale < kNothingKeptFraction) {
    return Explain("motion_bound",
                   "zero correction: the axis motion bound scaled the change "
                   "to nothing (motion_scale " +
                       Num(s.motion_scale) + ")");
  }
  if (s.effective_dof < kNoEffectiveDirectionDof) return NothingAboveNoise(s);
  return Explain(
      "negligible_change",
      "zero correction: the change the solve keeps (size " +
          Num(s.correction_size) + ", " + Num(s.effective_dof, "%.3g") +
          " effective directions of rank " + std::to_string(s.rank) +
          ", step fraction " + Num(s.step_fraction) +
          ") moves the flank by less than a thousandth of a micrometre");
}

}  // namespace gearloop
