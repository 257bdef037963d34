// engine/correction/problem.h (internal): the correction problem of one
// request, built once (correction.h, "Notation"): the measured flank (several
// teeth averaged here and only here), the error e = m - t, the point weights
// and noise shares, the free coefficients and their Legendre coordinates T, the
// bounds, and the model linearised at a parameter point (d0, S, S T, the
// reached and the used grid points).
//
//   CorrectionProblem problem;
//   std::string error;
//   if (!PrepareCorrectionProblem(options, input, &problem, &summary, &error))
//   { /* invalid input */ } const CorrectionProblem at_state =
//   RelinearisedAt(problem, commanded + h);  // step 0
#ifndef GEARLOOP_ENGINE_CORRECTION_PROBLEM_H_
#define GEARLOOP_ENGINE_CORRECTION_PROBLEM_H_

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"
#include "engine/correction/correction.h"

namespace gearloop {
namespace correction_internal {

class SvdMemo;  // svd_memo.h

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The measurement of a request: input.measured_um, or the point-wise mean of
// input.measured_teeth_um (AverageTeeth) with each point's noise variance
// divided by its count.
struct MeasuredFlank {
  Eigen::VectorXd measured_um;  // NaN = missing
  Eigen::VectorXd noise_share;  // noise variance of a point / sigma^2 (1 /
                                // teeth averaged; 1 if none)
  double mean_teeth_averaged =
      1.0;  // mean count over the delivered points (1 for a single grid)
  std::vector<int> tooth_outliers;  // points where a tooth's value was left out
};

// Roll angles at which the regularised solve and the refinement hold the
// motion bound (the safe step checks 41 afterwards and scales the change if one
// is still out).
constexpr int kMotionBoundSamples = 17;

struct CorrectionProblem {
  const MachineModel* model = nullptr;
  // The SVDs of the correction's linear systems, remembered (svd_memo.h):
  // made by PrepareCorrectionProblem and shared by the problems copied from
  // this one (the state fit's, the relinearised ones); nullptr: none kept.
  std::shared_ptr<SvdMemo> svd_memo;
  std::vector<ParameterBlock> blocks;
  int num_parameters = 0;
  int num_points = 0;

  // What this solve is asked (the machine-state estimate of step 0 changes
  // them).
  CorrectionMode mode = CorrectionMode::kNextPart;
  // The machine-state fit of step 0 (machine_state.h): its change is an
  // estimate of the machine's errors, not a change the machine makes.
  bool machine_state_fit = false;
  RegularisationRule rule =
      RegularisationRule::kNone;  // ChooseRegularisationRule(options)
  double probe_noise_um = -1.0;   // sigma [um] (< 0 unknown)
  // The stated sigma [um] where the state fit's scatter contradicted it and
  // replaced it in probe_noise_um (RaiseContradictedNoise); NaN otherwise.
  double stated_probe_noise_um = kNaN;
  // The state fit's scatter that contradicted it (per tooth) [um]; NaN
  // otherwise.
  double probe_scatter_um = kNaN;
  // > 0: the regularised solve filters each direction by its own signal to
  // noise (regularisation.h, SignalFilter) at this sigma [um] of one grid (the
  // stated noise, or the one estimated from the machine-state fit), down to
  // directions of kWeakFlankEffectShare x min_flank_effect_um per unit; 0: one
  // Tikhonov level by `rule` over the directions above min_flank_effect_um.
  double signal_noise_um = 0.0;

  // The measurement: m (teeth averaged), e = m - t [um] (NaN where missing),
  // weights w and noise shares per point.
  Eigen::VectorXd measured_um;
  Eigen::VectorXd error_um;
  // The target t [um] (NaN where the problem has none: the machine-state
  // fit's "target" is the measurement).
  Eigen::VectorXd target_um;
  Eigen::VectorXd weights;
  Eigen::VectorXd noise_share;
  double mean_teeth_averaged = 1.0;
  std::vector<int> tooth_outliers;  // MeasuredFlank::tooth_outliers

  // Step 1: the roll range, the free coefficients and their coordinates.
  double roll_min_rad = 0.0;
  double roll_max_rad = 0.0;
  std::vector<int> free;   // parameter indices that may change
  Eigen::MatrixXd t_map;   // T: free coordinates -> delta (np x nf)
  Eigen::MatrixXd t_free;  // the rows `free` of T (nf x nf)

