// engine/correction/correction.h: the closed-loop correction of MODEL.md §6:
// from a measured flank, the wanted target and the current machine parameters,
// the change of the parameters that makes the next part (or the reground part)
// match the target.
//
//   FlatWheelGrinder grinder(setup);
//   CorrectionInput input;
//   input.model = &grinder;
//   input.current_parameters = NominalSettings(setup).ToVector();
//   input.measured_um = measured;          // NaN = point not delivered by the
//   measuring machine input.target_um = EvaluateTargetModifications(target,
//   grinder.grid(), setup.gear, setup.flank); CorrectionOptions options; //
//   default solver "regularised", mode next part CorrectionResult result =
//   ComputeCorrection(options, input); if (result.summary.IsSolutionUsable()) {
//   use result.parameters; }
//
// The solver works against the abstract MachineModel only
// (engine/core/machine_model.h): any model that reports polynomial axis blocks
// and scalar blocks plugs in.
//
// Notation: m the measured deviations, t the target, e = m - t the flank error
// (um, per grid point), S the model's Jacobian d deviation / d parameter at the
// current parameters. A change dzeta is predicted to leave the error e + S
// dzeta (linear) or, exactly, e + d(zeta + dzeta) - d(zeta) with d the model's
// deviations.
//
// Correction size (MODEL.md §6): for a polynomial block (an axis C(phi1) =
// sum_k a_k phi1^k) the mean over the roll range [roll_min, roll_max] of
// (dC(phi1) / s)^2, for a scalar block (dp / s)^2; the size is the square root
// of the sum over blocks. s is the block's scale (ParameterBlock::default_scale
// unless overridden; MODEL.md §6 defaults: 1 um for X, Y, Z, 1 um / r_j for A,
// B, C, 1 um / R_w for theta_w, 1e-5 /mm for a_w, 1 mm for d_w).
//
// Default solver "regularised" (what the product uses):
//  0. (estimate_machine_state) The machine really runs commanded + unknown
//  errors h. Steps 1-4
//     are first run with the model's own flank d(commanded) as the
//     "measurement" and the measured flank as the "target" (same freedom, no
//     bounds, next-part mode): their change is an estimate h^ of h within the
//     reachable directions. Steps 1-4 then run for the real problem at
//     commanded + h^ (S, the roll range kept from the commanded point, the
//     exact change d(commanded + h^ + delta) - d(commanded + h^)); the answer
//     is commanded + delta. If the estimate is unusable or loses a used grid
//     point, the commanded point is used, as without the option.
//  1. Each free polynomial block is written in orthonormal Legendre coordinates
//  over the roll
//     range: dC(phi1) = s sum_k y_k sqrt(2k+1) P_k((phi1 - c) / h), c and h the
//     centre and half width of the range, so that the correction size is
//     exactly |y| (Euclidean). Scalar blocks: dp = s y. dzeta = T y.
//  2. With W the point weights, A = W^1/2 S T over the usable points and b =
//  -W^1/2 e, the
//     thin SVD A = U Sigma V' is taken (from the eigen-decomposition of A'A
//     where that resolves every direction the solve uses, else the Jacobi
//     SVD; regularisation.h, ComputeSvd). A direction counts toward the
//     numerical
//     rank when one unit of correction size moves the flank by at least
//     min_flank_effect_um rms (sigma_i >= min_flank_effect_um sqrt(sum w)); the
//     rest is the null space (MODEL.md §5) and never enters a correction. "Best
//     reachable" is b projected off U over that rank.
//  3. Tikhonov regularisation inside those directions: y = sum_{i<rank} f_i
//  (u_i'b / sigma_i) v_i
//     with f_i = sigma_i^2 / (sigma_i^2 + lambda^2), i.e. min |A y - b|^2 +
//     lambda^2 |y|^2 over y in span(v_0..v_rank-1). lambda by a stated rule,
//     reported with lambda and dof:
//     - probe noise sigma known, > 0: the unbiased predictive risk estimator
//     (UPRE, Mallows'
//       C_L; Vogel, Computational Methods for Inverse Problems, 2002, ch. 7):
//       minimise sum_i (1 - f_i)^2 (u_i'b)^2 + 2 sigma^2 dof(lambda) over a
//       logarithmic grid, dof = sum f_i (with point weights or averaged teeth,
//       sigma^2 is the mean noise variance of the reachable directions). This
//       minimises the expected error left in the reachable directions after the
//       correction, i.e. the true residual of the next part. On request
//       (use_discrepancy_principle) the discrepancy principle instead: the
//       in-range residual equals the noise expected there, sigma^2 sum_{i<rank}
//       sum_r w_r U_ri^2;
//     - sigma = 0, exact data: lambda = min_relative_regularisation * sigma_1
//     (reported as the
//       discrepancy principle with no noise), the floor that GCV also respects;
//     - sigma unknown (negative): generalised cross-validation (minimum of
//       |A y - b|^2 / (m - dof)^2, m the points used). GCV reads a systematic
//       misfit (a target the model cannot reach) as noise and then corrects
//       less; with exact data give sigma = 0.
//  4. The change delta = T V_rank z is refined by Ceres (Levenberg-Marquardt)
//  on the exact
//     nonlinear model in the same subspace with the same lambda^2 |z|^2 term,
//     starting from the linear answer (or from no change if the exact model
//     loses a point there; and once more from no change when the first run does
//     not converge, keeping the lower cost), within the per-coefficient bounds
//     (then over the free monomials, with a penalty sigma_1 for leaving the
//     subspace), and reported as the machine's monomial coefficients.
//  Rework mode (material can only be removed): the exact predicted change
//  d(zeta + dzeta) - d(zeta) must be <= 0 at every reached point. Steps 3-4
//  become a sequence of convex quadratic programs in z (same objective, the
//  linearised change <= 0 and the bounds as constraints, solved through their
//  dual with the active-set method of Lawson and Hanson), each re-linearised on
//  the exact model.
//
// Solver "pso" (the published method, Jiang 2015 / MODEL.md §6, kept for
// comparison, run as a competent reader of the paper runs it;
// baseline_solvers.h): the global-best particle swarm over the same free
// coefficients as the default (max_order; the paper's published case is
// default_max_order = 0 with {"C", 6}, its two-axis variant default_max_order
// = -1 with {"Z", 6}, {"C", 6} and the wheel parabola named with 0), each
// within +-pso_box (0.02) of the current value in its own unit (mm for X, Y, Z
// and d_w, rad for A, B, C and the cone angle, 1/mm for a_w) and the bounds.
// It searches the model linearised at the commanded parameters, with the point
// weights and delta = t - m: the next part minimises sum_i w_i (S_i dzeta -
// delta_i)^2; rework minimises the paper's one-sided sum_i w_i f_i^2, f_i = S_i
// dzeta - delta_i where S_i dzeta < 0 (the wheel reaches point i), f_i =
// -delta_i elsewhere. 40 particles x 200 generations, inertia 0.7, c1 = c2 =
// 1.5, random factors per particle and coordinate, velocity clamped to +-0.2 x
// the box width, positions clipped to the box (that coordinate's velocity
// zeroed), uniform random start plus one particle at no change, at rest;
// seeded by pso_seed. No machine-state estimate, outlier test or safe step;
// the reported residual is the exact model's at the answer.
//
// Solver "lsq-plain" (for comparison): the minimum-norm unregularised
// least-squares solution in the raw parameter units, dzeta = pinv(W^1/2 S)
// (-W^1/2 e), no refinement.
//
// Outliers (default solver): after a regularised linear fit, each point's
// standardised residual r_i / sqrt(1 - h_ii) (h the hat matrix of the fit) is
// compared with the median over all points and with its grid neighbours along
// each line through it (row, column, both diagonals: the mean of the neighbours
// on the line); the point standing out most from all of them is a gross outlier
// when that smallest distance exceeds max(outlier_threshold * max(1.4826 * MAD,
// sigma), outlier_min_um). A misfit shared by its neighbours (a relief the
// model cannot follow) is not an outlier. It is dropped, the fit repeated (at
// most max_outlier_fraction of the points), and the dropped indices reported in
// the summary; they never take part in the final solve.
#ifndef GEARLOOP_ENGINE_CORRECTION_CORRECTION_H_
#define GEARLOOP_ENGINE_CORRECTION_CORRECTION_H_

