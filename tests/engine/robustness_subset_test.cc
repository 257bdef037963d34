// The first 20 scenarios of the robustness benchmark
// (bench/robustness_scenarios.h, seed 2026, the benchmark's default) as a test:
// three rounds of grind -> measure -> correct each, and no round may make the
// part worse (issue 13: the next part's true rms above the current part's by
// more than max(0.1 um, 10 %)), with the default options (every order 0-6
// open) and with every axis held to its cubic term. The full benchmark
// (bench/robustness_benchmark.cc) also measures reach, prediction and CPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "bench/robustness_scenarios.h"
#include "engine/correction/correction.h"
#include "engine/grinder/flat_wheel_grinder.h"

namespace gearloop {
namespace {

constexpr std::uint64_t kBenchmarkSeed = 2026;
constexpr int kSubsetScenarios = 20;
constexpr int kRounds = 3;

// Runs the subset with `options`; one failure per round that made a part worse
// or moved an axis beyond its bound (0.2 mm, 3e-3 rad) over the roll range.
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
      EXPECT_TRUE(round.motion_within_bounds)
          << "scenario " << index << ", round " << r + 1 << ": "
          << round.max_linear_motion_mm << " mm, "
          << round.max_angular_motion_rad << " rad";
    }
  }
}

// The closed loop of kRounds rounds on scenario `index` of `seed` at the
// default options; one failure per round that made the part worse.
bench::LoopRecord LoopMakingNoPartWorse(std::uint64_t seed, int index) {
  const bench::Scenario s = bench::DrawGrinderScenario(seed, index);
  const bench::LoopRecord loop =
      bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
  for (int round = 0; round < kRounds; ++round) {
    const bench::RoundRecord& r = loop.rounds[round];
    EXPECT_FALSE(r.worse) << "seed " << seed << ", scenario " << index
                          << ", round " << round + 1 << ": " << r.rms_before_um
                          << " -> " << r.rms_after_um << " um, predicted "
                          << r.predicted_rms_um << " um";
    EXPECT_TRUE(r.motion_within_bounds)
        << "seed " << seed << ", scenario " << index << ", round " << round + 1
        << ": " << r.max_linear_motion_mm << " mm, " << r.max_angular_motion_rad
        << " rad";
  }
  return loop;
}

// Round 2 of scenario `s` at `options`: its measurement, drawn as
// RunClosedLoop draws it, of the part ground with round 1's answer, and the
// correction's input for it.
struct RoundTwo {
  SimulatedMeasurement measurement;
  CorrectionInput input;
};

RoundTwo RoundTwoOf(const bench::Scenario& s, CorrectionOptions* options) {
  const Eigen::VectorXd commanded =
      bench::RunClosedLoop(s, *options, 1).final_parameters;
  MeasurementSimulationOptions measurement = s.measurement;
  measurement.seed += 1;  // round 2's measurement, as RunClosedLoop draws it
  RoundTwo two;
  two.measurement =
      SimulateMeasurement(*s.model, commanded, s.hidden_errors, measurement);
  two.input = bench::LoopCorrectionInput(
      s, commanded, two.measurement, measurement.teeth, options);
  return two;
}

// The summary of round 2's correction of the scenario drawn by `seed` and
// `index`, default options.
CorrectionSummary RoundTwoSummary(std::uint64_t seed, int index) {
  const bench::Scenario s = bench::DrawGrinderScenario(seed, index);
  CorrectionOptions options;
  return ComputeCorrection(options, RoundTwoOf(s, &options).input).summary;
}

// A round is told apart by the points the two parts have: the rms of each
// over the points both have, and the count of points the next part has that
// the current one lacked (a region the real machine grinds again); a point the
// next part lost is in neither.
TEST(ClosedLoop, TellsThePointsThePartLackedFromTheCommonOnes) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd before(5), after(5);
  before << 1.0, nan, 2.0, 3.0, nan;
  after << 3.0, 40.0, nan, 4.0, 50.0;
  double before_rms = 0.0, after_rms = 0.0;
  int regained = 0;
  bench::CommonPointsRms(before, after, &before_rms, &after_rms, &regained);
  EXPECT_EQ(regained, 2);
  EXPECT_NEAR(before_rms, std::sqrt((1.0 + 9.0) / 2.0), 1e-12);
  EXPECT_NEAR(after_rms, std::sqrt((9.0 + 16.0) / 2.0), 1e-12);
  // Nothing in common: no figure.
  before << nan, nan, nan, nan, nan;
  bench::CommonPointsRms(before, after, &before_rms, &after_rms, &regained);
  EXPECT_EQ(regained, 4);
  EXPECT_TRUE(std::isnan(before_rms));
  EXPECT_TRUE(std::isnan(after_rms));
}

// The outlier tests are scored against the simulator's spikes: a point left
// out by either test counts once, a left-out point without a spike is a false
// drop, a spike not left out is kept.
TEST(ClosedLoop, CountsTheOutlierTestsAgainstTheSpikesDrawn) {
  CorrectionSummary summary;
  summary.outlier_indices = {5, 7, 9};
  summary.tooth_outlier_indices = {9, 12};
  bench::RoundRecord round;
  bench::CountOutliers({1, 5, 9}, summary, &round);
  EXPECT_EQ(round.spikes_drawn, 3);
  EXPECT_EQ(round.outliers_dropped, 4);       // 5, 7, 9, 12
  EXPECT_EQ(round.dropped_without_spike, 2);  // 7, 12
  EXPECT_EQ(round.spikes_kept, 1);            // 1
}

