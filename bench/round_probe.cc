// One round of one robustness scenario in detail
// (bench/robustness_scenarios.h): why a round made a part worse. Not a timing
// and not a study; a tool for whoever looks into a worse round the robustness
// benchmark lists.
//
//   round_probe --seed 12 --scenario 103 --round 3 --told-noise-scale 0
//               [--error-scale F] [--noise-scale F] [--point ROW,COL] [--scan]
//
// Runs the closed loop to the part before `--round` (1 = the first
// correction), corrects it as the loop does (default options), and prints:
// the correction's summary; the deviation grids [um, against the target; NR
// the wheel does not reach the point, NC no contact found] of the true
// machine (the commanded settings + the hidden errors), of the model at the
// point the correction was linearised at (the estimated state) and of the
// model at the commanded settings, before and after the step; the estimated
// state against the hidden errors; and, for `--point`, that point's
// deviation, contact roll and contact margin along fractions of the step on
// each of the three. Rows count from 0 at the root side (MODEL.md §4).
// `--scan`: every grid point whose contact on the true machine is lost or
// found by the step, or whose deviation there jumps by more than 20 um, at
// fractions 0, 0.05, ..., 1 of the step (status, deviation and contact roll):
// how the envelope solve behaves along the way.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "bench/robustness_scenarios.h"

namespace gearloop {
namespace {

void PrintGrid(const char* title,
               const MachineModel& model,
               const ModelEvaluation& eval,
               const Eigen::VectorXd& target_um) {
  const int columns = model.GridColumns();
  std::printf("%s\n", title);
  for (int i = 0; i < eval.deviations_um.size(); ++i) {
    if (i % columns == 0) std::printf("  row %d:", i / columns);
    if (eval.status[i] == PointStatus::kOk)
      std::printf(" %8.2f", eval.deviations_um(i) - target_um(i));
    else
      std::printf(" %8s",
                  eval.status[i] == PointStatus::kNotReached ? "NR" : "NC");
    if (i % columns == columns - 1) std::printf("\n");
  }
}

// The point's deviation, contact roll and margin at `parameters` + f x step
// for a few fractions f.
void PrintAlongStep(const char* name,
                    const MachineModel& model,
                    const Eigen::VectorXd& parameters,
                    const Eigen::VectorXd& step,
                    const Eigen::VectorXd& target_um,
                    int point) {
  for (double f : {0.0, 0.25, 0.5, 0.75, 0.9, 1.0}) {
    ModelEvaluation eval;
    model.Evaluate(parameters + f * step, false, &eval);
    std::printf("  %-10s f = %4.2f: ", name, f);
    if (eval.status[point] != PointStatus::kOk) {
      std::printf("%s\n", PointStatusName(eval.status[point]));
      continue;
    }
    std::printf("deviation %9.3f um, contact roll %9.5f rad",
                eval.deviations_um(point) - target_um(point),
                eval.contact_roll_rad[point]);
    if (static_cast<int>(eval.contact_margin_mm.size()) > point)
      std::printf(", margin %7.3f mm", eval.contact_margin_mm[point]);
    std::printf("\n");
  }
}

int Usage() {
  std::fprintf(stderr,
               "usage: round_probe --seed S --scenario I --round R "
               "[--told-noise-scale F] [--error-scale F] [--noise-scale F] "
               "[--point ROW,COL] [--scan]\n");
  return 2;
}

}  // namespace
}  // namespace gearloop