#include <Eigen/Core>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"

namespace gearloop {

enum class CorrectionSolver {
  kRegularised,        // "regularised" (default)
  kParticleSwarm,      // "pso"
  kPlainLeastSquares,  // "lsq-plain"
};
const char* CorrectionSolverName(CorrectionSolver solver);
bool ParseCorrectionSolver(const std::string& name, CorrectionSolver* solver);

enum class CorrectionMode {
  kNextPart,  // "next-part": the next part is ground with the new settings
              // (default)
  kRework,  // "rework": the same part is reground, material can only be removed
};
const char* CorrectionModeName(CorrectionMode mode);
bool ParseCorrectionMode(const std::string& name, CorrectionMode* mode);

enum class RegularisationRule {
  kUnbiasedPredictiveRisk,  // "upre" (probe noise sigma known, > 0; the default
                            // there)
  kDiscrepancyPrinciple,    // "discrepancy-principle" (sigma known, on request;
                            // sigma = 0: exact data)
  kGeneralisedCrossValidation,  // "gcv" (sigma unknown)
  kNone,                        // "none" (pso, lsq-plain)
};
const char* RegularisationRuleName(RegularisationRule rule);

struct CorrectionOptions {
  CorrectionSolver solver = CorrectionSolver::kRegularised;
  CorrectionMode mode = CorrectionMode::kNextPart;

