// One round of one robustness scenario in detail
// (bench/robustness_scenarios.h): why a round made a part worse. Not a timing
// and not a study; a tool for whoever looks into a worse round the robustness
// benchmark lists.
//
//   round_probe --seed 12 --scenario 103 --round 3 --told-noise-scale 0
//               [--error-scale F] [--noise-scale F] [--point ROW,COL] [--scan]
//               [--state-error] [--reach] [--two-parts]
//
// Runs the closed loop to the part before `--round` (1 = the first
// correction), corrects it as the loop does (default options), and prints:
// the measurement the correction got (teeth averaged, against the target;
// "--" missing, "*" a gross error the simulator put there, "o" a point the
// correction set aside as an outlier); the correction's summary; the deviation
// grids [um, against the target; NR the wheel does not reach the point, NC no
// contact found] of the true machine (the commanded settings + the hidden
// errors), of the model at the point the correction was linearised at (the
// estimated state) and of the model at the commanded settings, before and after
// the step; the estimated state against the hidden errors; and, for `--point`,
// that point's deviation, contact roll and contact margin along fractions of
// the step on each of the three. Rows count from 0 at the root side (MODEL.md
// §4).
// `--scan`: every grid point whose contact on the true machine is lost or
// found by the step, or whose deviation there jumps by more than 20 um, at
// fractions 0, 0.05, ..., 1 of the step (status, deviation and contact roll):
// how the envelope solve behaves along the way.
// `--state-error` (linearised at an estimated state p): how the step's
// outcome depends on the machine's state. The next part (rms over the points
// the true machine and the state both grind; the true part's deviations as the
// measurement, without noise) at states along the line from p to the commanded
// settings and at the true machine; at the true machine to first order in the
// state's error v = truth - p, e + d(p + step) - d(p) + (J(p + step) - J(p)) v
// (the exact Jacobians at the two ends of the step); the true machine's flank
// less the state's before the step; and v in correction-size coordinates
// (MODEL.md §6), block by block; the next part at the state with one block
// of it set to the true machine's; and the true wheel parabola taken up by
// the axes (what the safe step's spread asks, safe_step.cc StateUncertainty):
// the next part's error from it to first order.
// `--two-parts` (round 2 or later): how well the wheel parabola's coefficient
// (fixed in every fit today) is told apart from the axes by the two parts the
// loop ground last, at the commanded settings of round R - 1 and of round R,
// against the current part alone: the Cramer-Rao standard deviation at the
// true machine (the probe's sigma; the state's coordinates every axis block to
// order 3 and the wheel's cone, each held as the safe step holds the machine's
// errors, MakeMachineErrorPrior: 10 um or 20 urad rms of motion over the roll
// range, 200 urad; the parabola coefficient free, its vertex at the truth's),
// in um rms of the parabola's flank; beside the true parabola's
// flank and its next-part error through the step (first order).
// `--reach`: how far the exact model reaches from the true machine and from
// the estimated state (the benchmark's reference optimiser, every order to 6,
// started at no change, the least-squares steps and the step): what the
// correction left on the table, and whether its state would have found it.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "bench/best_reachable.h"
#include "bench/robustness_scenarios.h"
#include "engine/correction/safe_step.h"

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

// The rms over `used` of e + d(at + step) - d(at); -1 where a point is lost.
double NextPartRms(const MachineModel& model,
                   const Eigen::VectorXd& at,
                   const Eigen::VectorXd& step,
                   const Eigen::VectorXd& e_um,
                   const std::vector<int>& used) {
  ModelEvaluation before, after;
  model.Evaluate(at, false, &before);
  model.Evaluate(at + step, false, &after);
  double sum = 0.0;
  for (int i : used) {
    if (after.status[i] != PointStatus::kOk ||
        before.status[i] != PointStatus::kOk)
      return -1.0;
    const double r = e_um(i) + after.deviations_um(i) - before.deviations_um(i);
    sum += r * r;
  }
  return std::sqrt(sum / static_cast<double>(used.size()));
}

