// The plain parts of correction.h: solver, mode, rule and status names,
// CorrectionOptions::IsValid and CorrectionSummary::BriefReport. The solver
// itself is correction.cc and its stages.
#include <cmath>
#include <sstream>
#include <string>

#include "engine/correction/correction.h"

namespace gearloop {

const char* CorrectionSolverName(CorrectionSolver solver) {
  switch (solver) {
    case CorrectionSolver::kRegularised:
      return "regularised";
    case CorrectionSolver::kParticleSwarm:
      return "pso";
    case CorrectionSolver::kPlainLeastSquares:
      return "lsq-plain";
  }
  return "unknown";
}

bool ParseCorrectionSolver(const std::string& name, CorrectionSolver* solver) {
  for (CorrectionSolver s : {CorrectionSolver::kRegularised,
                             CorrectionSolver::kParticleSwarm,
                             CorrectionSolver::kPlainLeastSquares}) {
    if (name == CorrectionSolverName(s)) {
      *solver = s;
      return true;
    }
  }
  return false;
}

const char* CorrectionModeName(CorrectionMode mode) {
  return mode == CorrectionMode::kRework ? "rework" : "next-part";
}

bool ParseCorrectionMode(const std::string& name, CorrectionMode* mode) {
  if (name == "next-part") {
    *mode = CorrectionMode::kNextPart;
    return true;
  }
  if (name == "rework") {
    *mode = CorrectionMode::kRework;
    return true;
  }
  return false;
}

const char* RegularisationRuleName(RegularisationRule rule) {
  switch (rule) {
    case RegularisationRule::kUnbiasedPredictiveRisk:
      return "upre";
    case RegularisationRule::kDiscrepancyPrinciple:
      return "discrepancy-principle";
    case RegularisationRule::kGeneralisedCrossValidation:
      return "gcv";
    case RegularisationRule::kNone:
      return "none";
  }
  return "unknown";
}

const char* CorrectionStatusName(CorrectionStatus status) {
  switch (status) {
    case CorrectionStatus::kConverged:
      return "converged";
    case CorrectionStatus::kNotConverged:
      return "not_converged";
    case CorrectionStatus::kInvalidInput:
      return "invalid_input";
    case CorrectionStatus::kNoSafeImprovement:
      return "no_safe_improvement";
  }
  return "unknown";
}

bool CorrectionOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (default_max_order < -1)
    return fail("default_max_order must be -1 (fixed) or an order >= 0");
  for (const auto& [name, order] : max_order) {
    if (order < -1)
      return fail("max_order[" + name +
                  "] must be -1 (fixed) or an order >= 0");
  }
  if (point_weights.size() > 0 &&
      !((point_weights.array() >= 0.0).all() && point_weights.allFinite())) {
    return fail("point_weights must be finite and >= 0");
  }
  if (lower_delta.size() != upper_delta.size())
    return fail("lower_delta and upper_delta must have the same size");
  for (int j = 0; j < lower_delta.size(); ++j) {
    if (std::isnan(lower_delta(j)) || std::isnan(upper_delta(j)) ||
        lower_delta(j) > 0.0 || upper_delta(j) < 0.0) {
      return fail("bounds on the change of parameter " + std::to_string(j) +
                  " must satisfy lower <= 0 <= upper");
    }
  }
  if (!std::isfinite(probe_noise_um))
    return fail("probe_noise_um must be finite (negative = unknown)");
  for (const auto& [name, scale] : block_scales) {
    if (!(scale > 0.0) || !std::isfinite(scale))
      return fail("block_scales[" + name + "] must be > 0");
  }
  if (!(min_relative_regularisation >= 0.0 &&
        min_relative_regularisation < 1.0)) {
    return fail("min_relative_regularisation must lie in [0, 1)");
  }
  if (!(min_flank_effect_um > 0.0) || !std::isfinite(min_flank_effect_um)) {
    return fail("min_flank_effect_um must be finite and > 0");
  }
  if (safe_step_halvings < 0 || safe_step_halvings > 30)
    return fail("safe_step_halvings must lie in [0, 30]");
  if (!(max_axis_motion_mm >= 0.0) || !std::isfinite(max_axis_motion_mm) ||
      !(max_axis_motion_rad >= 0.0) || !std::isfinite(max_axis_motion_rad)) {
    return fail("max_axis_motion_mm and max_axis_motion_rad must be >= 0");
  }
  if (max_num_iterations < 0) return fail("max_num_iterations must be >= 0");
  if (max_rework_passes < 1) return fail("max_rework_passes must be >= 1");
  if (!(rework_tolerance_um >= 0.0))
    return fail("rework_tolerance_um must be >= 0");
  if (!(outlier_threshold >= 0.0) || !(outlier_min_um >= 0.0))
    return fail("outlier settings must be >= 0");
  if (!(max_outlier_fraction >= 0.0 && max_outlier_fraction < 1.0))
    return fail("max_outlier_fraction must lie in [0, 1)");
  if (pso_particles < 1 || pso_generations < 1)
    return fail("pso_particles and pso_generations must be >= 1");
  if (!(pso_box > 0.0) || !(pso_inertia >= 0.0) || !(pso_cognitive >= 0.0) ||
      !(pso_social >= 0.0)) {
    return fail("pso_box must be > 0 and the swarm coefficients >= 0");
  }
  return true;
}