// With the default options, every order 0-6 open, no round may make a part
// worse (enabled since orders 4-6 answer only where their exact prediction
// beats the cubic answer by max(0.05-0.1 um, 20 %), docs/correction-safety.md:
// the full benchmark went from 7 worse rounds of 600 to 1, seed 2026; the
// default since the screen before the every-order solve).
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
// the safe step, the order choice or the machine-state fit
// (docs/correction-safety.md) or of the envelope solve was added; each names
// the rule it guards. Seed 1, scenario
// 146 left the list when the envelope solve began to follow each contact from
// the nominal settings (flat_wheel_grinder.cc, SolveGroundContact): the rule
// it was listed for caught the old solve's jump to another root at the
// commanded end, a symptom of the tip row's fold; the contact now stays on its
// branch, runs 0.04 rad along the roll over the step, and round 2 goes 1.25 ->
// 1.60 um (BENCHMARKS.md, "Each contact followed on its branch").
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
      {4, 30, 3, "another branch: half a roll range"},
      {2, 170, 6, "orders 4-6 keep the measured points at the commanded end"},
      {1, 156, 3, "at the noise floor only what stands above the noise"},
      {1, 172, 3, "at the noise floor only what stands above the noise"},
      {4, 174, 3, "at the noise floor only what stands above the noise"},
      {1, 164, 6, "each contact followed on its branch from the nominal"},
      {14, 132, 6, "each contact followed on its branch from the nominal"},
      {17, 129, 6, "each contact followed on its branch from the nominal"},
      {20, 106, 6, "each contact followed on its branch from the nominal"},
      {34, 97, 6, "orders 4-6 agree at the commanded end, not the plausible"},
      {36, 42, 6, "orders 4-6 agree at the commanded end, not the plausible"},
      {41, 69, 6, "orders 4-6 agree at the commanded end, not the plausible"},
      {49, 168, 6, "orders 4-6 agree at the commanded end, not the plausible"},
      {23, 175, 6, "the state fitted again where it reaches more"},
      {28, 198, 6, "the state fitted again where it reaches more"},
      {14, 138, 6, "the state fitted again where it reaches more"},
      {422, 44, 6, "no contact a millimetre off the nominal flank"},
      {315, 169, 6, "no orders 4-6 at the estimated noise"},
      {301, 52, 6, "no orders 4-6 at the estimated noise"},
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

// Seed 115, scenario 180 (z 92, m_n 1.09 mm, a 138 mm wheel; the state fits
// the measurement to the noise): round 1 once took the commanded settings
// where the model finds no contact at any of the 30 measured grid points,
// while the machine still ground them, and rounds 2 and 3 were refused as
// invalid input. The safe step now refuses a step whose commanded end loses
// every measured point (safe_step.cc, ModelsDisagree): every round's
// correction is usable.
TEST(RobustnessSubset, NoLoopLocksItselfOutOfTheModel) {
  const bench::Scenario s = bench::DrawGrinderScenario(115, 180);
  const bench::LoopRecord loop =
      bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
  ASSERT_EQ(loop.rounds.size(), static_cast<size_t>(kRounds));
  for (int round = 0; round < kRounds; ++round) {
    EXPECT_TRUE(loop.rounds[round].usable)
        << "round " << round + 1 << ": " << loop.rounds[round].status;
  }
}

// The exact-model search (engine/correction/exact_search.h) on narrow gears
// whose lead crowning the linearised answer cannot make (BENCHMARKS.md, "Where
// the narrow gears' reach is"): seed 4, scenario 185 (b = 8 mm, kept at 9.1 um
// without the search, the reference 0.28 um) and seed 2026, scenario 91 (b =
// 15 mm, 1.01 um without it, the reference 0.45 um). Three rounds each: the
// search is taken at least once, the loop ends within 1.2 x the reference +
// the probe noise, and no round makes the part worse.
TEST(ExactSearch, MakesTheNarrowGearsCrowningTheLinearAnswerCannot) {
  struct Case {
    std::uint64_t seed;
    int index;
    double reference_um;  // best reachable (robustness benchmark)
  };
  for (const Case& c : {Case{4, 185, 0.276}, Case{2026, 91, 0.446}}) {
    const bench::Scenario s = bench::DrawGrinderScenario(c.seed, c.index);
    const bench::LoopRecord loop =
        bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
    int taken = 0;
    for (int round = 0; round < kRounds; ++round) {
      const bench::RoundRecord& r = loop.rounds[round];
      EXPECT_TRUE(r.usable) << r.status;
      EXPECT_FALSE(r.worse)
          << "seed " << c.seed << ", scenario " << c.index << ", round "
          << round + 1 << ": " << r.rms_before_um << " -> " << r.rms_after_um;
      EXPECT_FALSE(r.exact_search.empty());
      if (r.exact_search.rfind("taken", 0) == 0) {
        ++taken;
        EXPECT_LT(r.exact_search_after_rms_um,
                  0.8 * r.exact_search_before_rms_um)
            << r.exact_search;
      }
    }
    EXPECT_GE(taken, 1) << "seed " << c.seed << ", scenario " << c.index;
    EXPECT_LE(loop.part_rms_um.back(), 1.2 * c.reference_um + s.probe_noise_um)
        << "seed " << c.seed << ", scenario " << c.index;
  }
}

// The wide search (exact_search.cc, kWideSearchShare): seed 2026, scenario 176
// (z = 22, b = 9 mm, a 6 um lead crowning, the wheel cone 21.9 mrad off). The
// lead crowning lies along a direction of 8.9e-5 um rms per unit of correction
// size, just under the weak-flank floor (1e-4): without it every round's linear
// best is 2.2 um and the loop ends at 2.17 um, the reference 0.374 um. The
// first round's search is taken over the directions under the floor too, and
// the loop ends within 1.2 x the reference + the probe noise, no round worse.
TEST(ExactSearch, ContinuesOverTheDirectionsUnderTheFloor) {
  const bench::Scenario s = bench::DrawGrinderScenario(2026, 176);
  const bench::LoopRecord loop =
      bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
  const bench::RoundRecord& first = loop.rounds[0];
  EXPECT_EQ(first.exact_search.rfind("taken", 0), 0u) << first.exact_search;
  EXPECT_NE(first.exact_search.find("under the weak-flank floor"),
            std::string::npos)
      << first.exact_search;
  for (int round = 0; round < kRounds; ++round) {
    EXPECT_FALSE(loop.rounds[round].worse)
        << "round " << round + 1 << ": " << loop.rounds[round].rms_before_um
        << " -> " << loop.rounds[round].rms_after_um;
  }
  constexpr double kReferenceUm = 0.374;  // robustness benchmark, seed 2026
  EXPECT_LE(loop.part_rms_um.back(), 1.2 * kReferenceUm + s.probe_noise_um);
}