// `--state-error` (see the file comment).
void PrintStateError(const bench::Scenario& s,
                     const Eigen::VectorXd& state,
                     const Eigen::VectorXd& commanded,
                     const Eigen::VectorXd& truth,
                     const Eigen::VectorXd& step) {
  const MachineModel& model = *s.model;
  ModelEvaluation true_part, at_state, after_step;
  model.Evaluate(truth, false, &true_part);
  model.Evaluate(state, true, &at_state);
  model.Evaluate(state + step, true, &after_step);
  std::vector<int> used;
  Eigen::VectorXd e_um = Eigen::VectorXd::Zero(model.NumPoints());
  for (int i = 0; i < model.NumPoints(); ++i) {
    if (true_part.status[i] != PointStatus::kOk ||
        at_state.status[i] != PointStatus::kOk ||
        after_step.status[i] != PointStatus::kOk)
      continue;
    used.push_back(i);
    e_um(i) = true_part.deviations_um(i) - s.target_um(i);
  }
  if (used.empty()) return;
  const double n = static_cast<double>(used.size());
  std::printf(
      "\nthe next part over %d points both grind (the true part now %.3f "
      "um):\n",
      static_cast<int>(used.size()),
      std::sqrt(e_um.squaredNorm() / n));
  for (double t : {0.0, 0.05, 0.15, 0.5, 1.0}) {
    std::printf(
        "  at the state moved %4.2f of the way to the commanded settings: %.3f "
        "um\n",
        t,
        NextPartRms(model, state + t * (commanded - state), step, e_um, used));
  }
  std::printf("  at the true machine: %.3f um\n",
              NextPartRms(model, truth, step, e_um, used));
  const Eigen::VectorXd v = truth - state;
  double first_order = 0.0, shown = 0.0;
  for (int i : used) {
    const double r =
        e_um(i) + after_step.deviations_um(i) - at_state.deviations_um(i) +
        (after_step.jacobian_um.row(i) - at_state.jacobian_um.row(i)).dot(v);
    first_order += r * r;
    const double x = true_part.deviations_um(i) - at_state.deviations_um(i);
    shown += x * x;
  }
  std::printf(
      "  at the true machine to first order in the state's error: %.3f um\n",
      std::sqrt(first_order / n));
  std::printf("the true machine's flank less the state's: %.3f um rms\n",
              std::sqrt(shown / n));
  const std::vector<ParameterBlock> blocks = model.ParameterBlocks();
  const Eigen::VectorXd y =
      CorrectionCoordinates(blocks, v, s.roll_min_rad, s.roll_max_rad);
  std::printf(
      "the state's error in correction-size coordinates: %.3g; by block:",
      y.norm());
  for (const ParameterBlock& b : blocks)
    std::printf(" %s %.3g",
                b.name.c_str(),
                y.segment(b.first_index, b.num_coefficients).norm());
  std::printf("\n");
  std::printf("the next part at the state with the true machine's block:");
  for (const ParameterBlock& b : blocks) {
    Eigen::VectorXd at = state;
    at.segment(b.first_index, b.num_coefficients) =
        truth.segment(b.first_index, b.num_coefficients);
    std::printf(
        " %s %.3f", b.name.c_str(), NextPartRms(model, at, step, e_um, used));
  }
  std::printf(" um\n");
  // The wheel's parabola (fixed: no fit sees it), taken up by the axes and
  // the cone (orders 0-3, least squares): the next part's error from that at
  // the true machine's parabola, to first order.
  std::vector<int> free;
  for (const ParameterBlock& b : blocks) {
    for (int k = 0; k < std::min(b.num_coefficients, 4); ++k) {
      if (b.is_polynomial || b.name == "cone_angle")
        free.push_back(b.first_index + k);
    }
  }
  const int np = model.NumParameters();
  const int nf = static_cast<int>(free.size());
  const int n_used = static_cast<int>(used.size());
  const int ia = kParabolaCoefficientIndex;
  Eigen::MatrixXd t(np, nf);  // correction-size coordinates -> parameters
  for (int c = 0; c < nf; ++c) {
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(np);
    unit(free[c]) = 1.0;
    t.col(c) = DeltaFromCorrectionCoordinates(
        blocks, unit, s.roll_min_rad, s.roll_max_rad);
  }
  Eigen::MatrixXd js(n_used, nf), dj(n_used, nf);
  Eigen::VectorXd ja(n_used), dja(n_used);
  for (int r = 0; r < n_used; ++r) {
    const int i = used[r];
    js.row(r) = at_state.jacobian_um.row(i) * t;
    dj.row(r) = after_step.jacobian_um.row(i) * t - js.row(r);
    ja(r) = at_state.jacobian_um(i, ia);
    dja(r) = after_step.jacobian_um(i, ia) - ja(r);
  }
  // The take-up per unit, held as the safe step holds the state's
  // take-up (a prior of 10 correction-size units at the probe's noise).
  const double ridge = std::pow(std::max(s.probe_noise_um, 0.05) / 10.0, 2);
  Eigen::MatrixXd info = js.transpose() * js;
  info.diagonal().array() += ridge;
  const Eigen::VectorXd absorbed = info.ldlt().solve(js.transpose() * ja);
  const double a = truth(ia) - state(ia);
  const double root_n = std::sqrt(static_cast<double>(n_used));
  std::printf(
      "the true parabola (%.3g 1/mm, %.3f um rms of flank, %.3f left after "
      "the axes take it up): next-part error %.3f um rms; per um of its "
      "flank %.3f\n",
      a,
      ja.norm() * std::abs(a) / root_n,
      (ja - js * absorbed).norm() * std::abs(a) / root_n,
      (dja - dj * absorbed).norm() * std::abs(a) / root_n,
      (dja - dj * absorbed).norm() / ja.norm());
}

