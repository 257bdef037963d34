// The constrained steps of the correction (rework_qp.h).
#include "engine/correction/rework_qp.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace gearloop {
namespace correction_internal {

namespace {

// The columns of R = L^-1 G' (SolveConvexQp) held once per pair: `solved`
// has R's first `single` columns, then the first column of each pair; the
// pair's second column is the first negated (to the bit: rounding is
// symmetric in sign, and so is every product taken with it below).
struct PairedColumns {
  const Eigen::MatrixXd& solved;
  int single;
  // The column of `solved` that holds R's column i, and its sign.
  int Held(int i) const { return i < single ? i : single + (i - single) / 2; }
  double Sign(int i) const {
    return i < single || (i - single) % 2 == 0 ? 1.0 : -1.0;
  }
};

// R v for a v that is zero off a few entries (the passive multipliers).
Eigen::VectorXd TimesSparse(const PairedColumns& r, const Eigen::VectorXd& v) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(r.solved.rows());
  for (int i = 0; i < v.size(); ++i)
    if (v(i) != 0.0) out += (r.Sign(i) * v(i)) * r.solved.col(r.Held(i));
  return out;
}

// The dual of SolveConvexQp, min 1/2 mu' Q mu - q' mu, mu >= 0 with Q = R' R,
// by the active-set method of Lawson and Hanson. Q is never formed: the
// dual's gradient needs R' (R mu), which only the passive columns of R enter,
// and the passive block Q_pp = R_p' R_p. R' (R mu) is made over the columns
// held once (PairedColumns), a pair's second entry the first's negated.
Eigen::VectorXd SolveDualNonNegative(const PairedColumns& r,
                                     const Eigen::VectorXd& q_vec) {
  const int single = r.single;
  const int pairs = static_cast<int>(r.solved.cols()) - single;
  const int m = static_cast<int>(q_vec.size());
  const double tol =
      1e-12 * std::max(1.0, r.solved.colwise().squaredNorm().maxCoeff());
  Eigen::VectorXd mu = Eigen::VectorXd::Zero(m);
  std::vector<bool> passive(m, false), refused(m, false);
  auto solve_passive = [&](Eigen::VectorXd* z) {
    std::vector<int> idx;
    for (int i = 0; i < m; ++i)
      if (passive[i]) idx.push_back(i);
    z->setZero(m);
    if (idx.empty()) return;
    Eigen::MatrixXd rp(r.solved.rows(), idx.size());
    Eigen::VectorXd rhs(idx.size());
    for (size_t a = 0; a < idx.size(); ++a) {
      rp.col(a) = r.Sign(idx[a]) * r.solved.col(r.Held(idx[a]));
      rhs(a) = q_vec(idx[a]);
    }
    const Eigen::MatrixXd qpp = rp.transpose() * rp;
    const Eigen::VectorXd zp = qpp.completeOrthogonalDecomposition().solve(rhs);
    for (size_t a = 0; a < idx.size(); ++a) (*z)(idx[a]) = zp(a);
  };
  for (int outer = 0; outer < 3 * m + 10; ++outer) {
    // Minus the gradient of the dual, q - Q mu.
    const Eigen::VectorXd q_mu_once = r.solved.transpose() * TimesSparse(r, mu);
    Eigen::VectorXd w(m);
    w.head(single) = q_vec.head(single) - q_mu_once.head(single);
    for (int p = 0; p < pairs; ++p) {
      w(single + 2 * p) = q_vec(single + 2 * p) - q_mu_once(single + p);
      w(single + 2 * p + 1) = q_vec(single + 2 * p + 1) + q_mu_once(single + p);
    }
    int best = -1;
    double best_w = tol;
    for (int i = 0; i < m; ++i) {
      if (!passive[i] && !refused[i] && w(i) > best_w) {
        best_w = w(i);
        best = i;
      }
    }
    if (best < 0) break;
    passive[best] = true;
    // Lawson and Hanson's guard: a multiplier that would enter with a
    // non-positive value (rounding, or a constraint nearly dependent on the
    // passive ones, as neighbouring samples of the motion bound are) is
    // refused until another enters, instead of entering and leaving again
    // until the iteration limit.
    Eigen::VectorXd z;
    solve_passive(&z);
    if (!(z(best) > 0.0)) {
      passive[best] = false;
      refused[best] = true;
      continue;
    }
    std::fill(refused.begin(), refused.end(), false);
    for (int inner = 0; inner < 3 * m + 10; ++inner) {
      if (inner > 0) solve_passive(&z);
      bool all_positive = true;
      for (int i = 0; i < m; ++i)
        if (passive[i] && z(i) <= 0.0) all_positive = false;
      if (all_positive) {
        mu = z;
        break;
      }
      double alpha = 1.0;
      for (int i = 0; i < m; ++i) {
        if (passive[i] && z(i) <= 0.0)
          alpha = std::min(alpha, mu(i) / (mu(i) - z(i)));
      }
      mu += alpha * (z - mu);
      for (int i = 0; i < m; ++i) {
        if (passive[i] && mu(i) <= 1e-15) {
          passive[i] = false;
          mu(i) = 0.0;
        }
      }
    }
  }
  return mu;
}

}  // namespace