  // Which parameters may change. For a polynomial block: the highest order that
  // may change (0..num_coefficients-1), or -1 = fixed. For a scalar block: 0 =
  // free, -1 = fixed. `default_max_order` applies to every polynomial block not
  // named in `max_order` (clamped to the block's own degree); scalar blocks not
  // named are free, except those the model fixes by default
  // (ParameterBlock::fixed_by_default: the grinder's wheel parabola a_w, d_w;
  // name them with 0 to free them). Block names are the model's
  // (ParameterBlock::name: "X".."C", "cone_angle", ...). Example, the published
  // cutter case: default_max_order = 0, max_order = {{"C", 6}}.
  //
  // The default 6 (every order of every axis, issue 13): the regularised
  // solver first solves held to each axis' cubic term, and answers with orders
  // 4-6 only where their exact prediction is better by max(0.05-0.1 um,
  // 20 %; the absolute part 1 % of the measured part's rms, held within
  // 0.05-0.1 um), they keep every measured point at the commanded settings
  // and, linearised there while the cubic answer estimated a machine state,
  // they are predicted better by the same margin at that state
  // (summary.order_choice); the second solve runs only where orders 4-6 reach
  // enough above the noise from the cubic answer's predicted part. A Legendre
  // term of order k moves the axis by its amplitude inside the roll range but
  // accelerates it by ~k^4 / h^2 times that at the ends of the range (210 / h^2
  // for k = 6, h the half width); orders 4-6 of a few um once made the
  // envelope contacts of the spur gear's root row singular, and with them open
  // unguarded 11 of 24 loops scrapped parts; the order choice, their
  // smoothness weights and the safe step's commanded-end tests are what make
  // them safe (docs/correction-safety.md). The other solvers ("pso",
  // "lsq-plain") use every order asked as it is; 3 holds every axis to its
  // cubic term.
  int default_max_order = 6;
  std::map<std::string, int> max_order;

  // Per-point weights (row-major, >= 0; empty = all 1). A zero weight ignores
  // the point.
  Eigen::VectorXd point_weights;

  // Bounds on the change of each parameter [parameter units] (empty =
  // unbounded; use +-inf for single unbounded entries). lower <= 0 <= upper is
  // required.
  Eigen::VectorXd lower_delta;
  Eigen::VectorXd upper_delta;

