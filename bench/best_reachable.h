// bench/best_reachable.h: the reference of the robustness benchmark (issue 13):
// the lowest flank error a correction can reach from the machine's TRUE state
// (commanded + hidden errors, which a solver never sees), on the exact model,
// over the same free coefficients as the solver and within the motion bounds of
// issue 13. Slow and careful: multi-start Levenberg-Marquardt.
//
//   ReachOptions options;
//   options.max_order = 3;  // as CorrectionOptions::default_max_order
//   const ReachResult best = BestReachable(
//       model, commanded + hidden, target_um, roll_min, roll_max,
//       /*extra_starts=*/{}, options);
//   // best.rms_um, best.delta (parameter change), best.starts[k] per start
//
// Unknowns: the orthonormal Legendre coordinates over the roll range of each
// polynomial block up to max_order (CorrectionCoordinates,
// engine/correction/correction.h: one unit = 1 um rms of axis motion for X, Y,
// Z, 1 um / r_j for A, B, C), and every scalar block (the wheel). The monomials
// up to max_order span the same space, so this is the solver's freedom.
//
// Objective: 1/2 sum over the points the wheel reaches on the true part of
// (d(true + dzeta) - t)^2, plus a hinge penalty rho max(0, |v| - 1) on every
// bounded quantity v (relative to its bound): the change dC(phi_s) of every
// polynomial block at 33 roll angles phi_s over the roll range (0.2 mm for a
// block in mm, 3e-3 rad for one in rad), the scalar blocks named in
// scalar_bounds and, on request (wheel_depth_mm > 0), the flat-wheel profile:
// its change -u dtheta_w + a_w (u - d_w)^2 - a_w0 (u - d_w0)^2 within 0.2 mm
// and its slope within 3e-3 rad at 9 depths u over [0, D]. rho = 1e3 um per
// unit of relative excess makes the bounds hard for every practical purpose.
// The wheel is unbounded by default, as it is for the solver (issue 13 bounds
// the axes).
//
// A trial step that loses one of the objective's points is refused (the
// damping grows), so the best is always on the same points as the part; a
// start that loses one is halved toward no change until it does not. Damping:
// Marquardt's diagonal scaling, floored at 1e-6 of the largest diagonal entry,
// with Nielsen's update; at most max_iterations per start.
//
// Starts: no change; the linearised least-squares step (SVD, directions that
// move the flank by >= 0.01 um rms per unit, and a wider one to 1e-4 of the
// largest singular value); the exact cancellation of the hidden errors
// projected on the free coordinates (the caller's start); the solver's own
// final settings (so the reference is never worse than what the solver reached
// within the bounds) and the reference of a smaller free set (callers'
// starts); random directions of the size of the least-squares step. The best
// end point wins.
#ifndef GEARLOOP_BENCH_BEST_REACHABLE_H_
#define GEARLOOP_BENCH_BEST_REACHABLE_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "engine/core/machine_model.h"
#include "engine/correction/correction.h"