bool SolveConvexQp(const Eigen::MatrixXd& hessian,
                   const Eigen::VectorXd& g,
                   const Eigen::MatrixXd& constraints,
                   const Eigen::VectorXd& limits,
                   Eigen::VectorXd* y,
                   int paired_from) {
  const Eigen::LLT<Eigen::MatrixXd> llt(hessian);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::VectorXd y_free = llt.solve(g);
  if (constraints.rows() == 0 ||
      ((constraints * y_free - limits).array() <= 0.0).all()) {
    *y = y_free;
    return true;
  }
  // With H = L L': Q = G H^-1 G' = R' R for R = L^-1 G' (k x m). A pair's
  // second column is the first's negated: L^-1 (-g) is -(L^-1 g) to the bit
  // (rounding is symmetric in sign), so the solve is made for the first only.
  const int m = static_cast<int>(constraints.rows());
  const int single =
      paired_from >= 0 && paired_from <= m && (m - paired_from) % 2 == 0
          ? paired_from
          : m;
  const int pairs = (m - single) / 2;
  Eigen::MatrixXd solved(constraints.cols(), single + pairs);
  solved.leftCols(single) = constraints.topRows(single).transpose();
  for (int p = 0; p < pairs; ++p)
    solved.col(single + p) = constraints.row(single + 2 * p).transpose();
  llt.matrixL().solveInPlace(solved);
  const PairedColumns r{solved, single};
  const Eigen::VectorXd mu =
      SolveDualNonNegative(r, constraints * y_free - limits);
  // y = y_free - H^-1 G' mu = y_free - L'^-1 (R mu).
  *y = y_free - llt.matrixU().solve(TimesSparse(r, mu));
  return true;
}

bool SolveLinearisedQp(const CorrectionProblem& problem,
                       const KeptSubspace& subspace,
                       const Eigen::MatrixXd& jacobian_k,
                       const Eigen::VectorXd& change_k,
                       const Eigen::VectorXd& z_k,
                       Eigen::VectorXd* z,
                       const Eigen::MatrixXd* motion_tv) {
  const std::vector<int>& used = problem.used;
  const int k = subspace.k;
  const Eigen::MatrixXd& tv = subspace.tv;
  const Eigen::MatrixXd stv = jacobian_k * tv;  // n x k
  Eigen::MatrixXd a(used.size(), k);
  Eigen::VectorXd b(used.size());
  for (size_t r = 0; r < used.size(); ++r) {
    const int i = used[r];
    const double sw = std::sqrt(problem.weights(i));
    a.row(r) = sw * stv.row(i);
    b(r) = -sw * (problem.error_um(i) + change_k(i) - stv.row(i).dot(z_k));
  }
  Eigen::MatrixXd hess = a.transpose() * a;
  hess.diagonal().array() += subspace.ridge + subspace.mu.array().square();
  const Eigen::VectorXd grad = a.transpose() * b;
  // The constraint rows G and limits h of G z <= h: rework's no added
  // material, the parameter bounds, then the motion bound -1 <= rows T V_k z
  // <= 1.
  const bool rework = problem.mode == CorrectionMode::kRework;
  int bounds = 0;
  for (int c = 0; c < problem.NumFree(); ++c) {
    const int j = problem.free[c];
    bounds += std::isfinite(problem.upper(j)) + std::isfinite(problem.lower(j));
  }
  Eigen::MatrixXd made_here;
  if (motion_tv == nullptr) made_here = problem.motion_rows * tv;
  const Eigen::MatrixXd& motion = motion_tv != nullptr ? *motion_tv : made_here;
  const int num_rows = (rework ? static_cast<int>(problem.reached.size()) : 0) +
                       bounds + 2 * static_cast<int>(motion.rows());
  Eigen::MatrixXd g_mat(num_rows, k);
  Eigen::VectorXd h_vec(num_rows);
  int row = 0;
  auto add = [&](const auto& constraint, double limit) {
    g_mat.row(row) = constraint;
    h_vec(row) = limit;
    ++row;
  };
  if (rework) {
    for (int i : problem.reached)
      add(stv.row(i), stv.row(i).dot(z_k) - change_k(i));
  }
  for (int c = 0; c < problem.NumFree(); ++c) {
    const int j = problem.free[c];
    if (std::isfinite(problem.upper(j))) add(tv.row(j), problem.upper(j));
    if (std::isfinite(problem.lower(j))) add(-tv.row(j), -problem.lower(j));
  }
  const int paired_from = row;
  for (int r = 0; r < motion.rows(); ++r) {
    add(motion.row(r), 1.0);
    add(-motion.row(r), 1.0);
  }
  return SolveConvexQp(hess, grad, g_mat, h_vec, z, paired_from);
}