// The search nearer the noise (exact_search.cc, kSearchNoiseShare,
// kSearchGainMinUm): seed 7, scenario 112 (z = 126, b = 11 mm, a 2 um flank
// twist, Z0 off). The regularised answer leaves 0.2 um (linear best 0.2 um),
// under the old trigger (2 x the noise + 0.1 um); the search takes it to
// 0.11 um on the exact model and the loop ends within 1.2 x the reference +
// the probe noise (it ended at 0.204 um without). And seed 1, scenario 30
// (a 13 um root relief, the wheel cone off by four terms): with orders 4-6
// free the wide search is not run (there it took an answer predicted 0.93 um
// that made 1.17 -> 4.75 um); no round is worse.
TEST(ExactSearch, TakesAGainNearTheNoiseButNoWideSearchAtOrdersAboveCubic) {
  {
    const bench::Scenario s = bench::DrawGrinderScenario(7, 112);
    const bench::LoopRecord loop =
        bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
    int taken = 0;
    for (int round = 0; round < kRounds; ++round) {
      const bench::RoundRecord& r = loop.rounds[round];
      EXPECT_FALSE(r.worse) << "round " << round + 1;
      taken += r.exact_search.rfind("taken", 0) == 0;
    }
    EXPECT_GE(taken, 1);
    constexpr double kReferenceUm = 5.5e-5;  // robustness benchmark, seed 7
    EXPECT_LE(loop.part_rms_um.back(), 1.2 * kReferenceUm + s.probe_noise_um);
  }
  {
    const bench::LoopRecord loop = LoopMakingNoPartWorse(1, 30);
    for (int round = 0; round < kRounds; ++round) {
      const bench::RoundRecord& r = loop.rounds[round];
      EXPECT_EQ(r.exact_search.find("under the weak-flank floor"),
                std::string::npos)
          << "round " << round + 1 << ": " << r.exact_search;
    }
  }
}

// The regularised answer where the search's is refused (solve_problem.cc,
// TakeRegularisedAnswerWhereTheSearchsIsRefused). Seed 47, scenario 113 (z
// 144, a 3.9 um tip relief, the root rows not measured; the noise unknown): the
// search's answer fails the safe step in rounds 1 and 2, and answering that
// refusal kept the part at 51.0 um; the regularised answer is safe and the loop
// ends within 1.2 x the reference + the probe noise, no round worse.
TEST(ExactSearch, RefusedBySafeStepLeavesTheRegularisedAnswer) {
  const bench::Scenario s = bench::DrawGrinderScenario(47, 113);
  const bench::LoopRecord loop = LoopMakingNoPartWorse(47, 113);
  const bench::RoundRecord& first = loop.rounds[0];
  EXPECT_EQ(first.exact_search.rfind("refused by the safe step", 0), 0u)
      << first.exact_search;
  EXPECT_EQ(first.status, "converged") << first.exact_search;
  constexpr double kPartMadeUm = 1.0;  // the first round made 0.76 um
  EXPECT_LT(first.rms_after_um, kPartMadeUm);
  // The rough reference (--reach-iterations 1), seed 47.
  constexpr double kReferenceUm = 0.0666;
  EXPECT_LE(loop.part_rms_um.back(), 1.2 * kReferenceUm + s.probe_noise_um);
}

// The solve holds the motion bound where an orders 4-6 answer takes the next
// part's contacts beyond the roll range (solve_problem.cc,
// HoldTheBoundWhereTheContactsGo). Seed 2026, scenario 167 (z 89, b = 69 mm,
// an 18 um root relief and a 21 um lead crowning, hidden Y2, sigma 0.21 um
// told): the every-order answer predicted 0.36 um, but its contacts ran past
// the roll range where orders 4-6 grow; the safe step kept half of it (0.63
// um), the cubic answer stood, and the loop ended at 0.75 um. Solved again
// with the bound held there, orders 4-6 answer and the loop ends within 1.2 x
// the reference + the probe noise, no round worse.
TEST(OrderChoice, HoldsTheBoundWhereTheNextContactsGo) {
  const bench::Scenario s = bench::DrawGrinderScenario(2026, 167);
  const bench::LoopRecord loop = LoopMakingNoPartWorse(2026, 167);
  int held = 0;
  for (const bench::RoundRecord& r : loop.rounds) {
    held += !r.motion_bound_beyond_roll_range.empty() &&
            r.order_choice.rfind("orders 4-6 used", 0) == 0;
  }
  EXPECT_GE(held, 1);
  // The full reference (BENCHMARKS.md, "The motion bound where the next
  // contacts go"), seed 2026.
  constexpr double kReferenceUm = 0.216;
  EXPECT_LE(loop.part_rms_um.back(), 1.2 * kReferenceUm + s.probe_noise_um);
}

// The safe step asks what the state the measurement cannot see would do to
// the step (safe_step.cc, StateUncertainty): the next part spread by the free
// coordinates' posterior and by a wheel parabola the state fit takes up with
// the axes, through the change of the model's Jacobian over the step.
// Seed 1, scenario 146 (z 98, a 5 um lead crowning; hidden Y0 8.5 um and Z0;
// sigma 0.44 told): round 2 predicted 0.44 um from 1.25 and made 1.60 (the
// state's Y was off by what the noise hides). Seed 112, scenario 66 (a user
// grid; hidden A3, Z2, C1, B0, the cone and a 4.3 um wheel parabola): round 2
// predicted 0.26 um from 0.48 and made 0.71. Both steps are now shortened
// for the spread, and neither loop makes a part worse.
TEST(SafeStep, ShortensAStepTheStatesSpreadCouldMakeWorse) {
  struct Case {
    std::uint64_t seed;
    int index;
    double reference_um;  // the rough reference (--reach-iterations 1)
  };
  for (const Case& c : {Case{1, 146, 0.165}, Case{112, 66, 0.261}}) {
    const bench::Scenario s = bench::DrawGrinderScenario(c.seed, c.index);
    const bench::LoopRecord loop = LoopMakingNoPartWorse(c.seed, c.index);
    const bench::RoundRecord& second = loop.rounds[1];
    EXPECT_EQ(second.shortened_because.rfind("could make the part worse", 0),
              0u)
        << "seed " << c.seed << ", scenario " << c.index << ": "
        << second.shortened_because;
    EXPECT_LE(loop.part_rms_um.back(), 1.2 * c.reference_um + s.probe_noise_um)
        << "seed " << c.seed << ", scenario " << c.index;
  }
}

