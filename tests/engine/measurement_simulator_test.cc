#include "engine/simulation/measurement_simulator.h"

#include <gtest/gtest.h>

#include <cmath>

#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/target_modification.h"
#include "tests/engine/test_gears.h"
#include "tests/engine/test_statistics.h"

namespace gearloop {
namespace {

struct Cutter {
  GrindingSetup setup = testing::CutterSetup();
  FlatWheelGrinder grinder{setup};
  Eigen::VectorXd nominal = grinder.nominal().ToVector();
  Eigen::VectorXd Hidden(std::uint64_t seed) const {
    return RandomHiddenErrors(grinder,
                              grinder.roll_min_rad(),
                              grinder.roll_max_rad(),
                              2.0,
                              2,
                              0.4,
                              seed);
  }
};

TEST(SimulateMeasurement, NoiseFreeGridIsTheModelOfTheRealMachine) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(1);
  const SimulatedMeasurement m =
      SimulateMeasurement(c.grinder, c.nominal, hidden, {});
  ModelEvaluation eval;
  c.grinder.Evaluate(c.nominal + hidden, false, &eval);
  ASSERT_EQ(m.measured_um.size(), 45);
  EXPECT_LT((m.measured_um - eval.deviations_um).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((m.true_deviations_um - eval.deviations_um).cwiseAbs().maxCoeff(),
            1e-12);
  // The hidden errors are visible in the flank: several micrometres.
  EXPECT_GT(m.measured_um.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_TRUE(m.outlier_indices.empty());
  EXPECT_TRUE(m.missing_indices.empty());
}

TEST(SimulateMeasurement, ProbeNoiseHasTheRequestedSpreadAndIsSeeded) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(2);
  MeasurementSimulationOptions options;
  options.probe_noise_um = 0.5;
  double sum2 = 0.0;
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    options.seed = seed;
    const SimulatedMeasurement m =
        SimulateMeasurement(c.grinder, c.nominal, hidden, options);
    const Eigen::VectorXd noise = m.measured_um - m.true_deviations_um;
    sum2 += noise.squaredNorm();
    count += static_cast<int>(noise.size());
  }
  // 1800 samples: the sample standard deviation is within 10% of sigma with
  // overwhelming odds.
  EXPECT_NEAR(std::sqrt(sum2 / count), 0.5, 0.05);
  options.seed = 7;
  const SimulatedMeasurement a =
      SimulateMeasurement(c.grinder, c.nominal, hidden, options);
  const SimulatedMeasurement b =
      SimulateMeasurement(c.grinder, c.nominal, hidden, options);
  EXPECT_EQ(a.measured_um, b.measured_um);
  options.seed = 8;
  const SimulatedMeasurement d =
      SimulateMeasurement(c.grinder, c.nominal, hidden, options);
  EXPECT_NE(a.measured_um, d.measured_um);
}

TEST(SimulateMeasurement, OutliersAndMissingPointsAreReported) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(3);
  MeasurementSimulationOptions options;
  options.outlier_points = {5, 30};
  options.outlier_size_um = 20.0;
  options.missing_points = {44};
  options.seed = 3;
  const SimulatedMeasurement m =
      SimulateMeasurement(c.grinder, c.nominal, hidden, options);
  for (int i : {5, 30})
    EXPECT_NEAR(
        std::abs(m.measured_um(i) - m.true_deviations_um(i)), 20.0, 1e-9);
  EXPECT_EQ(m.outlier_indices, (std::vector<int>{5, 30}));
  EXPECT_TRUE(std::isnan(m.measured_um(44)));
  EXPECT_EQ(m.missing_indices, std::vector<int>{44});
  // Random missing points: every NaN is listed, and only those.
  options.missing_probability = 0.2;
  const SimulatedMeasurement r =
      SimulateMeasurement(c.grinder, c.nominal, hidden, options);
  EXPECT_GT(r.missing_indices.size(), 1u);
  int nan_count = 0;
  for (int i = 0; i < 45; ++i)
    nan_count += std::isnan(r.measured_um(i)) ? 1 : 0;
  EXPECT_EQ(nan_count, static_cast<int>(r.missing_indices.size()));
  for (int i : r.missing_indices) EXPECT_TRUE(std::isnan(r.measured_um(i)));
}

TEST(SimulateMeasurement, SeveralTeethAreAveraged) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(4);
  MeasurementSimulationOptions options;
  options.probe_noise_um = 1.0;
  options.teeth = 4;
  double sum2 = 0.0;
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    options.seed = seed;
    const SimulatedMeasurement m =
        SimulateMeasurement(c.grinder, c.nominal, hidden, options);
    ASSERT_EQ(m.teeth_um.size(), 4u);
    const Eigen::VectorXd noise = m.measured_um - m.true_deviations_um;
    sum2 += noise.squaredNorm();
    count += static_cast<int>(noise.size());
  }
  // The mean of 4 teeth: sigma / 2.
  EXPECT_NEAR(std::sqrt(sum2 / count), 0.5, 0.05);
}