namespace gearloop {
namespace bench {

struct ReachOptions {
  // Highest free order of every polynomial block (clamped to its degree).
  int max_order = 3;
  // Motion bounds anywhere over the roll range: blocks in mm and in rad.
  double linear_bound_mm = 0.2;
  double angular_bound_rad = 3e-3;
  // Bounds on scalar blocks by name [block unit]; blocks not named are
  // unbounded.
  std::map<std::string, double> scalar_bounds;
  // Blocks held at the state (not free in the reference), by name.
  std::vector<std::string> fixed_blocks;
  // Flat-wheel wheel profile (blocks "cone_angle", "parabola_coefficient",
  // "parabola_vertex"), when > 0: the working depth D [mm] of the wheel profile
  // over which its change is bounded like an axis (see the file comment).
  double wheel_depth_mm = 0.0;
  int random_starts = 3;
  int max_iterations = 300;
  std::uint64_t seed = 1;
};

struct ReachStart {
  std::string name;
  double rms_um =
      std::numeric_limits<double>::quiet_NaN();  // NaN: the start lost a point
  // At the start, after halving it toward no change so that it keeps every
  // point.
  double start_rms_um = std::numeric_limits<double>::quiet_NaN();
  int halvings = 0;
  int iterations = 0;
};

struct ReachResult {
  double rms_um =
      std::numeric_limits<double>::quiet_NaN();  // best over the starts
  double initial_rms_um = std::numeric_limits<double>::quiet_NaN();
  std::string best_start;
  Eigen::VectorXd delta;  // parameter change of the best end point
  int points = 0;         // points of the objective
  std::vector<ReachStart> starts;
  int evaluations = 0;
};

namespace internal {

class ReachProblem {
 public:
  ReachProblem(const MachineModel& model,
               const Eigen::VectorXd& state,
               const Eigen::VectorXd& target_um,
               double roll_min,
               double roll_max,
               const ReachOptions& options)
      : model_(model), state_(state), target_(target_um) {
    blocks_ = model.ParameterBlocks();
    const int n = model.NumParameters();
    std::vector<int> free;
    for (const ParameterBlock& b : blocks_) {
      if (std::find(options.fixed_blocks.begin(),
                    options.fixed_blocks.end(),
                    b.name) != options.fixed_blocks.end())
        continue;
      const int top = b.is_polynomial
                          ? std::min(options.max_order, b.num_coefficients - 1)
                          : b.num_coefficients - 1;
      for (int k = 0; k <= top; ++k) free.push_back(b.first_index + k);
    }
    free_ = free;
    basis_.resize(n, static_cast<int>(free.size()));
    for (size_t j = 0; j < free.size(); ++j) {
      Eigen::VectorXd unit = Eigen::VectorXd::Zero(n);
      unit(free[j]) = 1.0;
      basis_.col(static_cast<int>(j)) =
          DeltaFromCorrectionCoordinates(blocks_, unit, roll_min, roll_max);
    }
    // Motion rows: dC(phi_s) / bound for polynomial blocks, dp / bound for
    // bounded scalars.
    constexpr int kSamples = 33;
    std::vector<Eigen::RowVectorXd> rows;
    for (const ParameterBlock& b : blocks_) {
      if (b.is_polynomial) {
        const double bound = b.unit == "mm"    ? options.linear_bound_mm
                             : b.unit == "rad" ? options.angular_bound_rad
                                               : 0.0;
        if (bound <= 0.0) continue;
        for (int s = 0; s < kSamples; ++s) {
          const double phi =
              roll_min + (roll_max - roll_min) * s / (kSamples - 1.0);
          Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(n);
          double power = 1.0;
          for (int k = 0; k < b.num_coefficients; ++k, power *= phi)
            row(b.first_index + k) = power / bound;
          rows.push_back(row * basis_);
        }
      } else {
        const auto it = options.scalar_bounds.find(b.name);
        if (it == options.scalar_bounds.end() || !(it->second > 0.0)) continue;
        rows.push_back(basis_.row(b.first_index) / it->second);
      }
    }
    motion_.resize(static_cast<int>(rows.size()),
                   static_cast<int>(free.size()));
    for (size_t r = 0; r < rows.size(); ++r)
      motion_.row(static_cast<int>(r)) = rows[r];

    if (options.wheel_depth_mm > 0.0) {
      for (const ParameterBlock& b : blocks_) {
        if (b.name == "cone_angle") cone_ = b.first_index;
        if (b.name == "parabola_coefficient") parabola_ = b.first_index;
        if (b.name == "parabola_vertex") vertex_ = b.first_index;
      }
      if (cone_ >= 0 && parabola_ >= 0 && vertex_ >= 0) {
        constexpr int kDepthSamples = 9;
        for (int s = 0; s < kDepthSamples; ++s) {
          wheel_u_.push_back(options.wheel_depth_mm * s /
                             (kDepthSamples - 1.0));
        }
      }
      linear_bound_mm_ = options.linear_bound_mm;
      angular_bound_rad_ = options.angular_bound_rad;
    }
    ModelEvaluation eval;
    model.Evaluate(state, false, &eval);
    for (int i = 0; i < model.NumPoints(); ++i) {
      if (eval.status[i] == PointStatus::kOk && std::isfinite(target_um(i)))
        points_.push_back(i);
    }
  }

