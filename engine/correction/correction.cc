#include "engine/correction/correction.h"
#include "engine/core/units.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <ceres/ceres.h>

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// Orthonormal Legendre coordinates of one polynomial block.

// Column k: the monomial coefficients (in phi) of sqrt(2k+1) P_k((phi - c) / h), n x n, upper
// triangular. Mean over [c - h, c + h] of the square of sum_k y_k column_k(phi) is |y|^2.
Eigen::MatrixXd LegendreToMonomial(int n, double roll_min_rad, double roll_max_rad) {
  double c = 0.5 * (roll_min_rad + roll_max_rad);
  double h = 0.5 * (roll_max_rad - roll_min_rad);
  if (!(h > 0.0)) {  // no roll range known: fall back to [-1, 1]
    c = 0.0;
    h = 1.0;
  }
  // Legendre polynomials in s as monomial coefficients in s: p(k, j) multiplies s^j.
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(n, n);
  p(0, 0) = 1.0;
  if (n > 1) p(1, 1) = 1.0;
  for (int k = 1; k + 1 < n; ++k) {
    for (int j = 0; j < n; ++j) {
      double v = -k * p(k - 1, j);
      if (j > 0) v += (2 * k + 1) * p(k, j - 1);
      p(k + 1, j) = v / (k + 1);
    }
  }
  // s^j = ((phi - c) / h)^j = sum_i binom(j, i) phi^i (-c)^(j-i) / h^j.
  Eigen::MatrixXd s_to_phi = Eigen::MatrixXd::Zero(n, n);  // (i, j): coefficient of phi^i in s^j
  for (int j = 0; j < n; ++j) {
    double binom = 1.0;
    for (int i = 0; i <= j; ++i) {
      if (i > 0) binom = binom * (j - i + 1) / i;
      s_to_phi(i, j) = binom * std::pow(-c, j - i) / std::pow(h, j);
    }
  }
  Eigen::MatrixXd l(n, n);
  for (int k = 0; k < n; ++k) {
    l.col(k) = std::sqrt(2.0 * k + 1.0) * (s_to_phi * p.row(k).transpose());
  }
  return l;
}

double BlockScale(const ParameterBlock& block, const std::map<std::string, double>& scales) {
  const auto it = scales.find(block.name);
  return it != scales.end() ? it->second : block.default_scale;
}

