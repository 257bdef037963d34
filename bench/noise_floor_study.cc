// noise_floor_study: the closed loop of issue 3 on nine generated gears and
// targets, with the solver options given on the command line. Per case: the
// best reachable residual r of the first part's true error, the true rms error
// of each part of a noise-free loop of three corrections, and, over --seeds
// noise seeds (probe noise 0.5 um, two corrections), how many parts end within
// the least-squares noise floor sqrt(r^2 + sigma^2 chi^2_k(0.99) / N), with the
// mean and the worst final error. Prints a Markdown table (BENCHMARKS.md,
// "Noise floor").
//
//   build/bench/noise_floor_study [--seeds 100] [--max-order 3]
//   [--min-flank-effect 0.03]
//                                 [--discrepancy-principle]
//                                 [--at-commanded-settings]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench/bench_gears.h"
#include "engine/correction/correction.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/target_modification.h"
#include "engine/simulation/measurement_simulator.h"

namespace {

using namespace gearloop;

constexpr double kSigmaUm = 0.5;

struct Case {
  const char* name;
  GrindingSetup setup;
  std::vector<TargetModification> target;
  std::uint64_t hidden_seed;
  int hidden_order;
};

std::vector<Case> Cases() {
  const GrindingSetup cutter = bench::Cutter();
  const GrindingSetup right_hand = bench::RightHandLeftFlank();
  const GrindingSetup helical = bench::Helical();
  const GrindingSetup spur = bench::Spur();
  const std::vector<TargetModification> slopes = bench::SlopesAndCrowning();
  const TargetModification diagonal = bench::DiagonalEndRelief();
  return {
      {"cutter / slopes + crowning (hidden order 1)", cutter, slopes, 1001, 1},
      {"cutter / slopes + crowning", cutter, slopes, 42, 2},
      {"cutter / diagonal end relief", cutter, {diagonal}, 43, 2},
      {"cutter / 5 um lead crowning",
       cutter,
       {{ModificationKind::kLeadCrowning, 5.0}},
       48,
       2},
      {"right-hand, left flank / tip relief + twist",
       right_hand,
       {{ModificationKind::kTipRelief, 6.0, 0.3, ReliefShape::kParabolic},
        {ModificationKind::kFlankTwist, 4.0}},
       43,
       2},
      {"right-hand, left flank / 10 um root relief",
       right_hand,
       {{ModificationKind::kRootRelief, 10.0, 0.3, ReliefShape::kParabolic}},
       49,
       2},
      {"helical / crownings",
       helical,
       {{ModificationKind::kProfileCrowning, 3.0},
        {ModificationKind::kLeadCrowning, 5.0}},
       45,
       2},
      {"helical / slopes + crowning", helical, slopes, 46, 2},
      {"spur / crownings",
       spur,
       {{ModificationKind::kProfileCrowning, 3.0},
        {ModificationKind::kLeadCrowning, 3.0}},
       50,
       2},
  };
}

double ChiSquared99(int k) {  // Wilson-Hilferty
  const double z = 2.326348;
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

std::string Figure(double value) {
  if (!std::isfinite(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.3f", value);
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 100;
  CorrectionOptions options;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--seeds") == 0 && has_value) {
      seeds = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--max-order") == 0 && has_value) {
      options.default_max_order = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--min-flank-effect") == 0 && has_value) {
      options.min_flank_effect_um = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--discrepancy-principle") == 0) {
      options.use_discrepancy_principle = true;
    } else if (std::strcmp(argv[i], "--at-commanded-settings") == 0) {
      options.estimate_machine_state = false;
    } else {
      std::fprintf(stderr,
                   "usage: noise_floor_study [--seeds N] [--max-order K] "
                   "[--min-flank-effect UM] "
                   "[--discrepancy-principle] [--at-commanded-settings]\n");
      return 2;
    }
  }
  std::string error;
  if (seeds < 0 || !options.IsValid(&error)) {
    std::fprintf(stderr,
                 "noise_floor_study: %s\n",
                 seeds < 0 ? "--seeds must be >= 0" : error.c_str());
    return 2;
  }
  std::printf(
      "options: max order %d, min flank effect %.3g um, %s, %s; %d seeds of "
      "%.1f um probe noise\n\n",
      options.default_max_order,
      options.min_flank_effect_um,
      options.use_discrepancy_principle ? "discrepancy principle"
                                        : "unbiased predictive risk",
      options.estimate_machine_state ? "at the estimated machine state"
                                     : "at the commanded settings",
      seeds,
      kSigmaUm);
  std::printf(
      "| case | initial | r | noise-free loop: parts 1, 2, 3 | within the "
      "floor | floor | mean | worst |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : Cases()) {
    const FlatWheelGrinder grinder(c.setup);
    const Eigen::VectorXd nominal = grinder.nominal().ToVector();
    const Eigen::VectorXd hidden = RandomHiddenErrors(grinder,
                                                      grinder.roll_min_rad(),
                                                      grinder.roll_max_rad(),
                                                      2.0,
                                                      c.hidden_order,
                                                      0.4,
                                                      c.hidden_seed);
    const Eigen::VectorXd target = EvaluateTargetModifications(
        c.target, grinder.grid(), c.setup.gear, c.setup.flank);
    const int n = grinder.grid().NumPoints();

    CorrectionOptions exact = options;
    exact.probe_noise_um = 0.0;
    CorrectionInput input;
    input.model = &grinder;
    input.current_parameters = nominal;
    input.measured_um =
        SimulateMeasurement(grinder, nominal, hidden, {}).measured_um;
    input.target_um = target;
    const CorrectionResult first = ComputeCorrection(exact, input);
    const double r = first.summary.best_reachable_rms_um;

    ClosedLoopOptions noise_free;
    noise_free.corrections = 3;
    noise_free.correction = exact;
    const ClosedLoopResult run =
        SimulateClosedLoop(grinder, nominal, hidden, target, noise_free);
    std::string parts;
    for (size_t k = 1; k < 4; ++k) {
      if (!parts.empty()) parts += ", ";
      parts += k < run.iterations.size() ? Figure(run.iterations[k].true_rms_um)
                                         : "stopped";
      if (k - 1 < run.iterations.size() && run.iterations[k - 1].corrected &&
          run.iterations[k - 1].correction.status !=
              CorrectionStatus::kConverged) {
        parts += "*";
      }
    }

    int within = 0, stopped = 0;
    double sum = 0.0, worst = 0.0, floor_um = NAN;
    for (int seed = 1; seed <= seeds; ++seed) {
      ClosedLoopOptions loop;
      loop.corrections = 2;
      loop.measurement.probe_noise_um = kSigmaUm;
      loop.measurement.seed = 1000 + 2 * seed;
      loop.correction = options;
      loop.correction.probe_noise_um = kSigmaUm;
      const ClosedLoopResult noisy =
          SimulateClosedLoop(grinder, nominal, hidden, target, loop);
      if (!noisy.completed ||
          !std::isfinite(noisy.iterations.back().true_rms_um)) {
        ++stopped;
        continue;
      }
      const int k = noisy.iterations[1].correction.rank;
      floor_um = std::sqrt(r * r + kSigmaUm * kSigmaUm * ChiSquared99(k) / n);
      const double final_um = noisy.iterations.back().true_rms_um;
      if (final_um <= floor_um) ++within;
      sum += final_um;
      worst = std::max(worst, final_um);
    }
    const int finished = seeds - stopped;
    std::printf("| %s | %s | %s | %s | %d of %d%s | %s | %s | %s |\n",
                c.name,
                Figure(first.summary.initial_rms_um).c_str(),
                Figure(r).c_str(),
                parts.c_str(),
                within,
                seeds,
                stopped > 0
                    ? (" (" + std::to_string(stopped) + " stopped)").c_str()
                    : "",
                Figure(floor_um).c_str(),
                Figure(finished > 0 ? sum / finished : NAN).c_str(),
                Figure(finished > 0 ? worst : NAN).c_str());
    std::fflush(stdout);
  }
  return 0;
}