  int NumFree() const { return static_cast<int>(free_.size()); }
  int NumPoints() const { return static_cast<int>(points_.size()); }
  const Eigen::MatrixXd& basis() const { return basis_; }
  const std::vector<ParameterBlock>& blocks() const { return blocks_; }
  const std::vector<int>& free() const { return free_; }
  int evaluations() const { return evaluations_; }

  // Residuals (flank then penalty) and, when `jacobian` is non-null, their
  // Jacobian. False when a point of the objective is lost.
  bool Evaluate(const Eigen::VectorXd& y,
                Eigen::VectorXd* residuals,
                Eigen::MatrixXd* jacobian,
                double* flank_rms_um) {
    ++evaluations_;
    ModelEvaluation eval;
    model_.Evaluate(state_ + basis_ * y, jacobian != nullptr, &eval);
    const int m = NumPoints();
    const int p = static_cast<int>(motion_.rows());
    const int w = 2 * static_cast<int>(wheel_u_.size());
    residuals->resize(m + p + w);
    if (jacobian != nullptr) jacobian->setZero(m + p + w, NumFree());
    double sum = 0.0;
    for (int k = 0; k < m; ++k) {
      const int i = points_[k];
      if (eval.status[i] != PointStatus::kOk ||
          !std::isfinite(eval.deviations_um(i)))
        return false;
      (*residuals)(k) = eval.deviations_um(i) - target_(i);
      sum += (*residuals)(k) * (*residuals)(k);
      if (jacobian != nullptr)
        jacobian->row(k) = eval.jacobian_um.row(i) * basis_;
    }
    const Eigen::VectorXd v = motion_ * y;
    for (int r = 0; r < p; ++r) {
      const double excess = std::abs(v(r)) - 1.0;
      (*residuals)(m + r) = excess > 0.0 ? kPenalty * excess : 0.0;
      if (jacobian != nullptr && excess > 0.0) {
        jacobian->row(m + r) =
            kPenalty * (v(r) > 0.0 ? 1.0 : -1.0) * motion_.row(r);
      }
    }
    if (w > 0) {
      // The change of the wheel profile along its normal, -u dtheta +
      // a (u - d)^2 - a0 (u - d0)^2 [mm], and of its slope [rad], at depths u.
      const Eigen::VectorXd params = state_ + basis_ * y;
      const double dtheta = params(cone_) - state_(cone_);
      const double a = params(parabola_), d = params(vertex_);
      const double a0 = state_(parabola_), d0 = state_(vertex_);
      for (size_t s = 0; s < wheel_u_.size(); ++s) {
        const double u = wheel_u_[s];
        const double change =
            -u * dtheta + a * (u - d) * (u - d) - a0 * (u - d0) * (u - d0);
        const double slope = -dtheta + 2.0 * a * (u - d) - 2.0 * a0 * (u - d0);
        const double values[2] = {change / linear_bound_mm_,
                                  slope / angular_bound_rad_};
        // d value / d (theta, a, d).
        const double grads[2][3] = {{-u / linear_bound_mm_,
                                     (u - d) * (u - d) / linear_bound_mm_,
                                     -2.0 * a * (u - d) / linear_bound_mm_},
                                    {-1.0 / angular_bound_rad_,
                                     2.0 * (u - d) / angular_bound_rad_,
                                     -2.0 * a / angular_bound_rad_}};
        for (int q = 0; q < 2; ++q) {
          const int row = m + p + 2 * static_cast<int>(s) + q;
          const double excess = std::abs(values[q]) - 1.0;
          (*residuals)(row) = excess > 0.0 ? kPenalty * excess : 0.0;
          if (jacobian != nullptr && excess > 0.0) {
            const double sign = values[q] > 0.0 ? 1.0 : -1.0;
            jacobian->row(row) = kPenalty * sign *
                                 (grads[q][0] * basis_.row(cone_) +
                                  grads[q][1] * basis_.row(parabola_) +
                                  grads[q][2] * basis_.row(vertex_));
          }
        }
      }
    }
    *flank_rms_um = m > 0 ? std::sqrt(sum / m) : 0.0;
    return true;
  }