int main(int argc, char** argv) {
  using namespace gearloop;
  std::uint64_t seed = 2026;
  int index = -1, round = 1, point_row = -1, point_column = -1;
  bench::StressOptions stress;
  bool scan = false;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--scan") {
      scan = true;
      continue;
    }
    if (a + 1 >= argc) return Usage();
    const char* value = argv[++a];
    char* end = nullptr;
    if (arg == "--point") {
      if (std::sscanf(value, "%d,%d", &point_row, &point_column) != 2)
        return Usage();
      continue;
    }
    if (arg == "--seed") {
      seed = std::strtoull(value, &end, 10);
      if (end == value || *end != '\0') return Usage();
      continue;
    }
    const double number = std::strtod(value, &end);
    if (end == value || *end != '\0') return Usage();
    if (arg == "--scenario") {
      index = static_cast<int>(number);
    } else if (arg == "--round") {
      round = static_cast<int>(number);
    } else if (arg == "--told-noise-scale") {
      stress.told_noise_scale = number;
    } else if (arg == "--error-scale") {
      stress.error_scale = number;
    } else if (arg == "--noise-scale") {
      stress.noise_scale = number;
    } else {
      return Usage();
    }
  }
  if (index < 0 || round < 1) return Usage();

  const bench::Scenario s = bench::DrawGrinderScenario(seed, index, stress);
  const MachineModel& model = *s.model;
  std::printf("seed %llu, scenario %d, round %d: %s\n",
              static_cast<unsigned long long>(seed),
              index,
              round,
              s.Describe().c_str());

  // The part before this round, as the loop makes and measures it.
  const CorrectionOptions options;
  Eigen::VectorXd commanded = s.initial_parameters;
  if (round > 1)
    commanded = bench::RunClosedLoop(s, options, round - 1).final_parameters;
  MeasurementSimulationOptions measurement = s.measurement;
  measurement.seed += round - 1;
  const SimulatedMeasurement cmm =
      SimulateMeasurement(model, commanded, s.hidden_errors, measurement);
  CorrectionOptions asked = options;
  asked.probe_noise_um =
      s.noise_told ? s.told_noise_scale * s.probe_noise_um : -1.0;
  CorrectionInput input;
  input.model = &model;
  input.current_parameters = commanded;
  if (measurement.teeth > 1)
    input.measured_teeth_um = cmm.teeth_um;
  else
    input.measured_um = cmm.measured_um;
  input.target_um = s.target_um;
  const CorrectionResult result = ComputeCorrection(asked, input);
  std::printf("\n%s\n\n", result.summary.BriefReport().c_str());
  if (!result.summary.IsSolutionUsable()) return 0;

  const Eigen::VectorXd truth = commanded + s.hidden_errors;
  const Eigen::VectorXd& step = result.delta;
  const bool at_state = result.linearised_at.size() == truth.size() &&
                        result.summary.machine_state_estimated;
  ModelEvaluation before, after;
  model.Evaluate(truth, false, &before);
  model.Evaluate(truth + step, false, &after);
  std::printf("roll range of the nominal contacts %.5f .. %.5f rad\n",
              s.roll_min_rad,
              s.roll_max_rad);
  PrintGrid("the true machine, before the step", model, before, s.target_um);
  PrintGrid("the true machine, after the step", model, after, s.target_um);
  if (at_state) {
    model.Evaluate(result.linearised_at, false, &before);
    model.Evaluate(result.linearised_at + step, false, &after);
    PrintGrid("the estimated state, before", model, before, s.target_um);
    PrintGrid("the estimated state, after", model, after, s.target_um);
  }
  model.Evaluate(commanded, false, &before);
  model.Evaluate(commanded + step, false, &after);
  PrintGrid("the commanded settings, before", model, before, s.target_um);
  PrintGrid("the commanded settings, after", model, after, s.target_um);

  double linear_mm = 0.0, angular_rad = 0.0;
  bench::MaxAxisMotion(
      model, step, s.roll_min_rad, s.roll_max_rad, &linear_mm, &angular_rad);
  std::printf(
      "\nthe step's largest axis motion over the roll range: %.4g mm, "
      "%.4g rad\n",
      linear_mm,
      angular_rad);
  bench::MaxAxisMotion(model,
                       s.hidden_errors,
                       s.roll_min_rad,
                       s.roll_max_rad,
                       &linear_mm,
                       &angular_rad);
  std::printf("the hidden errors: %.4g mm, %.4g rad\n", linear_mm, angular_rad);
  if (at_state) {
    bench::MaxAxisMotion(model,
                         result.linearised_at - truth,
                         s.roll_min_rad,
                         s.roll_max_rad,
                         &linear_mm,
                         &angular_rad);
    std::printf("the estimated state less the true one: %.4g mm, %.4g rad\n",
                linear_mm,
                angular_rad);
  }

  if (scan) {
    ModelEvaluation start, end;
    model.Evaluate(truth, false, &start);
    model.Evaluate(truth + step, false, &end);
    constexpr double kJumpUm = 20.0;
    for (int i = 0; i < model.NumPoints(); ++i) {
      const bool had = start.status[i] == PointStatus::kOk;
      const bool has = end.status[i] == PointStatus::kOk;
      if (had == has && !(had && std::abs(end.deviations_um(i) -
                                          start.deviations_um(i)) > kJumpUm))
        continue;
      std::printf("\nthe true machine along the step, row %d, column %d:\n",
                  i / model.GridColumns(),
                  i % model.GridColumns());
      for (int k = 0; k <= 20; ++k) {
        ModelEvaluation eval;
        model.Evaluate(truth + (k / 20.0) * step, false, &eval);
        std::printf("  f = %4.2f: ", k / 20.0);
        if (eval.status[i] == PointStatus::kOk)
          std::printf("%9.3f um at roll %9.5f rad\n",
                      eval.deviations_um(i) - s.target_um(i),
                      eval.contact_roll_rad[i]);
        else
          std::printf("%s\n", PointStatusName(eval.status[i]));
      }
    }
  }

  if (point_row >= 0) {
    const int point = point_row * model.GridColumns() + point_column;
    if (point_column < 0 || point_column >= model.GridColumns() ||
        point >= model.NumPoints())
      return Usage();
    std::printf(
        "\npoint row %d, column %d along the step:\n", point_row, point_column);
    PrintAlongStep("true", model, truth, step, s.target_um, point);
    if (at_state)
      PrintAlongStep(
          "estimated", model, result.linearised_at, step, s.target_um, point);
    PrintAlongStep("commanded", model, commanded, step, s.target_um, point);
  }
  return 0;
}