  // Standard deviation of the probe noise [um]. Known (> 0): the unbiased
  // predictive risk estimator chooses lambda (or the discrepancy principle, see
  // below); 0 = exact measurements (lambda at its floor, every reachable
  // direction is fitted). Unknown (negative, the default): generalised
  // cross-validation chooses it.
  double probe_noise_um = -1.0;
  // With a known noise > 0: the discrepancy principle instead of the unbiased
  // predictive risk estimator. It leaves as much misfit in the reachable
  // directions as the noise there, which under-corrects: after two corrections
  // the error sits above the least-squares noise floor on about 1 seed in 5
  // (BENCHMARKS.md).
  bool use_discrepancy_principle = false;

  // Regularised solver: first estimate the machine's real state from the
  // measurement (the parameter change, in the same reachable directions and
  // with the same rule, that makes the model reproduce the measured flank),
  // then linearise and refine the correction there rather than at the commanded
  // parameters. The commanded parameters differ from what the machine really
  // runs by its unknown errors; S and the exact change depend on that state,
  // and a correction computed at the commanded point is off by (S(real) -
  // S(commanded)) * delta.
  // Next-part mode only: rework keeps its no-added-material constraint at the
  // commanded parameters.
  bool estimate_machine_state = true;

  // Correction-size scales per block name, overriding
  // ParameterBlock::default_scale (> 0).
  std::map<std::string, double> block_scales;

  // A direction of the scaled S counts toward its numerical rank (and may be
  // corrected) when one unit of correction size (1 um of axis motion with the
  // default scales) moves the flank by at least this much, rms over the points
  // [um]. 0.01 refuses corrections that need more than ~100 um of axis motion
  // per um of flank. Weaker directions are the first-order null space (whose
  // singular values leave zero as soon as the settings leave nominal) and
  // directions so nonlinear that a correction along them is not predicted by S
  // (rate terms of A, the vertex d_w while a_w is small). Before the safe step
  // and the fixed wheel parabola, 0.01 let a second correction of 44 um
  // predict 0.78 um and grind 3.8 um, and the limit was 0.03 (BENCHMARKS.md,
  // "Correction"); with them, 0.01 reaches lower on the robustness benchmark
  // (final median 1.10 -> 0.91 um, seed 2026; 1.26 -> 1.11, seed 7) with the
  // same worse rounds (1 and 3 of 600).
  double min_flank_effect_um = 0.01;

  // The per-direction signal filter (regularisation.h, SignalFilter): at an
  // estimated machine state with a noise (stated, or estimated from the state
  // fit), each direction of the correction is kept as far as its coefficient
  // stands above the noise along it, down to directions of 1e-4 um per unit
  // (kWeakFlankEffectShare of min_flank_effect_um) instead of
  // min_flank_effect_um, and with no single Tikhonov level. It reaches what
  // weak directions (a wheel dish for a lead crowning) can make; the motion
  // bound and the safe step keep it safe. false: one Tikhonov level by the
  // rule, as at the commanded parameters.
  bool signal_filter = true;

  // The safe step (regularised solver; safe_step.cc, "SafeStep"): before
  // answering, the next part is predicted on the exact model at the point the
  // correction was linearised at (the estimated machine state, or the
  // commanded parameters). A step is kept only where that prediction is better
  // (lower rms over the used points) than keeping the current settings;
  // otherwise it is halved, at most safe_step_halvings times,
  // and when no fraction is better the current settings are kept with status
  // no_safe_improvement. Before that, the whole change is scaled down so that
  // no axis moves more than max_axis_motion_mm (axes in mm) or
  // max_axis_motion_rad (axes in rad) anywhere over the roll range (0 = no
  // bound). false turns the stage off (the bare solver, for studies).
  bool safe_step = true;
  int safe_step_halvings = 5;
  double max_axis_motion_mm = 0.2;
  double max_axis_motion_rad = 3e-3;

  // Floor of the Tikhonov level lambda, relative to the largest singular value
  // of the scaled S (0 = none), for exact data (probe_noise_um = 0) and GCV:
  // there lambda >= min_relative_regularisation * sigma_1. With a known noise >
  // 0 the rule alone decides (unbiased predictive risk, or the discrepancy
  // principle on request).
  double min_relative_regularisation = 1e-3;