 private:
  static constexpr double kPenalty = 1e3;
  const MachineModel& model_;
  Eigen::VectorXd state_;
  Eigen::VectorXd target_;
  std::vector<ParameterBlock> blocks_;
  std::vector<int> free_;
  Eigen::MatrixXd basis_;   // parameters from free coordinates
  Eigen::MatrixXd motion_;  // relative motion rows
  int cone_ = -1, parabola_ = -1, vertex_ = -1;  // wheel parameter indices
  std::vector<double> wheel_u_;                  // depths of the wheel bound
  double linear_bound_mm_ = 0.2, angular_bound_rad_ = 3e-3;
  std::vector<int> points_;
  int evaluations_ = 0;
};

// Levenberg-Marquardt (Nielsen's damping update) from `y`; returns the flank
// rms at the end point and leaves the end point in `y`.
inline double Minimise(ReachProblem* problem,
                       int max_iterations,
                       Eigen::VectorXd* y,
                       ReachStart* record) {
  int* iterations = &record->iterations;
  Eigen::VectorXd r, r_trial, y_trial;
  Eigen::MatrixXd jacobian;
  double rms = 0.0, rms_trial = 0.0;
  *iterations = 0;
  // A start that loses a point is pulled toward no change (which keeps every
  // point) until it does not.
  int halvings = 0;
  while (!problem->Evaluate(*y, &r, &jacobian, &rms)) {
    if (++halvings > 40) return std::numeric_limits<double>::quiet_NaN();
    *y *= 0.5;
  }
  record->halvings = halvings;
  record->start_rms_um = rms;
  double cost = 0.5 * r.squaredNorm();
  double mu = -1.0, nu = 2.0;
  for (int it = 0; it < max_iterations; ++it) {
    *iterations = it + 1;
    const Eigen::MatrixXd h = jacobian.transpose() * jacobian;
    const Eigen::VectorXd g = jacobian.transpose() * r;
    if (mu < 0.0) mu = 1e-4;
    // Marquardt's scaling, floored at 1e-6 of the largest diagonal entry so
    // that directions that hardly move the flank still take a bounded step.
    const double floor = 1e-6 * std::max(h.diagonal().maxCoeff(), 1e-12);
    const Eigen::VectorXd scaling = h.diagonal().cwiseMax(floor);
    bool accepted = false;
    for (int inner = 0; inner < 30 && !accepted; ++inner) {
      Eigen::MatrixXd a = h;
      a.diagonal() += mu * scaling;
      const Eigen::VectorXd step = a.ldlt().solve(-g);
      if (!step.allFinite()) {
        mu *= nu;
        nu *= 2.0;
        continue;
      }
      y_trial = *y + step;
      if (!problem->Evaluate(y_trial, &r_trial, nullptr, &rms_trial)) {
        mu *= nu;
        nu *= 2.0;
        continue;
      }
      const double cost_trial = 0.5 * r_trial.squaredNorm();
      const double predicted = -(g.dot(step) + 0.5 * step.dot(h * step));
      if (cost_trial < cost && predicted > 0.0) {
        const double gain = (cost - cost_trial) / predicted;
        mu *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3));
        nu = 2.0;
        const double decrease = cost - cost_trial;
        const double step_norm = step.norm();
        *y = y_trial;
        problem->Evaluate(*y, &r, &jacobian, &rms);
        cost = 0.5 * r.squaredNorm();
        accepted = true;
        if (decrease <= 1e-12 * cost + 1e-18 ||
            step_norm <= 1e-10 * (y->norm() + 1e-6))
          return rms;
      } else {
        mu *= nu;
        nu *= 2.0;
      }
    }
    if (!accepted || mu > 1e20) break;
  }
  return rms;
}

}  // namespace internal

