// engine/correction/rework_qp.h (internal): the constrained steps of the
// correction (correction.h, "Rework mode" and the bounds): a convex QP solved
// through its dual with the active-set method of Lawson and Hanson, the QP in
// the kept coordinates z at a linearisation, and the rework passes that
// re-linearise it on the exact model.
//
//   Eigen::VectorXd y;
//   if (SolveConvexQp(hessian, g, constraints, limits, &y)) { /* min 1/2 y'Hy -
//   g'y, G y <= h */ }
#ifndef GEARLOOP_ENGINE_CORRECTION_REWORK_QP_H_
#define GEARLOOP_ENGINE_CORRECTION_REWORK_QP_H_

#include <Eigen/Core>
#include <string>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"
#include "engine/correction/regularisation.h"

namespace gearloop {
namespace correction_internal {

// Convex QP  min 1/2 y'Hy - g'y  s.t.  G y <= h  (H positive definite), through
// its dual min 1/2 mu'Q mu - q'mu, mu >= 0 with Q = G H^-1 G', q = G H^-1 g -
// h, solved by the active-set method of Lawson and Hanson (NNLS, "Solving Least
// Squares Problems", 1974, ch. 23), which needs only Q and q; y = H^-1 (g - G'
// mu). False when H is not positive definite. `paired_from` >= 0: the rows of
// G from it on come in pairs (g, -g) (a bound on |g y|), and the solve of H's
// factor against G' is made for one row of each pair (the same numbers).
bool SolveConvexQp(const Eigen::MatrixXd& hessian,
                   const Eigen::VectorXd& g,
                   const Eigen::MatrixXd& constraints,
                   const Eigen::VectorXd& limits,
                   Eigen::VectorXd* y,
                   int paired_from = -1);

// The QP in z at a linearisation (S_k = jacobian_k, exact change change_k at
// z_k): minimise |W^1/2 (e + change_k + S_k T V_k (z - z_k))|^2 + lambda^2
// |z|^2 subject to the bounds on delta = T V_k z and, in rework mode, the
// linearised change <= 0 at every reached point. `motion_tv`, when given, is
// problem.motion_rows * subspace.tv made once by a caller that solves many
// QPs in one subspace (the same numbers as made here).
bool SolveLinearisedQp(const CorrectionProblem& problem,
                       const KeptSubspace& subspace,
                       const Eigen::MatrixXd& jacobian_k,
                       const Eigen::VectorXd& change_k,
                       const Eigen::VectorXd& z_k,
                       Eigen::VectorXd* z,
                       const Eigen::MatrixXd* motion_tv = nullptr);

// Rework mode: sequential QPs on the exact model, re-linearised at the current
// change until the predicted added material is within rework_tolerance_um (at
// most max_rework_passes). Updates z and delta; returns the passes made; a lost
// grid point or a failed QP goes to not_converged.
int RunReworkPasses(const CorrectionOptions& options,
                    const CorrectionProblem& problem,
                    const KeptSubspace& subspace,
                    Eigen::VectorXd* z,
                    Eigen::VectorXd* delta,
                    std::string* not_converged);

// The QP's tolerance on the motion bound's rows (|rows delta| <= 1).
constexpr double kMotionBoundTolerance = 1e-9;

// Whether T V_k z keeps every sampled axis motion within its bound
// (problem.motion_rows, to kMotionBoundTolerance); true without rows.
bool WithinMotionBound(const CorrectionProblem& problem,
                       const KeptSubspace& subspace,
                       const Eigen::VectorXd& z);

// The next part with the motion bound active at the linear answer: sequential
// QPs on the exact model (SolveLinearisedQp at the current change, its motion
// rows and bounds held exactly), each step halved, at most kBoundedHalvings
// times, until the exact cost |W^1/2 (e + d(p + T V_k z) - d(p))|^2 + |mu z|^2
// falls (a step losing a used point counts as no fall), at most
// options.max_num_iterations passes, stopping when a pass lowers the cost by
// less than kBoundedStopRelative of it. Ceres' Levenberg-Marquardt with the
// bound as a penalty rejected most of its steps on such problems (13 of 21 on
// the robustness benchmark's scenario 133) and stopped at its iteration cap.
// A start beyond the bound first takes the QP's answer whole (it is within
// the bound). Updates z and delta; returns the passes made; a failed QP goes
// to not_converged (delta stays the last accepted change).
//
// A pass that lowers the cost by less than `stop_share` of it is the last;
// `end_evaluation`, when given, gets the model at the end point (its
// deviations; the Jacobian only when the last pass kept its start).
constexpr double kBoundedStopRelative = 1e-4;
int RefineWithinMotionBound(const CorrectionOptions& options,
                            const CorrectionProblem& problem,
                            const KeptSubspace& subspace,
                            Eigen::VectorXd* z,
                            Eigen::VectorXd* delta,
                            std::string* not_converged,
                            double stop_share = kBoundedStopRelative,
                            ModelEvaluation* end_evaluation = nullptr);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_REWORK_QP_H_
