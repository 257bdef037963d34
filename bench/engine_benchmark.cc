// engine_benchmark: one full 5 x 9 deviation evaluation and one full
// sensitivity matrix S on the published cutter (issue 2 targets on the 2-core
// machine, single thread: deviations under 0.1 ms, S under 0.5 ms). Run:
// build/bench/engine_benchmark (see BENCHMARKS.md). BM_Evaluate runs the same
// evaluation on the published cutter and three more gears (arg: gear index,
// with_jacobian) and counts the contact Newton's iterations per grid point.
#include <benchmark/benchmark.h>

#include <cmath>

#include "bench/bench_gears.h"
#include "engine/core/units.h"
#include "engine/grinder/flat_wheel_grinder.h"

namespace {

gearloop::GrindingSetup Cutter() {
  gearloop::GrindingSetup s;
  s.gear.teeth = 37;
  s.gear.normal_module_mm = 6.0;
  s.gear.normal_pressure_angle_rad = 20.0 * gearloop::kRadPerDeg;
  s.gear.helix_angle_rad = 15.0 * gearloop::kRadPerDeg;
  s.gear.face_width_mm = 78.0;
  s.gear.tip_radius_mm = 120.9157;
  s.gear.root_radius_mm = 107.1569;
  s.wheel.radius_mm = 350.0;
  return s;
}

// Settings a little off nominal, as after a correction, so Newton has work to
// do.
Eigen::VectorXd OffNominal(const gearloop::FlatWheelGrinder& grinder) {
  Eigen::VectorXd zeta = grinder.nominal().ToVector();
  zeta(gearloop::ParameterIndex(gearloop::Axis::kA, 1)) += 3e-5;
  zeta(gearloop::ParameterIndex(gearloop::Axis::kC, 2)) += 1e-4;
  zeta(gearloop::kConeAngleIndex) = 1e-4;
  return zeta;
}

void BM_DeviationGrid(benchmark::State& state) {
  const gearloop::FlatWheelGrinder grinder(Cutter());
  const Eigen::VectorXd zeta = OffNominal(grinder);
  gearloop::ModelEvaluation eval;
  for (auto _ : state) {
    grinder.Evaluate(zeta, /*with_jacobian=*/false, &eval);
    benchmark::DoNotOptimize(eval.deviations_um.data());
  }
}
BENCHMARK(BM_DeviationGrid)->Unit(benchmark::kMicrosecond);

void BM_SensitivityMatrix(benchmark::State& state) {
  const gearloop::FlatWheelGrinder grinder(Cutter());
  const Eigen::VectorXd zeta = OffNominal(grinder);
  gearloop::ModelEvaluation eval;
  for (auto _ : state) {
    grinder.Evaluate(zeta, /*with_jacobian=*/true, &eval);
    benchmark::DoNotOptimize(eval.jacobian_um.data());
  }
}
BENCHMARK(BM_SensitivityMatrix)->Unit(benchmark::kMicrosecond);

gearloop::GrindingSetup BenchGear(int index) {
  switch (index) {
    case 0:
      return gearloop::bench::Cutter();
    case 1:
      return gearloop::bench::RightHandLeftFlank();
    case 2:
      return gearloop::bench::Helical();
    default:
      return gearloop::bench::Spur();
  }
}

// Newton iterations per contact at `zeta` (mean over the grid).
double NewtonIterationsPerContact(const gearloop::FlatWheelGrinder& grinder,
                                  const Eigen::VectorXd& zeta) {
  const auto settings = gearloop::MachineSettings::FromVector(zeta);
  int total = 0;
  for (const auto& point : grinder.grid().points)
    total += grinder.SolveContact(settings, point).iterations;
  return double(total) / grinder.grid().NumPoints();
}

void BM_Evaluate(benchmark::State& state) {
  const gearloop::FlatWheelGrinder grinder(BenchGear(state.range(0)));
  const bool with_jacobian = state.range(1) != 0;
  const Eigen::VectorXd zeta = OffNominal(grinder);
  gearloop::ModelEvaluation eval;
  for (auto _ : state) {
    grinder.Evaluate(zeta, with_jacobian, &eval);
    benchmark::DoNotOptimize(eval.deviations_um.data());
  }
  state.counters["newton_per_contact"] =
      NewtonIterationsPerContact(grinder, zeta);
}
BENCHMARK(BM_Evaluate)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->ArgNames({"gear", "jac"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
