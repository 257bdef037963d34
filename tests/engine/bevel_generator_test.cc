// Tests of the free-form spiral-bevel generator as a MachineModel
// (engine/bevel/freeform_generator.h): meshing equation, exact Jacobian,
// axis-error sensitivity, and a closed-loop correction.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "engine/bevel/conversion.h"
#include "engine/bevel/freeform_generator.h"
#include "engine/core/units.h"
#include "engine/correction/correction.h"
#include "engine/simulation/measurement_simulator.h"

namespace gearloop {
namespace {

struct Fixture {
  explicit Fixture(BevelFlankSide side)
      : job(PublishedPinionJob(side)),
        conversion(ConvertCradleToFreeForm(ConversionOptions(), job)),
        generator(job, conversion.grid, conversion.motion) {}
  BevelPinionJob job;
  ConversionResult conversion;
  BevelFreeFormGenerator generator;
};

const Fixture& Convex() {
  static const Fixture* f = new Fixture(BevelFlankSide::kConvex);
  return *f;
}

TEST(BevelFreeFormGenerator, BlocksCoverParameters) {
  const BevelFreeFormGenerator& g = Convex().generator;
  ASSERT_TRUE(Convex().conversion.ok);
  EXPECT_EQ(g.NumParameters(), 30);
  EXPECT_EQ(g.NumPoints(), 45);
  int covered = 0;
  for (const ParameterBlock& b : g.ParameterBlocks()) {
    EXPECT_TRUE(b.is_polynomial);
    EXPECT_EQ(b.first_index, covered);
    covered += b.num_coefficients;
    EXPECT_GT(b.default_scale, 0.0);
  }
  EXPECT_EQ(covered, 30);
  EXPECT_EQ(g.ParameterName(0), "A0");
  EXPECT_EQ(g.ParameterName(29), "Z5");
}

// With a perturbed motion every contact still satisfies its meshing equation
// and lies on the normal line of its grid point at the reported deviation.
TEST(BevelFreeFormGenerator, PerturbedFlankSatisfiesMeshingEquation) {
  const Fixture& f = Convex();
  FreeFormMotion motion = f.conversion.motion;
  motion.coefficients[static_cast<int>(FreeFormAxis::kX)](0) += 0.01;
  motion.coefficients[static_cast<int>(FreeFormAxis::kB)](1) += 1e-4;
  for (int i = 0; i < f.generator.NumPoints(); ++i) {
    const BevelContact c = f.generator.SolveContact(motion, i);
    ASSERT_EQ(c.status, PointStatus::kOk) << i;
    Eigen::Vector3d n;
    double meshing = 1.0;
    const Eigen::Vector3d r = f.generator.SurfacePoint(
        motion, c.blade_u_mm, c.cutter_theta_rad, c.roll_rad, &n, &meshing);
    EXPECT_NEAR(meshing, 0.0, 1e-9);
    const BevelGridPoint& p = f.generator.grid().points[i];
    EXPECT_LT((r - p.position_mm - c.deviation_mm * p.normal).norm(), 1e-9);
    EXPECT_GT(std::abs(c.deviation_mm),
              1e-4);  // the perturbation really moves the flank
  }
}

// The exact Jacobian against central differences of the model, column by
// column; steps are chosen per coefficient so the axis moves ~1e-4 mm (or 1e-6
// rad) at the end of the roll range.
TEST(BevelFreeFormGenerator, JacobianMatchesCentralDifferences) {
  const BevelFreeFormGenerator& g = Convex().generator;
  const Eigen::VectorXd p0 = Convex().conversion.motion.ToVector();
  ModelEvaluation base;
  g.Evaluate(p0, /*with_jacobian=*/true, &base);
  ASSERT_TRUE(base.AllReached());
  const double h_roll =
      std::max(std::abs(g.roll_min_rad()), std::abs(g.roll_max_rad()));
  const double tol_relative = 1e-7;  // measured: 2.3e-9 (convex)
  for (int j = 0; j < g.NumParameters(); ++j) {
    const int axis = j / (g.degree() + 1), order = j % (g.degree() + 1);
    const double step = (axis < 2 ? 1e-6 : 1e-4) / std::pow(h_roll, order);
    Eigen::VectorXd plus = p0, minus = p0;
    plus(j) += step;
    minus(j) -= step;
    ModelEvaluation ep, em;
    g.Evaluate(plus, false, &ep);
    g.Evaluate(minus, false, &em);
    const Eigen::VectorXd numeric =
        (ep.deviations_um - em.deviations_um) / (2.0 * step);
    const Eigen::VectorXd exact = base.jacobian_um.col(j);
    EXPECT_LT((numeric - exact).norm(), tol_relative * exact.norm() + 1e-9)
        << g.ParameterName(j);
  }
}

// The axis-error table (Tang 2011 Table 2 style): linear prediction matches the
// re-evaluated model for the published 0.01 mm / 0.01 deg offsets, and the
// ranking is by rms.
TEST(ComputeAxisSensitivity, OffsetsMatchExactModelAndAreRanked) {
  const BevelFreeFormGenerator& g = Convex().generator;
  const AxisSensitivityTable table =
      ComputeAxisSensitivity(g, Convex().conversion.motion.ToVector());
  ASSERT_EQ(table.offsets.size(), 5u);
  EXPECT_EQ(table.coefficients.size(), 30u);
  for (const AxisSensitivityEntry& e : table.offsets) {
    EXPECT_GT(e.max_abs_um, 0.1)
        << e.axis;  // every axis moves the flank by micrometres
    EXPECT_NEAR(e.max_abs_um, e.exact_max_abs_um, 0.02 * e.exact_max_abs_um)
        << e.axis;
    EXPECT_LE(e.rms_um, e.max_abs_um);
  }
  for (size_t k = 1; k < table.offset_ranking.size(); ++k) {
    EXPECT_GE(table.offsets[table.offset_ranking[k - 1]].rms_um,
              table.offsets[table.offset_ranking[k]].rms_um);
  }
}

TEST(AxisSensitivityOptions, RejectsNonPositiveErrors) {
  AxisSensitivityOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error));
  options.angular_error_rad = 0.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("angular_error_rad"), std::string::npos);
}

