// The published chain end to end (issue 18, "Must show"; Jiang 2015): the
// designer's diagonal modification of the pinion -> the plunge-shaving
// cutter's target (SHAVING.md) -> closed-loop correction of the flat-wheel
// grinder grinding that cutter, with hidden machine errors in the simulator
// (MODEL.md §8) -> three rounds. The true error of each part is measured
// against the target on the points the pinion generates (the others carry
// weight 0 in every correction).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "engine/correction/correction.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/shaving/cutter_target.h"
#include "engine/simulation/measurement_simulator.h"
#include "tests/engine/shaving_test_cases.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

// rms of `error` over the points with weight > 0.
double WeightedPointsRms(const Eigen::VectorXd& error,
                         const Eigen::VectorXd& weights) {
  double sum2 = 0.0;
  int n = 0;
  for (int i = 0; i < error.size(); ++i) {
    if (weights(i) <= 0.0 || !std::isfinite(error(i))) continue;
    sum2 += error(i) * error(i);
    ++n;
  }
  return n > 0 ? std::sqrt(sum2 / n) : std::nan("");
}

double WeightedPointsMaxAbs(const Eigen::VectorXd& error,
                            const Eigen::VectorXd& weights) {
  double m = 0.0;
  for (int i = 0; i < error.size(); ++i) {
    if (weights(i) > 0.0 && std::isfinite(error(i)))
      m = std::max(m, std::abs(error(i)));
  }
  return m;
}

TEST(ShavingChain, PinionModificationToCorrectedCutterInThreeRounds) {
  // 1. The pinion's modification -> the cutter's stock target on the cutter's
  // MODEL.md §4 grid (5 x 9).
  ShavingInput shaving = testing::PublishedShaving();
  shaving.diagonal_modification = testing::CertifiedModification();
  const ShavingResult target =
      ComputeShavingCutterTarget(ShavingOptions(), shaving);
  ASSERT_TRUE(target.summary.IsSolutionUsable()) << target.summary.message;
  const GrindingSetup setup = testing::CutterSetup();
  const FlatWheelGrinder grinder(setup);
  const int n = grinder.grid().NumPoints();
  ASSERT_EQ(target.rows * target.columns, n);

  // 2. The correction's target and weights: points the pinion does not
  // generate (row 0, beyond the pinion's tip) get weight 0.
  Eigen::VectorXd target_um = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd weights = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    if (target.status[i] != ShavingPointStatus::kOk) continue;
    target_um(i) = target.stock_target_um(i);
    weights(i) = 1.0;
  }
  EXPECT_EQ(weights.sum(), 36.0);

  // 3. The published cutter on a grinder with hidden machine errors (every
  // axis up to order 2, ~2 um of axis motion each, and the wheel), measured
  // with 0.2 um probe noise, corrected three times.
  const Eigen::VectorXd nominal = grinder.nominal().ToVector();
  const Eigen::VectorXd hidden = RandomHiddenErrors(grinder,
                                                    grinder.roll_min_rad(),
                                                    grinder.roll_max_rad(),
                                                    2.0,
                                                    2,
                                                    0.4,
                                                    /*seed=*/7);
  ClosedLoopOptions loop;
  loop.corrections = 3;
  loop.measurement.probe_noise_um = 0.2;
  loop.measurement.seed = 11;
  loop.correction.probe_noise_um = 0.2;
  loop.correction.point_weights = weights;
  const ClosedLoopResult run =
      SimulateClosedLoop(grinder, nominal, hidden, target_um, loop);
  ASSERT_TRUE(run.completed) << run.message;
  ASSERT_EQ(run.iterations.size(), 4u);

  std::vector<double> rms;
  for (const ClosedLoopIteration& part : run.iterations) {
    rms.push_back(WeightedPointsRms(part.true_error_um, weights));
    std::cout << "part " << part.part << ": true error against the cutter "
              << "target " << rms.back() << " um rms (max |.| "
              << WeightedPointsMaxAbs(part.true_error_um, weights) << " um)";
    if (part.corrected) std::cout << "; " << part.correction.BriefReport();
    std::cout << "\n";
  }
  // What one exact, noise-free correction linearised at the nominal settings
  // could reach (the best reachable rms of a part ground without machine
  // errors): the target needs axis changes too large for one linear step.
  CorrectionOptions exact;
  exact.probe_noise_um = 0.0;
  exact.point_weights = weights;
  CorrectionInput input;
  input.model = &grinder;
  input.current_parameters = nominal;
  input.measured_um = SimulateMeasurement(grinder,
                                          nominal,
                                          Eigen::VectorXd::Zero(nominal.size()),
                                          MeasurementSimulationOptions())
                          .measured_um;
  input.target_um = target_um;
  const CorrectionResult one_step = ComputeCorrection(exact, input);
  std::cout << "best reachable against the cutter target: "
            << one_step.summary.best_reachable_rms_um << " um rms\n";
  // The first part (nominal settings, hidden errors) is far from the target.
  // With the default options (the wheel parabola fixed since issue 13, each
  // direction filtered by its own signal to noise, the motion bound inside
  // the solve) the loop goes 8.09 -> 0.174 -> 0.155 -> 0.153 um rms: no part
  // worse than the one before, and below the 1 um after three rounds,
  // lower than one linear step from nominal promised (2.26 um: the wheel's
  // dish and the axes' weak directions were counted out by its rank).
  EXPECT_GT(rms[0], 4.0);
  for (size_t k = 1; k < rms.size(); ++k)
    EXPECT_LE(rms[k], rms[k - 1] + std::max(0.1, 0.1 * rms[k - 1]))
        << "part " << k << " is worse than the one before";
  EXPECT_LT(rms[3], /*issue 18, um=*/1.0);
  EXPECT_LT(rms[3], one_step.summary.best_reachable_rms_um);
}

}  // namespace
}  // namespace gearloop
