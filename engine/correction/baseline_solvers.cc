// The comparison solvers of the correction (baseline_solvers.h), kept as
// published.
#include "engine/correction/baseline_solvers.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "engine/core/units.h"

namespace gearloop {
namespace correction_internal {
namespace {

// The search box of each free coefficient: +-pso_box in the published units (mm
// and rad, except the wheel's cone angle in degrees), within the bounds.
void SwarmBox(const CorrectionOptions& options,
              const CorrectionProblem& problem,
              Eigen::VectorXd* box_lo,
              Eigen::VectorXd* box_hi) {
  const int nf = problem.NumFree();
  box_lo->resize(nf);
  box_hi->resize(nf);
  for (int c = 0; c < nf; ++c) {
    const int j = problem.free[c];
    bool is_cone = false;
    for (const ParameterBlock& b : problem.blocks) {
      if (b.name == "cone_angle" && j >= b.first_index &&
          j < b.first_index + b.num_coefficients)
        is_cone = true;
    }
    const double half = options.pso_box * (is_cone ? kPi / 180.0 : 1.0);
    (*box_lo)(c) = std::max(-half, problem.lower(j));
    (*box_hi)(c) = std::min(half, problem.upper(j));
  }
}

// The published stock-limited objective over the used points.
class StockLimitedObjective {
 public:
  explicit StockLimitedObjective(const CorrectionProblem& problem) {
    const std::vector<int>& used = problem.used;
    const int nf = problem.NumFree();
    s_used_.resize(used.size(), nf);
    wanted_.resize(used.size());
    sw_.resize(used.size());
    for (size_t r = 0; r < used.size(); ++r) {
      for (int c = 0; c < nf; ++c)
        s_used_(r, c) = problem.jacobian_um(used[r], problem.free[c]);
      wanted_(r) = -problem.error_um(used[r]);  // delta_i = t - m
      sw_(r) = problem.weights(used[r]);
    }
  }
  double operator()(const Eigen::VectorXd& x) const {
    const Eigen::VectorXd change = s_used_ * x;
    double f = 0.0;
    for (int r = 0; r < change.size(); ++r) {
      const double fi = change(r) < 0.0 ? change(r) - wanted_(r) : -wanted_(r);
      f += sw_(r) * fi * fi;
    }
    return f;
  }

 private:
  Eigen::MatrixXd s_used_;
  Eigen::VectorXd wanted_;
  Eigen::VectorXd sw_;
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

// The published parameters fix the swarm size, generations, inertia and c1, c2;
// the rest is the textbook global-best swarm: positions uniform in the box,
// velocities uniform in +-(box width), velocities clamped to the box width and
// positions to the box.
Eigen::VectorXd SolveParticleSwarm(const CorrectionOptions& options,
                                   const CorrectionProblem& problem) {
  const int nf = problem.NumFree();
  Eigen::VectorXd box_lo, box_hi;
  SwarmBox(options, problem, &box_lo, &box_hi);
  const StockLimitedObjective objective(problem);
  std::mt19937_64 rng(options.pso_seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int np_swarm = options.pso_particles;
  std::vector<Eigen::VectorXd> x(np_swarm), vel(np_swarm), best_x(np_swarm);
  std::vector<double> best_f(np_swarm);
  Eigen::VectorXd global_x;
  double global_f = kInf;
  const Eigen::VectorXd width = box_hi - box_lo;
  for (int k = 0; k < np_swarm; ++k) {
    x[k].resize(nf);
    vel[k].resize(nf);
    for (int c = 0; c < nf; ++c) {
      x[k](c) = box_lo(c) + width(c) * unit(rng);
      vel[k](c) = (2.0 * unit(rng) - 1.0) * width(c);
    }
    best_x[k] = x[k];
    best_f[k] = objective(x[k]);
    if (best_f[k] < global_f) {
      global_f = best_f[k];
      global_x = x[k];
    }
  }
  for (int gen = 0; gen < options.pso_generations; ++gen) {
    for (int k = 0; k < np_swarm; ++k) {
      for (int c = 0; c < nf; ++c) {
        vel[k](c) =
            options.pso_inertia * vel[k](c) +
            options.pso_cognitive * unit(rng) * (best_x[k](c) - x[k](c)) +
            options.pso_social * unit(rng) * (global_x(c) - x[k](c));
        vel[k](c) = std::clamp(vel[k](c), -width(c), width(c));
        x[k](c) = std::clamp(x[k](c) + vel[k](c), box_lo(c), box_hi(c));
      }
      const double f = objective(x[k]);
      if (f < best_f[k]) {
        best_f[k] = f;
        best_x[k] = x[k];
        if (f < global_f) {
          global_f = f;
          global_x = x[k];
        }
      }
    }
  }
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(problem.num_parameters);
  for (int c = 0; c < nf; ++c) delta(problem.free[c]) = global_x(c);
  return delta;
}

}  // namespace correction_internal
}  // namespace gearloop