// The posterior standard deviation of the parabola's coefficient, in um rms
// of its flank (`flank_per_unit` per unit of it): [(A^T A / sigma^2 +
// diag(1 / prior^2))^-1]_pp over the columns of `a` scaled to unit norm
// (`scale`; a coordinate x' = scale x, its prior scale x prior; an infinite
// prior adds nothing).
double PosteriorParabolaFlankUm(const Eigen::MatrixXd& a,
                                const Eigen::VectorXd& scale,
                                const std::vector<double>& prior,
                                int parabola,
                                double sigma,
                                double flank_per_unit) {
  const int m = static_cast<int>(a.cols());
  Eigen::MatrixXd info = a.transpose() * a / (sigma * sigma);
  for (int c = 0; c < m; ++c)
    if (std::isfinite(prior[c]))
      info(c, c) += 1.0 / std::pow(scale(c) * prior[c], 2);
  const Eigen::VectorXd unit = Eigen::VectorXd::Unit(m, parabola);
  const double var = unit.dot(info.ldlt().solve(unit));
  return var > 0.0 ? std::sqrt(var) / scale(parabola) * flank_per_unit
                   : std::numeric_limits<double>::infinity();
}

// `--two-parts` (see the file comment).
void PrintTwoPartInformation(const bench::Scenario& s,
                             const Eigen::VectorXd& previous,
                             const Eigen::VectorXd& commanded,
                             const Eigen::VectorXd& step) {
  const MachineModel& model = *s.model;
  // Each coordinate's prior standard deviation as the safe step holds the
  // machine's errors (MakeMachineErrorPrior); the parabola none.
  int parabola_index = -1;
  for (const ParameterBlock& b : model.ParameterBlocks())
    if (b.name == "parabola_coefficient") parabola_index = b.first_index;
  const correction_internal::MachineErrorPrior state_prior =
      correction_internal::MakeMachineErrorPrior(model.ParameterBlocks(),
                                                 s.roll_min_rad,
                                                 s.roll_max_rad,
                                                 parabola_index);
  const std::vector<int>& columns = state_prior.columns;
  const std::vector<double>& prior = state_prior.sd;
  const int parabola = state_prior.parabola_column;
  if (parabola < 0) return;
  const Eigen::VectorXd& h = s.hidden_errors;
  ModelEvaluation part[2], next;
  model.Evaluate(previous + h, true, &part[0]);
  model.Evaluate(commanded + h, true, &part[1]);
  model.Evaluate(commanded + h + step, true, &next);
  std::vector<int> rows;
  for (int i = 0; i < model.NumPoints(); ++i)
    if (part[0].status[i] == PointStatus::kOk &&
        part[1].status[i] == PointStatus::kOk &&
        next.status[i] == PointStatus::kOk)
      rows.push_back(i);
  const int n = static_cast<int>(rows.size());
  const int m = static_cast<int>(columns.size());
  if (n == 0) return;
  const double sigma = s.probe_noise_um;
  Eigen::MatrixXd a(2 * n, m);
  for (int k = 0; k < 2; ++k)
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < m; ++c)
        a(k * n + r, c) = part[k].jacobian_um(rows[r], columns[c]);
  // Columns to unit norm over both parts (the coordinates' units apart).
  Eigen::VectorXd scale(m);
  for (int c = 0; c < m; ++c) {
    scale(c) = a.col(c).norm();
    if (!(scale(c) > 0.0)) scale(c) = 1.0;
    a.col(c) /= scale(c);
  }
  // The parabola's flank per unit of its coefficient on the current part.
  const double flank_per_unit =
      a.col(parabola).bottomRows(n).norm() * scale(parabola) / std::sqrt(n);
  const auto deviation = [&](const Eigen::MatrixXd& rows_used) {
    return PosteriorParabolaFlankUm(
        rows_used, scale, prior, parabola, sigma, flank_per_unit);
  };
  const double one = deviation(a.bottomRows(n));
  const double two = deviation(a);
  // The true parabola's flank and its next-part error through the step.
  const int p = columns[parabola];
  double true_flank = 0.0, next_error = 0.0;
  for (int r = 0; r < n; ++r) {
    const int i = rows[r];
    true_flank += std::pow(part[1].jacobian_um(i, p) * h(p), 2);
    next_error += std::pow(
        (next.jacobian_um(i, p) - part[1].jacobian_um(i, p)) * h(p), 2);
  }
  std::printf(
      "\ntwo parts (%d points both grind, sigma %.3g um, %d state "
      "coordinates): the parabola's coefficient to 1 sigma, in um rms of its "
      "flank: the current part alone %.3g, with the part before %.3g; the "
      "true parabola %.3g um rms of flank, through the step %.3g um of "
      "next-part error (first order, not taken up)\n",
      n,
      sigma,
      m,
      one,
      two,
      std::sqrt(true_flank / n),
      std::sqrt(next_error / n));
}