int RunReworkPasses(const CorrectionOptions& options,
                    const CorrectionProblem& problem,
                    const KeptSubspace& subspace,
                    Eigen::VectorXd* z,
                    Eigen::VectorXd* delta,
                    std::string* not_converged) {
  int pass = 0;
  for (; pass < options.max_rework_passes; ++pass) {
    ModelEvaluation ev;
    problem.model->Evaluate(problem.parameters + *delta, true, &ev);
    Eigen::VectorXd change = Eigen::VectorXd::Zero(problem.num_points);
    double worst = 0.0;
    bool lost = false;
    for (int i : problem.reached) {
      if (ev.status[i] != PointStatus::kOk) {
        lost = true;
        continue;
      }
      change(i) = ev.deviations_um(i) - problem.d0()(i);
      worst = std::max(worst, change(i));
    }
    if (lost) {
      *not_converged =
          "a grid point leaves the wheel under the rework correction";
      break;
    }
    if (pass > 0 && worst <= options.rework_tolerance_um) break;
    Eigen::VectorXd z_new;
    if (!SolveLinearisedQp(
            problem, subspace, ev.jacobian_um, change, *z, &z_new)) {
      *not_converged = "the constrained linear problem failed";
      break;
    }
    *z = z_new;
    *delta = subspace.tv * *z;
  }
  return pass;
}

bool WithinMotionBound(const CorrectionProblem& problem,
                       const KeptSubspace& subspace,
                       const Eigen::VectorXd& z) {
  if (problem.motion_rows.rows() == 0) return true;
  return (problem.motion_rows * (subspace.tv * z)).cwiseAbs().maxCoeff() <=
         1.0 + kMotionBoundTolerance;
}

namespace {

constexpr int kBoundedHalvings = 4;
// Walking out from no change (the linear answer lost a point) the walk may
// halve further at every pass: a step whose linearisation is poor far out
// (the wheel parabola's vertex and coefficient enter as a product) can still
// fall near the start. Case: the guide's 37-tooth gear with a 10 um tip relief
// and the parabola freed, where 1/16 of the QP step was still worse and the
// answer a zero correction at 6.6 um (1/256: 0.72 um predicted, best reachable
// 0.77 um). Not for a step in orders 4-6: there a far-out poor linearisation is
// what the safe step guards against (robustness benchmark, every order open: 7
// -> 8 and 7 -> 10 rounds worse on seeds 2026 and 7 with it).
constexpr int kHalvingsFromNoChange = 8;

// The exact cost of the next part at z (infinity when a used point is lost);
// `evaluation` gets the model at p + T V_k z, with its Jacobian on request.
double ExactBoundedCost(const CorrectionProblem& problem,
                        const KeptSubspace& subspace,
                        const Eigen::VectorXd& z,
                        bool with_jacobian,
                        ModelEvaluation* evaluation) {
  problem.model->Evaluate(
      problem.parameters + subspace.tv * z, with_jacobian, evaluation);
  double cost = (subspace.mu.array() * z.array()).matrix().squaredNorm();
  for (int i : problem.used) {
    if (evaluation->status[i] != PointStatus::kOk) return kInf;
    const double r =
        problem.error_um(i) + evaluation->deviations_um(i) - problem.d0()(i);
    cost += problem.weights(i) * r * r;
  }
  return cost;
}

}  // namespace

