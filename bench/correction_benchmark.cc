// correction_benchmark: the three correction solvers on the same generated
// cases (issue 3). Each case: a gear, a target modification and hidden machine
// errors; the part ground with the nominal settings is measured with probe
// noise 0.3 um, corrected once by each solver, and the next part is ground with
// the corrected settings plus the same hidden errors. Reported per case and
// solver: the time of one correction (the benchmark's own timing), the true rms
// error of the next part against the target (true_rms_um), the correction size
// (size: rms axis motion over the roll range in um, MODEL.md §6), and the best
// the model could reach (best_um). Run: build/bench/correction_benchmark (see
// BENCHMARKS.md, "## Correction").
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench_gears.h"
#include "engine/correction/correction.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/target_modification.h"
#include "engine/simulation/measurement_simulator.h"

namespace {

using namespace gearloop;

struct Case {
  std::string name;
  GrindingSetup setup;
  std::vector<TargetModification> target;
  std::uint64_t hidden_seed;
};

std::vector<Case> Cases() {
  const GrindingSetup cutter = bench::Cutter();
  const GrindingSetup right_hand = bench::RightHandLeftFlank();
  const GrindingSetup helical = bench::Helical();
  const std::vector<TargetModification> slopes = bench::SlopesAndCrowning();
  const std::vector<TargetModification> relief = {
      {ModificationKind::kTipRelief, 6.0, 0.3, ReliefShape::kParabolic},
      {ModificationKind::kFlankTwist, 4.0}};
  const TargetModification diagonal = bench::DiagonalEndRelief();
  const std::vector<TargetModification> crowned = {
      {ModificationKind::kProfileCrowning, 3.0},
      {ModificationKind::kLeadCrowning, 3.0}};
  return {
      {"cutter/slopes", cutter, slopes, 42},
      {"cutter/diagonal", cutter, {diagonal}, 43},
      {"right_hand_left_flank/relief", right_hand, relief, 44},
      {"right_hand_left_flank/crowned", right_hand, crowned, 45},
      {"helical/slopes", helical, slopes, 46},
      {"helical/crowned", helical, crowned, 47},
  };
}

struct Prepared {
  std::unique_ptr<FlatWheelGrinder> grinder;
  Eigen::VectorXd nominal, hidden, target, measured;
};

Prepared Prepare(const Case& c) {
  Prepared p;
  p.grinder = std::make_unique<FlatWheelGrinder>(c.setup);
  p.nominal = p.grinder->nominal().ToVector();
  p.hidden = RandomHiddenErrors(*p.grinder,
                                p.grinder->roll_min_rad(),
                                p.grinder->roll_max_rad(),
                                2.0,
                                2,
                                0.4,
                                c.hidden_seed);
  p.target = EvaluateTargetModifications(
      c.target, p.grinder->grid(), c.setup.gear, c.setup.flank);
  MeasurementSimulationOptions cmm;
  cmm.probe_noise_um = 0.3;
  cmm.seed = c.hidden_seed;
  p.measured =
      SimulateMeasurement(*p.grinder, p.nominal, p.hidden, cmm).measured_um;
  return p;
}

double Rms(const Eigen::VectorXd& v) {
  double s = 0.0;
  int n = 0;
  for (int i = 0; i < v.size(); ++i) {
    if (std::isfinite(v(i))) {
      s += v(i) * v(i);
      ++n;
    }
  }
  return n > 0 ? std::sqrt(s / n) : std::nan("");
}

// The next part, ground with the corrected settings on the machine with its
// hidden errors: its true rms error against the target, the points it lost,
// and the correction's size, best reachable and initial error.
void ReportNextPart(const Prepared& p,
                    const CorrectionResult& result,
                    benchmark::State* state) {
  const SimulatedMeasurement next =
      SimulateMeasurement(*p.grinder, result.parameters, p.hidden, {});
  const Eigen::VectorXd true_error = next.true_deviations_um - p.target;
  state->counters["true_rms_um"] = Rms(true_error);
  state->counters["lost_points"] =
      static_cast<double>(next.missing_indices.size());
  state->counters["size"] = result.summary.correction_size;
  state->counters["best_um"] = result.summary.best_reachable_rms_um;
  state->counters["initial_rms_um"] = result.summary.initial_rms_um;
}

void BM_Correction(benchmark::State& state) {
  const std::vector<Case> cases = Cases();
  const Case& c = cases[state.range(0)];
  const CorrectionSolver solver = static_cast<CorrectionSolver>(state.range(1));
  const Prepared p = Prepare(c);
  CorrectionOptions options;
  options.solver = solver;
  options.probe_noise_um = 0.3;
  CorrectionInput input;
  input.model = p.grinder.get();
  input.current_parameters = p.nominal;
  input.measured_um = p.measured;
  input.target_um = p.target;
  CorrectionResult result;
  for (auto _ : state) {
    result = ComputeCorrection(options, input);
    benchmark::DoNotOptimize(result.delta.data());
  }
  ReportNextPart(p, result, &state);
  state.SetLabel(c.name + " " + CorrectionSolverName(solver) + " " +
                 CorrectionStatusName(result.summary.status));
}

// The published case (MODEL.md §6, Jiang 2015): the cutter / diagonal case
// above with the paper's freedoms, corrected once by the default and by "pso".
// Freedom 0: C orders 0-6, the other axes order 0, the cone angle (the
// published case); 1: the paper's two-axis variant, Z and C orders 0-6 and the
// wheel; 2: every axis orders 0-6 and the wheel (all 45 coefficients).
void BM_PublishedCase(benchmark::State& state) {
  const Case c = Cases()[1];
  const int freedom = static_cast<int>(state.range(0));
  const CorrectionSolver solver = static_cast<CorrectionSolver>(state.range(1));
  const Prepared p = Prepare(c);
  CorrectionOptions options;
  options.solver = solver;
  options.probe_noise_um = 0.3;
  options.default_max_order = freedom == 0 ? 0 : freedom == 1 ? -1 : 6;
  options.max_order = {{"C", 6}};
  if (freedom > 0) {
    options.max_order["Z"] = 6;
    options.max_order["parabola_coefficient"] = 0;
    options.max_order["parabola_vertex"] = 0;
  }
  CorrectionInput input;
  input.model = p.grinder.get();
  input.current_parameters = p.nominal;
  input.measured_um = p.measured;
  input.target_um = p.target;
  CorrectionResult result;
  for (auto _ : state) {
    result = ComputeCorrection(options, input);
    benchmark::DoNotOptimize(result.delta.data());
  }
  ReportNextPart(p, result, &state);
  state.counters["predicted_um"] = result.summary.residual_rms_um;
  state.counters["free"] = result.summary.num_free_parameters;
  const char* names[] = {"published", "two-axis", "all 45"};
  state.SetLabel(c.name + " " + names[freedom] + " " +
                 CorrectionSolverName(solver) + " " +
                 CorrectionStatusName(result.summary.status));
}

// The same cases run as a closed loop of three corrections (grind, measure with
// 0.3 um noise, correct, repeat): the true rms error of the part after the
// third correction (final_true_rms_um) and the largest single correction
// (max_size). Timing covers the whole loop.
void BM_ClosedLoop(benchmark::State& state) {
  const std::vector<Case> cases = Cases();
  const Case& c = cases[state.range(0)];
  const CorrectionSolver solver = static_cast<CorrectionSolver>(state.range(1));
  const Prepared p = Prepare(c);
  ClosedLoopOptions loop;
  loop.corrections = 3;
  loop.measurement.probe_noise_um = 0.3;
  loop.measurement.seed = c.hidden_seed;
  loop.correction.solver = solver;
  loop.correction.probe_noise_um = 0.3;
  ClosedLoopResult run;
  for (auto _ : state) {
    run = SimulateClosedLoop(*p.grinder, p.nominal, p.hidden, p.target, loop);
    benchmark::DoNotOptimize(run.iterations.data());
  }
  double max_size = 0.0;
  for (const ClosedLoopIteration& it : run.iterations) {
    if (it.corrected)
      max_size = std::max(max_size, it.correction.correction_size);
  }
  state.counters["final_true_rms_um"] =
      run.completed ? run.iterations.back().true_rms_um
                    : std::numeric_limits<double>::quiet_NaN();
  state.counters["max_size"] = max_size;
  state.SetLabel(c.name + " " + CorrectionSolverName(solver) +
                 (run.completed ? "" : " stopped: " + run.message));
}

void Arguments(benchmark::internal::Benchmark* b) {
  const int num_cases = static_cast<int>(Cases().size());
  for (int c = 0; c < num_cases; ++c) {
    for (int s : {static_cast<int>(CorrectionSolver::kRegularised),
                  static_cast<int>(CorrectionSolver::kParticleSwarm),
                  static_cast<int>(CorrectionSolver::kPlainLeastSquares)}) {
      b->Args({c, s});
    }
  }
}

BENCHMARK(BM_Correction)->Apply(Arguments)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ClosedLoop)->Apply(Arguments)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PublishedCase)
    ->ArgsProduct({{0, 1, 2},
                   {static_cast<int>(CorrectionSolver::kRegularised),
                    static_cast<int>(CorrectionSolver::kParticleSwarm)}})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
