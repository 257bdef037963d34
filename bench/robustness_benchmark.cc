// robustness_benchmark: how safe and how good the correction solver is on a
// broad, seeded range of gears (issue 13). For every scenario
// (bench/robustness_scenarios.h) and solver configuration, three rounds of
// grind -> measure -> correct against the machine with its hidden errors, and
// the best flank error reachable from the true hidden state
// (bench/best_reachable.h). Reports rounds that made a part worse, final / best
// reachable, prediction against achievement, axis motion against the bounds and
// CPU per correction; each worse round with the points the next part has that
// the current one lacked and both parts' rms over the points both have
// (RoundRecord). A study, not a timing test (BENCHMARKS.md, "Robustness";
// bench/round_probe.cc looks at one round in detail).
//
//   build/bench/robustness_benchmark
//       [--scenarios 200] [--bevel 10] [--seed 2026]
//       [--orders default|cubic|both] [--threads 1] [--json FILE] [--verbose]
//       [--only I] [--only-bevel I] [--bound-wheel] [--reach-iterations 300]
//       [--fix BLOCK]... [--no-state] [--solver pso] [--compare pso]
//       [--error-scale 1] [--noise-scale 1] [--told-noise-scale 1]
//
// --only I runs the flat-wheel scenario I alone, drawn as in the full run;
// --only-bevel I the bevel generator's scenario I.
// --bound-wheel bounds the reference's wheel profile (bench/best_reachable.h).
// --fix BLOCK (repeatable) fixes a parameter block in every configuration
// (max_order[BLOCK] = -1); --no-state turns estimate_machine_state off. Both
// are for studies; the figures in BENCHMARKS.md use neither.
// --error-scale F and --noise-scale F multiply every hidden error's size and
// the probe noise (bench/robustness_scenarios.h, StressOptions): a stress
// study outside the shop ranges, the scenarios otherwise drawn as without.
// --told-noise-scale F tells the solver F x the probe's sigma in the
// scenarios whose noise is told (a shop stating its probe wrong).
// --reach-iterations 1 skips most of the reference optimiser's work (its
// figures are then meaningless) for a quick count of worse rounds (~25 s).
//
// --orders default: the solver's default options (default_max_order 6: every
// order 0-6 open, the bevel generator's degree 5); cubic: every axis held to
// its cubic term (default_max_order 3, the default before issue 13's order
// choice); both (the default) runs both. "all" is a second name of
// "default".
// --solver NAME runs every configuration with that solver instead of the
// default ("regularised"; "pso" is the published swarm, MODEL.md §6).
// --compare NAME runs, beside each configuration, its twin with that solver on
// the same scenarios (scored against the same best reachable) and reports,
// per scenario, the true rms of the next part, the correction size (largest
// axis motion over the roll range against its bound, and MODEL.md §6 size)
// and the CPU per correction of both: round 1 from the same measured part, and
// each solver's own three-round loop (BENCHMARKS.md, "Default vs published pso
// on the robustness scenarios").
// --threads runs scenarios in parallel; every correction stays on one thread
// and its CPU time is that thread's (CLOCK_THREAD_CPUTIME_ID).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "bench/best_reachable.h"
#include "bench/robustness_scenarios.h"
#include "engine/correction/correction.h"

namespace {

using namespace gearloop;
using bench::LoopRecord;
using bench::RoundRecord;
using bench::Scenario;

constexpr int kRounds = 3;

struct Config {
  std::string name;
  CorrectionOptions options;
  int reach_order = 3;
  // A baseline twin (--compare) of configuration `reference_of`: the same
  // options but the solver, and that configuration's best reachable (the
  // reference is not run again, and the twin's end points are not among its
  // starts). -1: a configuration of its own.
  int reference_of = -1;
};

struct ConfigOutcome {
  LoopRecord loop;
  bench::ReachResult reach;
  double ratio = 0.0;   // final / max(best, 0.01 um)
  bool within = false;  // final <= 1.2 best + sigma
};

struct ScenarioOutcome {
  Scenario scenario;
  std::vector<ConfigOutcome> configs;
  double reference_cpu_s = 0.0;
};

double Quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(
              v.begin(), v.end(), [](double x) { return std::isnan(x); }),
          v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double at = q * (v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at));
  const size_t hi = std::min(v.size() - 1, lo + 1);
  return v[lo] + (at - lo) * (v[hi] - v[lo]);
}

std::string Num(double v, const char* format = "%.3g") {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[64];
  std::snprintf(text, sizeof(text), format, v);
  return text;
}

