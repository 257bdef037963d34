// The comparison solvers of the correction (baseline_solvers.h): "lsq-plain"
// and "pso", the published particle swarm as a competent reader of the paper
// runs it (MODEL.md §6).
#include "engine/correction/baseline_solvers.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace gearloop {
namespace correction_internal {
namespace {

// The search box of each free coefficient: +-pso_box in the coefficient's own
// unit (mm, rad or 1/mm: the published box; the paper's cone angle moves 0.6
// deg, so its box was not in degrees either), within the bounds.
void SwarmBox(const CorrectionOptions& options,
              const CorrectionProblem& problem,
              Eigen::VectorXd* box_lo,
              Eigen::VectorXd* box_hi) {
  const int nf = problem.NumFree();
  box_lo->resize(nf);
  box_hi->resize(nf);
  for (int c = 0; c < nf; ++c) {
    const int j = problem.free[c];
    (*box_lo)(c) = std::max(-options.pso_box, problem.lower(j));
    (*box_hi)(c) = std::min(options.pso_box, problem.upper(j));
  }
}

// The swarm's objective, on the model linearised at the current parameters
// over the used points, with the point weights w_i and delta = t - m (um):
// next part, sum_i w_i (S_i dzeta - delta_i)^2 (the new part is ground from a
// blank with stock, every point is in contact); rework (the paper's one-sided
// form), f_i = S_i dzeta - delta_i where S_i dzeta < 0 (the wheel reaches point
// i) and f_i = -delta_i elsewhere.
class SwarmObjective {
 public:
  explicit SwarmObjective(const CorrectionProblem& problem)
      : one_sided_(problem.mode == CorrectionMode::kRework) {
    const std::vector<int>& used = problem.used;
    const int nf = problem.NumFree();
    a_.resize(used.size(), nf);
    b_.resize(used.size());
    for (size_t r = 0; r < used.size(); ++r) {
      const double sw = std::sqrt(problem.weights(used[r]));
      for (int c = 0; c < nf; ++c)
        a_(r, c) = sw * problem.jacobian_um(used[r], problem.free[c]);
      b_(r) = -sw * problem.error_um(used[r]);  // sqrt(w_i) delta_i
    }
  }
  double operator()(const Eigen::VectorXd& x) const {
    change_.noalias() = a_ * x;
    if (!one_sided_) return (change_ - b_).squaredNorm();
    double f = 0.0;
    for (int r = 0; r < change_.size(); ++r) {
      const double fi = change_(r) < 0.0 ? change_(r) - b_(r) : -b_(r);
      f += fi * fi;
    }
    return f;
  }

 private:
  bool one_sided_;
  Eigen::MatrixXd a_;  // W^1/2 S over the used points and free coefficients
  Eigen::VectorXd b_;  // W^1/2 delta
  mutable Eigen::VectorXd change_;
};

// The velocity clamp, a fraction of the box width (MODEL.md §6).
constexpr double kVelocityFractionOfBox = 0.2;

// One particle of the swarm: position, velocity and its own best.
struct Particle {
  Eigen::VectorXd x, v, best_x;
  double best_f = 0.0;
};

}  // namespace

Eigen::VectorXd SolvePlainLeastSquares(const CorrectionProblem& problem) {
  const std::vector<int>& used = problem.used;
  const int nf = problem.NumFree();
  Eigen::MatrixXd a(used.size(), nf);
  Eigen::VectorXd b(used.size());
  for (size_t r = 0; r < used.size(); ++r) {
    const double sw = std::sqrt(problem.weights(used[r]));
    for (int c = 0; c < nf; ++c)
      a(r, c) = sw * problem.jacobian_um(used[r], problem.free[c]);
    b(r) = -sw * problem.error_um(used[r]);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(
      a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd x = svd.solve(b);
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(problem.num_parameters);
  for (int c = 0; c < nf; ++c) {
    const int j = problem.free[c];
    delta(j) = std::clamp(x(c), problem.lower(j), problem.upper(j));
  }
  return delta;
}

// The global-best swarm (Kennedy and Eberhart 1995 with the inertia weight of
// Shi and Eberhart 1998), the published size, generations and coefficients:
// v <- w v + c1 r1 (p - x) + c2 r2 (g - x), r1 and r2 drawn per particle and
// coordinate, v clamped to +-0.2 of the box width, x clipped to the box with
// the velocity of a clipped coordinate zeroed. Particle 0 starts at no change,
// the others uniformly in the box, all at rest. The global best is updated
// after each particle (asynchronously).
Eigen::VectorXd SolveParticleSwarm(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   SwarmTrace* trace) {
  const int nf = problem.NumFree();
  Eigen::VectorXd lo, hi;
  SwarmBox(options, problem, &lo, &hi);
  const Eigen::VectorXd v_max = kVelocityFractionOfBox * (hi - lo);
  const SwarmObjective objective(problem);
  std::mt19937_64 rng(options.pso_seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Particle> swarm(options.pso_particles);
  Eigen::VectorXd global_x = Eigen::VectorXd::Zero(nf);
  double global_f = objective(global_x);
  for (size_t k = 0; k < swarm.size(); ++k) {
    Particle& p = swarm[k];
    p.x = Eigen::VectorXd::Zero(nf);
    if (k > 0) {
      for (int c = 0; c < nf; ++c) p.x(c) = lo(c) + (hi(c) - lo(c)) * unit(rng);
    }
    p.v = Eigen::VectorXd::Zero(nf);
    p.best_x = p.x;
    p.best_f = objective(p.x);
    if (p.best_f < global_f) {
      global_f = p.best_f;
      global_x = p.x;
    }
  }
  if (trace != nullptr) trace->best_objective.assign(1, global_f);
  for (int gen = 0; gen < options.pso_generations; ++gen) {
    for (Particle& p : swarm) {
      for (int c = 0; c < nf; ++c) {
        double v = options.pso_inertia * p.v(c) +
                   options.pso_cognitive * unit(rng) * (p.best_x(c) - p.x(c)) +
                   options.pso_social * unit(rng) * (global_x(c) - p.x(c));
        v = std::clamp(v, -v_max(c), v_max(c));
        double x = p.x(c) + v;
        if (x < lo(c) || x > hi(c)) {
          x = std::clamp(x, lo(c), hi(c));
          v = 0.0;
        }
        p.x(c) = x;
        p.v(c) = v;
      }
      const double f = objective(p.x);
      if (f < p.best_f) {
        p.best_f = f;
        p.best_x = p.x;
        if (f < global_f) {
          global_f = f;
          global_x = p.x;
        }
      }
    }
    if (trace != nullptr) trace->best_objective.push_back(global_f);
  }
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(problem.num_parameters);
  for (int c = 0; c < nf; ++c) delta(problem.free[c]) = global_x(c);
  return delta;
}

}  // namespace correction_internal
}  // namespace gearloop
