// correction_fingerprint: every number ComputeCorrection reports, in
// hexadecimal floating point
// (%a), for the gears of the engine tests and the benchmark under every solver
// and rule: the regularised solver with the probe noise known, zero and
// unknown, the discrepancy principle, rework, bounds, point weights, several
// teeth, outliers, missing points, the published cutter freedom, no refinement,
// pso and lsq-plain, each with and without the machine-state estimate, plus
// rejected input. A refactoring of the solver that keeps the arithmetic keeps
// this output byte for byte: run it before and after and compare (the last line
// counts the values).
//
//   build/bench/correction_fingerprint > before.txt   (and after.txt; then cmp
//   before.txt after.txt)
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "bench/bench_gears.h"
#include "engine/correction/correction.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/target_modification.h"
#include "engine/simulation/measurement_simulator.h"

namespace {

using namespace gearloop;

long long num_values = 0;

void PrintValue(const char* name, double value) {
  std::printf("  %s %a\n", name, value);
  ++num_values;
}

void PrintVector(const char* name, const Eigen::VectorXd& v) {
  std::printf("  %s [%d]", name, static_cast<int>(v.size()));
  for (int i = 0; i < v.size(); ++i) std::printf(" %a", v(i));
  std::printf("\n");
  num_values += v.size();
}

void PrintIndices(const char* name, const std::vector<int>& v) {
  std::printf("  %s [%d]", name, static_cast<int>(v.size()));
  for (int i : v) std::printf(" %d", i);
  std::printf("\n");
}

void PrintResult(const std::string& name, const CorrectionResult& r) {
  const CorrectionSummary& s = r.summary;
  std::printf("%s\n  status %s solver %s mode %s rule %s message '%s'\n",
              name.c_str(),
              CorrectionStatusName(s.status),
              CorrectionSolverName(s.solver),
              CorrectionModeName(s.mode),
              RegularisationRuleName(s.rule),
              s.message.c_str());
  std::printf(
      "  truncation_rank %d num_points_used %d num_free_parameters %d rank %d "
      "iterations %d state %d\n",
      s.truncation_rank,
      s.num_points_used,
      s.num_free_parameters,
      s.rank,
      s.iterations,
      s.machine_state_estimated ? 1 : 0);
  PrintVector("parameters", r.parameters);
  PrintVector("delta", r.delta);
  PrintVector("predicted_residual_um", r.predicted_residual_um);
  PrintVector("predicted_change_um", r.predicted_change_um);
  PrintValue("regularisation_level", s.regularisation_level);
  PrintValue("effective_dof", s.effective_dof);
  PrintValue("condition_number", s.condition_number);
  PrintVector("singular_values", s.singular_values);
  PrintValue("roll_min_rad", s.roll_min_rad);
  PrintValue("roll_max_rad", s.roll_max_rad);
  PrintValue("initial_rms_um", s.initial_rms_um);
  PrintValue("initial_max_um", s.initial_max_um);
  PrintValue("residual_rms_um", s.residual_rms_um);
  PrintValue("residual_max_um", s.residual_max_um);
  PrintValue("best_reachable_rms_um", s.best_reachable_rms_um);
  PrintValue("linear_residual_rms_um", s.linear_residual_rms_um);
  PrintValue("max_added_material_um", s.max_added_material_um);
  PrintValue("correction_size", s.correction_size);
  for (const BlockCorrectionSize& b : s.block_sizes)
    PrintValue(("block " + b.name).c_str(), b.size);
  PrintIndices("outlier_indices", s.outlier_indices);
  PrintIndices("missing_indices", s.missing_indices);
  PrintValue("refinement_initial_cost", s.refinement_initial_cost);
  PrintValue("refinement_final_cost", s.refinement_final_cost);
  PrintValue("machine_state_size", s.machine_state_size);
  PrintValue("machine_state_misfit_rms_um", s.machine_state_misfit_rms_um);
}

struct Gear {
  const char* name;
  GrindingSetup setup;
  std::vector<TargetModification> target;
  std::uint64_t hidden_seed;
};

// One variation of the options and the input.
struct Variant {
  const char* name;
  std::function<void(const FlatWheelGrinder&,
                     CorrectionOptions*,
                     CorrectionInput*,
                     MeasurementSimulationOptions*)>
      apply;
};

std::vector<Variant> Variants() {
  using G = const FlatWheelGrinder&;
  using O = CorrectionOptions*;
  using I = CorrectionInput*;
  using M = MeasurementSimulationOptions*;
  return {
      {"gcv", [](G, O, I, M) {}},
      {"exact", [](G, O o, I, M) { o->probe_noise_um = 0.0; }},
      {"upre",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.5;
         m->probe_noise_um = 0.5;
       }},
      {"discrepancy",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.5;
         o->use_discrepancy_principle = true;
         m->probe_noise_um = 0.5;
       }},
      {"gcv noisy", [](G, O, I, M m) { m->probe_noise_um = 0.5; }},
      {"rework exact",
       [](G, O o, I, M) {
         o->probe_noise_um = 0.0;
         o->mode = CorrectionMode::kRework;
       }},
      {"rework upre",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.3;
         o->mode = CorrectionMode::kRework;
         m->probe_noise_um = 0.3;
       }},
      {"bounds exact",
       [](G g, O o, I, M) {
         o->probe_noise_um = 0.0;
         const int np = g.NumParameters();
         o->lower_delta = Eigen::VectorXd::Constant(
             np, -std::numeric_limits<double>::infinity());
         o->upper_delta = Eigen::VectorXd::Constant(
             np, std::numeric_limits<double>::infinity());
         for (int j = 0; j < np; j += 3) {
           o->lower_delta(j) = -2e-4;
           o->upper_delta(j) = 1e-4;
         }
       }},
      {"bounds gcv noisy",
       [](G g, O o, I, M m) {
         m->probe_noise_um = 0.4;
         const int np = g.NumParameters();
         o->lower_delta = Eigen::VectorXd::Constant(np, -1e-3);
         o->upper_delta = Eigen::VectorXd::Constant(np, 5e-4);
       }},
      {"weights upre",
       [](G g, O o, I, M m) {
         o->probe_noise_um = 0.5;
         m->probe_noise_um = 0.5;
         const int n = g.NumPoints();
         o->point_weights.resize(n);
         for (int i = 0; i < n; ++i)
           o->point_weights(i) = i % 7 == 3 ? 0.0 : 0.5 + 0.1 * (i % 11);
       }},
      {"three teeth upre",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.5;
         m->probe_noise_um = 0.5;
         m->teeth = 3;
         m->missing_points = {5};
         m->missing_probability = 0.05;
       }},
      {"three teeth discrepancy",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.5;
         o->use_discrepancy_principle = true;
         m->probe_noise_um = 0.5;
         m->teeth = 3;
         m->missing_probability = 0.05;
       }},
      {"three teeth gcv",
       [](G, O, I, M m) {
         m->probe_noise_um = 0.5;
         m->teeth = 3;
       }},
      {"outliers",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.3;
         m->probe_noise_um = 0.3;
         m->outlier_points = {12, 30};
         m->outlier_size_um = 25.0;
       }},
      {"outliers gcv",
       [](G, O, I, M m) {
         m->probe_noise_um = 0.3;
         m->outlier_points = {7};
         m->outlier_size_um = 30.0;
       }},
      {"missing exact",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.0;
         m->missing_points = {0, 8, 22, 40};
       }},
      {"published freedom",
       [](G, O o, I, M) {
         o->probe_noise_um = 0.0;
         o->default_max_order = 0;
         o->max_order = {{"C", 6}};
       }},
      {"scales and orders",
       [](G, O o, I, M m) {
         o->probe_noise_um = 0.2;
         m->probe_noise_um = 0.2;
         o->default_max_order = 2;
         o->max_order = {{"X", 1}, {"A", -1}};
         o->block_scales = {{"Y", 2.0}};
         o->min_relative_regularisation = 1e-2;
       }},
      {"no refinement",
       [](G, O o, I, M) {
         o->probe_noise_um = 0.0;
         o->max_num_iterations = 0;
       }},
      {"pso",
       [](G, O o, I, M) { o->solver = CorrectionSolver::kParticleSwarm; }},
      {"pso bounded",
       [](G g, O o, I, M m) {
         o->solver = CorrectionSolver::kParticleSwarm;
         o->pso_generations = 50;
         m->probe_noise_um = 0.5;
         const int np = g.NumParameters();
         o->lower_delta = Eigen::VectorXd::Constant(np, -5e-3);
         o->upper_delta = Eigen::VectorXd::Constant(np, 1e-2);
       }},
      {"lsq-plain",
       [](G, O o, I, M) { o->solver = CorrectionSolver::kPlainLeastSquares; }},
      {"lsq-plain weighted",
       [](G g, O o, I, M m) {
         o->solver = CorrectionSolver::kPlainLeastSquares;
         m->probe_noise_um = 0.5;
         o->point_weights = Eigen::VectorXd::LinSpaced(g.NumPoints(), 0.2, 2.0);
       }},
      {"given roll range and jacobian",
       [](G g, O o, I in, M) {
         o->probe_noise_um = 0.1;
         in->roll_min_rad = g.roll_min_rad() - 0.01;
         in->roll_max_rad = g.roll_max_rad() + 0.02;
         ModelEvaluation eval;
         g.Evaluate(in->current_parameters, true, &eval);
         in->jacobian_um = eval.jacobian_um;
       }},
      {"invalid target size", [](G, O, I in, M) { in->target_um.resize(3); }},
      {"invalid no free parameter",
       [](G, O o, I, M) {
         o->default_max_order = -1;
         o->max_order = {{"cone_angle", -1},
                         {"parabola_coefficient", -1},
                         {"parabola_vertex", -1}};
       }},
      {"invalid unknown block",
       [](G, O o, I, M) {
         o->max_order = {{"Q", 2}};
       }},
      {"invalid options", [](G, O o, I, M) { o->min_flank_effect_um = -1.0; }},
      {"invalid tooth size",
       [](G, O, I in, M) {
         in->measured_teeth_um = {Eigen::VectorXd::Zero(4)};
       }},
      {"invalid all missing",
       [](G, O, I in, M) {
         in->measured_um.setConstant(std::numeric_limits<double>::quiet_NaN());
       }},
  };
}

}  // namespace