std::string JsonNum(double v) {
  if (!std::isfinite(v)) return "null";
  char text[64];
  std::snprintf(text, sizeof(text), "%.6g", v);
  return text;
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// The best reachable for configuration k (bench/best_reachable.h), started
// from the cancellation of the hidden errors, the end points of the
// configurations with no more freedom and their references (baseline twins'
// left out).
bench::ReachResult ReferenceFor(const Scenario& s,
                                const std::vector<Config>& configs,
                                size_t k,
                                const ScenarioOutcome& out,
                                const bench::ReachOptions& reach) {
  std::vector<std::pair<std::string, Eigen::VectorXd>> starts;
  starts.push_back({"cancel hidden errors", -s.hidden_errors});
  // The solver's own end points: of this configuration and of any with no
  // more freedom.
  for (size_t j = 0; j < configs.size(); ++j) {
    if (configs[j].reference_of < 0 &&
        configs[j].reach_order <= configs[k].reach_order) {
      starts.push_back(
          {"solver final (" + configs[j].name + ")",
           out.configs[j].loop.final_parameters - s.initial_parameters});
    }
  }
  // The references of configurations with no more freedom: a larger free set
  // reaches at least as low.
  for (size_t j = 0; j < k; ++j) {
    if (configs[j].reference_of < 0 &&
        configs[j].reach_order <= configs[k].reach_order &&
        out.configs[j].reach.delta.size() > 0) {
      starts.push_back(
          {"reference (" + configs[j].name + ")", out.configs[j].reach.delta});
    }
  }
  const Eigen::VectorXd true_state = s.initial_parameters + s.hidden_errors;
  return bench::BestReachable(*s.model,
                              true_state,
                              s.target_um,
                              s.roll_min_rad,
                              s.roll_max_rad,
                              starts,
                              reach);
}

// final / best reachable and whether final <= 1.2 best + sigma.
void ScoreAgainstReference(const Scenario& s, ConfigOutcome* o) {
  const double final_rms = o->loop.part_rms_um.back();
  o->ratio = final_rms / std::max(o->reach.rms_um, 0.01);
  o->within = final_rms <= 1.2 * o->reach.rms_um + s.probe_noise_um;
}

void PrintReachStarts(const Scenario& s,
                      const std::string& config,
                      const bench::ReachResult& reach) {
  for (const bench::ReachStart& st : reach.starts) {
    std::fprintf(stderr,
                 "  scenario %d %s: start %s (%.4g um, %d halvings) -> %.4g um "
                 "in %d iterations\n",
                 s.index,
                 config.c_str(),
                 st.name.c_str(),
                 st.start_rms_um,
                 st.halvings,
                 st.rms_um,
                 st.iterations);
  }
}

ScenarioOutcome RunScenario(const Scenario& s,
                            const std::vector<Config>& configs,
                            std::uint64_t seed,
                            bool bound_wheel,
                            int reach_iterations,
                            const std::vector<std::string>& reference_fixed) {
  ScenarioOutcome out;
  out.scenario = s;
  for (const Config& c : configs) {
    ConfigOutcome o;
    o.loop = bench::RunClosedLoop(s, c.options, kRounds);
    out.configs.push_back(o);
  }
  const double start = bench::ThreadCpuMs();
  for (size_t k = 0; k < configs.size(); ++k) {
    if (configs[k].reference_of >= 0) continue;
    bench::ReachOptions reach;
    reach.max_order = configs[k].reach_order;
    reach.max_iterations = reach_iterations;
    reach.seed = seed + s.index;
    reach.fixed_blocks = reference_fixed;
    // The wheel is as free as the solver's (issue 13 bounds the axes). With
    // --bound-wheel its profile is bounded like an axis over the working depth
    // D = (r_a - r_f) / cos(alpha_n): change within 0.2 mm, slope within
    // 3e-3 rad (the solver's own wheel changes may then lie outside).
    if (!s.bevel && bound_wheel) {
      const GearData& g = s.setup.gear;
      reach.wheel_depth_mm = (g.tip_radius_mm - g.root_radius_mm) /
                             std::cos(g.normal_pressure_angle_rad);
    }
    ConfigOutcome& o = out.configs[k];
    o.reach = ReferenceFor(s, configs, k, out, reach);
    ScoreAgainstReference(s, &o);
    if (std::getenv("ROBUSTNESS_DEBUG_REACH") != nullptr)
      PrintReachStarts(s, configs[k].name, o.reach);
  }
  // A baseline twin is scored against its configuration's best reachable.
  for (size_t k = 0; k < configs.size(); ++k) {
    if (configs[k].reference_of < 0) continue;
    out.configs[k].reach = out.configs[configs[k].reference_of].reach;
    ScoreAgainstReference(s, &out.configs[k]);
  }
  out.reference_cpu_s = 1e-3 * (bench::ThreadCpuMs() - start);
  return out;
}

// What the scenarios drew (PrintDistribution's counts and value lists).
struct DrawnScenarios {
  int grinder = 0, spur = 0, left_hand = 0, right_hand = 0, left_flank = 0,
      k_offsets = 0, user_grids = 0;
  int told = 0, outliers = 0, missing = 0, teeth = 0, redraws = 0, bevel = 0,
      perturbed = 0;
  std::vector<double> z, module, helix, face, wheel, sigma, errors;
  std::map<std::string, int> blocks, kinds;
  std::map<int, int> orders;
};

DrawnScenarios CountDrawn(const std::vector<ScenarioOutcome>& outcomes) {
  DrawnScenarios d;
  for (const ScenarioOutcome& o : outcomes) {
    const Scenario& s = o.scenario;
    d.redraws += s.redraws;
    for (const bench::HiddenErrorTerm& t : s.hidden_terms) {
      ++d.blocks[t.block];
      if (t.block.size() == 1) ++d.orders[t.order];
    }
    d.errors.push_back(s.hidden_terms.size());
    d.sigma.push_back(s.probe_noise_um);
    d.told += s.noise_told;
    d.outliers += s.measurement.outlier_probability > 0.0;
    d.missing += s.measurement.missing_probability > 0.0;
    d.teeth += s.measurement.teeth > 1;
    if (s.bevel) {
      ++d.bevel;
      d.perturbed += s.bevel_perturbed;
      continue;
    }
    ++d.grinder;
    const GearData& g = s.setup.gear;
    d.z.push_back(g.teeth);
    d.module.push_back(g.normal_module_mm);
    d.helix.push_back(std::abs(g.helix_angle_rad) / kRadPerDeg);
    d.face.push_back(g.face_width_mm / g.normal_module_mm);
    d.wheel.push_back(s.setup.wheel.radius_mm);
    d.spur += g.helix_angle_rad == 0.0;
    d.left_hand += g.helix_angle_rad > 0.0;
    d.right_hand += g.helix_angle_rad < 0.0;
    d.left_flank += s.setup.flank == Flank::kLeft;
    d.k_offsets += s.setup.machine.k1_mm != 0.0;
    d.user_grids += s.user_grid;
    for (const TargetModification& m : s.target_kinds)
      ++d.kinds[ModificationKindName(m.kind)];
  }
  return d;
}

void PrintDistribution(const std::vector<ScenarioOutcome>& outcomes) {
  const DrawnScenarios d = CountDrawn(outcomes);
  auto range = [](const std::vector<double>& v, const char* format) {
    if (v.empty()) return std::string("-");
    return Num(*std::min_element(v.begin(), v.end()), format) + ".." +
           Num(Quantile(v, 0.5), format) + ".." +
           Num(*std::max_element(v.begin(), v.end()), format);
  };
  std::printf("## Scenarios drawn (min..median..max)\n\n");
  std::printf(
      "flat-wheel grinder: %d scenarios (%d redraws refused by validation or "
      "reach, over all)\n",
      d.grinder,
      d.redraws);
  if (d.grinder > 0) {
    std::printf(
        "  spur %d, helical %d (left hand %d, right hand %d), |beta| %s deg\n",
        d.spur,
        d.grinder - d.spur,
        d.left_hand,
        d.right_hand,
        range(d.helix, "%.1f").c_str());
    std::printf("  right flank %d, left flank %d; K1/K2 offsets %d\n",
                d.grinder - d.left_flank,
                d.left_flank,
                d.k_offsets);
    std::printf("  z %s, m_n %s mm, b/m_n %s, R_w %s mm\n",
                range(d.z, "%.0f").c_str(),
                range(d.module, "%.2f").c_str(),
                range(d.face, "%.1f").c_str(),
                range(d.wheel, "%.0f").c_str());
    std::printf("  targets: user grids %d; kinds:", d.user_grids);
    for (const auto& k : d.kinds)
      std::printf(" %s %d,", k.first.c_str(), k.second);
    std::printf("\n");
  }
  std::printf("bevel generator: %d scenarios (%d perturbed pinions)\n",
              d.bevel,
              d.perturbed);
  std::printf("hidden errors per scenario %s; by block:",
              range(d.errors, "%.0f").c_str());
  for (const auto& b : d.blocks)
    std::printf(" %s %d,", b.first.c_str(), b.second);
  std::printf(" axis terms by order:");
  for (const auto& k : d.orders) std::printf(" %d: %d,", k.first, k.second);
  std::printf(
      "\nprobe noise %s um, told %d of %zu; outliers %d, missing points %d, "
      "several teeth %d\n\n",
      range(d.sigma, "%.2f").c_str(),
      d.told,
      outcomes.size(),
      d.outliers,
      d.missing,
      d.teeth);
}

struct Summary {
  int scenarios = 0, rounds = 0, worse = 0, worse_on_common = 0,
      worse_regained = 0, worse_at_a_maximum = 0, unusable = 0, lost_points = 0,
      motion_violations = 0, within = 0, banded = 0, in_band[2] = {0, 0};
  // The outlier tests against the simulator's spikes (RoundRecord).
  int spikes_drawn = 0, outliers_dropped = 0, dropped_without_spike = 0,
      spikes_kept = 0;
  std::vector<std::string> worse_list;
  std::vector<double> ratio, cpu, achieved_over_predicted,
      achieved_over_expected, best, final_rms, initial, max_linear, max_angular,
      band_width;  // 2-sigma band high - low [um] of the banded rounds
};

Summary Summarise(const std::vector<ScenarioOutcome>& outcomes,
                  size_t config,
                  bool bevel) {
  Summary s;
  for (const ScenarioOutcome& o : outcomes) {
    if (o.scenario.bevel != bevel) continue;
    const ConfigOutcome& c = o.configs[config];
    ++s.scenarios;
    s.within += c.within;
    s.ratio.push_back(c.ratio);
    s.best.push_back(c.reach.rms_um);
    s.final_rms.push_back(c.loop.part_rms_um.back());
    s.initial.push_back(c.loop.part_rms_um.front());
    for (size_t r = 0; r < c.loop.rounds.size(); ++r) {
      const RoundRecord& round = c.loop.rounds[r];
      ++s.rounds;
      s.cpu.push_back(round.cpu_ms);
      s.spikes_drawn += round.spikes_drawn;
      s.outliers_dropped += round.outliers_dropped;
      s.dropped_without_spike += round.dropped_without_spike;
      s.spikes_kept += round.spikes_kept;
      if (round.worse) {
        ++s.worse;
        s.worse_on_common += round.worse_on_common_points;
        s.worse_regained += round.regained_points > 0;
        std::string points;
        if (round.regained_points > 0)
          points += "; " + std::to_string(round.regained_points) +
                    " point(s) the part lacked";
        if (round.true_points_at_a_maximum > 0) {
          ++s.worse_at_a_maximum;
          points += "; " + std::to_string(round.true_points_at_a_maximum) +
                    " true contact(s) at a maximum along the roll";
        }
        if (round.reached_after < round.reached_before)
          points += "; " +
                    std::to_string(round.reached_before - round.reached_after) +
                    " point(s) lost";
        if (!points.empty())
          points += "; on the common points " +
                    Num(round.common_rms_before_um) + " -> " +
                    Num(round.common_rms_after_um);
        s.worse_list.push_back(
            std::to_string(o.scenario.index) + "/" + std::to_string(r + 1) +
            " (" + Num(round.rms_before_um) + " -> " + Num(round.rms_after_um) +
            " um, predicted " + Num(round.predicted_rms_um) + points + ")");
      }
      if (!round.usable) ++s.unusable;
      if (round.reached_after < round.reached_before) ++s.lost_points;
      if (round.usable) {
        s.motion_violations += !round.motion_within_bounds;
        s.max_linear.push_back(round.max_linear_motion_mm);
        s.max_angular.push_back(round.max_angular_motion_rad);
        if (round.predicted_rms_um > 0.0)
          s.achieved_over_predicted.push_back(round.rms_after_um /
                                              round.predicted_rms_um);
        if (round.expected_true_rms_um > 0.0)
          s.achieved_over_expected.push_back(round.rms_after_um /
                                             round.expected_true_rms_um);
        // Rounds whose next part lost points are left out: their rms is
        // over fewer points than the prediction's.
        if (round.band_high_um[1] > 0.0 &&
            round.reached_after >= round.reached_before) {
          ++s.banded;
          s.band_width.push_back(round.band_high_um[1] - round.band_low_um[1]);
          for (int k = 0; k < 2; ++k)
            s.in_band[k] += round.rms_after_um >= round.band_low_um[k] &&
                            round.rms_after_um <= round.band_high_um[k];
        }
      }
    }
  }
  return s;
}

void PrintSummary(const Summary& s, const std::string& title) {
  if (s.scenarios == 0) return;
  std::printf("### %s: %d scenarios, %d rounds\n\n",
              title.c_str(),
              s.scenarios,
              s.rounds);
  std::printf("| figure | value |\n|---|---|\n");
  std::printf("| rounds that made the part worse (goal 0) | %d of %d |\n",
              s.worse,
              s.rounds);
  std::printf(
      "| of them worse on the grid points both parts have / with points the "
      "part lacked ground again | %d / %d |\n",
      s.worse_on_common,
      s.worse_regained);
  std::printf(
      "| of them with a true contact at a maximum of the deviation along the "
      "roll | %d |\n",
      s.worse_at_a_maximum);
  std::printf("| unusable corrections (settings kept) | %d |\n", s.unusable);
  std::printf(
      "| outlier tests: spikes drawn / points left out / of them without a "
      "spike / spikes kept | %d / %d / %d / %d |\n",
      s.spikes_drawn,
      s.outliers_dropped,
      s.dropped_without_spike,
      s.spikes_kept);
  std::printf(
      "| rounds that lost grid points (wheel no longer reaches) | %d |\n",
      s.lost_points);
  std::printf(
      "| corrections beyond 0.2 mm / 3e-3 rad of motion | %d of %zu usable "
      "(largest %s mm, %s rad) |\n",
      s.motion_violations,
      s.max_linear.size(),
      Num(s.max_linear.empty()
              ? NAN
              : *std::max_element(s.max_linear.begin(), s.max_linear.end()))
          .c_str(),
      Num(s.max_angular.empty()
              ? NAN
              : *std::max_element(s.max_angular.begin(), s.max_angular.end()))
          .c_str());
  std::printf("| initial true rms, median (90th) | %s (%s) um |\n",
              Num(Quantile(s.initial, 0.5)).c_str(),
              Num(Quantile(s.initial, 0.9)).c_str());
  std::printf(
      "| final true rms after %d rounds, median (90th, worst) | %s (%s, %s) um "
      "|\n",
      kRounds,
      Num(Quantile(s.final_rms, 0.5)).c_str(),
      Num(Quantile(s.final_rms, 0.9)).c_str(),
      Num(Quantile(s.final_rms, 1.0)).c_str());
  std::printf("| best reachable rms, median (90th) | %s (%s) um |\n",
              Num(Quantile(s.best, 0.5)).c_str(),
              Num(Quantile(s.best, 0.9)).c_str());
  std::printf(
      "| final / best reachable, median / 90th / worst | %s / %s / %s |\n",
      Num(Quantile(s.ratio, 0.5)).c_str(),
      Num(Quantile(s.ratio, 0.9)).c_str(),
      Num(Quantile(s.ratio, 1.0)).c_str());
  std::printf(
      "| final <= 1.2 x best reachable + probe noise (goal >= 95 %%) | %d of "
      "%d (%s %%) |\n",
      s.within,
      s.scenarios,
      Num(100.0 * s.within / s.scenarios, "%.1f").c_str());
  std::printf(
      "| achieved rms within the predicted 1-sigma / 2-sigma band (goal >= "
      "95 %% for 2 sigma) | %s %% / %s %% of %d rounds |\n",
      Num(100.0 * s.in_band[0] / std::max(s.banded, 1), "%.1f").c_str(),
      Num(100.0 * s.in_band[1] / std::max(s.banded, 1), "%.1f").c_str(),
      s.banded);
  // How much the band says: a band wide enough covers anything.
  std::printf(
      "| 2-sigma band width (high - low) per round, median (90th) | %s (%s) um "
      "|\n",
      Num(Quantile(s.band_width, 0.5)).c_str(),
      Num(Quantile(s.band_width, 0.9)).c_str());
  std::printf(
      "| achieved / expected true rms per round, median (10th..90th) | %s "
      "(%s..%s) |\n",
      Num(Quantile(s.achieved_over_expected, 0.5)).c_str(),
      Num(Quantile(s.achieved_over_expected, 0.1)).c_str(),
      Num(Quantile(s.achieved_over_expected, 0.9)).c_str());
  std::printf(
      "| achieved / predicted rms per round, median (10th..90th) | %s (%s..%s) "
      "|\n",
      Num(Quantile(s.achieved_over_predicted, 0.5)).c_str(),
      Num(Quantile(s.achieved_over_predicted, 0.1)).c_str(),
      Num(Quantile(s.achieved_over_predicted, 0.9)).c_str());
  std::printf("| CPU per correction, median / 90th / max | %s / %s / %s ms |\n",
              Num(Quantile(s.cpu, 0.5)).c_str(),
              Num(Quantile(s.cpu, 0.9)).c_str(),
              Num(Quantile(s.cpu, 1.0)).c_str());
  std::printf("\n");
  if (!s.worse_list.empty()) {
    std::printf("worse rounds (scenario/round): ");
    for (size_t k = 0; k < s.worse_list.size(); ++k)
      std::printf("%s%s", k ? "; " : "", s.worse_list[k].c_str());
    std::printf("\n\n");
  }
}

void PrintVerbose(const std::vector<ScenarioOutcome>& outcomes,
                  const std::vector<Config>& configs) {
  for (size_t k = 0; k < configs.size(); ++k) {
    std::printf("### Per scenario, %s\n\n", configs[k].name.c_str());
    std::printf(
        "| # | scenario | parts 0..3 true rms (um) | predicted per round | "
        "best (start) | final/best | "
        "worse | CPU ms |\n|---|---|---|---|---|---|---|---|\n");
    for (const ScenarioOutcome& o : outcomes) {
      const ConfigOutcome& c = o.configs[k];
      std::string parts, predicted, cpu;
      for (size_t p = 0; p < c.loop.part_rms_um.size(); ++p)
        parts += (p ? ", " : "") + Num(c.loop.part_rms_um[p]);
      int worse = 0;
      for (size_t r = 0; r < c.loop.rounds.size(); ++r) {
        const RoundRecord& round = c.loop.rounds[r];
        predicted +=
            (r ? ", " : "") + (round.usable ? Num(round.predicted_rms_um)
                                            : std::string("unusable"));
        if (!round.motion_within_bounds) predicted += "!";
        cpu += (r ? ", " : "") + Num(round.cpu_ms, "%.2f");
        worse += round.worse;
      }
      std::printf("| %d | %s | %s | %s | %s (%s) | %s%s | %d | %s |\n",
                  o.scenario.index,
                  o.scenario.Describe().c_str(),
                  parts.c_str(),
                  predicted.c_str(),
                  Num(c.reach.rms_um).c_str(),
                  c.reach.best_start.c_str(),
                  Num(c.ratio).c_str(),
                  c.within ? "" : " (out)",
                  worse,
                  cpu.c_str());
    }
    std::printf(
        "\n(\"!\": that correction moved an axis beyond 0.2 mm / 3e-3 rad; "
        "\"out\": final > 1.2 x best + "
        "sigma)\n\n");
  }
}

// --compare SOLVER: the default solver against a baseline on the same
// scenarios. Round 1 of both corrects the same measured part (the loop is
// deterministic in the scenario, and both start from it); the three-round
// loops then follow each solver's own parts. A pair of figures counts as
// equal within these tolerances:
constexpr double kSameRmsUm = 0.01;        // rms: max(0.01 um, 1 %)
constexpr double kSameRmsFraction = 0.01;  //   of the smaller
constexpr double kSameSizeOfBound = 0.01;  // size: 1 % of the motion bound
constexpr double kSameCpuFraction = 0.1;   // CPU: 10 % of the smaller
// MODEL.md §6 size (the solver's correction_size, um): 1 % of the smaller.
constexpr double kSameModelSizeFraction = 0.01;

// A correction's size as the benchmark measures it: the largest axis motion
// over the roll range as a fraction of its bound (0.2 mm for X, Y, Z; 3e-3
// rad for A, B, C); 0 for a correction not used (the settings kept).
double SizeOfBound(const RoundRecord& r) {
  if (!r.usable) return 0.0;
  return std::max(r.max_linear_motion_mm / bench::kLinearMotionBoundMm,
                  r.max_angular_motion_rad / bench::kAngularMotionBoundRad);
}

// The correction's size as MODEL.md §6 defines it (summary correction_size:
// axis motion and the wheel, scaled, um); 0 for a correction not used.
double ModelSize(const RoundRecord& r) {
  return r.usable ? r.correction_size : 0.0;
}

// One figure for both solvers, scenario by scenario: lower is better.
struct ComparedFigure {
  std::string name;
  double same_abs = 0.0, same_fraction = 0.0;
  std::vector<double> base, other;
  int better = 0, equal = 0, worse = 0;  // the default against the baseline

  void Add(double b, double o) {
    base.push_back(b);
    other.push_back(o);
    const double same =
        std::max(same_abs, same_fraction * std::min(std::abs(b), std::abs(o)));
    if (std::abs(b - o) <= same) {
      ++equal;
    } else if (b < o) {
      ++better;
    } else {
      ++worse;
    }
  }
};

struct Comparison {
  int scenarios = 0, rounds = 0;
  int different_start = 0;  // round 1 not on the same part (expected 0)
  // 0-3: round 1 true rms, size against the bound, MODEL.md size, CPU; 4-7:
  // the loop's final true rms, its largest sizes, its mean CPU per correction.
  std::vector<ComparedFigure> figures;
  int worse_rounds[2] = {0, 0}, beyond_bound[2] = {0, 0};
  std::vector<std::string> other_worse_list;
};

Comparison NewComparison() {
  Comparison c;
  auto add = [&c](const char* name, double same_abs, double same_fraction) {
    ComparedFigure f;
    f.name = name;
    f.same_abs = same_abs;
    f.same_fraction = same_fraction;
    c.figures.push_back(f);
  };
  add("round 1: true rms of the next part (um)", kSameRmsUm, kSameRmsFraction);
  add("round 1: correction size (of the bound)", kSameSizeOfBound, 0.0);
  add("round 1: MODEL.md §6 size (um)", 0.0, kSameModelSizeFraction);
  add("round 1: CPU per correction (ms)", 0.0, kSameCpuFraction);
  add("3 rounds: final true rms (um)", kSameRmsUm, kSameRmsFraction);
  add("3 rounds: largest correction size (of the bound)",
      kSameSizeOfBound,
      0.0);
  add("3 rounds: largest MODEL.md §6 size (um)", 0.0, kSameModelSizeFraction);
  add("3 rounds: mean CPU per correction (ms)", 0.0, kSameCpuFraction);
  return c;
}

// The loop's largest correction sizes (against the bound, MODEL.md §6) and
// mean CPU per correction; counts its worse rounds and corrections beyond the
// bound into `worse` and `beyond`.
void LoopFigures(const LoopRecord& loop,
                 double size[2],
                 double* cpu_ms,
                 int* worse,
                 int* beyond) {
  size[0] = size[1] = 0.0;
  *cpu_ms = 0.0;
  for (const RoundRecord& r : loop.rounds) {
    size[0] = std::max(size[0], SizeOfBound(r));
    size[1] = std::max(size[1], ModelSize(r));
    *cpu_ms += r.cpu_ms / loop.rounds.size();
    *worse += r.worse;
    *beyond += r.usable && !r.motion_within_bounds;
  }
}

Comparison Compare(const std::vector<ScenarioOutcome>& outcomes,
                   size_t base,
                   size_t other,
                   bool bevel) {
  Comparison c = NewComparison();
  for (const ScenarioOutcome& o : outcomes) {
    if (o.scenario.bevel != bevel) continue;
    const LoopRecord& b = o.configs[base].loop;
    const LoopRecord& p = o.configs[other].loop;
    ++c.scenarios;
    c.rounds += p.rounds.size();
    c.different_start += b.part_rms_um[0] != p.part_rms_um[0];
    const RoundRecord& b1 = b.rounds.front();
    const RoundRecord& p1 = p.rounds.front();
    c.figures[0].Add(b1.rms_after_um, p1.rms_after_um);
    c.figures[1].Add(SizeOfBound(b1), SizeOfBound(p1));
    c.figures[2].Add(ModelSize(b1), ModelSize(p1));
    c.figures[3].Add(b1.cpu_ms, p1.cpu_ms);
    double size[2][2], cpu[2];
    LoopFigures(b, size[0], &cpu[0], &c.worse_rounds[0], &c.beyond_bound[0]);
    LoopFigures(p, size[1], &cpu[1], &c.worse_rounds[1], &c.beyond_bound[1]);
    c.figures[4].Add(b.part_rms_um.back(), p.part_rms_um.back());
    c.figures[5].Add(size[0][0], size[1][0]);
    c.figures[6].Add(size[0][1], size[1][1]);
    c.figures[7].Add(cpu[0], cpu[1]);
    for (size_t r = 0; r < p.rounds.size(); ++r) {
      if (!p.rounds[r].worse) continue;
      c.other_worse_list.push_back(std::to_string(o.scenario.index) + "/" +
                                   std::to_string(r + 1) + " (" +
                                   Num(p.rounds[r].rms_before_um) + " -> " +
                                   Num(p.rounds[r].rms_after_um) + ")");
    }
  }
  return c;
}

std::string Spread(const std::vector<double>& v) {
  return Num(Quantile(v, 0.5)) + " / " + Num(Quantile(v, 0.9)) + " / " +
         Num(Quantile(v, 1.0));
}

// Round 1, scenario by scenario: where the default's correction is larger
// (against the bound) than the other's, whether its next part is better,
// equal or worse (the same tolerances as the table).
void PrintLargerCorrections(const Comparison& c, const std::string& other) {
  const ComparedFigure& rms = c.figures[0];
  const ComparedFigure& size = c.figures[1];
  int larger = 0, counts[3] = {0, 0, 0};  // better, equal, worse
  for (size_t k = 0; k < size.base.size(); ++k) {
    if (size.base[k] <= size.other[k] + kSameSizeOfBound) continue;
    ++larger;
    const double a = rms.base[k], b = rms.other[k];
    const double same = std::max(kSameRmsUm, kSameRmsFraction * std::min(a, b));
    ++counts[std::abs(a - b) <= same ? 1 : a < b ? 0 : 2];
  }
  std::printf(
      "Round 1, where the default's correction is the larger (%d of %d "
      "scenarios): its next part is better than %s's in %d, equal in %d, "
      "worse in %d.\n\n",
      larger,
      static_cast<int>(size.base.size()),
      other.c_str(),
      counts[0],
      counts[1],
      counts[2]);
}

void PrintComparison(const Comparison& c,
                     const std::string& title,
                     const std::string& other) {
  if (c.scenarios == 0) return;
  std::printf(
      "### Default vs \"%s\" on the same scenarios, %s: %d scenarios\n\n",
      other.c_str(),
      title.c_str(),
      c.scenarios);
  std::printf(
      "Round 1: both solvers correct the same measured part (%d scenarios "
      "started apart: expected 0). 3 rounds: each solver's own loop. Size: "
      "the largest axis motion over the roll range as a fraction of its bound "
      "(0.2 mm X, Y, Z; 3e-3 rad A, B, C; 0 when the settings were kept); "
      "MODEL.md §6 size: the solver's correction_size (axes and wheel). "
      "Equal within max(%g um, %g %%) (rms), %g of the bound (size), %g %% "
      "(MODEL.md size), %g %% (CPU).\n\n",
      c.different_start,
      kSameRmsUm,
      100.0 * kSameRmsFraction,
      kSameSizeOfBound,
      100.0 * kSameModelSizeFraction,
      100.0 * kSameCpuFraction);
  std::printf(
      "| figure | default: median / 90th / worst | %s: median / 90th / worst "
      "| default better / equal / worse |\n|---|---|---|---|\n",
      other.c_str());
  for (const ComparedFigure& f : c.figures) {
    std::printf("| %s | %s | %s | %d / %d / %d |\n",
                f.name.c_str(),
                Spread(f.base).c_str(),
                Spread(f.other).c_str(),
                f.better,
                f.equal,
                f.worse);
  }
  std::printf("| rounds that made the part worse | %d of %d | %d of %d | |\n",
              c.worse_rounds[0],
              c.rounds,
              c.worse_rounds[1],
              c.rounds);
  std::printf("| corrections beyond 0.2 mm / 3e-3 rad | %d | %d | |\n\n",
              c.beyond_bound[0],
              c.beyond_bound[1]);
  PrintLargerCorrections(c, other);
  if (!c.other_worse_list.empty()) {
    std::printf("%s worse rounds (scenario/round, true rms um): ",
                other.c_str());
    for (size_t k = 0; k < c.other_worse_list.size(); ++k)
      std::printf("%s%s", k ? "; " : "", c.other_worse_list[k].c_str());
    std::printf("\n\n");
  }
}

// Per scenario, round 1 and the final part of both solvers (--verbose).
void PrintComparisonVerbose(const std::vector<ScenarioOutcome>& outcomes,
                            size_t base,
                            size_t other,
                            const std::string& other_name) {
  std::printf(
      "### Per scenario, default vs \"%s\"\n\n| # | part 0 (um) | round 1: "
      "next part default / %s (um) | size default / %s | CPU default / %s "
      "(ms) | final default / %s (um) |\n|---|---|---|---|---|---|\n",
      other_name.c_str(),
      other_name.c_str(),
      other_name.c_str(),
      other_name.c_str(),
      other_name.c_str());
  for (const ScenarioOutcome& o : outcomes) {
    const LoopRecord& b = o.configs[base].loop;
    const LoopRecord& p = o.configs[other].loop;
    std::printf("| %s%d | %s | %s / %s | %s / %s | %s / %s | %s / %s |\n",
                o.scenario.bevel ? "bevel " : "",
                o.scenario.index,
                Num(b.part_rms_um[0]).c_str(),
                Num(b.rounds[0].rms_after_um).c_str(),
                Num(p.rounds[0].rms_after_um).c_str(),
                Num(SizeOfBound(b.rounds[0])).c_str(),
                Num(SizeOfBound(p.rounds[0])).c_str(),
                Num(b.rounds[0].cpu_ms, "%.2f").c_str(),
                Num(p.rounds[0].cpu_ms, "%.2f").c_str(),
                Num(b.part_rms_um.back()).c_str(),
                Num(p.part_rms_um.back()).c_str());
  }
  std::printf("\n");
}

// One configuration's summary over the grinder or the bevel scenarios.
void WriteSummaryJson(FILE* f,
                      const std::vector<ScenarioOutcome>& outcomes,
                      size_t k,
                      bool bevel) {
  const Summary s = Summarise(outcomes, k, bevel);
  std::fprintf(
      f,
      "%s\"%s\": {\"scenarios\": %d, \"rounds\": %d, "
      "\"worse_rounds\": %d, \"unusable\": %d, "
      "\"lost_points\": %d, \"motion_violations\": %d, "
      "\"within_1_2_best_plus_noise\": %d, "
      "\"ratio_median\": %s, \"ratio_p90\": %s, \"ratio_worst\": "
      "%s, \"banded_rounds\": %d, \"coverage_1sigma\": %s, "
      "\"coverage_2sigma\": %s, \"band_width_2sigma_median_um\": %s, "
      "\"band_width_2sigma_p90_um\": %s, "
      "\"achieved_over_predicted_median\": %s, \"cpu_ms_median\": "
      "%s, \"cpu_ms_p90\": %s}",
      bevel ? ", " : "",
      bevel ? "bevel" : "grinder",
      s.scenarios,
      s.rounds,
      s.worse,
      s.unusable,
      s.lost_points,
      s.motion_violations,
      s.within,
      JsonNum(Quantile(s.ratio, 0.5)).c_str(),
      JsonNum(Quantile(s.ratio, 0.9)).c_str(),
      JsonNum(Quantile(s.ratio, 1.0)).c_str(),
      s.banded,
      JsonNum(s.banded > 0 ? static_cast<double>(s.in_band[0]) / s.banded : NAN)
          .c_str(),
      JsonNum(s.banded > 0 ? static_cast<double>(s.in_band[1]) / s.banded : NAN)
          .c_str(),
      JsonNum(Quantile(s.band_width, 0.5)).c_str(),
      JsonNum(Quantile(s.band_width, 0.9)).c_str(),
      JsonNum(Quantile(s.achieved_over_predicted, 0.5)).c_str(),
      JsonNum(Quantile(s.cpu, 0.5)).c_str(),
      JsonNum(Quantile(s.cpu, 0.9)).c_str());
}

void WriteRoundJson(FILE* f, const RoundRecord& x, bool first) {
  std::fprintf(f,
               "%s{\"rms_before_um\": %s, \"rms_after_um\": %s, "
               "\"predicted_rms_um\": %s, "
               "\"linear_predicted_rms_um\": %s, \"status\": %s, "
               "\"usable\": %s, \"reached_before\": %d, "
               "\"reached_after\": %d, \"max_linear_motion_mm\": %s, "
               "\"max_angular_motion_rad\": %s, "
               "\"motion_within_bounds\": %s, \"correction_size\": %s, "
               "\"cpu_ms\": %s, \"worse\": %s, "
               "\"expected_true_rms_um\": %s, \"band_1sigma_um\": [%s, %s], "
               "\"band_2sigma_um\": [%s, %s], \"at_state\": %s, "
               "\"motion_scale\": %s, \"step_fraction\": %s, "
               "\"shortened_because\": %s, \"regained_points\": %d, "
               "\"true_points_at_a_maximum\": %d, \"spikes_drawn\": %d, "
               "\"outliers_dropped\": %d, \"dropped_without_spike\": %d, "
               "\"spikes_kept\": %d, "
               "\"common_rms_before_um\": %s, \"common_rms_after_um\": %s, "
               "\"worse_on_common_points\": %s, \"order_choice\": %s, "
               "\"motion_bound_beyond_roll_range\": %s, "
               "\"roll_range_rad\": [%s, %s]}",
               first ? "" : ", ",
               JsonNum(x.rms_before_um).c_str(),
               JsonNum(x.rms_after_um).c_str(),
               JsonNum(x.predicted_rms_um).c_str(),
               JsonNum(x.linear_predicted_rms_um).c_str(),
               JsonString(x.status).c_str(),
               x.usable ? "true" : "false",
               x.reached_before,
               x.reached_after,
               JsonNum(x.max_linear_motion_mm).c_str(),
               JsonNum(x.max_angular_motion_rad).c_str(),
               x.motion_within_bounds ? "true" : "false",
               JsonNum(x.correction_size).c_str(),
               JsonNum(x.cpu_ms).c_str(),
               x.worse ? "true" : "false",
               JsonNum(x.expected_true_rms_um).c_str(),
               JsonNum(x.band_low_um[0]).c_str(),
               JsonNum(x.band_high_um[0]).c_str(),
               JsonNum(x.band_low_um[1]).c_str(),
               JsonNum(x.band_high_um[1]).c_str(),
               x.at_state ? "true" : "false",
               JsonNum(x.motion_scale).c_str(),
               JsonNum(x.step_fraction).c_str(),
               JsonString(x.shortened_because).c_str(),
               x.regained_points,
               x.true_points_at_a_maximum,
               x.spikes_drawn,
               x.outliers_dropped,
               x.dropped_without_spike,
               x.spikes_kept,
               JsonNum(x.common_rms_before_um).c_str(),
               JsonNum(x.common_rms_after_um).c_str(),
               x.worse_on_common_points ? "true" : "false",
               JsonString(x.order_choice).c_str(),
               JsonString(x.motion_bound_beyond_roll_range).c_str(),
               JsonNum(x.roll_min_rad).c_str(),
               JsonNum(x.roll_max_rad).c_str());
}

// One scenario under configuration k: its parts, rounds and reference.
void WriteScenarioJson(FILE* f,
                       const ScenarioOutcome& o,
                       size_t k,
                       bool first) {
  const ConfigOutcome& c = o.configs[k];
  std::fprintf(f,
               "%s\n{\"index\": %d, \"bevel\": %s, \"seed\": %llu, "
               "\"description\": %s, \"probe_noise_um\": %s, "
               "\"part_rms_um\": [",
               first ? "" : ",",
               o.scenario.index,
               o.scenario.bevel ? "true" : "false",
               static_cast<unsigned long long>(o.scenario.seed),
               JsonString(o.scenario.Describe()).c_str(),
               JsonNum(o.scenario.probe_noise_um).c_str());
  for (size_t p = 0; p < c.loop.part_rms_um.size(); ++p) {
    std::fprintf(
        f, "%s%s", p ? ", " : "", JsonNum(c.loop.part_rms_um[p]).c_str());
  }
  std::fprintf(f, "], \"rounds\": [");
  for (size_t r = 0; r < c.loop.rounds.size(); ++r)
    WriteRoundJson(f, c.loop.rounds[r], r == 0);
  std::fprintf(f,
               "], \"best_reachable_um\": %s, \"best_start\": %s, "
               "\"final_over_best\": %s, \"within\": %s}",
               JsonNum(c.reach.rms_um).c_str(),
               JsonString(c.reach.best_start).c_str(),
               JsonNum(c.ratio).c_str(),
               c.within ? "true" : "false");
}

void WriteJson(const char* path,
               const std::vector<ScenarioOutcome>& outcomes,
               const std::vector<Config>& configs,
               std::uint64_t seed) {
  FILE* f = std::fopen(path, "w");
  if (f == nullptr) {
    std::fprintf(stderr, "robustness_benchmark: cannot write %s\n", path);
    return;
  }
  std::fprintf(f,
               "{\"seed\": %llu, \"rounds\": %d, \"configs\": [",
               static_cast<unsigned long long>(seed),
               kRounds);
  for (size_t k = 0; k < configs.size(); ++k) {
    std::fprintf(f,
                 "%s{\"name\": %s, \"default_max_order\": %d, \"summary\": {",
                 k ? ", " : "",
                 JsonString(configs[k].name).c_str(),
                 configs[k].options.default_max_order);
    WriteSummaryJson(f, outcomes, k, false);
    WriteSummaryJson(f, outcomes, k, true);
    std::fprintf(f, "}, \"scenarios\": [");
    for (size_t i = 0; i < outcomes.size(); ++i)
      WriteScenarioJson(f, outcomes[i], k, i == 0);
    std::fprintf(f, "]}");
  }
  std::fprintf(f, "]}\n");
  std::fclose(f);
}

// The command line (see the file comment).
struct Args {
  int scenarios = 200, bevel = 10, threads = 1, only = -1, only_bevel = -1;
  std::uint64_t seed = 2026;
  std::string orders = "both", solver = "regularised", compare;
  const char* json = nullptr;
  bool verbose = false, bound_wheel = false, no_state = false,
       no_signal_filter = false;
  std::vector<std::string> fixed_blocks, freed_blocks, reference_fixed;
  double min_flank_effect = -1.0;
  bench::StressOptions stress;
  int iterations = -1;
  int reach_iterations = bench::ReachOptions().max_iterations;
};

// False (with the usage printed) on an unknown flag or a missing value.
bool ParseArgs(int argc, char** argv, Args* a) {
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--scenarios") == 0 && has_value) {
      a->scenarios = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--bevel") == 0 && has_value) {
      a->bevel = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--seed") == 0 && has_value) {
      a->seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (std::strcmp(argv[i], "--orders") == 0 && has_value) {
      a->orders = argv[++i];
    } else if (std::strcmp(argv[i], "--solver") == 0 && has_value) {
      a->solver = argv[++i];
    } else if (std::strcmp(argv[i], "--compare") == 0 && has_value) {
      a->compare = argv[++i];
    } else if (std::strcmp(argv[i], "--threads") == 0 && has_value) {
      a->threads = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--json") == 0 && has_value) {
      a->json = argv[++i];
    } else if (std::strcmp(argv[i], "--only") == 0 && has_value) {
      a->only = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--only-bevel") == 0 && has_value) {
      a->only_bevel = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--reach-iterations") == 0 && has_value) {
      a->reach_iterations = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--fix") == 0 && has_value) {
      a->fixed_blocks.push_back(argv[++i]);
    } else if (std::strcmp(argv[i], "--reference-fix") == 0 && has_value) {
      a->reference_fixed.push_back(argv[++i]);
    } else if (std::strcmp(argv[i], "--free") == 0 && has_value) {
      a->freed_blocks.push_back(argv[++i]);
    } else if (std::strcmp(argv[i], "--no-signal-filter") == 0) {
      a->no_signal_filter = true;
    } else if (std::strcmp(argv[i], "--no-state") == 0) {
      a->no_state = true;
    } else if (std::strcmp(argv[i], "--min-flank-effect") == 0 && has_value) {
      a->min_flank_effect = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--iterations") == 0 && has_value) {
      a->iterations = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--error-scale") == 0 && has_value) {
      a->stress.error_scale = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--noise-scale") == 0 && has_value) {
      a->stress.noise_scale = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--told-noise-scale") == 0 && has_value) {
      a->stress.told_noise_scale = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--bound-wheel") == 0) {
      a->bound_wheel = true;
    } else if (std::strcmp(argv[i], "--verbose") == 0) {
      a->verbose = true;
    } else {
      std::fprintf(stderr,
                   "usage: robustness_benchmark [--scenarios N] [--bevel N] "
                   "[--seed S] [--orders default|cubic|both] "
                   "[--solver NAME] [--compare NAME] "
                   "[--threads N] [--json FILE] [--verbose] [--only I] "
                   "[--only-bevel I] "
                   "[--error-scale F] [--noise-scale F] "
                   "[--told-noise-scale F]\n");
      return false;
    }
  }
  return true;
}

