// engine/core/damped_newton.h: the damped Newton iteration shared by the
// contact solvers of the flat-wheel grinder
// (engine/grinder/flat_wheel_grinder.cc, 4 x 4, which solves its own step),
// the cradle bevel generator (engine/bevel/cradle_machine.cc, 3 x 3), the
// free-form bevel generator (engine/bevel/freeform_generator.cc, 4 x 4) and
// the shaving cutter's target (engine/shaving/cutter_target.cc).
//
// INTERNAL to the engine: it includes Eigen only (no Ceres), so each solver
// keeps its own way of evaluating the system (closed-form derivatives or
// ceres::Jet) in its .cc file.
//
//   Eigen::Vector4d x = first_guess;
//   const DampedNewtonSummary summary = DampedNewton<4>(
//       DampedNewtonOptions{options_.max_iterations,
//       options_.step_tolerance_mm, options_.max_step_mm}, step_scale,
//       [&](const Eigen::Vector4d& x, Eigen::Vector4d* g, Eigen::Matrix4d*
//       jacobian) { ... }, &x);
//   if (!summary.converged || !x.allFinite()) ...
#ifndef GEARLOOP_ENGINE_CORE_DAMPED_NEWTON_H_
#define GEARLOOP_ENGINE_CORE_DAMPED_NEWTON_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <utility>

