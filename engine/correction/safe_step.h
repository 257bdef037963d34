// engine/correction/safe_step.h (internal): the last stage before the exact
// prediction: never answer a correction that makes the next part worse.
//
//   1. BoundAxisMotion: the whole change is scaled down until no axis moves
//   more
//      than options.max_axis_motion_mm / _rad anywhere over the roll range.
//   2. ChooseSafeStep: while measured points have no contact on the model at
//      the linearisation point (problem.measured_not_reached), no change: the
//      real machine grinds them and the model cannot say what a step does
//      there (on the hold-out seeds 12-21 five of the nine worse rounds
//      were such steps, predicted 0.14-0.56 um, made up to 20.9). Otherwise
//      the next part is predicted on the exact model,
//      e + d(p + alpha delta) - d(p), at the linearisation point p (the
//      solver's estimate of the machine's state, or the commanded parameters);
//      alpha = 1, 1/2, 1/4, ... is kept at the first value whose prediction
//      (over every point it grinds, the unmeasured ones at the model's flank)
//      has a lower rms than the current part's measured points (e), even
//      without its 5 % most improved points, that loses no used point, and
//      that (linearised at an estimated state) passes the tests at the
//      commanded parameters: no point near the wheel's edge lost there, no
//      point lost there and halfway, no contact on another branch, and for
//      orders 4-6 the same change within the state's rms and the motion
//      bound where the contacts move (docs/correction-safety.md); and
//      (next-part mode) whose prediction, spread by what the measurement cannot
//      tell of the machine's state (the free coordinates' posterior and a
//      wheel parabola the axes take up, through J(p + alpha delta) - J(p)),
//      would still not make the part worse by more than max(0.1 um, 10 %).
//      When none is, the change is zero and the outcome says why. (Asking the
//      commanded point for a better rms, or for every point still reached, was
//      tried: where the estimated state earns its place, the commanded point
//      predicts the good step worse and the spur-crowning loop stalls at 7.9 um
//      instead of 1.10.)
//
//   3. DropNegligibleStep: a kept fraction whose exact change the measurement
//      could not see (below a tenth of the filter's noise) becomes no change.
//
//   SafeStepOutcome outcome;
//   delta = BoundAxisMotion(options, problem, delta, &outcome);
//   delta = ChooseSafeStep(options, problem, delta, &outcome);
//   DropNegligibleStep(problem, &delta, &outcome);
#ifndef GEARLOOP_ENGINE_CORRECTION_SAFE_STEP_H_
#define GEARLOOP_ENGINE_CORRECTION_SAFE_STEP_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// With the per-direction filter: a correction whose change of the flank is
// below this share of the probe noise (rms over the used points) is no
// correction (a noise coefficient just past the filter's three standard
// deviations moves a weak direction, and the axes, for nothing: 0.19 um rms of
// axis motion for a part measured as noise alone). Asked of the linear change
// (solve_problem.cc) and of the safe step's kept fraction (DropNegligibleStep).
constexpr double kNegligibleChangeShare = 0.1;

struct SafeStepOutcome {
  double motion_scale = 1.0;      // factor of the motion bound (1 = within it)
  double step_fraction = 1.0;     // alpha kept (0 = no safe improvement)
  double current_rms_um = 0.0;    // keeping the current settings
  double predicted_rms_um = 0.0;  // exact, at the linearisation point
  // The kept fraction's spread from what the measurement cannot tell of the
  // machine's state (rms over the used points, first order); 0 where not
  // asked or nothing was kept.
  double state_spread_um = 0.0;
  // The wheel parabola that spread hedged (asked or not, kept or not).
  WheelParabolaEvidence wheel_parabola;
  bool improved = true;   // false: no fraction was safe
  std::string message;    // why not, when !improved
  std::string shortened;  // why not the whole change, when 0 < fraction < 1
  // The model at p + the kept step (when one was kept: improved and a step
  // evaluated), for the exact prediction to reuse.
  bool has_evaluation = false;
  ModelEvaluation evaluation;
};

