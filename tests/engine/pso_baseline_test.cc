// The published particle swarm ("pso", MODEL.md §6; Jiang 2015) as a competent
// reader of the paper runs it: the published cutter case with hidden machine
// errors and probe noise, and the swarm's box, objective and determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/correction/baseline_solvers.h"
#include "engine/correction/correction.h"
#include "engine/correction/problem.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/target_modification.h"
#include "engine/simulation/measurement_simulator.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

// The paper: "grinding error < 2 um" (Fig. 4f).
constexpr double kPublishedErrorUm = 2.0;
// The probe noise of the published case's measurements [um].
constexpr double kProbeNoiseUm = 0.3;
// The published box: +-0.02 of every coefficient in its own unit.
constexpr double kPublishedBox = 0.02;

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

// The freedoms of the published case (CorrectionOptions::max_order).
enum class Freedom {
  kPublished,  // C orders 0-6, every other axis order 0, the cone angle
  kTwoAxis,    // the paper's two-axis variant: Z and C orders 0-6, the wheel
  kAll45,      // every axis orders 0-6 and the wheel (q = 45 in the paper)
};

void SetFreedom(Freedom freedom, CorrectionOptions* options) {
  switch (freedom) {
    case Freedom::kPublished:
      options->default_max_order = 0;
      options->max_order = {{"C", 6}};
      break;
    case Freedom::kTwoAxis:
      options->default_max_order = -1;
      options->max_order = {{"Z", 6},
                            {"C", 6},
                            {"parabola_coefficient", 0},
                            {"parabola_vertex", 0}};
      break;
    case Freedom::kAll45:
      options->default_max_order = 6;
      options->max_order = {{"parabola_coefficient", 0},
                            {"parabola_vertex", 0}};
      break;
  }
}

// The published cutter (right flank) with seeded hidden machine errors (every
// axis up to order 2, about 2 um of axis motion each, and the wheel), ground
// with the nominal settings and measured with 0.3 um of probe noise, to be
// corrected toward a diagonal end relief (the paper's cutter carries a
// diagonal modification). Not copyable: input.model points at grinder.
struct PublishedCutterCase {
  explicit PublishedCutterCase(std::uint64_t seed)
      : setup(testing::CutterSetup()),
        grinder(setup),
        nominal(grinder.nominal().ToVector()),
        hidden(RandomHiddenErrors(grinder,
                                  grinder.roll_min_rad(),
                                  grinder.roll_max_rad(),
                                  2.0,
                                  2,
                                  0.4,
                                  seed)) {
    TargetModification diagonal{ModificationKind::kDiagonalEndRelief, 5.0, 0.3};
    diagonal.second_amount_um = 5.0;
    MeasurementSimulationOptions cmm;
    cmm.probe_noise_um = kProbeNoiseUm;
    cmm.seed = seed;
    input.model = &grinder;
    input.current_parameters = nominal;
    input.measured_um =
        SimulateMeasurement(grinder, nominal, hidden, cmm).measured_um;
    input.target_um = EvaluateTargetModifications(
        {diagonal}, grinder.grid(), setup.gear, setup.flank);
  }
  PublishedCutterCase(const PublishedCutterCase&) = delete;
  PublishedCutterCase& operator=(const PublishedCutterCase&) = delete;

  // The true rms error against the target of the next part, ground with the
  // corrected settings on the machine with its hidden errors.
  double NextPartTrueRmsUm(const CorrectionResult& result) const {
    return Rms(SimulateMeasurement(grinder, result.parameters, hidden, {})
                   .true_deviations_um -
               input.target_um);
  }

  const GrindingSetup setup;
  const FlatWheelGrinder grinder;
  const Eigen::VectorXd nominal;
  const Eigen::VectorXd hidden;
  CorrectionInput input;
};

struct Outcome {
  double predicted_um = 0.0;  // exact model, over the used points
  double true_um = 0.0;       // the next part
  double size = 0.0;          // correction size (MODEL.md §6)
};

Outcome Correct(const PublishedCutterCase& c,
                CorrectionSolver solver,
                Freedom freedom) {
  CorrectionOptions options;
  options.solver = solver;
  options.probe_noise_um = kProbeNoiseUm;
  SetFreedom(freedom, &options);
  const CorrectionResult result = ComputeCorrection(options, c.input);
  EXPECT_EQ(result.summary.status, CorrectionStatus::kConverged)
      << CorrectionSolverName(solver) << ": " << result.summary.message;
  return {result.summary.residual_rms_um,
          c.NextPartTrueRmsUm(result),
          result.summary.correction_size};
}