int Usage() {
  std::fprintf(stderr,
               "usage: round_probe --seed S --scenario I --round R "
               "[--told-noise-scale F] [--error-scale F] [--noise-scale F] "
               "[--point ROW,COL] [--scan] [--state-error] [--reach] "
               "[--two-parts]\n");
  return 2;
}

struct ProbeArguments {
  std::uint64_t seed = 2026;
  int index = -1;
  int round = 1;
  int point_row = -1;  // < 0: no --point
  int point_column = -1;
  bool scan = false;
  bool state_error = false;
  bool reach = false;
  bool two_parts = false;
  bench::StressOptions stress;
};

// False on anything the usage does not name.
bool ParseArguments(int argc, char** argv, ProbeArguments* args) {
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--scan") {
      args->scan = true;
      continue;
    }
    if (arg == "--state-error") {
      args->state_error = true;
      continue;
    }
    if (arg == "--reach") {
      args->reach = true;
      continue;
    }
    if (arg == "--two-parts") {
      args->two_parts = true;
      continue;
    }
    if (a + 1 >= argc) return false;
    const char* value = argv[++a];
    char* end = nullptr;
    if (arg == "--point") {
      if (std::sscanf(value, "%d,%d", &args->point_row, &args->point_column) !=
          2)
        return false;
      continue;
    }
    if (arg == "--seed") {
      args->seed = std::strtoull(value, &end, 10);
      if (end == value || *end != '\0') return false;
      continue;
    }
    const double number = std::strtod(value, &end);
    if (end == value || *end != '\0') return false;
    if (arg == "--scenario") {
      args->index = static_cast<int>(number);
    } else if (arg == "--round") {
      args->round = static_cast<int>(number);
    } else if (arg == "--told-noise-scale") {
      args->stress.told_noise_scale = number;
    } else if (arg == "--error-scale") {
      args->stress.error_scale = number;
    } else if (arg == "--noise-scale") {
      args->stress.noise_scale = number;
    } else {
      return false;
    }
  }
  return args->index >= 0 && args->round >= 1;
}

// The model at `parameters` and at `parameters` + `step`, as two grids.
void PrintBeforeAndAfter(const char* name,
                         const MachineModel& model,
                         const Eigen::VectorXd& parameters,
                         const Eigen::VectorXd& step,
                         const Eigen::VectorXd& target_um,
                         ModelEvaluation* before,
                         ModelEvaluation* after) {
  model.Evaluate(parameters, false, before);
  model.Evaluate(parameters + step, false, after);
  PrintGrid((std::string(name) + ", before the step").c_str(),
            model,
            *before,
            target_um);
  PrintGrid((std::string(name) + ", after the step").c_str(),
            model,
            *after,
            target_um);
}

