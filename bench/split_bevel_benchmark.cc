// split_bevel_benchmark: one split-bevel trajectory request of issue 14's size,
// 2 000 stations x 10 depth levels x 2 flanks (40 000 points, 360 000
// side-deviation foot points), engine side, single thread; goal < 50 ms on the
// 2-core machine. Run: build/bench/split_bevel_benchmark (see BENCHMARKS.md,
// "Split bevel trajectory").
#include <benchmark/benchmark.h>

#include "engine/core/units.h"
#include "engine/split_bevel/nc_program.h"
#include "engine/split_bevel/trajectory.h"

namespace {

// The right-hand wheel of the tests (tests/engine/split_bevel_test_gears.h): z
// = 75, delta = 70 deg, m_et = 40 mm, b = 240 mm, beta_m = 35 deg, alpha = 20
// deg, r0 = 8 mm, 0.2 mm stock, pivot 300 mm.
gearloop::SplitBevelRequest Request(bool nc) {
  gearloop::SplitBevelRequest r;
  r.gear.teeth = 75;
  r.gear.pitch_angle_rad = gearloop::DegToRad(70.0);
  r.gear.outer_transverse_module_mm = 40.0;
  r.gear.face_width_mm = 240.0;
  r.gear.mean_spiral_angle_rad = gearloop::DegToRad(35.0);
  r.gear.hand = gearloop::SplitBevelHand::kRight;
  r.gear.pressure_angle_rad = gearloop::DegToRad(20.0);
  r.tool.radius_mm = 8.0;
  r.tool.stock_mm = 0.2;
  r.cut.slot_index = 3;
  r.cut.flanks = {gearloop::SplitBevelFlank::kConvex,
                  gearloop::SplitBevelFlank::kConcave};
  r.cut.depth_levels = 10;
  r.cut.steps = 2000;
  r.machine.pivot_length_mm = 300.0;
  r.nc_program = nc;
  return r;
}

void BM_SplitTrajectory2000x10x2(benchmark::State& state) {
  const gearloop::SplitBevelRequest request = Request(/*nc=*/false);
  for (auto _ : state) {
    gearloop::SplitBevelResult result =
        gearloop::ComputeSplitTrajectory(request);
    if (!result.ok) state.SkipWithError(result.message.c_str());
    benchmark::DoNotOptimize(result.passes.data());
  }
}
BENCHMARK(BM_SplitTrajectory2000x10x2)->Unit(benchmark::kMillisecond);

void BM_SplitTrajectory2000x10x2WithNc(benchmark::State& state) {
  const gearloop::SplitBevelRequest request = Request(/*nc=*/true);
  for (auto _ : state) {
    gearloop::SplitBevelResult result =
        gearloop::ComputeSplitTrajectory(request);
    if (!result.ok) state.SkipWithError(result.message.c_str());
    benchmark::DoNotOptimize(result.nc_program.data());
  }
}
BENCHMARK(BM_SplitTrajectory2000x10x2WithNc)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