  // Ceres refinement (regularised solver): iterations of Levenberg-Marquardt (0
  // = no refinement).
  int max_num_iterations = 20;
  // Set by the order choice for its every-order solve (order_choice.cc), NaN
  // otherwise: the exact prediction [um] that answer must stay below to be
  // taken over the cubic one. The solve asks it before solving again to hold
  // the motion bound where the answer moves the next part's contacts
  // (solve_problem.cc, HoldTheBoundWhereTheContactsGo): an answer predicted
  // no lower before that bound is added is not solved again. Callers leave it.
  double orders_above_cubic_bar_um = std::numeric_limits<double>::quiet_NaN();
  // Rework mode: re-linearisations of the constrained problem on the exact
  // model.
  int max_rework_passes = 4;
  // Rework mode: predicted added material above this [um] counts as a
  // violation.
  double rework_tolerance_um = 1e-6;

  // Outlier test (see the file comment). 0 disables it.
  double outlier_threshold = 5.0;
  double outlier_min_um = 2.0;
  // At most this fraction of the usable points may be dropped as outliers.
  double max_outlier_fraction = 0.2;

  // Particle swarm (solver "pso"), as published (see the file comment).
  int pso_particles = 40;
  int pso_generations = 200;
  double pso_inertia = 0.7;
  double pso_cognitive = 1.5;  // c1
  double pso_social = 1.5;     // c2
  // Half width of the search box, in each coefficient's own unit (mm, rad,
  // 1/mm).
  double pso_box = 0.02;
  unsigned long long pso_seed = 2015;

  bool IsValid(std::string* error) const;
};

struct CorrectionInput {
  const MachineModel* model = nullptr;
  // The parameters the measured part was ground with (NumParameters entries).
  Eigen::VectorXd current_parameters;
  // The measured deviations [um], row-major, NaN = missing.
  Eigen::VectorXd measured_um;
  // Alternatively several measured teeth of the flank (each row-major, NaN =
  // missing): when not empty, measured_um is ignored and the point-wise mean of
  // the delivered values is used (AverageTeeth), with the probe noise of a
  // point divided by sqrt(number of teeth averaged) in the discrepancy
  // principle.
  std::vector<Eigen::VectorXd> measured_teeth_um;
  // The target modification [um], row-major (e.g. EvaluateTargetModifications).
  Eigen::VectorXd target_um;
  // The roll range used [rad]. When roll_min_rad >= roll_max_rad (the default)
  // it is taken from the model's contact roll angles at current_parameters over
  // the reached points.
  double roll_min_rad = 0.0;
  double roll_max_rad = 0.0;
  // Optional: the model's Jacobian at current_parameters [um per unit], when
  // the caller has it (e.g. the same machine state corrected many times);
  // otherwise evaluated here.
  Eigen::MatrixXd jacobian_um;
};

enum class CorrectionStatus {
  kConverged,     // "converged"
  kNotConverged,  // "not_converged": the message says why; the result may still
                  // be usable
  kInvalidInput,  // the options or input were rejected; nothing was computed
  kNoSafeImprovement,  // "no_safe_improvement": no fraction of the correction
                       // is predicted (exact model) to make a better part than
                       // the current settings; the current settings are kept
                       // and the message says why
};
const char* CorrectionStatusName(CorrectionStatus status);

struct BlockCorrectionSize {
  std::string name;
  double size = 0.0;  // sqrt(mean (dC/s)^2) or |dp|/s
};

struct PredictionBand {
  double noise_sigma_um = 0.0;
  bool noise_stated = false;
  // The stated probe noise [um] where the measurement contradicted it (the
  // machine-state fit's misfit scattered more than 1.5 times as much from
  // point to point, machine_state.h RaiseContradictedNoise): noise_sigma_um
  // is then that scatter and noise_stated false. NaN otherwise.
  double stated_noise_um = std::numeric_limits<double>::quiet_NaN();
  // The noise was estimated from a misfit above what a probe scatters (1 um,
  // prediction_band.h): the expected value reads the rest as flank the next
  // part keeps, the bands reach over both readings.
  bool misfit_read_as_flank = false;
  // Where misfit_read_as_flank: the share of the estimated noise the expected
  // value reads as probe scatter [um] (kStateNoiseCeilingUm); NaN otherwise.
  // The reports print it, so a change of the ceiling reaches every client.
  double noise_read_as_probe_um = std::numeric_limits<double>::quiet_NaN();
  double expected_true_rms_um = 0.0;
  double true_rms_low_um[2] = {0.0, 0.0};   // 1 sigma, 2 sigma
  double true_rms_high_um[2] = {0.0, 0.0};  // 1 sigma, 2 sigma
};

// The wheel profile's parabola the safe step hedged (docs/correction-safety.md,
// "How much parabola the measurement allows"): no fit frees the parabola's
// coefficient, so the safe step asks how large a parabola the measured flank
// less the commanded one shows when the axes and the wheel's cone are held to
// the size machines err. Flanks are rms over the used points [um].
struct WheelParabolaEvidence {
  bool asked = false;  // the safe step asked (next-part mode, not the state
                       // fit, the parabola's coefficient not a free one)
  bool from_measurement = false;  // false: assumed, the noise neither stated
                                  // nor estimated
  double estimate_flank_um = std::numeric_limits<double>::quiet_NaN();
  double sd_flank_um = std::numeric_limits<double>::quiet_NaN();
  // What the spread hedged: sqrt(estimate^2 + sd^2), or 1 um assumed.
  double hedged_flank_um = 0.0;
};

// A solve that keeps fewer effective directions than this (the sum of its
// filter factors, CorrectionSummary::effective_dof) keeps none: nothing above
// the noise, whatever its change.
constexpr double kNoEffectiveDirectionDof = 0.01;

struct CorrectionSummary {
  CorrectionStatus status = CorrectionStatus::kInvalidInput;
  std::string message;
  CorrectionSolver solver = CorrectionSolver::kRegularised;
  CorrectionMode mode = CorrectionMode::kNextPart;