// The wheel parabola's flank the safe step hedges is the one the measurement
// allows (safe_step.cc, ParabolaFlankTheMeasurementAllows: the measured flank
// less the commanded one fitted by the axes, each held to the size machines
// err, the cone by 200 urad and the parabola by 2 um of flank), no longer a
// fixed 1 um. Three rounds the fixed hedge let through, each a wheel parabola
// the state fit took up with the axes: seed 22, scenario 183, round 2 (z 129, a
// diagonal end relief, a profile slope and crowning; a 4 um parabola alone)
// predicted 0.37 um from 0.71 and made 0.95; seed 102, scenario 63, round 2 (a
// user grid; three parabola terms and Y0); seed 93, scenario 196, round 2
// (a 4.1 um parabola and the cone). The measurement shows 2.39 +- 0.35 um of
// parabola flank in the first, and none of the three loops makes a part worse
// now.
TEST(SafeStep, HedgesTheWheelParabolaTheMeasurementShows) {
  LoopMakingNoPartWorse(22, 183);
  LoopMakingNoPartWorse(102, 63);
  LoopMakingNoPartWorse(93, 196);
}

// The parabola the state takes up, asked of a step in orders 4-6
// (safe_step.cc, MakeStateUncertainty: the take-up through every free
// coordinate, orders 4-6 included). There the take-up runs through
// combinations of the high orders the measurement hardly tells apart, and
// a step that moves them spreads by 7-20 um, so the every-order answer is
// shortened and the cubic one answers. Taken up through orders 0-3 only
// (tried in the thirty-sixth session, BENCHMARKS.md) the every-order steps
// pass, and two loops make a part worse in round 1: seed 114, scenario 31
// (z 42, a 13.7 um tip relief; hidden Z3 alone, no parabola) predicted
// 0.24 um from 7.76 and made 12.97; seed 109, scenario 101 (z 129, a
// flank twist; the cone, Z2, Y1, Y3) predicted 0.25 um from 7.65 and made
// 15.5. Neither loop makes a part worse today.
TEST(SafeStep, HoldsAnEveryOrderStepTheParabolaTakeUpCouldMakeWorse) {
  LoopMakingNoPartWorse(114, 31);
  LoopMakingNoPartWorse(109, 101);
}

// The per-direction filter at the commanded settings where the state fit
// explains nothing (correction.cc, Correct). Seed 8, scenario 42 (z 36, b =
// 45 mm, a user grid; hidden C1 and X0; sigma 0.40 told, outliers): by the
// third round the part is at 0.132 um, the measurement noise alone, and the
// state fit keeps no direction; the single Tikhonov level fitted the noise
// there and made 0.255 um. With the filter the loop makes no part worse.
TEST(SignalFilter, FollowsWhereTheStateFitExplainsNothing) {
  LoopMakingNoPartWorse(8, 42);
}

// The state fit's outliers leave the correction's points (correction.cc,
// LeaveOutOutliers). Seed 10, scenario 149 (z 59, b = 16 mm, helix
// slope and tip relief; hidden X0, Y0, Z1, C1; sigma 0.29 unknown, outliers,
// missing points): in round 2 a -14.8 um spike at the tip corner stood out of
// the state fit (spread 0.33 um) but not of the correction's fit at the
// state, which carries the tip relief the axes cannot make (spread 0.93 um);
// kept, it made 1.37 -> 1.56 um.
TEST(Outliers, TheStateFitsOutliersLeaveTheCorrectionsPoints) {
  LoopMakingNoPartWorse(10, 149);
}

// The outlier test takes a spike before the neighbour its fit bends away
// (outliers.cc, StandAlone). Seed 777, bevel scenario 47 (the published
// concave pinion perturbed; hidden A1; sigma 0.43 told, outliers): round 1
// measures a -13.2 um spike at a grid corner (leverage 0.9); the test dropped
// its two row neighbours and kept it, the state fit took it for the machine,
// and the part went 0.075 -> 2.34 um. Seed 31, bevel scenario 81 (hidden X, Y
// and Z terms; sigma 0.11 told, outliers, missing points): round 3 went 0.061
// -> 1.08 um, predicted 3.31 um. Now no round makes either part worse.
TEST(Outliers, ASpikeAtACornerGoesBeforeItsNeighbours) {
  for (const auto& [seed, index] :
       {std::pair<std::uint64_t, int>{777, 47}, {31, 81}}) {
    const bench::Scenario s = bench::DrawBevelScenario(seed, index);
    const bench::LoopRecord loop =
        bench::RunClosedLoop(s, CorrectionOptions(), kRounds);
    for (int round = 0; round < kRounds; ++round) {
      const bench::RoundRecord& r = loop.rounds[round];
      EXPECT_FALSE(r.worse)
          << "seed " << seed << ", bevel scenario " << index << ", round "
          << round + 1 << ": " << r.rms_before_um << " -> " << r.rms_after_um
          << " um";
    }
  }
}

// The every-order answer keeps the cubic answer's gross outliers aside
// (order_choice.cc): orders 4-6 give a grid corner a direction of its own,
// and the every-order outlier test cannot see a spike there. Seed 25,
// scenario 60 with the probe noise doubled (z 17, m_n 11.6, a lead crowning;
// hidden cone angle and B2; sigma 0.59 told, outliers, missing points): round
// 2 measures a -20.9 um spike at the tip-end corner (row 4, column 8); the
// every-order answer fitted it, answered, and ground +18.1 um into the corner
// (0.50 -> 2.77 um). Now the corner is an outlier of the answer, its change
// there stays within a micrometre, and no round makes the part worse.
constexpr int kSpikedCorner = 4 * 9 + 8;
constexpr double kCornerChangeUm = 1.0;

TEST(Outliers, TheCubicAnswersOutliersStayAsideAtEveryOrder) {
  bench::StressOptions stress;
  stress.noise_scale = 2.0;
  const bench::Scenario s = bench::DrawGrinderScenario(25, 60, stress);
  CorrectionOptions options;
  const RoundTwo two = RoundTwoOf(s, &options);
  const std::vector<int>& spikes = two.measurement.outlier_indices;
  ASSERT_NE(std::find(spikes.begin(), spikes.end(), kSpikedCorner),
            spikes.end());
  const CorrectionResult result = ComputeCorrection(options, two.input);
  const std::vector<int>& outliers = result.summary.outlier_indices;
  EXPECT_NE(std::find(outliers.begin(), outliers.end(), kSpikedCorner),
            outliers.end())
      << result.summary.BriefReport();
  ASSERT_EQ(result.predicted_change_um.size(), s.model->NumPoints());
  EXPECT_LT(std::abs(result.predicted_change_um(kSpikedCorner)),
            kCornerChangeUm)
      << result.summary.BriefReport();

  const bench::LoopRecord loop = bench::RunClosedLoop(s, options, kRounds);
  for (int round = 0; round < kRounds; ++round) {
    const bench::RoundRecord& r = loop.rounds[round];
    EXPECT_FALSE(r.worse) << "round " << round + 1 << ": " << r.rms_before_um
                          << " -> " << r.rms_after_um << " um, predicted "
                          << r.predicted_rms_um << " um";
  }
}