void PrintMotion(const char* what,
                 const bench::Scenario& s,
                 const Eigen::VectorXd& change) {
  double linear_mm = 0.0, angular_rad = 0.0;
  bench::MaxAxisMotion(*s.model,
                       change,
                       s.roll_min_rad,
                       s.roll_max_rad,
                       &linear_mm,
                       &angular_rad);
  std::printf("%s: %.4g mm, %.4g rad\n", what, linear_mm, angular_rad);
}

// `--scan`: the true machine's points whose contact the step loses or finds,
// or whose deviation jumps by more than kJumpUm, along 21 fractions.
void PrintScan(const MachineModel& model,
               const Eigen::VectorXd& truth,
               const Eigen::VectorXd& step,
               const Eigen::VectorXd& target_um,
               const ModelEvaluation& start,
               const ModelEvaluation& end) {
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
                    eval.deviations_um(i) - target_um(i),
                    eval.contact_roll_rad[i]);
      else
        std::printf("%s\n", PointStatusName(eval.status[i]));
    }
  }
}

// `--reach`: the benchmark's reference optimiser (bench/best_reachable.h,
// every order to 6, the wheel's parabola held as the benchmark's
// --reference-fix does, no random starts) from `from`, started at no change,
// the two least-squares steps and the step; each start's end, the best
// change's axis motion and wheel changes, and that change applied at the true
// machine `truth`.
void PrintReach(const char* name,
                const bench::Scenario& s,
                const Eigen::VectorXd& from,
                const Eigen::VectorXd& truth,
                const Eigen::VectorXd& step) {
  const MachineModel& model = *s.model;
  bench::ReachOptions reach;
  reach.max_order = 6;  // the default options' highest order
  reach.fixed_blocks = {"parabola_coefficient", "parabola_vertex"};
  reach.random_starts = 0;
  const bench::ReachResult r = bench::BestReachable(model,
                                                    from,
                                                    s.target_um,
                                                    s.roll_min_rad,
                                                    s.roll_max_rad,
                                                    {{"step", step}},
                                                    reach);
  std::printf("\nreach from %s (every order to 6, the wheel's cone free):\n",
              name);
  for (const bench::ReachStart& start : r.starts)
    std::printf("  start %s: %.4g -> %.4g um in %d iterations\n",
                start.name.c_str(),
                start.start_rms_um,
                start.rms_um,
                start.iterations);
  if (r.delta.size() != model.NumParameters()) return;
  PrintMotion("  the best change's largest axis motion", s, r.delta);
  for (const ParameterBlock& b : model.ParameterBlocks()) {
    if (b.is_polynomial) continue;
    std::printf("  %s changed by %.4g %s (the step: %.4g)\n",
                b.name.c_str(),
                r.delta(b.first_index),
                b.unit.c_str(),
                step(b.first_index));
  }
  ModelEvaluation e;
  model.Evaluate(truth + r.delta, false, &e);
  Eigen::VectorXd residual_um = Eigen::VectorXd::Constant(
      e.deviations_um.size(), std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < residual_um.size(); ++i)
    if (e.status[i] == PointStatus::kOk)
      residual_um(i) = e.deviations_um(i) - s.target_um(i);
  std::printf("  that change at the true machine: %.4g um rms\n",
              bench::FiniteRms(residual_um));
}

// The part before round `round` (from 1), as the loop makes and measures
// it (its commanded settings into `commanded`), and its correction.
CorrectionResult CorrectTheRound(const bench::Scenario& s,
                                 int round,
                                 Eigen::VectorXd* commanded) {
  CorrectionOptions options;
  *commanded = s.initial_parameters;
  if (round > 1)
    *commanded = bench::RunClosedLoop(s, options, round - 1).final_parameters;
  MeasurementSimulationOptions measurement = s.measurement;
  measurement.seed += round - 1;
  const SimulatedMeasurement cmm =
      SimulateMeasurement(*s.model, *commanded, s.hidden_errors, measurement);
  const CorrectionInput input = bench::LoopCorrectionInput(
      s, *commanded, cmm, measurement.teeth, &options);
  CorrectionResult result = ComputeCorrection(options, input);
  // The measurement as the solver got it, less the target: "--" missing,
  // "*" a gross error the simulator put there, "o" a point the solver set
  // aside as an outlier.
  const int columns = s.model->GridColumns();
  const auto listed = [](const std::vector<int>& v, int i) {
    return std::find(v.begin(), v.end(), i) != v.end();
  };
  std::printf("the measurement (teeth averaged), less the target\n");
  for (int i = 0; i < cmm.measured_um.size(); ++i) {
    if (i % columns == 0) std::printf("  row %d:", i / columns);
    if (std::isfinite(cmm.measured_um(i)))
      std::printf(" %7.2f%s%s",
                  cmm.measured_um(i) - s.target_um(i),
                  listed(cmm.outlier_indices, i) ? "*" : " ",
                  listed(result.summary.outlier_indices, i) ? "o" : " ");
    else
      std::printf(" %9s", "--");
    if (i % columns == columns - 1) std::printf("\n");
  }
  return result;
}

}  // namespace
}  // namespace gearloop