  RegularisationRule rule = RegularisationRule::kNone;
  double regularisation_level =
      0.0;  // lambda, in units of the scaled S (um per unit size)
  double effective_dof = 0.0;  // sum of the Tikhonov filter factors (<= rank)
  int truncation_rank = 0;  // directions the regularised solve may use (= rank;
                            // 0 for pso, lsq-plain)

  int num_points_used = 0;
  int num_free_parameters = 0;
  int rank = 0;  // numerical rank of the scaled, weighted S (free columns)
  double condition_number = 0.0;    // over that rank
  Eigen::VectorXd singular_values;  // of the scaled, weighted S, descending

  double roll_min_rad = 0.0;
  double roll_max_rad = 0.0;

  double initial_rms_um = 0.0;  // of e over the points used
  double initial_max_um = 0.0;
  // How rough e is over the grid: the mean square difference of e between
  // neighbouring used points (along the profile and along the lead) over twice
  // e's variance there. About 1 for probe scatter alone (independent points),
  // near 0 for a smooth flank shape; NaN with fewer than two neighbours or no
  // variance. Tells a zero correction's advice (measure again, or free more
  // of the machine) without the solve's figures.
  double error_neighbour_ratio = std::numeric_limits<double>::quiet_NaN();
  double residual_rms_um = 0.0;  // predicted (exact model) over the points used
  double residual_max_um = 0.0;
  double best_reachable_rms_um =
      0.0;  // |e projected off the range of the weighted S| (rms), S where
            // linearised (see machine_state_estimated), over the rank
  double linear_residual_rms_um =
      0.0;  // predicted by the linear model before refinement
  double max_added_material_um =
      0.0;  // largest predicted change > 0 (rework: must be <= tol)

  double correction_size = 0.0;
  std::vector<BlockCorrectionSize> block_sizes;

  std::vector<int> outlier_indices;  // grid points dropped as gross outliers
  // Several teeth: grid points where a tooth's value stood out from the other
  // teeth and was left out of the mean (with two teeth: the point itself).
  std::vector<int> tooth_outlier_indices;
  std::vector<int>
      missing_indices;  // grid points without a usable measurement or contact
  // Of those, the points that were measured but where the model at the
  // settings it was linearised at has no contact (the wheel does not reach
  // them there, or the contact was not found): the correction neither
  // corrects nor predicts them, and residual_rms_um and the prediction band
  // leave them out. The largest |measured - target| among them [um] (NaN when
  // there are none): a measured error the answer does not cover.
  std::vector<int> measured_not_reached_indices;
  double measured_not_reached_max_um = std::numeric_limits<double>::quiet_NaN();