// Every-order steps keep every axis within its bound between the samples the
// bound is held at, too (safe_step.cc, AxisMotionRatio). Seed 313, scenario
// 102, round 1, and seed 406, scenario 154, round 1: orders 4-6 answered,
// scaled to 0.99 of the 3e-3 rad bound at 41 roll angles, and moved an angle
// 1.0108 and 1.0109 x the bound between them.
TEST(MotionBound, HoldsBetweenTheSamples) {
  LoopMakingNoPartWorse(313, 102);
  LoopMakingNoPartWorse(406, 154);
}

// Nor does it set aside the spikes' genuine neighbours: the spikes stay out of
// the every-order state fit as well (MachineStateProblem). Taken back there,
// that fit bent to a corner spike with the corner's own direction free, its
// outlier test took the points next to the spike for outliers, and orders 4-6
// shaped the corner. Seed 625, scenario 78, round 1 (z 44, a 20.5 um tip
// relief; a +23 um spike at the tip-end corner): orders 4-6 set aside its two
// row neighbours, predicted 0.43 um and made 13.2 -> 19.9 um; seed 529,
// scenario 176, round 2 (a -27 um spike at the same corner): 0.41 -> 2.0 um.
// Now the every-order answer keeps the neighbours, predicts no better than the
// cubic one there, and neither loop makes a part worse.
TEST(Outliers, TheSpikesNeighboursStayInAtEveryOrder) {
  struct Case {
    std::uint64_t seed;
    int index;
    int round;
  };
  for (const Case& c : {Case{625, 78, 1}, Case{529, 176, 2}}) {
    const bench::LoopRecord loop = LoopMakingNoPartWorse(c.seed, c.index);
    const std::string& choice = loop.rounds[c.round - 1].order_choice;
    EXPECT_EQ(choice.rfind("orders 0-3 used", 0), 0u)
        << "seed " << c.seed << ", scenario " << c.index << ": " << choice;
    EXPECT_NE(choice.find("not better by"), std::string::npos)
        << "seed " << c.seed << ", scenario " << c.index << ": " << choice;
  }
}

// A relief the cubic terms cannot make is no probe spike: the cubic answer
// may leave its corner out as a gross outlier, but the measured machine
// error m - d(commanded) is smooth there, so the every-order solve keeps the
// point and may make the relief (outliers.cc, ProbeSpikes). Seed 25,
// scenario 140 (z 21, a 19.2 um diagonal end relief and a helix slope):
// orders 4-6 answer in round 1 and the loop ends at 0.25 um; with every cubic
// outlier kept out of the every-order solve it ended at 2.07 um.
constexpr double kDiagonalReliefFinalUm = 0.5;

TEST(Outliers, AReliefTheCubicTermsCannotMakeIsNoProbeSpike) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(25, 140);
  ASSERT_EQ(static_cast<int>(loop.rounds.size()), kRounds);
  EXPECT_LT(loop.rounds.back().rms_after_um, kDiagonalReliefFinalUm);
}

// No change while measured points have no contact on the model at the
// linearisation point (safe_step.cc, MeasuredNotReachedRefusal). Seed 19,
// scenario 66 (z 21, a 12.2 um tip relief, hidden A3 and the wheel's
// parabola; noise unknown): in round 2 the model at the state reached none of
// the measured tip row, orders 4-6 predicted 0.14 um and the part went 3.64 ->
// 20.9 um. Now round 2 keeps the settings, and round 3, whose state reaches
// the row, takes the part under 1 um. Seed 21, scenario 117 (a root relief,
// hidden C3): 1.41 -> 5.84 um in round 2, now kept.
TEST(SafeStep, KeepsTheSettingsWhileMeasuredPointsHaveNoContact) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(19, 66);
  EXPECT_EQ(loop.rounds[1].status, "no_safe_improvement");
  EXPECT_LT(loop.part_rms_um.back(), 1.0);
  LoopMakingNoPartWorse(21, 117);
}

// A kept fraction whose exact change is below a tenth of the noise is dropped
// (safe_step.cc, DropNegligibleStep). Seed 8, scenario 40 (sigma 0.43 told):
// half a step of 0.03 um predicted to gain 0.012 um moved a tip corner onto
// the envelope's other sheet, 0.406 -> 27.1 um.
TEST(SafeStep, DropsAKeptFractionTheMeasurementCouldNotSee) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(8, 40);
  EXPECT_LT(loop.part_rms_um.back(), 0.5);
}

// The plausible end (machine_state.h, PlausibleShare; safe_step.cc,
// ModelsDisagree). Seed 7, scenario 168 (z 41, b = 19 mm, tip relief, helix
// slope and end relief; hidden A1, A3, Z1, C0 and the wheel's parabola, the
// noise unknown): the true machine leaves the root row unground, and the
// step that makes the part loses two grid rows at the commanded settings and
// halfway there, so every fraction was refused (10.3 um, three rounds). The
// state fits to the noise (F 321 over 4): the machine runs no farther than
// 0.11 of the way, where the rows are kept, and the first round makes the
// part. Seed 1, scenario 114 (the state leaves 3.4 um where the noise is
// 0.37: the halfway test stays at the commanded settings): no round worse.
// (Seed 1, scenario 146 was here too: see
// RobustnessSubset.ScenariosThatOnceMadeAPartWorseNoLongerDo.)
TEST(SafeStep, AsksThePlausibleEndWhereTheStateFitsToTheNoise) {
  {
    const bench::LoopRecord loop = LoopMakingNoPartWorse(7, 168);
    const bench::RoundRecord& first = loop.rounds[0];
    EXPECT_LT(first.rms_after_um, 0.5 * first.rms_before_um)
        << first.rms_before_um << " -> " << first.rms_after_um;
  }
  LoopMakingNoPartWorse(1, 114);
}

