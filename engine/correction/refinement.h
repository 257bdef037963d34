// engine/correction/refinement.h (internal): step 4 of the correction
// (correction.h): the linear change refined by Ceres (Levenberg-Marquardt) on
// the exact nonlinear model, in the kept subspace with the same lambda^2 |z|^2
// term, within the bounds. Ceres stays in refinement.cc (the cost functor
// ExactModelCost and the solver options); this header names no Ceres type.
//
//   RefineOnExactModel(options, problem, subspace, z, &delta, &summary,
//   &not_converged);
#ifndef GEARLOOP_ENGINE_CORRECTION_REFINEMENT_H_
#define GEARLOOP_ENGINE_CORRECTION_REFINEMENT_H_

#include <Eigen/Core>
#include <string>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"
#include "engine/correction/regularisation.h"

namespace gearloop {
namespace correction_internal {

// Refines *delta (= T V_k z, the linear answer, clamped to the bounds) on the
// exact model. Without bounds the variables are z; with bounds the free
// monomial coefficients, leaving the subspace penalised by sigma_1 |(I - V_k
// V_k') T_ff^-1 v|. Starts from no change where the exact model loses a used
// point at the linear answer, and once more from no change when the first run
// does not converge (keeping the lower cost). Reports the Ceres costs and
// iterations in `summary`; a refinement that does not converge or fails goes to
// `not_converged` (on failure *delta stays the linear answer).
void RefineOnExactModel(const CorrectionOptions& options,
                        const CorrectionProblem& problem,
                        const KeptSubspace& subspace,
                        const Eigen::VectorXd& z,
                        Eigen::VectorXd* delta,
                        CorrectionSummary* summary,
                        std::string* not_converged);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_REFINEMENT_H_