const std::uint64_t kSeeds[] = {1, 2, 3, 4, 5, 6};

// "pso" reaches the published "< 2 um" on the exact model and on the next part
// with the published freedom (C up to order 6), the paper's two-axis variant
// and all 45 coefficients free.
TEST(PsoBaseline, ReachesThePublishedTwoMicronsOnTheCutter) {
  for (std::uint64_t seed : kSeeds) {
    const PublishedCutterCase c(seed);
    for (Freedom freedom :
         {Freedom::kPublished, Freedom::kTwoAxis, Freedom::kAll45}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", freedom " +
                   std::to_string(static_cast<int>(freedom)));
      const Outcome pso = Correct(c, CorrectionSolver::kParticleSwarm, freedom);
      EXPECT_LT(pso.predicted_um, kPublishedErrorUm);
      EXPECT_LT(pso.true_um, kPublishedErrorUm);
    }
  }
}

// On the same cases and freedoms the default solver moves the axes less and
// leaves a lower true residual, summed over the seeds (seed by seed "pso" may
// land lower, the default leaving what its filter says is noise, or move less:
// seed 6, published freedom, 62 against 74, where the default follows a weak
// direction the measurement shows well above the noise).
TEST(PsoBaseline, DefaultSolverReachesLowerWithASmallerCorrection) {
  for (Freedom freedom : {Freedom::kPublished, Freedom::kTwoAxis}) {
    double pso_true_sum = 0.0, default_true_sum = 0.0;
    double pso_size_sum = 0.0, default_size_sum = 0.0;
    for (std::uint64_t seed : kSeeds) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", freedom " +
                   std::to_string(static_cast<int>(freedom)));
      const PublishedCutterCase c(seed);
      const Outcome pso = Correct(c, CorrectionSolver::kParticleSwarm, freedom);
      const Outcome regularised =
          Correct(c, CorrectionSolver::kRegularised, freedom);
      pso_true_sum += pso.true_um;
      default_true_sum += regularised.true_um;
      pso_size_sum += pso.size;
      default_size_sum += regularised.size;
    }
    EXPECT_LT(default_true_sum, pso_true_sum)
        << "freedom " << static_cast<int>(freedom);
    EXPECT_LT(default_size_sum, pso_size_sum)
        << "freedom " << static_cast<int>(freedom);
  }
}

// ---------------------------------------------------------------------------------------------
// The swarm itself (correction_internal::SolveParticleSwarm).

using correction_internal::CorrectionProblem;
using correction_internal::SolveParticleSwarm;
using correction_internal::SwarmTrace;

CorrectionProblem Prepare(const CorrectionOptions& options,
                          const CorrectionInput& input) {
  CorrectionProblem problem;
  CorrectionSummary summary;
  std::string error;
  EXPECT_TRUE(correction_internal::PrepareCorrectionProblem(
      options, input, &problem, &summary, &error))
      << error;
  return problem;
}

// sum_i w_i (S_i dzeta - delta_i)^2 over the used points, delta = t - m.
double NextPartObjective(const CorrectionProblem& problem,
                         const Eigen::VectorXd& delta) {
  const Eigen::VectorXd r = problem.error_um + problem.jacobian_um * delta;
  double f = 0.0;
  for (int i : problem.used) f += problem.weights(i) * r(i) * r(i);
  return f;
}

// The swarm minimises the plain weighted sum on the linearised model for the
// next part: its best never increases, starts no worse than no change (a
// particle starts there) and is the objective of the answer it returns.
TEST(PsoBaseline, SwarmMinimisesTheWeightedLinearisedObjective) {
  const PublishedCutterCase c(7);
  CorrectionOptions options;
  options.solver = CorrectionSolver::kParticleSwarm;
  SetFreedom(Freedom::kTwoAxis, &options);
  const int n = c.grinder.grid().NumPoints();
  options.point_weights = Eigen::VectorXd::Ones(n);
  for (int i = 0; i < n; i += 3) options.point_weights(i) = 4.0;
  const CorrectionProblem problem = Prepare(options, c.input);
  SwarmTrace trace;
  const Eigen::VectorXd delta = SolveParticleSwarm(options, problem, &trace);
  ASSERT_EQ(trace.best_objective.size(),
            static_cast<size_t>(options.pso_generations + 1));
  for (size_t g = 1; g < trace.best_objective.size(); ++g)
    EXPECT_LE(trace.best_objective[g], trace.best_objective[g - 1]);
  const double at_zero =
      NextPartObjective(problem, Eigen::VectorXd::Zero(delta.size()));
  EXPECT_LE(trace.best_objective.front(), at_zero * (1.0 + 1e-12));
  const double at_answer = NextPartObjective(problem, delta);
  EXPECT_NEAR(trace.best_objective.back(), at_answer, 1e-9 * at_answer);
  // It gets somewhere: the weighted sum falls below a hundredth (weighted rms
  // 7.7 um with no change, 0.52 um at the answer).
  EXPECT_LT(at_answer, 1e-2 * at_zero);
}