// The state fitted again where it reaches more (correction.cc,
// FitTheStateAgainAtTheState). Seed 49, scenario 64 (z 13, b = 19 mm,
// flank twist, profile crowning and diagonal end relief; hidden A1, Y1, Y3;
// sigma 0.15 um told): after the first round the commanded settings leave
// the root row without a contact, so the state fit, linearised there, never
// saw it; the state reached it 8 um from the measurement, and round 2's step
// changed it by 0.11 um there and by 2.2 um on the real machine (0.287 ->
// 0.96 um). Fitted again at the state with the row's 9 points, no round is
// worse.
TEST(MachineState, FittedAgainWhereTheStateReachesMore) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(49, 64);
  const std::string& reason = loop.rounds[1].machine_state_reason;
  EXPECT_NE(reason.find("with 9 measured grid point(s) the commanded "
                        "settings do not reach"),
            std::string::npos)
      << reason;
}

// The state fit as Gauss-Newton (correction.cc, FitTheStateAgainAtTheState).
// Seed 75, scenario 169 (z 19, b = 11 mm, spur, lead crowning and diagonal
// end relief; a hidden cubic Z error of 4 um; sigma 0.30 um unknown, 4
// teeth): a cubic Z error that small moves the root row by 45 um, so the
// state fit linearised at the commanded settings stopped short of the state
// (1.31 um of misfit); round 2's step, predicted 2.14 um, made 3.41 -> 6.39
// um. Fitted again at the state the misfit falls to the noise (0.12 um) and
// no round is worse.
TEST(MachineState, FittedAgainWhereTheFirstFitStopsShort) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(75, 169);
  const bench::RoundRecord& second = loop.rounds[1];
  EXPECT_NE(second.machine_state_reason.find("fitted again at the state ("),
            std::string::npos)
      << second.machine_state_reason;
  EXPECT_LT(second.rms_after_um, 0.6 * second.rms_before_um)
      << second.rms_before_um << " -> " << second.rms_after_um;
}

// An unknown noise estimated from the state's last pass (correction.cc,
// SolveAtMachineState). Seed 22, scenario 170 (z 126, b = 17 mm, root relief
// and lead crowning; hidden X0, A0, Z0, Z1, B1, C3; the noise unknown): from
// round 2 on the state is fitted again at itself, and with the noise taken
// from the first fit's misfit the filter held the part at 2.17 and 2.07 um;
// from the last pass's, round 3 makes 0.315 um.
TEST(MachineState, EstimatesTheNoiseFromTheLastPass) {
  const bench::LoopRecord loop = LoopMakingNoPartWorse(22, 170);
  EXPECT_LT(loop.part_rms_um.back(), 1.0) << loop.part_rms_um.back();
}

// A state fit that took no step says so (machine_state.cc,
// TestMachineState): seed 86, scenario 76, round 2 (z 87, b = 8 mm, tip, root
// and end relief; hidden X2, C0, Y2, X3; sigma 0.41 um told): the commanded
// settings leave 11.8 um of misfit, the state fit's linear answer loses grid
// points and no fraction of it is better, so it changes nothing. The answer
// said the fit "explains nothing the commanded settings do not"; it now names
// the fit's own reason.
TEST(MachineState, SaysWhenTheStateFitTookNoStep) {
  const CorrectionSummary summary = RoundTwoSummary(86, 76);
  ASSERT_FALSE(summary.machine_state_estimated) << summary.BriefReport();
  const std::string& reason = summary.machine_state_reason;
  EXPECT_EQ(reason.rfind("the state fit took no step (the linear answer loses "
                         "grid points on the exact model",
                         0),
            0u)
      << reason;
  EXPECT_EQ(reason.find("explains nothing"), std::string::npos) << reason;
}

// The state the answer reports is the one the passes reached (correction.cc,
// FitTheStateAgainAndSaySo): machine_state's misfit is the last pass's, the
// figure its reason ends on, not the first fit's. Seed 75, scenario 169,
// round 2 (see FittedAgainWhereTheFirstFitStopsShort): the first fit left
// 1.31 um, the pass 0.12 um; the prediction band's estimated noise follows
// (expected 1.15 -> 1.69 um for a part of 1.43 um, in both bands).
TEST(MachineState, ReportsTheStateThePassesReached) {
  const CorrectionSummary summary = RoundTwoSummary(75, 169);
  ASSERT_TRUE(summary.machine_state_estimated) << summary.BriefReport();
  const std::string& reason = summary.machine_state_reason;
  const std::string before = " pass(es), misfit ";
  const std::string after = " -> ";
  const size_t misfit = reason.find(before);
  ASSERT_NE(misfit, std::string::npos) << reason;
  const size_t arrow = reason.find(after, misfit);
  ASSERT_NE(arrow, std::string::npos) << reason;
  const double first_um = std::stod(reason.substr(misfit + before.size()));
  const double last_um = std::stod(reason.substr(arrow + after.size()));
  EXPECT_LT(last_um, 0.5 * first_um) << reason;
  constexpr double kPrintedDigits = 5e-3;  // the reason prints 3 digits
  EXPECT_NEAR(
      summary.machine_state_misfit_rms_um, last_um, kPrintedDigits * last_um)
      << reason;
}

// A noise estimated from the state's misfit above what a probe scatters
// (kStateNoiseCeilingUm) may be flank the state cannot explain or measurement
// the part does not have: the band reaches over both readings
// (prediction_band.cc, EstimatePredictionBand). Seed 11, scenario 138 (z 17,
// b = 37 mm, spur, end relief; hidden A0, A3, B2, Z0 and the wheel's
// parabola; the noise unknown): the state, fitted again with 9 more measured
// points, leaves 3.9 um; read only as noise, the band said 0 .. 3.57 um for a
// part that stays at 4.02 um. Seed 22, scenario 70 (outliers, the noise
// unknown): a part of 1.13 um measured at 5.49 um; read only as flank, the
// band said 5.08 .. 5.69 um.
TEST(PredictionBand, ReachesOverNoiseAndFlankAboveWhatAProbeScatters) {
  for (const auto& [seed, index] : {std::pair<int, int>{11, 138}, {22, 70}}) {
    const bench::LoopRecord loop = LoopMakingNoPartWorse(seed, index);
    for (int round = 1; round < kRounds; ++round) {
      const bench::RoundRecord& r = loop.rounds[round];
      EXPECT_GE(r.rms_after_um, r.band_low_um[1])
          << "seed " << seed << ", scenario " << index << ", round "
          << round + 1;
      EXPECT_LE(r.rms_after_um, r.band_high_um[1])
          << "seed " << seed << ", scenario " << index << ", round "
          << round + 1;
    }
  }
}