int RefineWithinMotionBound(const CorrectionOptions& options,
                            const CorrectionProblem& problem,
                            const KeptSubspace& subspace,
                            Eigen::VectorXd* z,
                            Eigen::VectorXd* delta,
                            std::string* not_converged,
                            double stop_share,
                            ModelEvaluation* end_evaluation) {
  // The start is evaluated with its Jacobian once (Evaluate gives the same
  // deviations with and without it), for its cost and the first pass.
  ModelEvaluation at;
  double cost = ExactBoundedCost(problem, subspace, *z, true, &at);
  const bool linear_loses_a_point = !std::isfinite(cost);
  const bool from_no_change = linear_loses_a_point || z->isZero(0.0);
  if (linear_loses_a_point) {
    // The linear answer loses a point: walk out from no change instead.
    z->setZero();
    cost = ExactBoundedCost(problem, subspace, *z, true, &at);
  }
  // The motion rows in the subspace, once for every pass's QP.
  const Eigen::MatrixXd motion_tv = options.max_num_iterations > 0
                                        ? problem.motion_rows * subspace.tv
                                        : Eigen::MatrixXd();
  int pass = 0;
  bool settled = false;
  bool jacobian_at_z = true;
  for (; pass < options.max_num_iterations; ++pass) {
    // The Jacobian only where a pass starts (the trial points need none).
    if (!jacobian_at_z)
      problem.model->Evaluate(problem.parameters + subspace.tv * *z, true, &at);
    jacobian_at_z = false;
    Eigen::VectorXd change = Eigen::VectorXd::Zero(problem.num_points);
    for (int i : problem.used)
      change(i) = at.deviations_um(i) - problem.d0()(i);
    Eigen::VectorXd z_qp;
    if (!SolveLinearisedQp(
            problem, subspace, at.jacobian_um, change, *z, &z_qp, &motion_tv)) {
      *not_converged = "the constrained linear problem failed";
      break;
    }
    Eigen::VectorXd step = z_qp - *z;
    double trial_cost = kInf;
    ModelEvaluation trial;
    if (!WithinMotionBound(problem, subspace, *z)) {
      // A start beyond the bound (lower cost, not allowed): the QP's answer
      // is within it; take it whole if it keeps every point.
      trial_cost = ExactBoundedCost(problem, subspace, z_qp, false, &trial);
      if (!std::isfinite(trial_cost)) break;
      *z = z_qp;
      cost = trial_cost;
      std::swap(at, trial);
      continue;
    }
    const int halvings =
        from_no_change && !UsesOrdersAboveCubic(problem, subspace.tv * step)
            ? kHalvingsFromNoChange
            : kBoundedHalvings;
    for (int h = 0; h <= halvings; ++h, step *= 0.5) {
      trial_cost =
          ExactBoundedCost(problem, subspace, *z + step, false, &trial);
      if (trial_cost < cost) break;
    }
    if (!(trial_cost < cost)) {  // no fall along the QP step: settled
      settled = true;
      break;
    }
    const double fall = cost - trial_cost;
    *z += step;
    cost = trial_cost;
    std::swap(at, trial);  // `at` is the model at z (its Jacobian or not)
    if (fall < stop_share * cost) {
      ++pass;
      settled = true;
      break;
    }
  }
  if (!settled && pass == options.max_num_iterations && not_converged->empty())
    *not_converged = "the exact-model refinement reached max_num_iterations";
  if (linear_loses_a_point && z->isZero(0.0) && not_converged->empty()) {
    *not_converged =
        "the linear answer loses grid points on the exact model and no "
        "fraction of a step toward it (down to 1/" +
        std::to_string(1 << kHalvingsFromNoChange) +
        ") makes a better part: no change";
  }
  *delta = subspace.tv * *z;
  if (end_evaluation != nullptr) *end_evaluation = std::move(at);
  return pass;
}

}  // namespace correction_internal
}  // namespace gearloop