// Every free coefficient stays within +-0.02 in its own unit (mm, rad, 1/mm:
// the cone angle too), and within tighter bounds where given; nothing else
// moves. The same seed gives the same answer, another seed another.
TEST(PsoBaseline, StaysInThePublishedBoxAndIsSeeded) {
  const PublishedCutterCase c(8);
  CorrectionOptions options;
  options.solver = CorrectionSolver::kParticleSwarm;
  SetFreedom(Freedom::kAll45, &options);
  options.lower_delta = Eigen::VectorXd::Constant(kNumGrinderParameters, -1.0);
  options.upper_delta = Eigen::VectorXd::Constant(kNumGrinderParameters, 1.0);
  const double tight = 1e-4;
  options.lower_delta(kConeAngleIndex) = -tight;
  options.upper_delta(ParameterIndex(Axis::kA, 0)) = tight;
  const CorrectionProblem problem = Prepare(options, c.input);
  ASSERT_EQ(problem.NumFree(), kNumGrinderParameters);
  const Eigen::VectorXd a = SolveParticleSwarm(options, problem);
  for (int j = 0; j < kNumGrinderParameters; ++j) {
    EXPECT_LE(std::abs(a(j)), kPublishedBox) << GrinderParameterName(j);
    EXPECT_GE(a(j), options.lower_delta(j)) << GrinderParameterName(j);
    EXPECT_LE(a(j), options.upper_delta(j)) << GrinderParameterName(j);
  }
  EXPECT_EQ(SolveParticleSwarm(options, problem), a);
  options.pso_seed = 99;
  EXPECT_NE(SolveParticleSwarm(options, problem), a);
}

// Rework (the same part reground, material can only be removed): the paper's
// one-sided objective counts a point only where the wheel reaches it. A part
// that lacks material everywhere (t - m > 0 at every point) cannot be helped,
// so the swarm's best stays at sum w_i delta_i^2, while for the next part
// (ground from a blank with stock) the same swarm removes most of it.
TEST(PsoBaseline, ReworkCountsOnlyThePointsTheWheelReaches) {
  const PublishedCutterCase c(9);
  CorrectionInput input;
  input.model = &c.grinder;
  input.current_parameters = c.nominal;
  const int n = c.grinder.grid().NumPoints();
  input.measured_um = Eigen::VectorXd::Zero(n);
  input.target_um =
      Eigen::VectorXd::Constant(n, 3.0) +
      EvaluateTargetModifications({{ModificationKind::kProfileCrowning, -2.0}},
                                  c.grinder.grid(),
                                  c.setup.gear,
                                  c.setup.flank);
  ASSERT_GT(input.target_um.minCoeff(), 0.0);
  CorrectionOptions options;
  options.solver = CorrectionSolver::kParticleSwarm;
  SetFreedom(Freedom::kTwoAxis, &options);
  options.mode = CorrectionMode::kRework;
  const CorrectionProblem rework = Prepare(options, input);
  SwarmTrace trace;
  SolveParticleSwarm(options, rework, &trace);
  const double untouched =
      NextPartObjective(rework, Eigen::VectorXd::Zero(rework.num_parameters));
  EXPECT_DOUBLE_EQ(trace.best_objective.back(), untouched);
  options.mode = CorrectionMode::kNextPart;
  const CorrectionProblem next_part = Prepare(options, input);
  SolveParticleSwarm(options, next_part, &trace);
  EXPECT_LT(trace.best_objective.back(), 1e-2 * untouched);
}

}  // namespace
}  // namespace gearloop