namespace gearloop {
namespace engine_internal {

struct DampedNewtonOptions {
  // Newton iterations allowed; each evaluates the system and its Jacobian once.
  int max_iterations = 40;
  // Converged when a full step moves every unknown by less than this [mm], each
  // unknown counted in mm through its entry of `step_scale` (an angle as an arc
  // on some radius).
  double step_tolerance_mm = 1e-11;
  // A step whose scaled size max_i |dx_i * step_scale_i| exceeds this [mm] is
  // shortened to it, direction kept: keeps Newton on the branch of its first
  // guess.
  double max_step_mm = 20.0;
};

struct DampedNewtonSummary {
  // True once a full (unshortened) step was below step_tolerance_mm; that step
  // is applied.
  bool converged = false;
  // Steps taken, the converging one included; a step that failed to solve is
  // not counted.
  int num_iterations = 0;
};

// The sum of p[0..length) as Eigen's unrolled reductions add it: the first
// half's sum plus the second half's, recursively.
inline double HalvingSum(const double* p, int length) {
  if (length == 1) return p[0];
  const int half = length / 2;
  return HalvingSum(p, half) + HalvingSum(p + half, length - half);
}

// Solves a * x = b by Gaussian elimination with partial pivoting, written out
// for a small fixed N: the same operations in the same order as Eigen's
// a.partialPivLu().solve(b) for N <= 8 (pivot: the first largest |entry| of
// the column; the column below it divided by it; rank-1 update of the rest;
// then row by row L y = P b and U x = y, each row's products summed by
// halves), so the same numbers, without the dynamic loops, the permutation
// objects and the L1 norm Eigen also computes. An exactly zero pivot gives a
// non-finite x, as Eigen's does.
template <int N>
Eigen::Matrix<double, N, 1> SolveByPartialPivoting(
    Eigen::Matrix<double, N, N> a, Eigen::Matrix<double, N, 1> b) {
  static_assert(N >= 1 && N <= 8, "Eigen unrolls its solve up to 8");
  for (int k = 0; k + 1 < N; ++k) {
    int pivot = k;
    double biggest = std::abs(a(k, k));
    for (int i = k + 1; i < N; ++i) {
      if (std::abs(a(i, k)) > biggest) {
        biggest = std::abs(a(i, k));
        pivot = i;
      }
    }
    if (biggest != 0.0) {
      if (pivot != k) {
        a.row(k).swap(a.row(pivot));
        std::swap(b(k), b(pivot));
      }
      for (int i = k + 1; i < N; ++i) a(i, k) /= a(k, k);
    }
    for (int j = k + 1; j < N; ++j) {
      for (int i = k + 1; i < N; ++i) a(i, j) -= a(i, k) * a(k, j);
    }
  }
  double products[N];
  for (int i = 1; i < N; ++i) {  // L y = P b, L unit lower
    for (int j = 0; j < i; ++j) products[j] = a(i, j) * b(j);
    b(i) -= HalvingSum(products, i);
  }
  for (int i = N - 1; i >= 0; --i) {  // U x = y
    const int count = N - 1 - i;
    if (count > 0) {
      for (int j = 0; j < count; ++j)
        products[j] = a(i, i + 1 + j) * b(i + 1 + j);
      b(i) -= HalvingSum(products, count);
    }
    b(i) /= a(i, i);
  }
  return b;
}

// Two unit tangents orthogonal to the normal n and to each other (rows), for
// NormalLineNewtonStep.
inline Eigen::Matrix<double, 2, 3> NormalLineTangents(
    const Eigen::Vector3d& n) {
  const Eigen::Vector3d t1 = n.unitOrthogonal();
  Eigen::Matrix<double, 2, 3> t;
  t.row(0) = t1.transpose();
  t.row(1) = n.cross(t1).normalized().transpose();
  return t;
}

// The Newton step dx = -J^-1 g of a contact on a point's normal line: the
// unknowns are three surface variables and lambda, rows 0-2 are R(x3) - P -
// lambda n and row 3 a scalar condition f(x3), so J's last column is (-n, 0):
// J3 dx3 - n dlambda = -g3 and f' dx3 = -g_f. The tangents T (T n = 0,
// NormalLineTangents) take dlambda out: T J3 dx3 = -T g3 with row 3 is a
// 3 x 3 system M dx3 = r, solved by Cramer's rule (its cofactors and one
// division); then dlambda = n . (J3 dx3 + g3) / |n|^2. The same step as
// SolveByPartialPivoting<4> to rounding, in a far shorter chain of dependent
// operations, which is what a Newton iteration waits for (the flat-wheel
// grinder's contact: the 4 x 4 LU was 18 % of a correction's CPU on the
// robustness benchmark, as much as its system). A singular M gives a
// non-finite step, as the LU's zero pivot does.
// What NormalLineNewtonStep and NormalLineLambdaRow share: J3 (J's top-left
// 3 x 3), and the 3 x 3 M (rows T J3 and the meshing row J[3, 0:3]) by its
// cofactors, M^-1 = [c0 c1 c2] / det.
struct NormalLineCofactors {
  NormalLineCofactors(const Eigen::Matrix4d& jacobian,
                      const Eigen::Matrix<double, 2, 3>& tangents)
      : j3(jacobian.topLeftCorner<3, 3>()) {
    Eigen::Matrix3d m;
    m.topRows<2>() = tangents * j3;
    m.row(2) = jacobian.block<1, 3>(3, 0);
    c0 = m.row(1).cross(m.row(2));
    c1 = m.row(2).cross(m.row(0));
    c2 = m.row(0).cross(m.row(1));
    inverse_det = 1.0 / m.row(0).dot(c0);
  }
  Eigen::Matrix3d j3;
  Eigen::Vector3d c0, c1, c2;
  double inverse_det = 0.0;
};

inline Eigen::Vector4d NormalLineNewtonStep(
    const Eigen::Matrix4d& jacobian,
    const Eigen::Vector4d& g,
    const Eigen::Vector3d& n,
    const Eigen::Matrix<double, 2, 3>& tangents) {
  const NormalLineCofactors m(jacobian, tangents);
  const Eigen::Vector3d g3 = g.head<3>();
  const Eigen::Vector2d tg = tangents * g3;
  const Eigen::Vector3d r(-tg(0), -tg(1), -g(3));
  const Eigen::Vector3d dx3 =
      (m.c0 * r(0) + m.c1 * r(1) + m.c2 * r(2)) * m.inverse_det;
  Eigen::Vector4d dx;
  dx.head<3>() = dx3;
  dx(3) = n.dot(m.j3 * dx3 + g3) / n.squaredNorm();
  return dx;
}

// The row of J^-1 that gives dlambda, for the same system as
// NormalLineNewtonStep: y with J^T y = e_4, so that dlambda = -y . dG for a
// change dG of the system (the implicit function theorem of a contact's
// sensitivity). Column 3 of J, (-n, 0), asks n . y_r = -1 of y's first three
// entries y_r; with y_r = -n / |n|^2 + T^T a (T the tangents) the columns 0-2
// ask M^T (a, y_4) = s = J3^T n / |n|^2, M the 3 x 3 matrix of
// NormalLineNewtonStep (rows T J3 and the meshing row), solved by its
// cofactors: M^-1 = [c0 c1 c2] / det, so (a, y_4)_i = c_i . s / det. LU's
// answer of the transposed 4 x 4 system to rounding; a singular M gives a
// non-finite y.
inline Eigen::Vector4d NormalLineLambdaRow(
    const Eigen::Matrix4d& jacobian,
    const Eigen::Vector3d& n,
    const Eigen::Matrix<double, 2, 3>& tangents) {
  const NormalLineCofactors m(jacobian, tangents);
  const double n2 = n.squaredNorm();
  const Eigen::Vector3d s = m.j3.transpose() * n / n2;
  const double a0 = m.c0.dot(s) * m.inverse_det;
  const double a1 = m.c1.dot(s) * m.inverse_det;
  Eigen::Vector4d y;
  y.head<3>() = -n / n2 + tangents.transpose() * Eigen::Vector2d(a0, a1);
  y(3) = m.c2.dot(s) * m.inverse_det;
  return y;
}

// Whether the step after two whole Newton steps of sizes `previous_mm` then
// `step_mm` is predicted below a tenth of `tolerance_mm`: in the quadratic
// regime each step is about K times the square of the one before, so K is
// estimated as step_mm / previous_mm^2 and the next step as K step_mm^2. Only
// once the steps have fallen steeply (step_mm < 1e-3 previous_mm), so that a
// slow, linear approach is never taken for convergence. (Engine benchmark: the
// predicted step matched the one Newton then took to within a factor of a few,
// and the confirming iteration it saves was about one in five of the contact
// Newton's iterations.)
inline bool NextStepBelow(double previous_mm,
                          double step_mm,
                          double tolerance_mm) {
  if (!(previous_mm > 0.0) || !(step_mm < 1e-3 * previous_mm)) return false;
  const double k_per_mm = step_mm / (previous_mm * previous_mm);
  return k_per_mm * step_mm * step_mm < 0.1 * tolerance_mm;
}

// Solves g(x) = 0 for N unknowns by Newton's method from *x, leaving the last
// iterate in *x, with the Newton step supplied: each iteration calls
// `newton_step(x, &dx)` to fill dx = -J(x)^-1 g(x), and stops without moving
// when dx is not finite (a singular Jacobian). For systems whose structure
// solves the step more cheaply than a general LU (the flat-wheel grinder's
// contact); DampedNewton below is this with the step by partial pivoting. The
// step is shortened to max_step_mm when its scaled size max_i |dx_i *
// step_scale_i| exceeds that. Newton converges quadratically: once a full step
// is below step_tolerance_mm, the error left after it is far below the
// tolerance, so it stops there. The caller checks the result for branch jumps
// and finiteness (*x may hold a non-finite value only if the system produced
// one).
template <int N, typename NewtonStep>
DampedNewtonSummary DampedNewtonBySteps(
    const DampedNewtonOptions& options,
    const Eigen::Matrix<double, N, 1>& step_scale,
    const NewtonStep& newton_step,
    Eigen::Matrix<double, N, 1>* x) {
  DampedNewtonSummary summary;
  Eigen::Matrix<double, N, 1> dx;
  int iteration = 0;
  double last_full_step_mm = -1.0;  // the last step, when it was taken whole
  for (; iteration < options.max_iterations; ++iteration) {
    newton_step(*x, &dx);
    if (!dx.allFinite()) break;
    const double step_mm = dx.cwiseProduct(step_scale).cwiseAbs().maxCoeff();
    const double shrink =
        step_mm > options.max_step_mm ? options.max_step_mm / step_mm : 1.0;
    *x += shrink * dx;
    if (step_mm < options.step_tolerance_mm ||
        (shrink == 1.0 &&
         NextStepBelow(
             last_full_step_mm, step_mm, options.step_tolerance_mm))) {
      summary.converged = true;
      ++iteration;
      break;
    }
    last_full_step_mm = shrink == 1.0 ? step_mm : -1.0;
  }
  summary.num_iterations = iteration;
  return summary;
}

// DampedNewtonBySteps where `system(x, &g, &jacobian)` fills g(x) and dg/dx at
// x, and the step solves jacobian * dx = -g by LU with partial pivoting.
template <int N, typename System>
DampedNewtonSummary DampedNewton(const DampedNewtonOptions& options,
                                 const Eigen::Matrix<double, N, 1>& step_scale,
                                 const System& system,
                                 Eigen::Matrix<double, N, 1>* x) {
  Eigen::Matrix<double, N, 1> g;
  Eigen::Matrix<double, N, N> jacobian;
  return DampedNewtonBySteps<N>(
      options,
      step_scale,
      [&](const Eigen::Matrix<double, N, 1>& at,
          Eigen::Matrix<double, N, 1>* dx) {
        system(at, &g, &jacobian);
        *dx = SolveByPartialPivoting<N>(jacobian, -g);
      },
      x);
}

}  // namespace engine_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORE_DAMPED_NEWTON_H_