// The orders 4-6 margin scaled to the measured part (order_choice.cc,
// OrderGainMinUm). Seed 4, scenario 50: after the first round the part is at
// 0.22 um, and orders 4-6 answer a gain a fixed 0.1 um margin refused (with
// it the loop ends above 1.2 x the reference + the noise; with the margin
// scaled to the part, at 0.11 um). Seed 4, scenario 7 stood here until the
// safe step asked the agreement of orders 4-6 at the commanded settings:
// there they change that part's flank by 1.5 times what they do at the
// state, and the cubic answer stands at 0.149 um (BENCHMARKS.md, "The
// models' agreement at the commanded end"). Seed 4, scenario 21 (a 29.2 um
// part): orders 4-6 predict 0.36 um against 0.45 held to the cubic terms,
// within 20 % + 0.05 um, but 1 % of 29.2 um is 0.29 um: the cubic answer
// stands, and the first round makes under 1 um (with a flat 0.05 um margin
// it made 4.21 um).
TEST(OrderChoice, MarginScalesWithTheMeasuredPart) {
  {
    const bench::LoopRecord loop = LoopMakingNoPartWorse(4, 50);
    const double noise_um = bench::DrawGrinderScenario(4, 50).probe_noise_um;
    constexpr double kReferenceUm = 0.0165;  // robustness benchmark, seed 4
    EXPECT_LE(loop.part_rms_um.back(), 1.2 * kReferenceUm + noise_um);
  }
  {
    const bench::Scenario s = bench::DrawGrinderScenario(4, 21);
    const bench::LoopRecord loop =
        bench::RunClosedLoop(s, CorrectionOptions(), 1);
    EXPECT_LT(loop.rounds[0].rms_after_um, 1.0)
        << loop.rounds[0].rms_before_um << " -> "
        << loop.rounds[0].rms_after_um;
  }
}

// Where no noise is stated and the cubic answer's predicted part is within
// 1.5 x the noise the measurement shows, orders 4-6 are not solved for
// (order_choice.cc, AtTheEstimatedNoise). Held-out seed 315, scenario 169
// (sigma 0.47 um, not told): in round 2 orders 4-6 predicted 0.38 um against
// 0.58 held to the cubic terms at a noise estimated at 0.41 um, and made
// 0.42 -> 0.89 um; now the cubic answer stands and says why, and no round is
// worse. With the noise told the rule is not asked.
TEST(OrderChoice, NotSolvedWithOrdersAboveCubicAtTheEstimatedNoise) {
  const char kWhy[] = "x the noise estimated from the measurement";
  const bench::LoopRecord loop = LoopMakingNoPartWorse(315, 169);
  EXPECT_NE(loop.rounds[1].order_choice.find(kWhy), std::string::npos)
      << loop.rounds[1].order_choice;
  EXPECT_EQ(loop.rounds[1].order_choice.rfind("orders 0-3 used", 0), 0u);
  bench::Scenario told = bench::DrawGrinderScenario(315, 169);
  ASSERT_FALSE(told.noise_told);
  told.noise_told = true;
  const bench::LoopRecord stated =
      bench::RunClosedLoop(told, CorrectionOptions(), kRounds);
  for (const bench::RoundRecord& r : stated.rounds)
    EXPECT_EQ(r.order_choice.find(kWhy), std::string::npos) << r.order_choice;
}

// Orders 4-6 linearised at the commanded settings must be predicted better
// at the machine state the cubic answer estimated as well (order_choice.cc,
// BetterAtTheCubicState). Seed 10, scenario 166 (z 94, b = 13 mm, root
// relief, profile crowning and flank twist; hidden Z2 and C0; sigma 0.44
// um): the every-order solve found no state worth using (its fit has more
// free coefficients), and at the commanded settings orders 4-6 predicted
// 1.08 um against 4.17 held to the cubic terms and made 4.08 -> 4.51 um. Now
// the cubic answer stands and says why; no round is worse, and the loop ends
// below 0.5 um (0.162 um).
TEST(OrderChoice, OrdersAboveCubicCheckedAtTheCubicAnswersState) {
  const bench::Scenario s = bench::DrawGrinderScenario(10, 166);
  const SimulatedMeasurement cmm = SimulateMeasurement(
      *s.model, s.initial_parameters, s.hidden_errors, s.measurement);
  CorrectionOptions options;
  options.probe_noise_um = s.noise_told ? s.probe_noise_um : -1.0;
  CorrectionInput input;
  input.model = s.model.get();
  input.current_parameters = s.initial_parameters;
  input.measured_um = cmm.measured_um;
  input.target_um = s.target_um;
  const CorrectionResult first = ComputeCorrection(options, input);
  EXPECT_EQ(first.summary.order_choice.rfind("orders 0-3 used", 0), 0u)
      << first.summary.order_choice;
  EXPECT_NE(first.summary.order_choice.find(
                "at the machine state the cubic answer estimated"),
            std::string::npos)
      << first.summary.order_choice;
  EXPECT_LE(first.summary.highest_order_moved, 3);
  EXPECT_LT(LoopMakingNoPartWorse(10, 166).part_rms_um.back(), 0.5);
}

// Near the noise there is nothing to search for: a part on its target but
// for the probe noise leaves the search not run, and says why.
TEST(ExactSearch, IsNotRunNearTheNoise) {
  const bench::Scenario s = bench::DrawGrinderScenario(2026, 91);
  const SimulatedMeasurement cmm = SimulateMeasurement(
      *s.model, s.initial_parameters, s.hidden_errors, s.measurement);
  CorrectionOptions options;
  options.probe_noise_um = 0.3;
  options.estimate_machine_state = false;
  CorrectionInput input;
  input.model = s.model.get();
  input.current_parameters = s.initial_parameters;
  // The measured part is the target plus the simulated measurement's noise.
  input.measured_um = s.target_um + (cmm.measured_um - cmm.true_deviations_um);
  input.target_um = s.target_um;
  const CorrectionResult result = ComputeCorrection(options, input);
  ASSERT_TRUE(result.summary.IsSolutionUsable())
      << result.summary.BriefReport();
  EXPECT_EQ(result.summary.exact_search.rfind("not run", 0), 0u)
      << result.summary.exact_search;
  EXPECT_NE(result.summary.BriefReport().find("exact search"),
            std::string::npos);
}

