// The first 20 scenarios of the robustness benchmark
// (bench/robustness_scenarios.h, seed 2026, the benchmark's default) as a test:
// three rounds of grind -> measure -> correct each, and no round may make the
// part worse (issue 13: the next part's true rms above the current part's by
// more than max(0.1 um, 10 %)), with the default options and with every order
// 0-6 open. The full benchmark (bench/robustness_benchmark.cc) also measures
// reach, prediction and CPU.
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

// DISABLED: today's solver fails both. With the default options the second
// correction makes scenario 0 worse (9.41 -> 17.64 um, predicted 4.81) and
// scenario 19 worse (1.20 -> 2.60 um, predicted 0.27); with every order open
// the third correction makes scenarios 9 (0.36 -> 1.34, predicted 0.24), 11
// (0.37 -> 0.55, predicted 0.56) and 18 (0.19 -> 1.01, predicted 0.99) worse.
// The solver rework of issue 13 (never a worse part) must enable both, with
// this definition of worse unchanged.
TEST(RobustnessSubset, DISABLED_DefaultOptionsMakeNoPartWorse) {
  ExpectNoWorsePart(CorrectionOptions());
}

TEST(RobustnessSubset, DISABLED_EveryOrderOpenMakesNoPartWorse) {
  CorrectionOptions options;
  options.default_max_order = 6;
  ExpectNoWorsePart(options);
}

}  // namespace
}  // namespace gearloop