std::string CorrectionSummary::BriefReport() const {
  std::ostringstream out;
  out << "correction " << CorrectionSolverName(solver) << " ("
      << CorrectionModeName(mode) << "): " << CorrectionStatusName(status);
  if (!message.empty()) out << " (" << message << ")";
  if (IsSolutionUsable()) {
    out << ", rms " << initial_rms_um << " -> " << residual_rms_um
        << " um (best reachable " << best_reachable_rms_um << "), max "
        << residual_max_um << " um, size " << correction_size << ", rank "
        << rank << ", cond " << condition_number << ", "
        << RegularisationRuleName(rule) << " lambda " << regularisation_level
        << " dof " << effective_dof << ", " << iterations << " iterations, "
        << elapsed_ms << " ms";
    if (!outlier_indices.empty())
      out << ", " << outlier_indices.size() << " outlier(s)";
    if (!tooth_outlier_indices.empty())
      out << ", " << tooth_outlier_indices.size()
          << " point(s) with a tooth left out";
    if (!measured_not_reached_indices.empty())
      out << ", " << measured_not_reached_indices.size()
          << " measured point(s) the model does not reach, not predicted "
             "(largest |measured - target| "
          << measured_not_reached_max_um << " um)";
    out << ", machine state "
        << (machine_state_estimated ? "estimated" : "commanded");
    if (!machine_state_reason.empty())
      out << " (" << machine_state_reason << ")";
    if (!order_choice.empty()) out << ", " << order_choice;
    if (!motion_bound_beyond_roll_range.empty())
      out << ", motion bound " << motion_bound_beyond_roll_range;
    if (!exact_search.empty()) out << ", exact search " << exact_search;
    if (safe_step_checked) {
      out << ", safe step: motion x" << motion_scale << ", fraction "
          << step_fraction << " (exact rms " << safe_step_current_rms_um
          << " -> " << safe_step_predicted_rms_um;
      if (safe_step_state_spread_um > 0.0)
        out << ", spread " << safe_step_state_spread_um
            << " by what the measurement cannot tell of the state";
      const WheelParabolaEvidence& parabola = safe_step_wheel_parabola;
      if (parabola.asked && parabola.from_measurement)
        out << "; wheel parabola " << parabola.estimate_flank_um << " +- "
            << parabola.sd_flank_um
            << " um rms of flank as the measurement shows it";
      else if (parabola.asked)
        out << "; wheel parabola " << parabola.hedged_flank_um
            << " um rms of flank assumed (noise not known)";
      out << ")";
      if (!safe_step_shortened.empty())
        out << "; the whole change " << safe_step_shortened;
    }
    const PredictionBand& band = prediction_band;
    out << ", next part true rms " << band.expected_true_rms_um
        << " um (2 sigma " << band.true_rms_low_um[1] << ".."
        << band.true_rms_high_um[1] << ", noise " << band.noise_sigma_um
        << " um " << (band.noise_stated ? "stated" : "estimated");
    if (std::isfinite(band.stated_noise_um))
      out << " from the measurement's scatter; " << band.stated_noise_um
          << " um stated is contradicted";
    if (band.misfit_read_as_flank)
      out << " from a misfit, more than a probe scatters: the expected value "
             "counts all but "
          << band.noise_read_as_probe_um
          << " um of it as flank the next part keeps";
    out << ")";
  }
  return out.str();
}

}  // namespace gearloop
