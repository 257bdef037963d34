// The first 20 scenarios of the robustness benchmark
// (bench/robustness_scenarios.h, seed 2026, the benchmark's default) as a test:
// three rounds of grind -> measure -> correct each, and no round may make the
// part worse (issue 13: the next part's true rms above the current part's by
// more than max(0.1 um, 10 %)), with the default options (every order 0-6
// open) and with every axis held to its cubic term. The full benchmark
// (bench/robustness_benchmark.cc) also measures reach, prediction and CPU.
#include <gtest/gtest.h>

#include <string>

#include "bench/robustness_scenarios.h"
#include "engine/correction/correction.h"

namespace gearloop {
namespace {

constexpr std::uint64_t kBenchmarkSeed = 2026;
constexpr int kSubsetScenarios = 20;
constexpr int kRounds = 3;

// Runs the subset with `options`; one failure per round that made a part worse.
void ExpectNoWorsePart(const CorrectionOptions& options) {
  for (int index = 0; index < kSubsetScenarios; ++index) {
    const bench::Scenario s = bench::DrawGrinderScenario(kBenchmarkSeed, index);
    const bench::LoopRecord loop = bench::RunClosedLoop(s, options, kRounds);
    for (int r = 0; r < kRounds; ++r) {
      const bench::RoundRecord& round = loop.rounds[r];
      EXPECT_FALSE(round.worse)
          << "scenario " << index << " (" << s.Describe() << "), round "
          << r + 1 << ": " << round.rms_before_um << " -> "
          << round.rms_after_um << " um, predicted " << round.predicted_rms_um
          << " um";
    }
  }
}

// With the default options, every order 0-6 open, no round may make a part
// worse (enabled since orders 4-6 answer only where their exact prediction
// beats the cubic answer by max(0.1 um, 20 %), docs/correction-safety.md: the
// full benchmark went from 7 worse rounds of 600 to 1, seed 2026; the default
// since the screen before the every-order solve).
TEST(RobustnessSubset, DefaultOptionsMakeNoPartWorse) {
  ExpectNoWorsePart(CorrectionOptions());
}

// Every axis held to its cubic term (the default before orders 4-6 were safe)
// makes no part worse either (enabled since the wheel parabola is fixed by
// default and outliers are found by a robust fit and between teeth: 24 worse
// rounds of 600 in the full benchmark became 1).
TEST(RobustnessSubset, EveryAxisHeldToItsCubicTermMakesNoPartWorse) {
  CorrectionOptions options;
  options.default_max_order = 3;
  ExpectNoWorsePart(options);
}

// Scenarios of other seeds where a round made the part worse until a rule of
// the safe step or the order choice (docs/correction-safety.md) was added;
// each names the rule it guards.
struct RegressionScenario {
  std::uint64_t seed;
  int index;
  int default_max_order;
  const char* rule;
};

TEST(RobustnessSubset, ScenariosThatOnceMadeAPartWorseNoLongerDo) {
  const RegressionScenario kScenarios[] = {
      {11, 70, 3, "points the measurement lacks count in the next part"},
      {1, 60, 3, "the current part counts only its measured points"},
      {11, 87, 3, "wheel-edge margin share 0.7"},
      {1, 114, 3, "a point lost at the commanded end and halfway"},
      {11, 64, 3, "a point lost at the commanded end and halfway"},
      {1, 146, 3, "a contact on another branch at the commanded end"},
      {4, 30, 3, "another branch: half a roll range"},
      {2, 170, 6, "orders 4-6 keep the measured points at the commanded end"},
      {1, 156, 3, "at the noise floor only what stands above the noise"},
      {1, 172, 3, "at the noise floor only what stands above the noise"},
      {4, 174, 3, "at the noise floor only what stands above the noise"},
  };
  for (const RegressionScenario& r : kScenarios) {
    const bench::Scenario s = bench::DrawGrinderScenario(r.seed, r.index);
    CorrectionOptions options;
    options.default_max_order = r.default_max_order;
    const bench::LoopRecord loop = bench::RunClosedLoop(s, options, kRounds);
    for (int round = 0; round < kRounds; ++round) {
      EXPECT_FALSE(loop.rounds[round].worse)
          << "seed " << r.seed << ", scenario " << r.index << " (" << r.rule
          << "), round " << round + 1 << ": "
          << loop.rounds[round].rms_before_um << " -> "
          << loop.rounds[round].rms_after_um << " um";
    }
  }
}

}  // namespace
}  // namespace gearloop