// The machine's errors as the safe step's parabola estimate holds them
// (safe_step.cc, ParabolaFlankTheMeasurementAllows; round_probe --two-parts
// asks the same): every axis monomial to order 3, each with a prior standard
// deviation of 10 um (mm axes) or 20 urad (rad axes) rms of motion over
// [roll_min_rad, roll_max_rad], the wheel's cone with 200 urad, and the
// parameter `parabola` with none (infinite: the caller holds it). The largest
// hidden errors the robustness benchmark draws.
struct MachineErrorPrior {
  std::vector<int> columns;  // parameter indices
  std::vector<double> sd;    // each one's prior standard deviation [its unit]
  int parabola_column = -1;  // where `parabola` is in columns; -1: absent
};
MachineErrorPrior MakeMachineErrorPrior(
    const std::vector<ParameterBlock>& blocks,
    double roll_min_rad,
    double roll_max_rad,
    int parabola);

// The largest axis motion |dC(phi1)| of `delta` over the roll range for each
// polynomial block, relative to its bound (mm or rad); the largest ratio.
double AxisMotionRatio(const CorrectionOptions& options,
                       const CorrectionProblem& problem,
                       const Eigen::VectorXd& delta);

// Where `delta` (with orders above the cubic, in a problem with a motion
// bound) moves an axis beyond its bound at roll angles outside the problem's
// roll range where it moves the next part's contacts (the exact model at the
// linearisation point + delta and, at an estimated state, at the commanded
// settings + delta, as the safe step asks): motion rows (problem.motion_rows')
// sampling those stretches, for the solve to hold the bound there as well; no
// rows otherwise. The safe step would shorten such a change until it keeps the
// bound there (ChooseSafeStep). With rows, `*lo_rad` and `*hi_rad` (when
// given) get the roll range the next part's contacts span, the problem's
// range joined.
Eigen::MatrixXd MotionRowsWhereTheNextContactsGo(
    const CorrectionOptions& options,
    const CorrectionProblem& problem,
    const Eigen::VectorXd& delta,
    double* lo_rad = nullptr,
    double* hi_rad = nullptr);

Eigen::VectorXd BoundAxisMotion(const CorrectionOptions& options,
                                const CorrectionProblem& problem,
                                const Eigen::VectorXd& delta,
                                SafeStepOutcome* outcome);

// The exact rms of the part the current settings make, as the safe step
// compares every fraction with: the used points' e and, where the measurement
// has a figure but the point is not used (an outlier), the model's flank at
// the linearisation point against the target.
double CurrentPartRms(const CorrectionProblem& problem);

// Why no change can be answered while measured points have no contact on the
// model at the linearisation point (problem.measured_not_reached): the rows,
// the largest error, what to check; "" when there are none.
std::string MeasuredNotReachedRefusal(const CorrectionProblem& problem);

Eigen::VectorXd ChooseSafeStep(const CorrectionOptions& options,
                               const CorrectionProblem& problem,
                               const Eigen::VectorXd& delta,
                               SafeStepOutcome* outcome);

// After ChooseSafeStep, next-part mode with the filter's noise
// (problem.signal_noise_um > 0): a kept fraction whose exact change, rms over
// the used points, is below kNegligibleChangeShare of that noise is a change
// the measurement could not see either: the step becomes zero, the outcome
// keeps the current settings (still `improved`: nothing is refused), and true
// is returned. On twenty seeds x 200 scenarios (default options) 121 answered
// steps changed the flank by less than a tenth of the band's noise; 4 made the
// part better by more than 5 %, and seed 8's
// 40 (half a step, 0.03 um rms of change predicted to gain 0.012 um) moved a
// tip corner onto the envelope's other sheet, 0.41 -> 27.1 um.
bool DropNegligibleStep(const CorrectionProblem& problem,
                        Eigen::VectorXd* step,
                        SafeStepOutcome* outcome);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_SAFE_STEP_H_