// The configurations the flags ask for: default options and/or every order
// open, with the study flags and --solver; then, with --compare, each one's
// twin with the compared solver. False (with the reason printed) on bad
// values.
bool BuildConfigs(const Args& a, std::vector<Config>* configs) {
  CorrectionSolver main_solver, compared_solver;
  if (!ParseCorrectionSolver(a.solver, &main_solver) ||
      (!a.compare.empty() &&
       (!ParseCorrectionSolver(a.compare, &compared_solver) ||
        main_solver != CorrectionSolver::kRegularised))) {
    std::fprintf(
        stderr,
        "robustness_benchmark: bad --solver or --compare (regularised, "
        "pso or lsq-plain; --compare with the default solver)\n");
    return false;
  }
  // Less freedom first: a configuration's reference starts from those of the
  // configurations before it with no more freedom (ReferenceFor).
  if (a.orders == "cubic" || a.orders == "both") {
    Config cubic{"every axis held to order 3", CorrectionOptions(), 3};
    cubic.options.default_max_order = 3;
    configs->push_back(cubic);
  }
  if (a.orders != "cubic") {
    configs->push_back({"default options (orders 0-6)",
                        CorrectionOptions(),
                        CorrectionOptions().default_max_order});
  }
  for (Config& c : *configs) {
    for (const std::string& b : a.fixed_blocks) c.options.max_order[b] = -1;
    for (const std::string& b : a.freed_blocks) c.options.max_order[b] = 0;
    if (a.no_state) c.options.estimate_machine_state = false;
    if (a.no_signal_filter) c.options.signal_filter = false;
    if (a.min_flank_effect >= 0.0)
      c.options.min_flank_effect_um = a.min_flank_effect;
    if (a.iterations >= 0) c.options.max_num_iterations = a.iterations;
    // --solver: every configuration with that solver (named after it unless
    // it is the default).
    c.options.solver = main_solver;
    if (main_solver != CorrectionSolver::kRegularised)
      c.name = "\"" + a.solver + "\", " + c.name;
  }
  // --compare: each configuration's twin with the compared solver, scored
  // against the same best reachable.
  const size_t own_configs = configs->size();
  for (size_t k = 0; !a.compare.empty() && k < own_configs; ++k) {
    Config twin = (*configs)[k];
    twin.options.solver = compared_solver;
    twin.name = "\"" + a.compare + "\", " + (*configs)[k].name;
    twin.reference_of = static_cast<int>(k);
    configs->push_back(twin);
  }
  return true;
}

