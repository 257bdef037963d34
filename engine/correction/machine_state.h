// engine/correction/machine_state.h (internal): step 0 of the correction
// (correction.h, estimate_machine_state). The machine really runs commanded +
// unknown errors h. The state problem takes the model's own flank d(commanded)
// as the "measurement" and the measured flank as the "target" (same freedom, no
// bounds, next-part mode, the probe noise of the teeth average): its change is
// an estimate h^ of h within the reachable directions. The correction is then
// linearised and refined at commanded + h^ (RelinearisedAt, problem.h). A
// measured grid point the commanded settings do not reach is not in this fit,
// and where the flank bends between the commanded settings and the state the
// fit stops short: the state is fitted again linearised at commanded + h^
// where it reaches such points or leaves half the misfit there, Gauss-Newton
// passes while each lowers the misfit (correction.cc,
// FitTheStateAgainAtTheState).
//
//   CorrectionProblem state_problem;
//   if (MachineStateProblem(problem, &state_problem)) {
//     const CorrectionResult state = /* solve state_problem */;
//     Eigen::VectorXd at_state;
//     if (AcceptMachineState(problem, state, &at_state)) { /* solve
//     RelinearisedAt(problem, at_state) */ }
//   }
#ifndef GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_
#define GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_

#include <Eigen/Core>
#include <string>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// The state problem of `commanded` (a problem linearised at the commanded
// parameters): e = d0 - m (NaN where the model or the measurement has no
// value), the noise sigma / sqrt(mean teeth averaged) with no per-point shares,
// no bounds, next-part mode; the rule, weights, roll range, free set and
// linearisation are kept. A state estimate in orders 4-6 makes the spur gear's
// root contacts singular just as a correction in them does (see
// default_max_order), so it has the same max orders. False when no point is
// usable.
bool MachineStateProblem(const CorrectionProblem& commanded,
                         CorrectionProblem* state);

// Whether the solved state is used: usable, finite, and every measured grid
// point reached at the commanded parameters still reached at commanded + h^
// (then `state_parameters`), read from the state solve's exact prediction
// (predicted_change_um is NaN where a point is lost); a point the measurement
// lacks may be lost (the real machine may no longer grind it). Otherwise the
// correction is computed at the commanded parameters, as without the option;
// `refusal` (if given) then says why.
bool AcceptMachineState(const CorrectionProblem& commanded,
                        const CorrectionResult& state,
                        Eigen::VectorXd* state_parameters,
                        std::string* refusal = nullptr);

// Item 2 of issue 13: the state earns its place only when it explains the
// measurement significantly better than the commanded settings, and only
// within a stated size.
//  - Noise stated (sigma > 0, of the teeth average): chi = n (r_c^2 - r_s^2) /
//    sigma^2, r_c the rms misfit of the commanded flank, r_s the state's, n
//    its points, must exceed dof + kStateChiSds sqrt(2 dof), the chi-square
//    distribution's mean + 3 standard deviations at the state fit's effective
//    dof (what noise alone would explain). Noise stated 0: any fall.
//  - Noise unknown: F = (n (r_c^2 - r_s^2) / dof) / (n r_s^2 / (n - dof)) must
//    exceed kStateF, about the 1 % point of F(dof, n - dof) for the 5-12 dof
//    and 30-40 points these fits have (F(5, 35) 3.6, F(10, 35) 3.0).
//  - Size: its axis motion over the roll range within kStateMotionLimit times
//    the correction's motion bound (1 mm, 15 mrad by default): a machine that
//    far off is a setup error, not one to correct around.
constexpr double kStateChiSds = 3.0;
constexpr double kStateF = 4.0;
constexpr double kStateMotionLimit = 5.0;

struct MachineStateTest {
  bool used = false;
  std::string test;  // "chi-square", "F", "exact data" or "" (not tested)
  double statistic = 0.0;
  double threshold = 0.0;
  std::string reason;  // why it was used or not, in words
  // The state fit was made and kept every point the commanded settings reach,
  // whether or not it explained anything (set by the caller that made it).
  bool fit_made = false;
};

MachineStateTest TestMachineState(const CorrectionOptions& options,
                                  const CorrectionProblem& commanded,
                                  const CorrectionProblem& state_problem,
                                  const CorrectionResult& state);