int main() {
  const std::vector<TargetModification> slopes = bench::SlopesAndCrowning();
  const std::vector<Gear> gears = {
      {"cutter / slopes + crowning", bench::Cutter(), slopes, 42},
      {"cutter / diagonal end relief",
       bench::Cutter(),
       {bench::DiagonalEndRelief()},
       43},
      {"right-hand, left flank / tip relief + twist",
       bench::RightHandLeftFlank(),
       {{ModificationKind::kTipRelief, 6.0, 0.3, ReliefShape::kParabolic},
        {ModificationKind::kFlankTwist, 4.0}},
       43},
      {"helical / slopes + crowning", bench::Helical(), slopes, 46},
      {"spur / crownings",
       bench::Spur(),
       {{ModificationKind::kProfileCrowning, 3.0},
        {ModificationKind::kLeadCrowning, 3.0}},
       50},
  };
  for (const Gear& gear : gears) {
    const FlatWheelGrinder grinder(gear.setup);
    const Eigen::VectorXd nominal = grinder.nominal().ToVector();
    const Eigen::VectorXd hidden = RandomHiddenErrors(grinder,
                                                      grinder.roll_min_rad(),
                                                      grinder.roll_max_rad(),
                                                      2.0,
                                                      2,
                                                      0.4,
                                                      gear.hidden_seed);
    const Eigen::VectorXd target = EvaluateTargetModifications(
        gear.target, grinder.grid(), gear.setup.gear, gear.setup.flank);
    for (const Variant& variant : Variants()) {
      for (bool state : {true, false}) {
        // A variant touches the simulated measurement, the options and the
        // input: a first pass on scratch copies gives the measurement options,
        // the second the real ones.
        MeasurementSimulationOptions cmm;
        cmm.seed = gear.hidden_seed + 7;
        {
          CorrectionOptions scratch_options;
          CorrectionInput scratch_input;
          scratch_input.current_parameters = nominal;
          scratch_input.measured_um = target;
          scratch_input.target_um = target;
          variant.apply(grinder, &scratch_options, &scratch_input, &cmm);
        }
        const SimulatedMeasurement part =
            SimulateMeasurement(grinder, nominal, hidden, cmm);
        CorrectionOptions options;
        options.estimate_machine_state = state;
        CorrectionInput input;
        input.model = &grinder;
        input.current_parameters = nominal;
        input.target_um = target;
        input.measured_um = part.measured_um;
        if (cmm.teeth > 1) input.measured_teeth_um = part.teeth_um;
        MeasurementSimulationOptions unused = cmm;
        variant.apply(grinder, &options, &input, &unused);
        PrintResult(std::string(gear.name) + " | " + variant.name +
                        (state ? " | state" : " | commanded"),
                    ComputeCorrection(options, input));
      }
    }
  }
  std::printf("values %lld\n", num_values);
  return 0;
}