  // Ceres cost 1/2 |residuals|^2 of the exact-model refinement before and after
  // (0 if none).
  double refinement_initial_cost = 0.0;
  double refinement_final_cost = 0.0;

  // The estimated machine state (estimate_machine_state): whether it was used,
  // its correction size relative to the commanded parameters, and the rms flank
  // misfit it leaves (um); where the state was fitted again at itself, the
  // state the last pass reached.
  bool machine_state_estimated = false;
  double machine_state_size = 0.0;
  double machine_state_misfit_rms_um = 0.0;
  double machine_state_dof = 0.0;  // effective dof of the state fit
  // The test that decides whether the state is used (machine_state.h,
  // TestMachineState): "chi-square" (noise stated), "F" (noise unknown),
  // "exact data" or "" (no state fit), its statistic and threshold, and the
  // decision in words (also when the state was not used).
  // true: the correction filtered each direction by its own signal to noise
  // (options.signal_filter, regularisation.h SignalFilter; regularisation_level
  // is then the largest level of a kept direction); false: one Tikhonov level
  // by `rule`.
  bool signal_filter_used = false;
  std::string machine_state_test;
  double machine_state_statistic = 0.0;
  double machine_state_threshold = 0.0;
  std::string machine_state_reason;

  // How sure the prediction is (engine/correction/prediction_band.h): the
  // probe noise used (stated, or estimated from the state's or the
  // correction's misfit), the expected true rms of the next part (the
  // predicted rms less the noise the fit absorbed) and its 1- and 2-sigma
  // bands [um]. The model's own error is not in it.
  PredictionBand prediction_band;

  // The exact-model search (exact_search.h): what it did ("not run: ...",
  // "taken: ...", "kept the regularised answer: ...", "refused by the safe
  // step (...): ..." where no fraction of the search's answer was safe and the
  // regularised answer went through the safe step instead, "" when the solver
  // has none), and the exact predictions at the linearisation point of the
  // regularised answer and of the search's [um] (NaN when not computed).
  std::string exact_search;
  double exact_search_before_rms_um = std::numeric_limits<double>::quiet_NaN();
  double exact_search_after_rms_um = std::numeric_limits<double>::quiet_NaN();

  // The safe step (CorrectionOptions::safe_step): the factor applied to the
  // solver's change for the motion bound (1 = within it), the fraction of the
  // bounded change kept by the exact-model check (1 = all, 0 = none), the rms
  // the exact model predicts for the kept change at the linearisation point,
  // and the rms of keeping the current settings it was compared with.
  bool safe_step_checked = false;
  double motion_scale = 1.0;
  double step_fraction = 1.0;
  double safe_step_current_rms_um = 0.0;
  double safe_step_predicted_rms_um = 0.0;
  // How far the kept change's next part may lie from that prediction if the
  // machine is off the state it was predicted at by what the measurement
  // cannot see (rms over the used points, first order: the free
  // coordinates' posterior and a wheel parabola the axes take up, of the
  // flank the measurement allows, 1 um where the noise is not known;
  // docs/correction-safety.md); 0 where not asked or nothing was kept.
  double safe_step_state_spread_um = 0.0;
  // The wheel parabola in that spread (not asked: asked == false).
  WheelParabolaEvidence safe_step_wheel_parabola;
  // Where a fraction below 1 was kept: why the whole (bounded) change was not
  // (a test it failed, or its exact prediction); "" when it was kept whole or
  // nothing was kept (then the message says why).
  std::string safe_step_shortened;