TEST(RandomHiddenErrors, HaveTheRequestedAxisMotion) {
  const Cutter c;
  const std::vector<ParameterBlock> blocks = c.grinder.ParameterBlocks();
  double sum2 = 0.0;
  const int kSeeds = 200;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const Eigen::VectorXd hidden = RandomHiddenErrors(c.grinder,
                                                      c.grinder.roll_min_rad(),
                                                      c.grinder.roll_max_rad(),
                                                      3.0,
                                                      2,
                                                      0.0,
                                                      seed,
                                                      {"B"});
    std::vector<BlockCorrectionSize> sizes;
    CorrectionSize(blocks,
                   hidden,
                   c.grinder.roll_min_rad(),
                   c.grinder.roll_max_rad(),
                   {},
                   &sizes);
    sum2 += sizes[0].size * sizes[0].size;                // X
    EXPECT_EQ(sizes[4].size, 0.0);                        // B is fixed
    EXPECT_EQ(hidden(ParameterIndex(Axis::kX, 3)), 0.0);  // above max_order
    EXPECT_EQ(hidden(kConeAngleIndex), 0.0);              // wheel size 0
  }
  // E[size^2] = block_size^2: 200 samples of chi^2_3 / 3 have a relative spread
  // of ~6%.
  EXPECT_NEAR(std::sqrt(sum2 / kSeeds), 3.0, 0.4);
}

TEST(SimulateClosedLoop, CorrectsTheHiddenErrorsAndRecordsEachPart) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(5);
  const Eigen::VectorXd target =
      EvaluateTargetModifications({{ModificationKind::kProfileCrowning, 2.0}},
                                  c.grinder.grid(),
                                  c.setup.gear,
                                  c.setup.flank);
  ClosedLoopOptions loop;
  loop.corrections = 2;
  loop.measurement.probe_noise_um = 0.2;
  loop.correction.probe_noise_um = 0.2;
  const ClosedLoopResult run =
      SimulateClosedLoop(c.grinder, c.nominal, hidden, target, loop);
  ASSERT_TRUE(run.completed) << run.message;
  ASSERT_EQ(run.iterations.size(), 3u);
  EXPECT_TRUE(run.iterations[0].corrected);
  EXPECT_TRUE(run.iterations[1].corrected);
  EXPECT_FALSE(run.iterations[2].corrected);
  EXPECT_EQ(run.iterations[0].commanded_parameters, c.nominal);
  EXPECT_GT(run.iterations[0].true_rms_um, 0.5);
  // Two corrections bring the true error down to the least-squares noise floor
  // of the best reachable residual (r from the noise-free measurement of the
  // first part).
  const SimulatedMeasurement truth =
      SimulateMeasurement(c.grinder, c.nominal, hidden, {});
  CorrectionOptions exact;
  exact.probe_noise_um = 0.0;
  CorrectionInput input;
  input.model = &c.grinder;
  input.current_parameters = c.nominal;
  input.measured_um = truth.measured_um;
  input.target_um = target;
  const double r =
      ComputeCorrection(exact, input).summary.best_reachable_rms_um;
  EXPECT_LE(run.iterations[2].true_rms_um,
            testing::NoiseFloorUm(r,
                                  0.2,
                                  run.iterations[1].correction.rank,
                                  c.grinder.grid().NumPoints()));
  EXPECT_LT(run.iterations[2].true_rms_um,
            0.25 * run.iterations[0].true_rms_um);
  // The solver never saw the hidden errors: the commanded settings differ from
  // nominal - hidden.
  EXPECT_GT((run.iterations[2].commanded_parameters - (c.nominal - hidden))
                .cwiseAbs()
                .maxCoeff(),
            1e-6);
  // Reproducible.
  const ClosedLoopResult again =
      SimulateClosedLoop(c.grinder, c.nominal, hidden, target, loop);
  EXPECT_EQ(again.iterations[2].true_rms_um, run.iterations[2].true_rms_um);
}

TEST(SimulateClosedLoop, ReportsWhatTheMachineMeasuredForEachPart) {
  const Cutter c;
  const Eigen::VectorXd hidden = c.Hidden(5);
  const Eigen::VectorXd target = Eigen::VectorXd::Zero(c.grinder.NumPoints());
  ClosedLoopOptions loop;
  loop.corrections = 2;
  loop.measurement.probe_noise_um = 0.3;
  loop.measurement.seed = 11;
  loop.correction.probe_noise_um = 0.3;
  const ClosedLoopResult run =
      SimulateClosedLoop(c.grinder, c.nominal, hidden, target, loop);
  ASSERT_EQ(run.iterations.size(), 3u);
  for (size_t k = 0; k < run.iterations.size(); ++k) {
    // Part k is measured with the seed advanced by k: the same grid a client
    // would get from the measuring machine for the commanded parameters of that
    // part.
    MeasurementSimulationOptions part = loop.measurement;
    part.seed += k;
    const SimulatedMeasurement cmm = SimulateMeasurement(
        c.grinder, run.iterations[k].commanded_parameters, hidden, part);
    ASSERT_EQ(run.iterations[k].measured_um.size(), cmm.measured_um.size());
    for (int i = 0; i < cmm.measured_um.size(); ++i) {
      if (std::isnan(cmm.measured_um(i))) {
        EXPECT_TRUE(std::isnan(run.iterations[k].measured_um(i)));
      } else {
        EXPECT_EQ(run.iterations[k].measured_um(i), cmm.measured_um(i))
            << "part " << k << " point " << i;
      }
    }
  }
}

}  // namespace
}  // namespace gearloop