  // The axis motion bound (options.max_axis_motion_mm / _rad) as linear rows:
  // dC(phi_s) / bound of every bounded polynomial block at
  // kMotionBoundSamples roll angles over the roll range, per unit of the
  // parameter change (rows x num_parameters; no rows without a bound). The
  // regularised solve and the refinement keep |rows delta| <= 1.
  // The machine-state fit has none: the bound limits a correction, not the
  // machine's errors (TestMachineState bounds the state's size).
  Eigen::MatrixXd motion_rows;

  // Bounds on delta [parameter units] (+-inf = unbounded); has_bounds: a free
  // one is finite.
  bool has_bounds = false;
  Eigen::VectorXd lower;
  Eigen::VectorXd upper;

  // The commanded parameters (the measured part was ground with them), kept
  // when the problem is linearised again at an estimated machine state.
  Eigen::VectorXd commanded_parameters;
  // The model's flank there (deviations, statuses), evaluated once.
  Eigen::VectorXd commanded_deviations_um;
  std::vector<PointStatus> commanded_status;
  // Linearised at an estimated state: the farthest point toward the
  // commanded parameters the machine plausibly runs, as a share of the way
  // from the state (1: the commanded parameters themselves; PlausibleShare,
  // machine_state.h; the point is TowardCommanded(plausible_share)).
  double plausible_share = 1.0;

  // The linearisation at `parameters`.
  Eigen::VectorXd parameters;
  ModelEvaluation evaluation;   // d0 = evaluation.deviations_um, statuses,
                                // contact roll angles
  Eigen::MatrixXd jacobian_um;  // S (n x np)
  Eigen::MatrixXd st;           // S T (n x nf)
  std::vector<int> reached;     // grid points with a contact
  std::vector<int> used;  // reached, with a finite e and a weight > 0 (outliers
                          // removed later)
  std::vector<int> missing;  // the others
  // Of the missing: points measured (finite error, weight > 0) where the model
  // at `parameters` has no contact. The correction neither sees nor predicts
  // them; the summary says so (measured_not_reached_indices).
  std::vector<int> measured_not_reached;
  // Gross outliers found before this problem was solved (the state fit's,
  // correction.cc), grid indices already out of `used`; reported with the
  // outlier test's own.
  std::vector<int> outliers_found_before;