// Against the published axis-error table (Tang 2011, Table 2, convex side, 0.01
// mm / 0.01 deg per axis): B moves the flank most, and each axis's largest
// flank error is within 45 % of the published one (X 8, Y 7, Z 3, A 4, B 14 um;
// their flank came from a CAD cut, ours is exact).
TEST(ComputeAxisSensitivity, AgreesWithPublishedTable) {
  const AxisSensitivityTable table = ComputeAxisSensitivity(
      Convex().generator, Convex().conversion.motion.ToVector());
  EXPECT_EQ(table.offsets[table.offset_ranking[0]].axis, "B");
  const std::map<std::string, double> published_max_um = {
      {"X", 8.0}, {"Y", 7.0}, {"Z", 3.0}, {"A", 4.0}, {"B", 14.0}};
  for (const AxisSensitivityEntry& e : table.offsets) {
    EXPECT_NEAR(e.max_abs_um / published_max_um.at(e.axis), 1.0, 0.45)
        << e.axis << " " << e.max_abs_um;
  }
  // Z moves the cutter along its own axis: the cone's normal shift is 0.01 mm
  // sin(blade angle) everywhere on the straight blade.
  for (const AxisSensitivityEntry& e : table.offsets) {
    if (e.axis != "Z") continue;
    EXPECT_NEAR(e.min_um, 10.0 * std::sin(25.0 * kPi / 180.0), 1e-6);
    EXPECT_NEAR(e.max_um, 10.0 * std::sin(25.0 * kPi / 180.0), 1e-6);
  }
}