int main(int argc, char** argv) {
  using namespace gearloop;
  ProbeArguments args;
  if (!ParseArguments(argc, argv, &args)) return Usage();
  const bench::Scenario s =
      bench::DrawGrinderScenario(args.seed, args.index, args.stress);
  const MachineModel& model = *s.model;
  const int columns = model.GridColumns();
  const int point = args.point_row * columns + args.point_column;
  if (args.point_row >= 0 &&
      (args.point_column < 0 || args.point_column >= columns ||
       point >= model.NumPoints()))
    return Usage();
  std::printf("seed %llu, scenario %d, round %d: %s\n",
              static_cast<unsigned long long>(args.seed),
              args.index,
              args.round,
              s.Describe().c_str());

  Eigen::VectorXd commanded;
  const CorrectionResult result = CorrectTheRound(s, args.round, &commanded);
  std::printf("\n%s\n\n", result.summary.BriefReport().c_str());
  if (!result.summary.IsSolutionUsable()) return 0;

  const Eigen::VectorXd truth = commanded + s.hidden_errors;
  const Eigen::VectorXd& step = result.delta;
  const bool at_state = result.linearised_at.size() == truth.size() &&
                        result.summary.machine_state_estimated;
  std::printf("roll range of the nominal contacts %.5f .. %.5f rad\n",
              s.roll_min_rad,
              s.roll_max_rad);
  ModelEvaluation true_before, true_after, before, after;
  PrintBeforeAndAfter("the true machine",
                      model,
                      truth,
                      step,
                      s.target_um,
                      &true_before,
                      &true_after);
  if (at_state)
    PrintBeforeAndAfter("the estimated state",
                        model,
                        result.linearised_at,
                        step,
                        s.target_um,
                        &before,
                        &after);
  PrintBeforeAndAfter("the commanded settings",
                      model,
                      commanded,
                      step,
                      s.target_um,
                      &before,
                      &after);

  std::printf("\n");
  PrintMotion("the step's largest axis motion over the roll range", s, step);
  PrintMotion("the hidden errors", s, s.hidden_errors);
  if (at_state)
    PrintMotion("the estimated state less the true one",
                s,
                result.linearised_at - truth);

  if (args.state_error && at_state)
    PrintStateError(s, result.linearised_at, commanded, truth, step);
  if (args.two_parts && args.round < 2)
    std::printf("\n--two-parts asks for round 2 or later: no part before\n");
  if (args.two_parts && args.round >= 2) {
    const Eigen::VectorXd previous =
        args.round == 2
            ? s.initial_parameters
            : bench::RunClosedLoop(s, CorrectionOptions(), args.round - 2)
                  .final_parameters;
    PrintTwoPartInformation(s, previous, commanded, step);
  }
  if (args.reach) {
    PrintReach("the true machine", s, truth, truth, step);
    if (at_state)
      PrintReach("the estimated state", s, result.linearised_at, truth, step);
  }
  if (args.scan)
    PrintScan(model, truth, step, s.target_um, true_before, true_after);
  if (args.point_row >= 0) {
    std::printf("\npoint row %d, column %d along the step:\n",
                args.point_row,
                args.point_column);
    PrintAlongStep("true", model, truth, step, s.target_um, point);
    if (at_state)
      PrintAlongStep(
          "estimated", model, result.linearised_at, step, s.target_um, point);
    PrintAlongStep("commanded", model, commanded, step, s.target_um, point);
  }
  return 0;
}