// The envelope solve follows each grid point's contact from its contact at the
// nominal settings (flat_wheel_grinder.cc, SolveGroundContact), so the ground
// flank follows the settings without jumping to another root: along the
// straight path from the nominal settings to twice the first part's true
// settings (the target's settings with the hidden errors) of the benchmark's
// 200 scenarios, in 100 equal steps, no reached point's deviation jumps (its
// second difference stays under kJumpUm). The solve from the plane-wheel guess,
// with 20 mm steps, jumped at scenario 131 (row 2, column 0: 12.2 -> 18.9 um at
// 1.96 x); past 2 x that point still lands on a maximum of the deviation
// along the roll (2.1 x; BENCHMARKS.md).
TEST(EnvelopeSolve, FollowsEachContactOnItsBranch) {
  constexpr double kJumpUm = 5.0;
  constexpr double kPathScale = 2.0;
  constexpr int kSteps = 100;
  int jumps = 0;
  for (int index = 0; index < 200; ++index) {
    const bench::Scenario s = bench::DrawGrinderScenario(kBenchmarkSeed, index);
    const auto* grinder = dynamic_cast<const FlatWheelGrinder*>(s.model.get());
    ASSERT_NE(grinder, nullptr);
    const Eigen::VectorXd nominal = grinder->nominal().ToVector();
    const Eigen::VectorXd path =
        kPathScale * (s.initial_parameters + s.hidden_errors - nominal);
    std::vector<ModelEvaluation> last(2);
    for (int step = 0; step <= kSteps; ++step) {
      ModelEvaluation now;
      grinder->Evaluate(nominal + (double(step) / kSteps) * path, false, &now);
      for (int i = 0; step >= 2 && i < now.deviations_um.size(); ++i) {
        if (now.status[i] != PointStatus::kOk ||
            last[0].status[i] != PointStatus::kOk ||
            last[1].status[i] != PointStatus::kOk)
          continue;
        const double second = now.deviations_um(i) -
                              2.0 * last[0].deviations_um(i) +
                              last[1].deviations_um(i);
        if (std::abs(second) > kJumpUm) {
          ++jumps;
          ADD_FAILURE() << "scenario " << index << ", point " << i << " at "
                        << kPathScale * step / kSteps
                        << " x: " << last[0].deviations_um(i) << " -> "
                        << now.deviations_um(i) << " um";
        }
      }
      last[1] = std::move(last[0]);
      last[0] = std::move(now);
    }
  }
  EXPECT_EQ(jumps, 0);
}

// The meshing slope tells a contact at a maximum of the deviation along the
// roll (FlatWheelGrinder::MeshingSlope). Seed 98, scenario 95: the true machine
// of round 3's part (commanded settings with 1/32 of the third correction,
// plus the hidden errors; written down from the loop at commit ddb48ad).
// Newton from the nominal contact of row 1, column 5 ends at roll -0.055 rad,
// a maximum 29.1 um above the flank (the deviation along the roll, solved
// roll by roll: 27.4 um at -0.043 and 27.1 um at -0.067 rad; the minimum, -1.1
// um, lies near 0.029 rad): its slope has the other sign than its nominal
// contact's; its row neighbours' contacts, at the minimum near 0.025 rad, the
// same sign. The solve does not refuse the maximum yet (BENCHMARKS.md, "The
// contact's Newton step, and contacts at a maximum along the roll").
TEST(EnvelopeSolve, TheMeshingSlopeTellsAMaximumAlongTheRoll) {
  const bench::Scenario s = bench::DrawGrinderScenario(98, 95);
  const auto* grinder = dynamic_cast<const FlatWheelGrinder*>(s.model.get());
  ASSERT_NE(grinder, nullptr);
  const std::vector<double> recorded = {
      10.885094076656706,
      -2.3791697172429873,
      -117.51841758525777,
      -727.91963893623267,
      0,
      0,
      0,
      268.93071628113955,
      -0.36506677285593342,
      -131.83431456006721,
      -1673.2662203930397,
      0,
      0,
      0,
      69.00151419678734,
      -74.111451999331635,
      56.705927877418013,
      796.21673080272944,
      0,
      0,
      0,
      0.34829936933193156,
      0.0073281470127615211,
      0.85789950670274151,
      7.6756144297802527,
      0,
      0,
      0,
      0.15264385477822179,
      -0.012291396006514339,
      0.39085153061626232,
      -4.0088112387415116,
      0,
      0,
      0,
      -0.00080841628401252428,
      1.0441252988019623,
      1.5872796752511096,
      5.6170129931491832,
      0,
      0,
      0,
      -0.060099414125782805,
      0,
      0,
  };
  ASSERT_EQ(recorded.size(), 45u);
  const MachineSettings truth = MachineSettings::FromVector(
      Eigen::Map<const Eigen::VectorXd>(recorded.data(), 45));
  const int columns = grinder->GridColumns();
  for (int column : {4, 5, 6}) {
    const FlankGridPoint& point = grinder->grid().points[1 * columns + column];
    const EnvelopeContact nominal =
        grinder->SolveContact(grinder->nominal(), point);
    const EnvelopeContact contact = grinder->SolveContact(truth, point);
    ASSERT_EQ(nominal.status, PointStatus::kOk) << "column " << column;
    ASSERT_EQ(contact.status, PointStatus::kOk) << "column " << column;
    const double nominal_slope =
        grinder->MeshingSlope(grinder->nominal(), point, nominal);
    const double slope = grinder->MeshingSlope(truth, point, contact);
    ASSERT_NE(nominal_slope, 0.0);
    const bool same_sign = slope * nominal_slope > 0.0;
    if (column == 5) {
      EXPECT_LT(contact.roll_rad, -0.05);
      EXPECT_GT(contact.deviation_mm * 1e3, 25.0);
      EXPECT_FALSE(same_sign) << slope << " against " << nominal_slope;
    } else {
      EXPECT_GT(contact.roll_rad, 0.0) << "column " << column;
      EXPECT_TRUE(same_sign) << "column " << column;
    }
  }
}

}  // namespace
}  // namespace gearloop