// The best reachable flank error from `true_state` (see the file comment).
// `extra_starts` are parameter changes (e.g. the solver's final settings minus
// the initial ones), projected on the free coordinates.
inline ReachResult BestReachable(
    const MachineModel& model,
    const Eigen::VectorXd& true_state,
    const Eigen::VectorXd& target_um,
    double roll_min,
    double roll_max,
    const std::vector<std::pair<std::string, Eigen::VectorXd>>& extra_starts,
    const ReachOptions& options) {
  ReachResult result;
  internal::ReachProblem problem(
      model, true_state, target_um, roll_min, roll_max, options);
  result.points = problem.NumPoints();
  const int n = problem.NumFree();
  if (problem.NumPoints() == 0) return result;

  std::vector<std::pair<std::string, Eigen::VectorXd>> starts;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  starts.push_back({"zero", zero});

  Eigen::VectorXd r0;
  Eigen::MatrixXd j0;
  double rms0 = 0.0;
  problem.Evaluate(zero, &r0, &j0, &rms0);
  result.initial_rms_um = rms0;
  const int m = problem.NumPoints();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(
      j0.topRows(m), Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd ub = svd.matrixU().transpose() * r0.head(m);
  const Eigen::VectorXd& sv = svd.singularValues();
  auto ls_step = [&](double threshold) {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < sv.size(); ++i) {
      if (sv(i) >= threshold && sv(i) > 0.0)
        y -= (ub(i) / sv(i)) * svd.matrixV().col(i);
    }
    return y;
  };
  const Eigen::VectorXd ls = ls_step(0.01 * std::sqrt(static_cast<double>(m)));
  starts.push_back({"least-squares", ls});
  if (sv.size() > 0)
    starts.push_back({"least-squares (wide)", ls_step(1e-4 * sv(0))});

  auto project = [&](const Eigen::VectorXd& delta) {
    const Eigen::VectorXd c =
        CorrectionCoordinates(problem.blocks(), delta, roll_min, roll_max);
    Eigen::VectorXd y(n);
    for (int j = 0; j < n; ++j) y(j) = c(problem.free()[j]);
    return y;
  };
  for (const auto& start : extra_starts)
    starts.push_back({start.first, project(start.second)});

  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.3, 1.0);
  const double scale = std::max(ls.norm(), 1.0);
  for (int k = 0; k < options.random_starts; ++k) {
    Eigen::VectorXd y(n);
    for (int j = 0; j < n; ++j) y(j) = gauss(rng);
    y *= scale * unit(rng) / y.norm();
    starts.push_back({"random " + std::to_string(k + 1), y});
  }

  Eigen::VectorXd best_y = zero;
  for (auto& start : starts) {
    ReachStart record;
    record.name = start.first;
    Eigen::VectorXd y = start.second;
    record.rms_um =
        internal::Minimise(&problem, options.max_iterations, &y, &record);
    if (std::isfinite(record.rms_um) && !(record.rms_um >= result.rms_um)) {
      result.rms_um = record.rms_um;
      result.best_start = record.name;
      best_y = y;
    }
    result.starts.push_back(record);
  }
  result.delta = problem.basis() * best_y;
  result.evaluations = problem.evaluations();
  return result;
}

}  // namespace bench
}  // namespace gearloop

#endif  // GEARLOOP_BENCH_BEST_REACHABLE_H_