// Every job (bevel?, index) on `threads` threads, in the order of the jobs.
std::vector<ScenarioOutcome> RunJobs(
    const Args& a,
    const std::vector<Config>& configs,
    const std::vector<std::pair<bool, int>>& jobs) {
  const int total = static_cast<int>(jobs.size());
  std::vector<ScenarioOutcome> outcomes(total);
  std::atomic<int> next{0};
  auto work = [&]() {
    for (int i = next++; i < total; i = next++) {
      const Scenario s =
          jobs[i].first
              ? bench::DrawBevelScenario(a.seed, jobs[i].second, a.stress)
              : bench::DrawGrinderScenario(a.seed, jobs[i].second, a.stress);
      outcomes[i] = RunScenario(s,
                                configs,
                                a.seed,
                                a.bound_wheel,
                                a.reach_iterations,
                                a.reference_fixed);
      std::fprintf(stderr, "scenario %d of %d done\n", i + 1, total);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < a.threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return outcomes;
}

// The --compare reports: each baseline twin against its configuration.
void PrintComparisons(const Args& a,
                      const std::vector<ScenarioOutcome>& outcomes,
                      const std::vector<Config>& configs) {
  for (size_t k = 0; k < configs.size(); ++k) {
    if (configs[k].reference_of < 0) continue;
    const size_t base = configs[k].reference_of;
    for (int bevel = 0; bevel < 2; ++bevel) {
      PrintComparison(Compare(outcomes, base, k, bevel == 1),
                      (bevel ? "bevel generator, " : "flat-wheel grinder, ") +
                          configs[base].name,
                      a.compare);
    }
    if (a.verbose) PrintComparisonVerbose(outcomes, base, k, a.compare);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!ParseArgs(argc, argv, &a)) return 2;
  if (a.scenarios < 0 || a.bevel < 0 || a.threads < 1 ||
      !(a.stress.error_scale > 0.0) || !(a.stress.noise_scale > 0.0) ||
      !(a.stress.told_noise_scale >= 0.0) ||
      (a.orders != "default" && a.orders != "all" && a.orders != "cubic" &&
       a.orders != "both")) {
    std::fprintf(stderr,
                 "robustness_benchmark: bad --scenarios, --bevel, --threads, "
                 "--orders, --error-scale, --noise-scale or "
                 "--told-noise-scale\n");
    return 2;
  }
  std::vector<Config> configs;
  if (!BuildConfigs(a, &configs)) return 2;

  // The jobs: (bevel?, index). --only I runs the flat-wheel scenario I alone,
  // --only-bevel I the bevel generator's (for diagnosis; drawn exactly as in
  // the full run).
  std::vector<std::pair<bool, int>> jobs;
  if (a.only >= 0) {
    jobs.push_back({false, a.only});
    a.scenarios = 1;
    a.bevel = 0;
  } else if (a.only_bevel >= 0) {
    jobs.push_back({true, a.only_bevel});
    a.scenarios = 0;
    a.bevel = 1;
  } else {
    for (int i = 0; i < a.scenarios; ++i) jobs.push_back({false, i});
    for (int i = 0; i < a.bevel; ++i) jobs.push_back({true, i});
  }
  const std::vector<ScenarioOutcome> outcomes = RunJobs(a, configs, jobs);

  std::printf(
      "# Robustness benchmark: seed %llu, %d flat-wheel and %d bevel "
      "scenarios, %d rounds each\n\n",
      static_cast<unsigned long long>(a.seed),
      a.scenarios,
      a.bevel,
      kRounds);
  if (a.stress.error_scale != 1.0 || a.stress.noise_scale != 1.0 ||
      a.stress.told_noise_scale != 1.0) {
    std::printf(
        "Stress study: every hidden error x %g, probe noise x %g, noise told "
        "to the solver x %g of the probe's (outside the shop ranges below)"
        "\n\n",
        a.stress.error_scale,
        a.stress.noise_scale,
        a.stress.told_noise_scale);
  }
  PrintDistribution(outcomes);
  std::printf(
      "A round is worse when the next part's true rms exceeds the current "
      "part's by more than "
      "max(0.1 um, 10 %%). Best reachable: multi-start Levenberg-Marquardt "
      "from the true hidden state, "
      "same free orders, motion within 0.2 mm / 3e-3 rad; final / best uses "
      "max(best, 0.01 um).\n\n");
  double reference_s = 0.0;
  for (const ScenarioOutcome& o : outcomes) reference_s += o.reference_cpu_s;
  for (size_t k = 0; k < configs.size(); ++k) {
    PrintSummary(Summarise(outcomes, k, false),
                 "Flat-wheel grinder, " + configs[k].name);
    PrintSummary(Summarise(outcomes, k, true),
                 "Bevel generator, " + configs[k].name);
  }
  std::printf("(reference optimiser: %.1f s CPU over all scenarios)\n\n",
              reference_s);
  if (a.verbose) PrintVerbose(outcomes, configs);
  PrintComparisons(a, outcomes, configs);
  if (a.json != nullptr) WriteJson(a.json, outcomes, configs, a.seed);
  return 0;
}