// Closed loop: hidden errors on the free-form axes (offsets and drifts) are
// recovered by the same solver and simulated measuring machine as the
// grinder's.
TEST(BevelCorrection, RecoversHiddenAxisErrors) {
  const Fixture& f = Convex();
  const BevelFreeFormGenerator& g = f.generator;
  const Eigen::VectorXd commanded = f.conversion.motion.ToVector();
  const int n = g.degree() + 1;
  Eigen::VectorXd hidden = Eigen::VectorXd::Zero(g.NumParameters());
  hidden(0 * n + 0) = 0.004 * kPi / 180.0;   // A offset 0.004 deg
  hidden(1 * n + 0) = -0.003 * kPi / 180.0;  // B offset
  hidden(2 * n + 0) = 0.008;                 // X offset [mm]
  hidden(3 * n + 1) = -0.02;                 // Y drift [mm/rad]
  hidden(4 * n + 0) = 0.005;                 // Z offset [mm]
  MeasurementSimulationOptions m;
  m.probe_noise_um = 0.0;
  m.seed = 6;
  const SimulatedMeasurement cmm = SimulateMeasurement(g, commanded, hidden, m);
  double initial_rms = 0.0;
  for (int i = 0; i < cmm.measured_um.size(); ++i)
    initial_rms += cmm.measured_um(i) * cmm.measured_um(i);
  initial_rms = std::sqrt(initial_rms / cmm.measured_um.size());
  ASSERT_GT(initial_rms, 1.0);

  CorrectionInput input;
  input.model = &g;
  input.current_parameters = commanded;
  input.measured_um = cmm.measured_um;
  input.target_um = Eigen::VectorXd::Zero(g.NumPoints());
  CorrectionOptions options;
  options.default_max_order = 2;
  const CorrectionResult result = ComputeCorrection(options, input);
  ASSERT_TRUE(result.summary.IsSolutionUsable()) << result.summary.message;

  // Grind again with the corrected commands: the machine still carries the
  // hidden errors.
  ModelEvaluation after;
  g.Evaluate(result.parameters + hidden, false, &after);
  ASSERT_TRUE(after.AllReached());
  const double rms_after =
      std::sqrt(after.deviations_um.squaredNorm() / after.deviations_um.size());
  EXPECT_LT(rms_after, 0.05 * initial_rms)
      << "initial " << initial_rms << " um";
  EXPECT_LT(after.deviations_um.cwiseAbs().maxCoeff(), 0.2);
}

// The simulated closed loop (grind, measure with probe noise, correct, twice)
// on the concave side with random hidden axis errors up to order 2 drawn by the
// grinder's own generator.
TEST(BevelCorrection, ClosedLoopConvergesWithProbeNoise) {
  static const Fixture* concave = new Fixture(BevelFlankSide::kConcave);
  const BevelFreeFormGenerator& g = concave->generator;
  ASSERT_TRUE(concave->conversion.ok);
  const Eigen::VectorXd hidden = RandomHiddenErrors(g,
                                                    g.roll_min_rad(),
                                                    g.roll_max_rad(),
                                                    /*block_size=*/5.0,
                                                    /*max_order=*/2,
                                                    /*wheel_size=*/0.0,
                                                    /*seed=*/11);
  ClosedLoopOptions loop;
  loop.corrections = 2;
  loop.measurement.probe_noise_um = 0.2;
  loop.measurement.seed = 5;
  loop.correction.default_max_order = 2;
  loop.correction.probe_noise_um = 0.2;
  const ClosedLoopResult run =
      SimulateClosedLoop(g,
                         concave->conversion.motion.ToVector(),
                         hidden,
                         Eigen::VectorXd::Zero(g.NumPoints()),
                         loop);
  ASSERT_TRUE(run.completed) << run.message;
  ASSERT_EQ(run.iterations.size(), 3u);
  const double initial = run.iterations.front().true_rms_um;
  const double final_rms = run.iterations.back().true_rms_um;
  EXPECT_GT(initial, 1.0);
  EXPECT_LT(final_rms, 0.25);  // about the probe noise
  EXPECT_LT(final_rms, 0.1 * initial) << "initial " << initial << " um";
}

}  // namespace
}  // namespace gearloop