  int NumFree() const { return static_cast<int>(free.size()); }
  // Linearised at an estimated machine state: the commanded parameters are
  // known and differ from the linearisation point.
  bool AtEstimatedState() const {
    return commanded_parameters.size() == parameters.size() &&
           commanded_parameters != parameters;
  }
  const Eigen::VectorXd& d0() const { return evaluation.deviations_um; }
  // The point `share` of the way from `parameters` to
  // `commanded_parameters`: parameters + share (commanded - parameters).
  // Requires the commanded parameters.
  Eigen::VectorXd TowardCommanded(double share) const {
    return parameters + share * (commanded_parameters - parameters);
  }
};

// The sizes and the options of a request; "" when valid, else what is wrong
// (the summary message).
std::string ValidateCorrectionInput(const CorrectionOptions& options,
                                    const CorrectionInput& input);

// The measured flank of a (validated) input, averaging several teeth.
MeasuredFlank AverageMeasurement(const CorrectionOptions& options,
                                 const CorrectionInput& input);

// The problem of a validated input at input.current_parameters: the model
// evaluated there (S from input.jacobian_um if given), the roll range (input's,
// else the span of the contacts), the used points, the free set, T, S T and the
// bounds. Fills roll range, missing points, free parameters and points used in
// `summary` as it goes; false with `error` when no point is usable, max_order
// names an unknown block or no parameter is free.
bool PrepareCorrectionProblem(const CorrectionOptions& options,
                              const CorrectionInput& input,
                              CorrectionProblem* problem,
                              CorrectionSummary* summary,
                              std::string* error);

// left * right where each column of `right` is nonzero over one run of rows
// (the coordinate map T: a free coordinate moves one axis's coefficients),
// summed over that run only, row by row in order: the numbers of the full
// product wherever Eigen's product sums each entry in row order (at 45 rows,
// its blocks are one), for 45 / 7 of its work.
Eigen::MatrixXd TimesColumnRuns(const Eigen::MatrixXd& left,
                                const Eigen::MatrixXd& right);
// left * right where each row of `left` is nonzero over one run of columns
// (T's rows: a coefficient is moved by one axis's coordinates), summed over
// that run only, in order (as TimesColumnRuns).
Eigen::MatrixXd RowRunsTimes(const Eigen::MatrixXd& left,
                             const Eigen::MatrixXd& right);

// The axis motion dC(phi) / bound of every polynomial block with a bound
// (options.max_axis_motion_mm / _rad) at each of `rolls_rad`, per unit of the
// parameter change (blocks x rolls rows, num_parameters columns; no rows
// without a bound).
Eigen::MatrixXd MotionRowsAt(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const std::vector<double>& rolls_rad);

// The largest |MotionRowsAt(options, problem, rolls_rad) * delta|, 0 without
// a bounded block, made without the rows.
double LargestRelativeMotion(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const std::vector<double>& rolls_rad,
                             const Eigen::VectorXd& delta);

// The largest relative motion of `delta` over the whole roll range of
// `problem`, not only at samples: each maximum of |dC(phi) / bound| that
// `samples` evenly spaced roll angles bracket, refined by golden section.
// Between 41 samples an order-6 motion may exceed the sampled largest by a few
// per cent: robustness benchmark, seed 313, scenario 102, round 1, a step
// scaled to 0.99 of the 3e-3 rad bound at the samples moved 1.0108 x the bound
// between them.
double LargestRelativeMotionOverRollRange(const CorrectionOptions& options,
                                          const CorrectionProblem& problem,
                                          int samples,
                                          const Eigen::VectorXd& delta);

// `samples` roll angles evenly over `problem`'s roll range, both ends
// included.
std::vector<double> RollSamples(const CorrectionProblem& problem, int samples);

// The axis motion dC(phi_s) / bound of every polynomial block with a bound
// (options.max_axis_motion_mm / _rad) at `samples` roll angles evenly over
// `problem`'s roll range, per unit of the parameter change (rows x
// num_parameters; no rows without a bound): motion_rows at
// kMotionBoundSamples, and the safe step's check (AxisMotionRatio).
Eigen::MatrixXd RelativeMotionRows(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   int samples);

// The same problem linearised at `parameters` (S evaluated there; roll range
// and T kept).
CorrectionProblem RelinearisedAt(const CorrectionProblem& problem,
                                 const Eigen::VectorXd& parameters);

// Evaluates the model at `parameters` (with S unless `given_jacobian` is
// non-empty), and recomputes S T and the reached, used and missing points.
void LineariseAt(const Eigen::VectorXd& parameters,
                 const Eigen::MatrixXd& given_jacobian,
                 CorrectionProblem* problem);

// Re-selects the reached, used and missing points from the evaluation, e and
// the weights.
void SelectPoints(CorrectionProblem* problem);

// Roll range, missing points, free parameters and points used of `problem` into
// `summary`.
void ReportProblem(const CorrectionProblem& problem,
                   CorrectionSummary* summary);

// Root mean square and largest magnitude of r over the indices idx (0 when
// empty).
double Rms(const Eigen::VectorXd& r, const std::vector<int>& idx);

// The points a prediction may speak of: the used ones, then the measured ones
// the model does not reach (predicted only where no change is answered, the
// part staying as measured). Callers keep those with a finite prediction.
std::vector<int> PredictedPoints(const CorrectionProblem& problem);

// A figure for a summary message, three significant digits ("%.3g").
std::string FormatUm(double um);

// The cubic term of an axis polynomial: every correction is first computed
// held to it (order_choice.cc, CorrectWithOrderChoice); orders above it (4-6)
// answer only where they earn their place and the safe step asks more of them
// (docs/correction-safety.md).
constexpr int kCubicOrder = 3;

// The highest polynomial order `delta` (num_parameters entries) changes on
// any block of `blocks` (-1: none).
int HighestOrderMoved(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& delta);

// Whether `delta` moves any axis polynomial coefficient above
// kCubicOrder.
bool UsesOrdersAboveCubic(const CorrectionProblem& problem,
                          const Eigen::VectorXd& delta);
double MaxAbs(const Eigen::VectorXd& r, const std::vector<int>& idx);

// Whether `options` hold a polynomial block that moves (order >= 0) below its
// highest order (num_coefficients - 1).
bool HoldsAnAxisBelowItsHighestOrder(const CorrectionOptions& options,
                                     const std::vector<ParameterBlock>& blocks);

// Whether `options` free an order above kCubicOrder on any
// polynomial block of `blocks`.
bool OpensOrdersAboveCubic(const CorrectionOptions& options,
                           const std::vector<ParameterBlock>& blocks);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_PROBLEM_H_
