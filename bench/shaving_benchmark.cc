// shaving_benchmark: the plunge-shaving cutter target of issue 18 on the
// published case (Jiang 2015: pinion z1 = 19, 9.91 deg right hand; cutter z_s =
// 37, 15 deg left hand; C1 = C2 = 20 um, l1 = l2 = 0.3, parabolic), default 5 x
// 9 grid: per point the global start over 49 work angles, the 4 x 4 Newton for
// the unmodified and the modified pinion, the wheel-radius formulas. Goal on
// the 2-core machine, single thread: < 20 ms. Run:
// build/bench/shaving_benchmark (see BENCHMARKS.md, "Shaving cutter target").
#include <benchmark/benchmark.h>

#include "engine/core/units.h"
#include "engine/shaving/cutter_target.h"

namespace {

gearloop::ShavingInput PublishedCase() {
  using gearloop::kRadPerDeg;
  gearloop::ShavingInput input;
  gearloop::GearData& work = input.work_gear;
  work.teeth = 19;
  work.normal_module_mm = 6.0;
  work.normal_pressure_angle_rad = 20.0 * kRadPerDeg;
  work.helix_angle_rad = -9.91 * kRadPerDeg;
  work.face_width_mm = 75.0;
  work = gearloop::WithStandardRadii(work);
  gearloop::GearData& cutter = input.cutter;
  cutter.teeth = 37;
  cutter.normal_module_mm = 6.0;
  cutter.normal_pressure_angle_rad = 20.0 * kRadPerDeg;
  cutter.helix_angle_rad = 15.0 * kRadPerDeg;
  cutter.face_width_mm = 78.0;
  cutter.tip_radius_mm = 120.9157;
  cutter.root_radius_mm = 107.1569;
  input.diagonal_modification.root_um = 20.0;
  input.diagonal_modification.tip_um = 20.0;
  input.diagonal_modification.root_band = 0.3;
  input.diagonal_modification.tip_band = 0.3;
  input.diagonal_modification.exponent = 2;
  input.wheel_check.h_s_mm = 2.0;
  return input;
}

void BM_ShavingCutterTarget(benchmark::State& state) {
  const gearloop::ShavingInput input = PublishedCase();
  const gearloop::ShavingOptions options;
  for (auto _ : state) {
    const gearloop::ShavingResult result =
        gearloop::ComputeShavingCutterTarget(options, input);
    benchmark::DoNotOptimize(result.stock_target_um.data());
    if (result.summary.num_solved != 36)
      state.SkipWithError("the published case should solve 36 of 45 points");
  }
}
BENCHMARK(BM_ShavingCutterTarget)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
