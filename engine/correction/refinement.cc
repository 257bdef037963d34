// Step 4 of the correction (refinement.h): Ceres on the exact model. The cost
// functor lives here, in the .cc, so that no header of the engine names a Ceres
// type.
#include "engine/correction/refinement.h"

#include <ceres/ceres.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <vector>

namespace gearloop {
namespace correction_internal {
namespace {

// The motion bound inside the refinement (issue 13): um of weighted flank
// residual per unit of relative motion beyond max_axis_motion_mm / _rad, large
// enough that the bound holds for every practical purpose (as the robustness
// benchmark's reference, bench/best_reachable.h), yet a penalty, so that a
// start outside the bound walks back into it instead of failing.
constexpr double kMotionPenalty = 1e3;

// ---------------------------------------------------------------------------------------------
// Ceres refinement on the exact model: parameters v, delta = P v, residuals
//   sqrt(w_i) (e_i + d_i(zeta_c + P v) - d0_i)  over the used points,  R v.
class ExactModelCost : public ceres::CostFunction {
 public:
  ExactModelCost(const MachineModel& model,
                 const Eigen::VectorXd& current,
                 const Eigen::VectorXd& d0,
                 const Eigen::VectorXd& error,
                 const Eigen::VectorXd& weights,
                 const std::vector<int>& used,
                 const Eigen::MatrixXd& p,
                 const Eigen::MatrixXd& regulariser,
                 const Eigen::MatrixXd& motion)
      : model_(model),
        current_(current),
        d0_(d0),
        error_(error),
        weights_(weights),
        used_(used),
        p_(p),
        regulariser_(regulariser),
        motion_(motion) {
    set_num_residuals(
        static_cast<int>(used.size() + regulariser.rows() + motion.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(p.cols()));
  }

  bool Evaluate(double const* const* parameters,
                double* residuals,
                double** jacobians) const override {
    const int nv = static_cast<int>(p_.cols());
    const Eigen::Map<const Eigen::VectorXd> v(parameters[0], nv);
    const Eigen::VectorXd zeta = current_ + p_ * v;
    ModelEvaluation eval;
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    model_.Evaluate(zeta, want_jacobian, &eval);
    const int nu = static_cast<int>(used_.size());
    for (int r = 0; r < nu; ++r) {
      const int i = used_[r];
      if (eval.status[i] != PointStatus::kOk)
        return false;  // leaves the wheel: reject the step
      const double sw = std::sqrt(weights_(i));
      residuals[r] = sw * (error_(i) + eval.deviations_um(i) - d0_(i));
    }
    const Eigen::VectorXd reg = regulariser_ * v;
    for (int r = 0; r < reg.size(); ++r) residuals[nu + r] = reg(r);
    // The motion bound: kMotionPenalty per unit of motion beyond the bound.
    const int nm = static_cast<int>(motion_.rows());
    const Eigen::VectorXd motion = motion_ * v;
    const int first_motion = nu + static_cast<int>(reg.size());
    for (int r = 0; r < nm; ++r) {
      const double excess = std::abs(motion(r)) - 1.0;
      residuals[first_motion + r] =
          excess > 0.0 ? kMotionPenalty * excess : 0.0;
    }
    if (want_jacobian) {
      Eigen::Map<
          Eigen::
              Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
          jac(jacobians[0], num_residuals(), nv);
      for (int r = 0; r < nu; ++r) {
        const int i = used_[r];
        jac.row(r) = std::sqrt(weights_(i)) * (eval.jacobian_um.row(i) * p_);
      }
      jac.middleRows(nu, regulariser_.rows()) = regulariser_;
      for (int r = 0; r < nm; ++r) {
        const double excess = std::abs(motion(r)) - 1.0;
        if (excess > 0.0) {
          jac.row(first_motion + r) =
              kMotionPenalty * (motion(r) > 0.0 ? 1.0 : -1.0) * motion_.row(r);
        } else {
          jac.row(first_motion + r).setZero();
        }
      }
    }
    return true;
  }

 private:
  const MachineModel& model_;
  const Eigen::VectorXd& current_;
  const Eigen::VectorXd& d0_;
  const Eigen::VectorXd& error_;
  const Eigen::VectorXd& weights_;
  const std::vector<int>& used_;
  Eigen::MatrixXd p_;
  Eigen::MatrixXd regulariser_;
  Eigen::MatrixXd motion_;  // axis motion at the samples / its bound, per v
};

// The variables of the refinement: delta = P v, the regulariser R v, and the
// start v.
struct RefinementVariables {
  Eigen::MatrixXd p;
  Eigen::MatrixXd reg;
  Eigen::MatrixXd motion;  // relative axis motion per v (rows: block, sample)
  Eigen::VectorXd v;
};

// Without bounds the variables are z (delta = T V_k z). With bounds they are
// the free monomial coefficients (box bounds), and leaving the subspace is
// penalised by sigma_1 |(I - V_k V_k') T_ff^-1 v|.
RefinementVariables ChooseVariables(const CorrectionProblem& problem,
                                    const KeptSubspace& s,
                                    const Eigen::VectorXd& z,
                                    const Eigen::VectorXd& delta) {
  const int np = problem.num_parameters, nf = problem.NumFree(), k = s.k;
  const std::vector<int>& free = problem.free;
  RefinementVariables x;
  if (problem.has_bounds) {
    x.p = Eigen::MatrixXd::Zero(np, nf);
    for (int c = 0; c < nf; ++c) x.p(free[c], c) = 1.0;
    const Eigen::MatrixXd t_inv = problem.t_free.inverse();
    x.reg.resize(nf + k, nf);
    x.reg.topRows(nf) =
        s.sigma1 *
        (Eigen::MatrixXd::Identity(nf, nf) - s.vk * s.vk.transpose()) * t_inv;
    x.reg.bottomRows(k) = s.mu.asDiagonal() * s.vk.transpose() * t_inv;
    x.v.resize(nf);
    for (int c = 0; c < nf; ++c)
      x.v(c) = std::clamp(
          delta(free[c]), problem.lower(free[c]), problem.upper(free[c]));
  } else {
    x.p = s.tv;
    x.reg = s.mu.asDiagonal();
    x.v = z;
  }
  x.motion = problem.motion_rows * x.p;
  return x;
}

// One Levenberg-Marquardt run of Ceres from *v.
void Refine(const CorrectionOptions& options,
            const CorrectionProblem& problem,
            const RefinementVariables& x,
            Eigen::VectorXd* v,
            ceres::Solver::Summary* ceres_summary) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres_problem.AddResidualBlock(new ExactModelCost(*problem.model,
                                                    problem.parameters,
                                                    problem.d0(),
                                                    problem.error_um,
                                                    problem.weights,
                                                    problem.used,
                                                    x.p,
                                                    x.reg,
                                                    x.motion),
                                 nullptr,
                                 v->data());
  if (problem.has_bounds) {
    for (int c = 0; c < problem.NumFree(); ++c) {
      const int j = problem.free[c];
      if (std::isfinite(problem.lower(j)))
        ceres_problem.SetParameterLowerBound(v->data(), c, problem.lower(j));
      if (std::isfinite(problem.upper(j)))
        ceres_problem.SetParameterUpperBound(v->data(), c, problem.upper(j));
    }
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.num_threads = 1;
  solver_options.function_tolerance = 1e-6;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-8;
  ceres::Solve(solver_options, &ceres_problem, ceres_summary);
}

// Ceres cannot start where the exact model loses a point: then start from no
// change (a valid point) and let the trust region find how far the linear step
// can be followed.
bool StartsOnTheFlank(const CorrectionProblem& problem,
                      const RefinementVariables& x) {
  ModelEvaluation ev;
  problem.model->Evaluate(problem.parameters + x.p * x.v, false, &ev);
  bool start_ok = true;
  for (int i : problem.used)
    start_ok = start_ok && ev.status[i] == PointStatus::kOk;
  return start_ok;
}

}  // namespace

void RefineOnExactModel(const CorrectionOptions& options,
                        const CorrectionProblem& problem,
                        const KeptSubspace& subspace,
                        const Eigen::VectorXd& z,
                        Eigen::VectorXd* delta,
                        CorrectionSummary* summary,
                        std::string* not_converged) {
  RefinementVariables x = ChooseVariables(problem, subspace, z, *delta);
  const bool from_zero = !StartsOnTheFlank(problem, x);
  if (from_zero) x.v.setZero();
  Eigen::VectorXd v = x.v;
  ceres::Solver::Summary ceres_summary;
  Refine(options, problem, x, &v, &ceres_summary);
  int iterations = static_cast<int>(ceres_summary.iterations.size()) - 1;
  if (ceres_summary.termination_type != ceres::CONVERGENCE && !from_zero) {
    // Far from the linear prediction (a strongly nonlinear direction), the
    // trust region may do better walking out from no change: try that too and
    // keep the lower cost.
    Eigen::VectorXd v_zero = Eigen::VectorXd::Zero(v.size());
    ceres::Solver::Summary zero_summary;
    Refine(options, problem, x, &v_zero, &zero_summary);
    iterations += static_cast<int>(zero_summary.iterations.size()) - 1;
    const bool zero_usable =
        zero_summary.termination_type == ceres::CONVERGENCE ||
        zero_summary.termination_type == ceres::NO_CONVERGENCE;
    const bool first_usable =
        ceres_summary.termination_type == ceres::NO_CONVERGENCE;
    if (zero_usable &&
        (!first_usable || zero_summary.final_cost < ceres_summary.final_cost)) {
      v = v_zero;
      ceres_summary = zero_summary;
    }
  }
  summary->refinement_initial_cost = ceres_summary.initial_cost;
  summary->refinement_final_cost = ceres_summary.final_cost;
  summary->iterations = iterations;
  if (ceres_summary.termination_type == ceres::CONVERGENCE) {
    *delta = x.p * v;
  } else if (ceres_summary.termination_type == ceres::NO_CONVERGENCE) {
    *delta = x.p * v;
    *not_converged = "the exact-model refinement reached max_num_iterations";
  } else {
    *delta = x.p * x.v;
    *not_converged = "the exact-model refinement failed (" +
                     ceres_summary.message +
                     "); the linear correction is reported";
  }
}

}  // namespace correction_internal
}  // namespace gearloop