  // The orders used (order_choice.cc, CorrectWithOrderChoice; regularised
  // solver): when the options free an axis order above 3, the correction is
  // computed held to the cubic terms and (where the screen lets it, see
  // default_max_order) with every order asked, and the
  // higher orders are used only when their exact prediction is better by
  // max(0.05-0.1 um, 20 % of the cubic one; 1 % of the measured part's rms
  // within 0.05-0.1 um) and they keep every measured point at
  // the commanded settings. order_choice says which and why (""
  // when no order above 3 was free); the two predicted rms [um] (NaN when not
  // computed or not usable). highest_order_moved: the highest polynomial
  // order the correction changes on any axis (-1: none).
  std::string order_choice;
  // Where an answer with orders 4-6 moved an axis beyond its bound at roll
  // angles outside the roll range that its own next-part contacts reach, the
  // solve held the bound there as well (solve_problem.cc,
  // HoldTheBoundWhereTheContactsGo): the roll angles [deg] and how often it
  // solved again; "" otherwise.
  std::string motion_bound_beyond_roll_range;
  double cubic_orders_predicted_rms_um =
      std::numeric_limits<double>::quiet_NaN();
  double all_orders_predicted_rms_um = std::numeric_limits<double>::quiet_NaN();
  int highest_order_moved = -1;
  // Whether the options hold an axis that moves below its highest order
  // (6 on the grinder): only then can "open higher orders" make more of the
  // target (false with every order 0-6 open, the default).
  bool axis_orders_held_below_highest = false;

  int iterations = 0;  // Ceres iterations, rework passes or PSO generations
  double elapsed_ms = 0.0;

  bool IsSolutionUsable() const {
    return status == CorrectionStatus::kConverged ||
           status == CorrectionStatus::kNotConverged ||
           status == CorrectionStatus::kNoSafeImprovement;
  }
  std::string BriefReport() const;
};

struct CorrectionResult {
  Eigen::VectorXd
      parameters;  // new parameters (monomial, as the machine takes them)
  Eigen::VectorXd delta;                  // parameters - current
  Eigen::VectorXd predicted_residual_um;  // e + exact change, NaN where no
                                          // measurement/contact
  Eigen::VectorXd
      predicted_change_um;  // exact d(new) - d(current), NaN where not reached
  // 1-sigma band of predicted_residual_um per point [um] (the probe noise
  // there, summary.prediction_band), NaN where there is no prediction.
  Eigen::VectorXd predicted_residual_sigma_um;
  // The parameters the correction was linearised and predicted at: the
  // estimated machine state (summary.machine_state_estimated) or the current
  // parameters; empty when no solve ran.
  Eigen::VectorXd linearised_at;
  CorrectionSummary summary;
};

CorrectionResult ComputeCorrection(const CorrectionOptions& options,
                                   const CorrectionInput& input);

// The correction size of `delta` (see the file comment) over the roll range,
// overall; per-block sizes go to `block_sizes` if non-null. `block_scales` as
// in CorrectionOptions.
double CorrectionSize(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& delta,
                      double roll_min_rad,
                      double roll_max_rad,
                      const std::map<std::string, double>& block_scales = {},
                      std::vector<BlockCorrectionSize>* block_sizes = nullptr);

// The change of parameters, block by block, whose orthonormal Legendre
// coordinates over the roll range (scaled as in the file comment) are
// `coordinates`, one entry per coefficient of each block; the inverse of
// CorrectionCoordinates. CorrectionSize(delta) == |coordinates|.
Eigen::VectorXd DeltaFromCorrectionCoordinates(
    const std::vector<ParameterBlock>& blocks,
    const Eigen::VectorXd& coordinates,
    double roll_min_rad,
    double roll_max_rad,
    const std::map<std::string, double>& block_scales = {});
Eigen::VectorXd CorrectionCoordinates(
    const std::vector<ParameterBlock>& blocks,
    const Eigen::VectorXd& delta,
    double roll_min_rad,
    double roll_max_rad,
    const std::map<std::string, double>& block_scales = {});

// Several measured teeth of one flank combined point by point: the mean of the
// finite values at each point, NaN where no tooth delivered the point. All
// grids must have the same size; `counts` (optional) receives how many teeth
// each point averaged.
Eigen::VectorXd AverageTeeth(const std::vector<Eigen::VectorXd>& teeth_um,
                             Eigen::VectorXi* counts = nullptr);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_CORRECTION_H_