// How far from the estimated state toward the commanded settings the machine
// plausibly runs, as a share t of the way (1: as far as the commanded
// settings). Along the way the misfit the commanded settings leave beyond the
// state's grows as t^2 (linear model), so the test's statistic falls to its
// threshold at t = sqrt(threshold / statistic): nearer than that the
// measurement cannot tell the machine from the state. That holds only where
// the state fits the measurement to the noise; where it leaves more, the
// model does not explain the measurement (an error it cannot represent, such
// as the wheel's parabola, taken up by other parameters) and the machine may
// be anywhere up to the commanded settings: t = 1.
//  - Noise stated (sigma of the teeth average): n r_s^2 / sigma^2 within
//    (n - dof) + kStateFitSds sqrt(2 (n - dof)), the chi-square distribution's
//    mean + 3 standard deviations for what the fit leaves.
//  - Noise unknown: the fit's own estimate of the probe noise (`noise_um`)
//    within kStateNoiseCeilingUm; more than a gear measuring machine's
//    probe scatters (a few tenths of a um) is misfit, not noise.
//  - Exact data (threshold 0) or the state not used: t = 1.
constexpr double kStateFitSds = 3.0;
constexpr double kStateNoiseCeilingUm = 1.0;

double PlausibleShare(const CorrectionProblem& state_problem,
                      const CorrectionResult& state,
                      const MachineStateTest& test,
                      double noise_um);

// The probe's scatter in the state fit's misfit, from its second differences
// along each grid row (across the face width): white noise of sigma gives
// them a variance of 6 sigma^2, a smooth misfit (what the model cannot
// represent) little. [um], of the measured grid (teeth averaged); NaN with
// fewer than kScatterMinDifferences differences.
// `relative_error` (if non-null) receives the estimate's standard error
// relative to it, for white noise (about 0.16 on a full 5 x 9 grid).
constexpr int kScatterMinDifferences = 12;
double ScatterOfStateMisfit(const CorrectionProblem& state_problem,
                            const CorrectionResult& state,
                            double* relative_error = nullptr);

// A stated probe noise the measurement contradicts: `scatter_um`
// (ScatterOfStateMisfit of the state fit of `state_problem`; NaN: none)
// above kNoiseContradictedShare x the stated sigma of `state_problem` (and
// above kExactDataScatterUm). Then the scatter raised by one standard error
// of it (`scatter_relative_error`, from ScatterOfStateMisfit) is the noise
// from here on: `commanded`'s probe_noise_um (per tooth, the stated value
// kept in its stated_probe_noise_um, the scatter in probe_scatter_um) and
// `state_problem`'s (of the teeth average), and both take the regularisation
// rule `options` would give it stated; true.
// Raised, because the noise decides which weak directions the filter
// follows: a scatter drawn low lets the probe's noise through as machine
// error, along directions where a little flank costs much axis motion
// (robustness benchmark, noise stated 0, seed 12: scenario 103's part at
// 0.141 um read a scatter of 0.26 um from a 0.34 um probe; the correction
// moved X by 0.198 mm for 0.09 um of predicted gain and took a root-row corner
// past the envelope's fold on the real machine, 89.7 um; scenario 90, 0.318
// of 0.448 um, 3.69 -> 51.4 um). A standard error is about 16 % on a full
// 5 x 9 grid.
// A shop that states its probe's repeatability from the data sheet leaves
// out the part's clamping and the gear's own scatter (robustness benchmark,
// the noise told at half the probe's: the 2-sigma band covered 83-86 % and
// parts at the noise were chased; BENCHMARKS.md). Exact data (sigma stated 0)
// is contradicted by a scatter above kExactDataScatterUm: a measuring
// machine's probe scatters by a few hundredths of a um at best, a noise-free
// simulation by far less.
constexpr double kNoiseContradictedShare = 1.5;
constexpr double kExactDataScatterUm = 0.01;
bool RaiseContradictedNoise(const CorrectionOptions& options,
                            double scatter_um,
                            double scatter_relative_error,
                            CorrectionProblem* commanded,
                            CorrectionProblem* state_problem);
// What RaiseContradictedNoise did to `commanded`, in words.
std::string ContradictedNoiseReason(const CorrectionProblem& commanded);
// Where `scatter_um` is below the stated sigma of `state_problem` by
// kNoiseContradictedShare, a note saying so in words (per tooth, with
// `mean_teeth_averaged`); "" otherwise. The stated noise is kept: a noise
// stated larger than the probe's makes the correction more careful, and the
// robustness benchmark with every told noise at twice the probe's lost reach
// (within 1.2 x best + noise 193 -> 188 of 200, seed 2026), not parts.
std::string QuieterThanStatedNote(const CorrectionProblem& state_problem,
                                  double scatter_um,
                                  double mean_teeth_averaged);

// The state's correction size and misfit into `summary`
// (machine_state_estimated = true).
void ReportMachineState(const CorrectionResult& state,
                        CorrectionSummary* summary);

// The test's outcome into `summary` (both when the state was used and not).
void ReportMachineStateTest(const MachineStateTest& test,
                            CorrectionSummary* summary);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_