// The linear map coordinates -> delta for all coefficients of all blocks (square, block diagonal).
Eigen::MatrixXd CoordinateMap(const std::vector<ParameterBlock>& blocks,
                              int num_parameters,
                              double roll_min_rad,
                              double roll_max_rad,
                              const std::map<std::string, double>& scales) {
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(num_parameters, num_parameters);
  for (const ParameterBlock& b : blocks) {
    const double s = BlockScale(b, scales);
    if (b.is_polynomial) {
      t.block(b.first_index, b.first_index, b.num_coefficients, b.num_coefficients) =
          s * LegendreToMonomial(b.num_coefficients, roll_min_rad, roll_max_rad);
    } else {
      for (int k = 0; k < b.num_coefficients; ++k) t(b.first_index + k, b.first_index + k) = s;
    }
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Singular value decomposition of the scaled, weighted S.

struct Svd {
  Eigen::MatrixXd u;        // n x p
  Eigen::VectorXd sigma;    // p, descending
  Eigen::MatrixXd v;        // q x p
  int rank = 0;
};

// Thin SVD of A; the numerical rank counts singular values >= rank_threshold (and > 0).
Svd ComputeSvd(const Eigen::MatrixXd& a, double rank_threshold) {
  Svd s;
  if (a.rows() == 0 || a.cols() == 0) return s;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  s.u = svd.matrixU();
  s.sigma = svd.singularValues();
  s.v = svd.matrixV();
  for (int i = 0; i < s.sigma.size(); ++i) {
    if (s.sigma(i) >= rank_threshold && s.sigma(i) > 0.0) ++s.rank;
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// Convex QP  min 1/2 y'Hy - g'y  s.t.  G y <= h  (H positive definite), through its dual
// min 1/2 mu'Q mu - q'mu, mu >= 0 with Q = G H^-1 G', q = G H^-1 g - h, solved by the active-set
// method of Lawson and Hanson (NNLS, "Solving Least Squares Problems", 1974, ch. 23), which needs
// only Q and q. y = H^-1 (g - G' mu).
bool SolveConvexQp(const Eigen::MatrixXd& hessian,
                   const Eigen::VectorXd& g,
                   const Eigen::MatrixXd& constraints,
                   const Eigen::VectorXd& limits,
                   Eigen::VectorXd* y) {
  const Eigen::LLT<Eigen::MatrixXd> llt(hessian);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::VectorXd y_free = llt.solve(g);
  const int m = static_cast<int>(constraints.rows());
  if (m == 0 || ((constraints * y_free - limits).array() <= 0.0).all()) {
    *y = y_free;
    return true;
  }
  const Eigen::MatrixXd hinv_gt = llt.solve(constraints.transpose());
  const Eigen::MatrixXd q_mat = constraints * hinv_gt;
  const Eigen::VectorXd q_vec = constraints * y_free - limits;
  const double tol = 1e-12 * std::max(1.0, q_mat.diagonal().cwiseAbs().maxCoeff());

  Eigen::VectorXd mu = Eigen::VectorXd::Zero(m);
  std::vector<bool> passive(m, false);
  auto solve_passive = [&](Eigen::VectorXd* z) {
    std::vector<int> idx;
    for (int i = 0; i < m; ++i) if (passive[i]) idx.push_back(i);
    z->setZero(m);
    if (idx.empty()) return;
    Eigen::MatrixXd qpp(idx.size(), idx.size());
    Eigen::VectorXd rhs(idx.size());
    for (size_t a = 0; a < idx.size(); ++a) {
      rhs(a) = q_vec(idx[a]);
      for (size_t b = 0; b < idx.size(); ++b) qpp(a, b) = q_mat(idx[a], idx[b]);
    }
    const Eigen::VectorXd zp = qpp.completeOrthogonalDecomposition().solve(rhs);
    for (size_t a = 0; a < idx.size(); ++a) (*z)(idx[a]) = zp(a);
  };
  for (int outer = 0; outer < 3 * m + 10; ++outer) {
    const Eigen::VectorXd w = q_vec - q_mat * mu;  // minus the gradient of the dual
    int best = -1;
    double best_w = tol;
    for (int i = 0; i < m; ++i) {
      if (!passive[i] && w(i) > best_w) {
        best_w = w(i);
        best = i;
      }
    }
    if (best < 0) break;
    passive[best] = true;
    for (int inner = 0; inner < 3 * m + 10; ++inner) {
      Eigen::VectorXd z;
      solve_passive(&z);
      bool all_positive = true;
      for (int i = 0; i < m; ++i) if (passive[i] && z(i) <= 0.0) all_positive = false;
      if (all_positive) {
        mu = z;
        break;
      }
      double alpha = 1.0;
      for (int i = 0; i < m; ++i) {
        if (passive[i] && z(i) <= 0.0) alpha = std::min(alpha, mu(i) / (mu(i) - z(i)));
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
  *y = y_free - hinv_gt * mu;
  return true;
}

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
                 const Eigen::MatrixXd& regulariser)
      : model_(model), current_(current), d0_(d0), error_(error), weights_(weights), used_(used), p_(p),
        regulariser_(regulariser) {
    set_num_residuals(static_cast<int>(used.size() + regulariser.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(p.cols()));
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int nv = static_cast<int>(p_.cols());
    const Eigen::Map<const Eigen::VectorXd> v(parameters[0], nv);
    const Eigen::VectorXd zeta = current_ + p_ * v;
    ModelEvaluation eval;
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    model_.Evaluate(zeta, want_jacobian, &eval);
    const int nu = static_cast<int>(used_.size());
    for (int r = 0; r < nu; ++r) {
      const int i = used_[r];
      if (eval.status[i] != PointStatus::kOk) return false;  // leaves the wheel: reject the step
      const double sw = std::sqrt(weights_(i));
      residuals[r] = sw * (error_(i) + eval.deviations_um(i) - d0_(i));
    }
    const Eigen::VectorXd reg = regulariser_ * v;
    for (int r = 0; r < reg.size(); ++r) residuals[nu + r] = reg(r);
    if (want_jacobian) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
          jacobians[0], num_residuals(), nv);
      for (int r = 0; r < nu; ++r) {
        const int i = used_[r];
        jac.row(r) = std::sqrt(weights_(i)) * (eval.jacobian_um.row(i) * p_);
      }
      jac.bottomRows(regulariser_.rows()) = regulariser_;
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
};

double Rms(const Eigen::VectorXd& r, const std::vector<int>& idx) {
  if (idx.empty()) return 0.0;
  double s = 0.0;
  for (int i : idx) s += r(i) * r(i);
  return std::sqrt(s / idx.size());
}

double MaxAbs(const Eigen::VectorXd& r, const std::vector<int>& idx) {
  double m = 0.0;
  for (int i : idx) m = std::max(m, std::abs(r(i)));
  return m;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t n = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + n, v.end());
  double m = v[n];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + n));
  }
  return m;
}

// Everything one regularised linear solve produces.
struct LinearSolve {
  Svd svd;
  Eigen::VectorXd beta;       // U' b
  int k = 0;                  // directions eligible (the numerical rank)
  double lambda = 0.0;        // Tikhonov level
  double dof = 0.0;           // sum of the filter factors
  Eigen::VectorXd y;          // free coordinates
  Eigen::VectorXd residual;   // weighted residual A y - b over the used rows
  Eigen::VectorXd best;       // weighted residual off the range over the used rows
};

}  // namespace

// -----------------------------------------------------------------------------------------------

const char* CorrectionSolverName(CorrectionSolver solver) {
  switch (solver) {
    case CorrectionSolver::kRegularised: return "regularised";
    case CorrectionSolver::kParticleSwarm: return "pso";
    case CorrectionSolver::kPlainLeastSquares: return "lsq-plain";
  }
  return "unknown";
}

bool ParseCorrectionSolver(const std::string& name, CorrectionSolver* solver) {
  for (CorrectionSolver s : {CorrectionSolver::kRegularised, CorrectionSolver::kParticleSwarm,
                             CorrectionSolver::kPlainLeastSquares}) {
    if (name == CorrectionSolverName(s)) {
      *solver = s;
      return true;
    }
  }
  return false;
}

const char* CorrectionModeName(CorrectionMode mode) {
  return mode == CorrectionMode::kRework ? "rework" : "next-part";
}

bool ParseCorrectionMode(const std::string& name, CorrectionMode* mode) {
  if (name == "next-part") {
    *mode = CorrectionMode::kNextPart;
    return true;
  }
  if (name == "rework") {
    *mode = CorrectionMode::kRework;
    return true;
  }
  return false;
}

const char* RegularisationRuleName(RegularisationRule rule) {
  switch (rule) {
    case RegularisationRule::kUnbiasedPredictiveRisk: return "upre";
    case RegularisationRule::kDiscrepancyPrinciple: return "discrepancy-principle";
    case RegularisationRule::kGeneralisedCrossValidation: return "gcv";
    case RegularisationRule::kNone: return "none";
  }
  return "unknown";
}

const char* CorrectionStatusName(CorrectionStatus status) {
  switch (status) {
    case CorrectionStatus::kConverged: return "converged";
    case CorrectionStatus::kNotConverged: return "not_converged";
    case CorrectionStatus::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

bool CorrectionOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (default_max_order < -1) return fail("default_max_order must be -1 (fixed) or an order >= 0");
  for (const auto& [name, order] : max_order) {
    if (order < -1) return fail("max_order[" + name + "] must be -1 (fixed) or an order >= 0");
  }
  if (point_weights.size() > 0 && !((point_weights.array() >= 0.0).all() && point_weights.allFinite())) {
    return fail("point_weights must be finite and >= 0");
  }
  if (lower_delta.size() != upper_delta.size()) return fail("lower_delta and upper_delta must have the same size");
  for (int j = 0; j < lower_delta.size(); ++j) {
    if (std::isnan(lower_delta(j)) || std::isnan(upper_delta(j)) || lower_delta(j) > 0.0 || upper_delta(j) < 0.0) {
      return fail("bounds on the change of parameter " + std::to_string(j) + " must satisfy lower <= 0 <= upper");
    }
  }
  if (!std::isfinite(probe_noise_um)) return fail("probe_noise_um must be finite (negative = unknown)");
  for (const auto& [name, scale] : block_scales) {
    if (!(scale > 0.0) || !std::isfinite(scale)) return fail("block_scales[" + name + "] must be > 0");
  }
  if (!(min_relative_regularisation >= 0.0 && min_relative_regularisation < 1.0)) {
    return fail("min_relative_regularisation must lie in [0, 1)");
  }
  if (!(min_flank_effect_um > 0.0) || !std::isfinite(min_flank_effect_um)) {
    return fail("min_flank_effect_um must be finite and > 0");
  }
  if (max_num_iterations < 0) return fail("max_num_iterations must be >= 0");
  if (max_rework_passes < 1) return fail("max_rework_passes must be >= 1");
  if (!(rework_tolerance_um >= 0.0)) return fail("rework_tolerance_um must be >= 0");
  if (!(outlier_threshold >= 0.0) || !(outlier_min_um >= 0.0)) return fail("outlier settings must be >= 0");
  if (!(max_outlier_fraction >= 0.0 && max_outlier_fraction < 1.0)) return fail("max_outlier_fraction must lie in [0, 1)");
  if (pso_particles < 1 || pso_generations < 1) return fail("pso_particles and pso_generations must be >= 1");
  if (!(pso_box > 0.0) || !(pso_inertia >= 0.0) || !(pso_cognitive >= 0.0) || !(pso_social >= 0.0)) {
    return fail("pso_box must be > 0 and the swarm coefficients >= 0");
  }
  return true;
}

std::string CorrectionSummary::BriefReport() const {
  std::ostringstream out;
  out << "correction " << CorrectionSolverName(solver) << " (" << CorrectionModeName(mode)
      << "): " << CorrectionStatusName(status);
  if (!message.empty()) out << " (" << message << ")";
  if (IsSolutionUsable()) {
    out << ", rms " << initial_rms_um << " -> " << residual_rms_um << " um (best reachable "
        << best_reachable_rms_um << "), max " << residual_max_um << " um, size " << correction_size
        << ", rank " << rank << ", cond " << condition_number << ", " << RegularisationRuleName(rule)
        << " lambda " << regularisation_level << " dof " << effective_dof << ", " << iterations
        << " iterations, " << elapsed_ms << " ms";
    if (!outlier_indices.empty()) out << ", " << outlier_indices.size() << " outlier(s)";
  }
  return out.str();
}

// -----------------------------------------------------------------------------------------------

Eigen::VectorXd DeltaFromCorrectionCoordinates(const std::vector<ParameterBlock>& blocks,
                                               const Eigen::VectorXd& coordinates,
                                               double roll_min_rad,
                                               double roll_max_rad,
                                               const std::map<std::string, double>& block_scales) {
  return CoordinateMap(blocks, static_cast<int>(coordinates.size()), roll_min_rad, roll_max_rad, block_scales) *
         coordinates;
}

Eigen::VectorXd CorrectionCoordinates(const std::vector<ParameterBlock>& blocks,
                                      const Eigen::VectorXd& delta,
                                      double roll_min_rad,
                                      double roll_max_rad,
                                      const std::map<std::string, double>& block_scales) {
  const Eigen::MatrixXd t =
      CoordinateMap(blocks, static_cast<int>(delta.size()), roll_min_rad, roll_max_rad, block_scales);
  // Block diagonal and each block upper triangular: a triangular solve per block is exact.
  Eigen::VectorXd y = Eigen::VectorXd::Zero(delta.size());
  for (const ParameterBlock& b : blocks) {
    const int f = b.first_index, n = b.num_coefficients;
    y.segment(f, n) = t.block(f, f, n, n).triangularView<Eigen::Upper>().solve(delta.segment(f, n));
  }
  return y;
}

double CorrectionSize(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& delta,
                      double roll_min_rad,
                      double roll_max_rad,
                      const std::map<std::string, double>& block_scales,
                      std::vector<BlockCorrectionSize>* block_sizes) {
  const Eigen::VectorXd y = CorrectionCoordinates(blocks, delta, roll_min_rad, roll_max_rad, block_scales);
  if (block_sizes != nullptr) block_sizes->clear();
  double total2 = 0.0;
  for (const ParameterBlock& b : blocks) {
    const double s2 = y.segment(b.first_index, b.num_coefficients).squaredNorm();
    total2 += s2;
    if (block_sizes != nullptr) block_sizes->push_back({b.name, std::sqrt(s2)});
  }
  return std::sqrt(total2);
}

Eigen::VectorXd AverageTeeth(const std::vector<Eigen::VectorXd>& teeth_um, Eigen::VectorXi* counts) {
  const int n = teeth_um.empty() ? 0 : static_cast<int>(teeth_um.front().size());
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(n);
  Eigen::VectorXi count = Eigen::VectorXi::Zero(n);
  for (const Eigen::VectorXd& tooth : teeth_um) {
    for (int i = 0; i < n && i < tooth.size(); ++i) {
      if (std::isfinite(tooth(i))) {
        sum(i) += tooth(i);
        ++count(i);
      }
    }
  }
  Eigen::VectorXd mean(n);
  for (int i = 0; i < n; ++i) mean(i) = count(i) > 0 ? sum(i) / count(i) : kNaN;
  if (counts != nullptr) *counts = count;
  return mean;
}

// -----------------------------------------------------------------------------------------------

namespace {

// Steps 1-4 of the file comment (and the other solvers) at input.current_parameters.
CorrectionResult SolveCorrection(const CorrectionOptions& options, const CorrectionInput& input) {
  const auto start = std::chrono::steady_clock::now();
  CorrectionResult result;
  CorrectionSummary& summary = result.summary;
  summary.solver = options.solver;
  summary.mode = options.mode;
  auto elapsed = [&start]() {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  };
  auto invalid = [&](const std::string& message) {
    summary.status = CorrectionStatus::kInvalidInput;
    summary.message = message;
    summary.elapsed_ms = elapsed();
    return result;
  };

  // ---- validation ------------------------------------------------------------------------
  std::string error;
  if (!options.IsValid(&error)) return invalid(error);
  if (input.model == nullptr) return invalid("no machine model");
  const MachineModel& model = *input.model;
  const int np = model.NumParameters();
  const int n = model.NumPoints();
  if (input.current_parameters.size() != np || !input.current_parameters.allFinite()) {
    return invalid("current_parameters must hold " + std::to_string(np) + " finite values");
  }
  // Several teeth: their point-wise mean, each point's noise variance divided by its count.
  Eigen::VectorXd measured = input.measured_um;
  Eigen::VectorXd noise_share = Eigen::VectorXd::Ones(n);  // variance of a point / sigma^2
  if (!input.measured_teeth_um.empty()) {
    for (size_t t = 0; t < input.measured_teeth_um.size(); ++t) {
      if (input.measured_teeth_um[t].size() != n) {
        return invalid("measured_teeth_um[" + std::to_string(t) + "] must hold " + std::to_string(n) + " values");
      }
    }
    Eigen::VectorXi counts;
    measured = AverageTeeth(input.measured_teeth_um, &counts);
    for (int i = 0; i < n; ++i) noise_share(i) = counts(i) > 0 ? 1.0 / counts(i) : 1.0;
  } else if (input.measured_um.size() != n) {
    return invalid("measured_um must hold " + std::to_string(n) + " values");
  }
  if (input.target_um.size() != n) return invalid("target_um must hold " + std::to_string(n) + " values");
  if (options.point_weights.size() != 0 && options.point_weights.size() != n) {
    return invalid("point_weights must be empty or hold " + std::to_string(n) + " values");
  }
  if (options.lower_delta.size() != 0 && options.lower_delta.size() != np) {
    return invalid("bounds must be empty or hold " + std::to_string(np) + " values");
  }
  if (input.jacobian_um.size() != 0 && (input.jacobian_um.rows() != n || input.jacobian_um.cols() != np)) {
    return invalid("jacobian_um must be " + std::to_string(n) + " x " + std::to_string(np));
  }
  const std::vector<ParameterBlock> blocks = model.ParameterBlocks();

  // ---- the model at the current parameters ------------------------------------------------
  ModelEvaluation eval0;
  model.Evaluate(input.current_parameters, input.jacobian_um.size() == 0, &eval0);
  const Eigen::MatrixXd& jac = input.jacobian_um.size() != 0 ? input.jacobian_um : eval0.jacobian_um;
  const Eigen::VectorXd& d0 = eval0.deviations_um;

  double roll_min = input.roll_min_rad, roll_max = input.roll_max_rad;
  if (!(roll_min < roll_max)) {
    roll_min = kInf;
    roll_max = -kInf;
    for (int i = 0; i < n; ++i) {
      if (eval0.status[i] == PointStatus::kOk && std::isfinite(eval0.contact_roll_rad[i])) {
        roll_min = std::min(roll_min, eval0.contact_roll_rad[i]);
        roll_max = std::max(roll_max, eval0.contact_roll_rad[i]);
      }
    }
    if (!(roll_min < roll_max)) {
      roll_min = -1.0;
      roll_max = 1.0;
    }
  }
  summary.roll_min_rad = roll_min;
  summary.roll_max_rad = roll_max;

  const Eigen::VectorXd weights =
      options.point_weights.size() == n ? options.point_weights : Eigen::VectorXd::Ones(n);
  const Eigen::VectorXd e = measured - input.target_um;  // NaN where missing
  std::vector<int> used;
  std::vector<int> reached;
  for (int i = 0; i < n; ++i) {
    const bool ok = eval0.status[i] == PointStatus::kOk;
    if (ok) reached.push_back(i);
    if (ok && std::isfinite(e(i)) && weights(i) > 0.0) {
      used.push_back(i);
    } else {
      summary.missing_indices.push_back(i);
    }
  }
  if (used.empty()) return invalid("no usable grid point (all missing, zero weight or not reached)");

  // ---- free parameters and their coordinates ---------------------------------------------
  std::vector<int> free;  // parameter indices that may change
  for (const ParameterBlock& b : blocks) {
    int order = b.is_polynomial ? std::min(options.default_max_order, b.num_coefficients - 1) : 0;
    const auto it = options.max_order.find(b.name);
    if (it != options.max_order.end()) order = std::min(it->second, b.num_coefficients - 1);
    for (int k = 0; k <= order; ++k) free.push_back(b.first_index + k);
  }
  for (const auto& [name, order] : options.max_order) {
    (void)order;
    bool known = false;
    for (const ParameterBlock& b : blocks) known = known || b.name == name;
    if (!known) return invalid("max_order names an unknown parameter block '" + name + "'");
  }
  const int nf = static_cast<int>(free.size());
  summary.num_free_parameters = nf;
  summary.num_points_used = static_cast<int>(used.size());
  if (nf == 0) return invalid("no parameter is free to change");

  const Eigen::MatrixXd t_full = CoordinateMap(blocks, np, roll_min, roll_max, options.block_scales);
  // T: free coordinates -> delta (np x nf). Orders 0..K of a Legendre block touch only
  // monomials 0..K, so restricting columns and rows to `free` is exact.
  Eigen::MatrixXd t_map = Eigen::MatrixXd::Zero(np, nf);
  Eigen::MatrixXd t_ff(nf, nf);
  for (int c = 0; c < nf; ++c) {
    t_map.col(c) = t_full.col(free[c]);
    for (int r = 0; r < nf; ++r) t_ff(r, c) = t_full(free[r], free[c]);
  }
  const Eigen::MatrixXd st = jac * t_map;  // n x nf

  bool has_bounds = false;
  Eigen::VectorXd lower = Eigen::VectorXd::Constant(np, -kInf), upper = Eigen::VectorXd::Constant(np, kInf);
  if (options.lower_delta.size() == np) {
    lower = options.lower_delta;
    upper = options.upper_delta;
    for (int j : free) has_bounds = has_bounds || std::isfinite(lower(j)) || std::isfinite(upper(j));
  }

  // The regularised linear solve on a set of rows: Tikhonov in the reachable directions of
  // A = W^1/2 S T with lambda chosen by the rule.
  auto linear_solve = [&](const std::vector<int>& rows) {
    LinearSolve ls;
    Eigen::MatrixXd a(rows.size(), nf);
    Eigen::VectorXd b(rows.size());
    double weight_sum = 0.0;
    for (size_t r = 0; r < rows.size(); ++r) {
      const double sw = std::sqrt(weights(rows[r]));
      a.row(r) = sw * st.row(rows[r]);
      b(r) = -sw * e(rows[r]);
      weight_sum += weights(rows[r]);
    }
    // A direction with singular value sigma changes the flank by sigma / sqrt(sum w) um rms per
    // unit of correction size; below min_flank_effect_um it is not counted as reachable.
    ls.svd = ComputeSvd(a, options.min_flank_effect_um * std::sqrt(weight_sum));
    const int rank = ls.svd.rank;
    ls.beta = ls.svd.u.transpose() * b;
    ls.best = b;
    for (int i = 0; i < rank; ++i) ls.best -= ls.beta(i) * ls.svd.u.col(i);
    const double out2 = ls.best.squaredNorm();
    // noise2 = the probe noise expected inside the range, sigma^2 sum_{i<rank} sum_r w_r U_ri^2.
    double noise2_total = 0.0;
    const double s2 = options.probe_noise_um > 0.0 ? options.probe_noise_um * options.probe_noise_um : 0.0;
    for (int i = 0; i < rank; ++i) {
      double v = 0.0;
      for (size_t r = 0; r < rows.size(); ++r) {
        v += weights(rows[r]) * noise_share(rows[r]) * ls.svd.u(r, i) * ls.svd.u(r, i);
      }
      noise2_total += s2 * v;
    }
    // Filter factor f_i = sigma_i^2 / (sigma_i^2 + lambda^2); in-range residual and dof.
    auto in_range2 = [&](double lambda) {
      double r2 = 0.0;
      for (int i = 0; i < rank; ++i) {
        const double f = lambda * lambda / (ls.svd.sigma(i) * ls.svd.sigma(i) + lambda * lambda);
        r2 += f * f * ls.beta(i) * ls.beta(i);
      }
      return r2;
    };
    auto dof = [&](double lambda) {
      double d = 0.0;
      for (int i = 0; i < rank; ++i) d += ls.svd.sigma(i) * ls.svd.sigma(i) / (ls.svd.sigma(i) * ls.svd.sigma(i) + lambda * lambda);
      return d;
    };
    ls.k = rank;
    const double sigma1 = rank > 0 ? ls.svd.sigma(0) : 0.0;
    const double lambda_lo = 1e-8 * sigma1, lambda_hi = 1e4 * sigma1;
    // The lambda of 193 logarithmically spaced levels in [lambda_lo, lambda_hi] where a rule's
    // criterion is smallest (the first, on ties).
    auto argmin_on_log_grid = [&](auto criterion) {
      const int kGrid = 193;
      double best_lambda = lambda_lo, best_value = std::numeric_limits<double>::infinity();
      for (int g = 0; g < kGrid; ++g) {
        const double lambda = std::exp(std::log(lambda_lo) + (std::log(lambda_hi) - std::log(lambda_lo)) * g / (kGrid - 1));
        const double value = criterion(lambda);
        if (value < best_value) {
          best_value = value;
          best_lambda = lambda;
        }
      }
      return best_lambda;
    };
    if (rank == 0) {
      ls.lambda = 0.0;
    } else if (options.probe_noise_um > 0.0 && !options.use_discrepancy_principle) {
      // Unbiased predictive risk: minimise the in-range residual + 2 sigma^2 dof (the part of b
      // off the range is the same for every lambda).
      const double noise_per_direction = noise2_total / rank;
      ls.lambda = argmin_on_log_grid([&](double lambda) { return in_range2(lambda) + 2.0 * noise_per_direction * dof(lambda); });
    } else if (options.probe_noise_um >= 0.0) {
      // Discrepancy principle on the part of b inside the range of A (the part outside cannot
      // be fitted by any correction): the in-range residual, increasing in lambda, equals the
      // probe noise expected in those directions. sigma = 0: exact data, lambda = 0.
      const double target = noise2_total;
      if (target <= 0.0 || in_range2(lambda_lo) >= target) {
        ls.lambda = 0.0;
      } else if (in_range2(lambda_hi) <= target) {
        ls.lambda = lambda_hi;  // everything in range is at the noise level: no correction
      } else {
        double lo = std::log(lambda_lo), hi = std::log(lambda_hi);
        for (int it = 0; it < 80; ++it) {
          const double mid = 0.5 * (lo + hi);
          if (in_range2(std::exp(mid)) < target) lo = mid; else hi = mid;
        }
        ls.lambda = std::exp(0.5 * (lo + hi));
      }
    } else {
      // Generalised cross-validation: minimise |A y - b|^2 / (m - dof)^2.
      const double m = static_cast<double>(rows.size());
      ls.lambda = argmin_on_log_grid([&](double lambda) {
        const double denom = std::max(m - dof(lambda), 0.5);
        return (in_range2(lambda) + out2) / (denom * denom);
      });
    }
    // Exact data (sigma = 0) and GCV: never below the floor. It keeps the exact-model
    // refinement well posed when the target is out of reach (lambda = 0 lets
    // Levenberg-Marquardt crawl along directions whose linear effect is tiny), at the cost of
    // fitting the weakest kept direction (sigma = 0.067 for N = 45) to about 86% per
    // correction. With a known sigma > 0 the rule (UPRE or the discrepancy principle) alone decides.
    if (rank > 0 && !(options.probe_noise_um > 0.0)) {
      ls.lambda = std::max(ls.lambda, options.min_relative_regularisation * sigma1);
    }
    ls.dof = dof(ls.lambda);
    ls.y = Eigen::VectorXd::Zero(nf);
    for (int i = 0; i < rank; ++i) {
      const double sg = ls.svd.sigma(i);
      ls.y += sg * ls.beta(i) / (sg * sg + ls.lambda * ls.lambda) * ls.svd.v.col(i);
    }
    ls.residual = a * ls.y - b;
    return ls;
  };

  // ---- gross outliers ----------------------------------------------------------------------
  if (options.outlier_threshold > 0.0 && options.solver == CorrectionSolver::kRegularised) {
    const int max_drop = static_cast<int>(std::floor(options.max_outlier_fraction * used.size()));
    for (int drop = 0; drop < max_drop; ++drop) {
      const LinearSolve ls = linear_solve(used);
      // h_ii from the hat matrix of the Tikhonov fit, U diag(f) U'.
      std::vector<double> loo(used.size());
      for (size_t r = 0; r < used.size(); ++r) {
        double h = 0.0;
        for (int i = 0; i < ls.k; ++i) {
          const double s2 = ls.svd.sigma(i) * ls.svd.sigma(i);
          h += s2 / (s2 + ls.lambda * ls.lambda) * ls.svd.u(r, i) * ls.svd.u(r, i);
        }
        // Standardised residual: r_i / sqrt(1 - h_ii) has the spread of the noise.
        loo[r] = ls.residual(r) / std::sqrt(weights(used[r])) / std::sqrt(std::max(1.0 - h, 1e-6));
      }
      const double med = Median(loo);
      std::vector<double> dev(loo.size());
      for (size_t r = 0; r < loo.size(); ++r) dev[r] = std::abs(loo[r] - med);
      const double spread = 1.4826 * Median(dev);
      const double limit = std::max(options.outlier_threshold * std::max(spread, std::max(options.probe_noise_um, 0.0)),
                                    options.outlier_min_um);
      // A gross outlier is an isolated point: it must also stand out from its grid neighbours
      // along every line through it (row, column and both diagonals; the mean of the one or two
      // neighbours on the line). A target the model cannot follow (a tip, root or end relief, a
      // diagonal band) leaves a misfit shared along some line, and that is not an outlier.
      std::vector<int> position(n, -1);
      for (size_t r = 0; r < used.size(); ++r) position[used[r]] = static_cast<int>(r);
      const int columns = model.GridColumns();
      const int rows_count = model.GridRows();
      std::vector<double> isolation(loo.size(), 0.0);
      for (size_t r = 0; r < used.size(); ++r) {
        const int row = used[r] / columns, col = used[r] % columns;
        double least = dev[r];
        for (const auto& [dr, dc] : {std::pair<int, int>{0, 1}, {1, 0}, {1, 1}, {1, -1}}) {
          double sum = 0.0;
          int count = 0;
          for (int sign : {-1, 1}) {
            const int rr = row + sign * dr, cc = col + sign * dc;
            if (rr < 0 || cc < 0 || rr >= rows_count || cc >= columns) continue;
            const int q = position[rr * columns + cc];
            if (q >= 0) {
              sum += loo[q];
              ++count;
            }
          }
          if (count > 0) least = std::min(least, std::abs(loo[r] - sum / count));
        }
        isolation[r] = least;
      }
      const size_t worst = std::max_element(isolation.begin(), isolation.end()) - isolation.begin();
      if (isolation[worst] <= limit) break;
      summary.outlier_indices.push_back(used[worst]);
      used.erase(used.begin() + worst);
    }
    std::sort(summary.outlier_indices.begin(), summary.outlier_indices.end());
    summary.num_points_used = static_cast<int>(used.size());
  }

  // ---- the linear solve on the final rows (also reports rank and best reachable) ----------
  const LinearSolve ls = linear_solve(used);
  summary.singular_values = ls.svd.sigma;
  summary.rank = ls.svd.rank;
  summary.condition_number = ls.svd.rank > 0 ? ls.svd.sigma(0) / ls.svd.sigma(ls.svd.rank - 1) : kInf;
  {
    Eigen::VectorXd best_um = Eigen::VectorXd::Zero(n);
    for (size_t r = 0; r < used.size(); ++r) best_um(used[r]) = ls.best(r) / std::sqrt(weights(used[r]));
    summary.best_reachable_rms_um = Rms(best_um, used);
  }
  summary.initial_rms_um = Rms(e, used);
  summary.initial_max_um = MaxAbs(e, used);

  Eigen::VectorXd delta = Eigen::VectorXd::Zero(np);
  std::string not_converged;
  const auto linear_prediction_rms = [&](const Eigen::VectorXd& d) {
    const Eigen::VectorXd r = e + jac * d;
    return Rms(r, used);
  };

  if (options.solver == CorrectionSolver::kRegularised) {
    summary.rule = options.probe_noise_um > 0.0 && !options.use_discrepancy_principle
                       ? RegularisationRule::kUnbiasedPredictiveRisk
                       : options.probe_noise_um >= 0.0 ? RegularisationRule::kDiscrepancyPrinciple
                                                       : RegularisationRule::kGeneralisedCrossValidation;
    const int k = ls.k;
    const double lambda = ls.lambda;
    summary.regularisation_level = lambda;
    summary.effective_dof = ls.dof;
    summary.truncation_rank = ls.k;
    const bool rework = options.mode == CorrectionMode::kRework;
    // The kept subspace: y = V_k z, delta = T V_k z.
    const Eigen::MatrixXd vk = ls.svd.v.leftCols(k);
    const Eigen::MatrixXd tv = t_map * vk;  // np x k
    Eigen::VectorXd z = Eigen::VectorXd::Zero(k);
    for (int i = 0; i < k; ++i) {
      z(i) = ls.svd.sigma(i) * ls.beta(i) / (ls.svd.sigma(i) * ls.svd.sigma(i) + lambda * lambda);
    }

    // The QP in z at a linearisation (jac_k, exact change change_k at z_k): minimise the
    // weighted predicted error, subject to bounds on delta and (rework) change <= 0.
    auto solve_qp = [&](const Eigen::MatrixXd& jac_k, const Eigen::VectorXd& change_k, const Eigen::VectorXd& z_k,
                        Eigen::VectorXd* z_out) {
      const Eigen::MatrixXd stv = jac_k * tv;  // n x k
      Eigen::MatrixXd a(used.size(), k);
      Eigen::VectorXd b(used.size());
      for (size_t r = 0; r < used.size(); ++r) {
        const int i = used[r];
        const double sw = std::sqrt(weights(i));
        a.row(r) = sw * stv.row(i);
        b(r) = -sw * (e(i) + change_k(i) - stv.row(i).dot(z_k));
      }
      const double ridge = 1e-12 * (ls.svd.sigma.size() > 0 ? ls.svd.sigma(0) * ls.svd.sigma(0) : 1.0);
      const Eigen::MatrixXd hess = a.transpose() * a + (ridge + lambda * lambda) * Eigen::MatrixXd::Identity(k, k);
      const Eigen::VectorXd grad = a.transpose() * b;
      std::vector<Eigen::RowVectorXd> rows;
      std::vector<double> lims;
      if (rework) {
        for (int i : reached) {
          rows.push_back(stv.row(i));
          lims.push_back(stv.row(i).dot(z_k) - change_k(i));
        }
      }
      for (int c = 0; c < nf; ++c) {
        const int j = free[c];
        if (std::isfinite(upper(j))) {
          rows.push_back(tv.row(j));
          lims.push_back(upper(j));
        }
        if (std::isfinite(lower(j))) {
          rows.push_back(-tv.row(j));
          lims.push_back(-lower(j));
        }
      }
      Eigen::MatrixXd g_mat(rows.size(), k);
      Eigen::VectorXd h_vec(rows.size());
      for (size_t r = 0; r < rows.size(); ++r) {
        g_mat.row(r) = rows[r];
        h_vec(r) = lims[r];
      }
      return SolveConvexQp(hess, grad, g_mat, h_vec, z_out);
    };

    if (k > 0 && (rework || has_bounds)) {
      Eigen::VectorXd z_new;
      if (solve_qp(jac, Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(k), &z_new)) {
        z = z_new;
      } else {
        not_converged = "the constrained linear problem failed";
      }
    }
    delta = tv * z;
    summary.linear_residual_rms_um = linear_prediction_rms(delta);

    if (k == 0) {
      // Nothing above the noise: no change.
    } else if (rework) {
      // Sequential QP on the exact model: re-linearise at the current change and solve again.
      int pass = 0;
      for (; pass < options.max_rework_passes; ++pass) {
        ModelEvaluation ev;
        model.Evaluate(input.current_parameters + delta, true, &ev);
        Eigen::VectorXd change = Eigen::VectorXd::Zero(n);
        double worst = 0.0;
        bool lost = false;
        for (int i : reached) {
          if (ev.status[i] != PointStatus::kOk) {
            lost = true;
            continue;
          }
          change(i) = ev.deviations_um(i) - d0(i);
          worst = std::max(worst, change(i));
        }
        if (lost) {
          not_converged = "a grid point leaves the wheel under the rework correction";
          break;
        }
        if (pass > 0 && worst <= options.rework_tolerance_um) break;
        Eigen::VectorXd z_new;
        if (!solve_qp(ev.jacobian_um, change, z, &z_new)) {
          not_converged = "the constrained linear problem failed";
          break;
        }
        z = z_new;
        delta = tv * z;
      }
      summary.iterations = pass;
    } else if (options.max_num_iterations > 0) {
      // Ceres refinement on the exact model in the same kept subspace. Without bounds the
      // variables are z (delta = T V_k z). With bounds they are the free monomial coefficients
      // (box bounds), and leaving the subspace is penalised by sigma_1 |(I - V_k V_k') T_ff^-1 v|.
      Eigen::MatrixXd p, reg;
      Eigen::VectorXd v;
      if (has_bounds) {
        p = Eigen::MatrixXd::Zero(np, nf);
        for (int c = 0; c < nf; ++c) p(free[c], c) = 1.0;
        const Eigen::MatrixXd t_inv = t_ff.inverse();
        reg.resize(nf + k, nf);
        reg.topRows(nf) = ls.svd.sigma(0) * (Eigen::MatrixXd::Identity(nf, nf) - vk * vk.transpose()) * t_inv;
        reg.bottomRows(k) = lambda * vk.transpose() * t_inv;
        v.resize(nf);
        for (int c = 0; c < nf; ++c) v(c) = std::clamp(delta(free[c]), lower(free[c]), upper(free[c]));
      } else {
        p = tv;
        reg = lambda * Eigen::MatrixXd::Identity(k, k);
        v = z;
      }
      // Ceres cannot start where the exact model loses a point: then start from no change (a
      // valid point) and let the trust region find how far the linear step can be followed.
      bool from_zero = false;
      {
        ModelEvaluation ev;
        model.Evaluate(input.current_parameters + p * v, false, &ev);
        bool start_ok = true;
        for (int i : used) start_ok = start_ok && ev.status[i] == PointStatus::kOk;
        if (!start_ok) {
          v.setZero();
          from_zero = true;
        }
      }
      auto refine = [&](Eigen::VectorXd* x, ceres::Solver::Summary* ceres_summary) {
        ceres::Problem::Options problem_options;
        problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
        ceres::Problem problem(problem_options);
        problem.AddResidualBlock(
            new ExactModelCost(model, input.current_parameters, d0, e, weights, used, p, reg), nullptr, x->data());
        if (has_bounds) {
          for (int c = 0; c < nf; ++c) {
            if (std::isfinite(lower(free[c]))) problem.SetParameterLowerBound(x->data(), c, lower(free[c]));
            if (std::isfinite(upper(free[c]))) problem.SetParameterUpperBound(x->data(), c, upper(free[c]));
          }
        }
        ceres::Solver::Options solver_options;
        solver_options.linear_solver_type = ceres::DENSE_QR;
        solver_options.max_num_iterations = options.max_num_iterations;
        solver_options.logging_type = ceres::SILENT;
        solver_options.minimizer_progress_to_stdout = false;
        solver_options.num_threads = 1;
        solver_options.function_tolerance = 1e-10;
        solver_options.gradient_tolerance = 1e-12;
        solver_options.parameter_tolerance = 1e-10;
        ceres::Solve(solver_options, &problem, ceres_summary);
      };
      const Eigen::VectorXd v0 = v;
      ceres::Solver::Summary ceres_summary;
      refine(&v, &ceres_summary);
      int iterations = static_cast<int>(ceres_summary.iterations.size()) - 1;
      if (ceres_summary.termination_type != ceres::CONVERGENCE && !from_zero) {
        // Far from the linear prediction (a strongly nonlinear direction), the trust region
        // may do better walking out from no change: try that too and keep the lower cost.
        Eigen::VectorXd v_zero = Eigen::VectorXd::Zero(v.size());
        ceres::Solver::Summary zero_summary;
        refine(&v_zero, &zero_summary);
        iterations += static_cast<int>(zero_summary.iterations.size()) - 1;
        const bool zero_usable = zero_summary.termination_type == ceres::CONVERGENCE ||
                                 zero_summary.termination_type == ceres::NO_CONVERGENCE;
        const bool first_usable = ceres_summary.termination_type == ceres::NO_CONVERGENCE;
        if (zero_usable && (!first_usable || zero_summary.final_cost < ceres_summary.final_cost)) {
          v = v_zero;
          ceres_summary = zero_summary;
        }
      }
      summary.refinement_initial_cost = ceres_summary.initial_cost;
      summary.refinement_final_cost = ceres_summary.final_cost;
      summary.iterations = iterations;
      if (ceres_summary.termination_type == ceres::CONVERGENCE) {
        delta = p * v;
      } else if (ceres_summary.termination_type == ceres::NO_CONVERGENCE) {
        delta = p * v;
        not_converged = "the exact-model refinement reached max_num_iterations";
      } else {
        delta = p * v0;
        not_converged = "the exact-model refinement failed (" + ceres_summary.message +
                        "); the linear correction is reported";
      }
    }
  } else if (options.solver == CorrectionSolver::kPlainLeastSquares) {
    // Minimum-norm least squares in raw parameter units, no regularisation, no refinement.
    Eigen::MatrixXd a(used.size(), nf);
    Eigen::VectorXd b(used.size());
    for (size_t r = 0; r < used.size(); ++r) {
      const double sw = std::sqrt(weights(used[r]));
      for (int c = 0; c < nf; ++c) a(r, c) = sw * jac(used[r], free[c]);
      b(r) = -sw * e(used[r]);
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd x = svd.solve(b);
    for (int c = 0; c < nf; ++c) delta(free[c]) = std::clamp(x(c), lower(free[c]), upper(free[c]));
    summary.linear_residual_rms_um = linear_prediction_rms(delta);
  } else {
    // Particle swarm, as published (Jiang 2015; MODEL.md §6).
    Eigen::VectorXd box_lo(nf), box_hi(nf);
    for (int c = 0; c < nf; ++c) {
      const int j = free[c];
      // Published units: mm and rad, except the wheel's cone angle in degrees.
      bool is_cone = false;
      for (const ParameterBlock& b : blocks) {
        if (b.name == "cone_angle" && j >= b.first_index && j < b.first_index + b.num_coefficients) is_cone = true;
      }
      const double half = options.pso_box * (is_cone ? kPi / 180.0 : 1.0);
      box_lo(c) = std::max(-half, lower(j));
      box_hi(c) = std::min(half, upper(j));
    }
    Eigen::MatrixXd s_used(used.size(), nf);
    Eigen::VectorXd wanted(used.size()), sw(used.size());
    for (size_t r = 0; r < used.size(); ++r) {
      for (int c = 0; c < nf; ++c) s_used(r, c) = jac(used[r], free[c]);
      wanted(r) = -e(used[r]);  // delta_i = t - m
      sw(r) = weights(used[r]);
    }
    auto objective = [&](const Eigen::VectorXd& x) {
      const Eigen::VectorXd change = s_used * x;
      double f = 0.0;
      for (int r = 0; r < change.size(); ++r) {
        const double fi = change(r) < 0.0 ? change(r) - wanted(r) : -wanted(r);
        f += sw(r) * fi * fi;
      }
      return f;
    };
    // The published parameters fix the swarm size, generations, inertia and c1, c2; the rest is
    // the textbook global-best swarm: positions uniform in the box, velocities uniform in
    // +-(box width), velocities clamped to the box width and positions to the box.
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
          vel[k](c) = options.pso_inertia * vel[k](c) +
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
    for (int c = 0; c < nf; ++c) delta(free[c]) = global_x(c);
    summary.iterations = options.pso_generations;
    summary.linear_residual_rms_um = linear_prediction_rms(delta);
  }

  // ---- the exact prediction at the new parameters ---------------------------------------------
  result.delta = delta;
  result.parameters = input.current_parameters + delta;
  ModelEvaluation eval1;
  model.Evaluate(result.parameters, false, &eval1);
  result.predicted_change_um = Eigen::VectorXd::Constant(n, kNaN);
  result.predicted_residual_um = Eigen::VectorXd::Constant(n, kNaN);
  int lost = 0;
  summary.max_added_material_um = 0.0;
  for (int i = 0; i < n; ++i) {
    if (eval0.status[i] != PointStatus::kOk) continue;
    if (eval1.status[i] != PointStatus::kOk) {
      ++lost;
      continue;
    }
    result.predicted_change_um(i) = eval1.deviations_um(i) - d0(i);
    summary.max_added_material_um = std::max(summary.max_added_material_um, result.predicted_change_um(i));
    if (std::isfinite(e(i))) result.predicted_residual_um(i) = e(i) + result.predicted_change_um(i);
  }
  std::vector<int> predicted_used;
  for (int i : used) if (std::isfinite(result.predicted_residual_um(i))) predicted_used.push_back(i);
  summary.residual_rms_um = Rms(result.predicted_residual_um, predicted_used);
  summary.residual_max_um = MaxAbs(result.predicted_residual_um, predicted_used);
  summary.correction_size =
      CorrectionSize(blocks, delta, roll_min, roll_max, options.block_scales, &summary.block_sizes);

  if (lost > 0 && not_converged.empty()) {
    not_converged = std::to_string(lost) + " grid point(s) are not reached by the corrected settings";
  }
  if (options.mode == CorrectionMode::kRework && options.solver == CorrectionSolver::kRegularised &&
      summary.max_added_material_um > options.rework_tolerance_um && not_converged.empty()) {
    not_converged = "rework: the correction still adds material at some point";
  }
  summary.status = not_converged.empty() ? CorrectionStatus::kConverged : CorrectionStatus::kNotConverged;
  summary.message = not_converged;
  summary.elapsed_ms = elapsed();
  return result;
}

}  // namespace

CorrectionResult ComputeCorrection(const CorrectionOptions& options, const CorrectionInput& input) {
  const auto start = std::chrono::steady_clock::now();
  CorrectionOptions plain = options;
  plain.estimate_machine_state = false;
  if (!options.estimate_machine_state || options.solver != CorrectionSolver::kRegularised || input.model == nullptr ||
      input.current_parameters.size() != input.model->NumParameters() || !input.current_parameters.allFinite()) {
    return SolveCorrection(plain, input);
  }
  const MachineModel& model = *input.model;
  const int n = model.NumPoints();

  // Step 0: the state h^ with d(commanded + h^) ~ measured, within the reachable directions of
  // the same freedom as the correction (max orders; not the bounds, which restrict the
  // correction, not the machine's errors), as a next-part problem whose "measurement" is the
  // model's own flank. A state estimate in orders 4-6 makes the spur gear's root contacts
  // singular just as a correction in them does (see default_max_order).
  Eigen::VectorXd measured = input.measured_um;
  double noise_um = options.probe_noise_um;
  if (!input.measured_teeth_um.empty()) {
    for (const Eigen::VectorXd& tooth : input.measured_teeth_um) {
      if (tooth.size() != n) return SolveCorrection(plain, input);  // reports the bad size
    }
    Eigen::VectorXi counts;
    measured = AverageTeeth(input.measured_teeth_um, &counts);
    double count_sum = 0.0;
    int delivered = 0;
    for (int i = 0; i < n; ++i) {
      if (counts(i) > 0) {
        count_sum += counts(i);
        ++delivered;
      }
    }
    if (noise_um > 0.0 && delivered > 0) noise_um /= std::sqrt(count_sum / delivered);
  }
  if (measured.size() != n) return SolveCorrection(plain, input);
  ModelEvaluation own;
  model.Evaluate(input.current_parameters, false, &own);
  CorrectionInput state_input;
  state_input.model = input.model;
  state_input.current_parameters = input.current_parameters;
  state_input.measured_um = own.deviations_um;
  for (int i = 0; i < n; ++i) {
    if (own.status[i] != PointStatus::kOk) state_input.measured_um(i) = kNaN;
  }
  state_input.target_um = measured;
  state_input.roll_min_rad = input.roll_min_rad;
  state_input.roll_max_rad = input.roll_max_rad;
  state_input.jacobian_um = input.jacobian_um;
  CorrectionOptions state_options = plain;
  state_options.mode = CorrectionMode::kNextPart;
  state_options.lower_delta.resize(0);
  state_options.upper_delta.resize(0);
  state_options.probe_noise_um = noise_um;
  const CorrectionResult state = SolveCorrection(state_options, state_input);

  CorrectionInput shifted = input;
  shifted.roll_min_rad = state.summary.roll_min_rad;
  shifted.roll_max_rad = state.summary.roll_max_rad;
  shifted.jacobian_um.resize(0, 0);
  bool use_state = state.summary.IsSolutionUsable() && state.delta.size() == input.current_parameters.size() &&
                   state.delta.allFinite();
  if (use_state) {
    shifted.current_parameters = input.current_parameters + state.delta;
    ModelEvaluation at_state;
    model.Evaluate(shifted.current_parameters, false, &at_state);
    for (int i = 0; i < n; ++i) {
      if (own.status[i] == PointStatus::kOk && at_state.status[i] != PointStatus::kOk) use_state = false;
    }
  }
  if (!use_state) return SolveCorrection(plain, input);

  CorrectionResult result = SolveCorrection(plain, shifted);
  if (!result.summary.IsSolutionUsable()) return SolveCorrection(plain, input);
  result.parameters = input.current_parameters + result.delta;
  result.summary.machine_state_estimated = true;
  result.summary.machine_state_size = state.summary.correction_size;
  result.summary.machine_state_misfit_rms_um = state.summary.residual_rms_um;
  result.summary.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gearloop
