#include "engine/core/axis_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/core/units.h"

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// sum_k c_k x^k by Horner. With phi1 of a few tenths of a radian the terms stay
// far below 1/eps times the sum even for coefficients of thousands of mm, so
// plain double suffices.
double Polynomial(const Eigen::VectorXd& c, double x) {
  double value = 0.0;
  for (int k = static_cast<int>(c.size()) - 1; k >= 0; --k)
    value = value * x + c(k);
  return value;
}

// Gauss-Legendre nodes and weights on [-1, 1] (n points, exact for degree 2n -
// 1): the roots of P_n by Newton from the usual cosine guesses, P_n by its
// three-term recurrence.
void GaussLegendre(int n,
                   std::vector<double>* nodes,
                   std::vector<double>* weights) {
  nodes->assign(n, 0.0);
  weights->assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double derivative = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = x;  // P_0, P_1
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      // p1 = P_n(x), p0 = P_{n-1}(x); P_n' = n (x P_n - P_{n-1}) / (x^2 - 1).
      derivative = n * (x * p1 - p0) / (x * x - 1.0);
      const double step = p1 / derivative;
      x -= step;
      if (std::fabs(step) < 1e-15) break;
    }
    (*nodes)[i] = x;
    (*weights)[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
  }
}

// max |p| over [a, b]: the largest of a fine sampling, then a golden-section
// search for the maximum of |p| between the neighbours of that sample. A
// polynomial of degree d has at most d - 1 extrema, so between two neighbours
// of the best of many samples |p| has a single peak.
double MaxAbsOverRange(const Eigen::VectorXd& c, double a, double b) {
  constexpr int kIntervals = 512;
  const double h = (b - a) / kIntervals;
  int best = 0;
  double best_value = -1.0;
  for (int i = 0; i <= kIntervals; ++i) {
    const double v = std::fabs(Polynomial(c, i == kIntervals ? b : a + i * h));
    if (v > best_value) {
      best_value = v;
      best = i;
    }
  }
  if (!(h > 0.0)) return best_value;
  double lo = a + std::max(0, best - 1) * h;
  double hi = best + 1 >= kIntervals ? b : a + (best + 1) * h;
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
  double f1 = std::fabs(Polynomial(c, x1)), f2 = std::fabs(Polynomial(c, x2));
  for (int iteration = 0;
       iteration < 80 && hi - lo > 1e-14 * (1.0 + std::fabs(lo));
       ++iteration) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - ratio * (hi - lo);
      f1 = std::fabs(Polynomial(c, x1));
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + ratio * (hi - lo);
      f2 = std::fabs(Polynomial(c, x2));
    }
  }
  return std::max({best_value, f1, f2});
}

}  // namespace

double AxisMotionUnitFactor(const std::string& unit, std::string* motion_unit) {
  if (unit == "mm") {
    *motion_unit = "um";
    return 1e3;
  }
  if (unit == "rad") {
    *motion_unit = "urad";
    return 1e6;
  }
  *motion_unit = unit;
  return 1.0;
}

AxisMotion ComputeAxisMotion(const std::vector<ParameterBlock>& blocks,
                             const Eigen::VectorXd& delta,
                             double roll_min_rad,
                             double roll_max_rad,
                             int num_samples) {
  AxisMotion motion;
  const int n = std::max(2, num_samples);
  const bool range_ok = std::isfinite(roll_min_rad) &&
                        std::isfinite(roll_max_rad) &&
                        roll_min_rad <= roll_max_rad;
  if (range_ok) {
    for (int i = 0; i < n; ++i) {
      // The last sample is the end itself, not a + (n - 1) h with its rounding.
      motion.roll_rad.push_back(
          i == n - 1
              ? roll_max_rad
              : roll_min_rad + (roll_max_rad - roll_min_rad) * i / (n - 1.0));
    }
  }
  for (const ParameterBlock& block : blocks) {
    BlockMotion b;
    b.name = block.name;
    b.is_polynomial = block.is_polynomial;
    const bool inside =
        block.first_index >= 0 && block.num_coefficients >= 0 &&
        block.first_index + block.num_coefficients <= delta.size();
    if (!block.is_polynomial) {
      b.unit = block.unit;
      const double value = inside && block.num_coefficients > 0
                               ? delta(block.first_index)
                               : kNaN;
      b.change = {value};
      b.rms = b.max_abs = std::fabs(value);
      motion.blocks.push_back(b);
      continue;
    }
    const double factor = AxisMotionUnitFactor(block.unit, &b.unit);
    if (!inside || !range_ok) {
      b.change.assign(motion.roll_rad.size(), kNaN);
      b.rms = b.max_abs = kNaN;
      motion.blocks.push_back(b);
      continue;
    }
    const Eigen::VectorXd c =
        delta.segment(block.first_index, block.num_coefficients) * factor;
    for (double roll : motion.roll_rad) b.change.push_back(Polynomial(c, roll));
    // mean of dC^2 over the range: dC^2 has degree 2(m - 1) for m coefficients,
    // integrated exactly by m Gauss-Legendre points; the weights sum to 2,
    // hence the half.
    const double centre = 0.5 * (roll_min_rad + roll_max_rad);
    const double half_width = 0.5 * (roll_max_rad - roll_min_rad);
    std::vector<double> nodes, weights;
    GaussLegendre(std::max(1, static_cast<int>(c.size())), &nodes, &weights);
    double mean2 = 0.0;
    for (size_t i = 0; i < nodes.size(); ++i) {
      const double v = Polynomial(c, centre + half_width * nodes[i]);
      mean2 += 0.5 * weights[i] * v * v;
    }
    b.rms = std::sqrt(mean2);
    b.max_abs = MaxAbsOverRange(c, roll_min_rad, roll_max_rad);
    motion.blocks.push_back(b);
  }
  return motion;
}

}  // namespace gearloop
