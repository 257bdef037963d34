#include "engine/grinder/target_modification.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gearloop {
namespace {

struct KindName {
  ModificationKind kind;
  const char* name;
};

constexpr KindName kKindNames[] = {
    {ModificationKind::kProfileCrowning, "profile_crowning"},
    {ModificationKind::kLeadCrowning, "lead_crowning"},
    {ModificationKind::kProfileSlope, "profile_slope"},
    {ModificationKind::kHelixSlope, "helix_slope"},
    {ModificationKind::kTipRelief, "tip_relief"},
    {ModificationKind::kRootRelief, "root_relief"},
    {ModificationKind::kEndRelief, "end_relief"},
    {ModificationKind::kFlankTwist, "flank_twist"},
    {ModificationKind::kDiagonalEndRelief, "diagonal_end_relief"},
};

double Exponent(ReliefShape shape) {
  return shape == ReliefShape::kParabolic ? 2.0 : 1.0;
}

// max(0, t)^e.
double Ramp(double t, double e) { return t > 0.0 ? std::pow(t, e) : 0.0; }

// Normalises v to [0, 1] over its own range; all zeros when the range is empty
// (a grid that is one point wide in that direction cannot happen for a valid
// grid, but stay finite).
Eigen::VectorXd NormaliseToUnit(const Eigen::VectorXd& v) {
  const double lo = v.minCoeff();
  const double hi = v.maxCoeff();
  if (!(hi > lo)) return Eigen::VectorXd::Zero(v.size());
  return (v.array() - lo) / (hi - lo);
}

}  // namespace

const char* ModificationKindName(ModificationKind kind) {
  for (const KindName& k : kKindNames) {
    if (k.kind == kind) return k.name;
  }
  return "unknown";
}

bool ParseModificationKind(const std::string& name, ModificationKind* kind) {
  for (const KindName& k : kKindNames) {
    if (name == k.name) {
      *kind = k.kind;
      return true;
    }
  }
  return false;
}

bool ValidateTargetModification(const TargetModification& m,
                                ValidationIssue* issue) {
  if (!std::isfinite(m.amount_um))
    return FailValidation(issue,
                          "amount_um",
                          "the amount must be a finite number of micrometres");
  const bool uses_length = m.kind == ModificationKind::kTipRelief ||
                           m.kind == ModificationKind::kRootRelief ||
                           m.kind == ModificationKind::kEndRelief ||
                           m.kind == ModificationKind::kDiagonalEndRelief;
  if (uses_length && !(m.length_fraction > 0.0 && m.length_fraction <= 1.0)) {
    return FailValidation(issue,
                          "length_fraction",
                          "the relief length fraction must lie in (0, 1]");
  }
  if (m.kind == ModificationKind::kDiagonalEndRelief) {
    if (!std::isfinite(m.second_amount_um)) {
      return FailValidation(
          issue,
          "second_amount_um",
          "the second amount must be a finite number of micrometres");
    }
    if (!(m.second_length_fraction > 0.0 && m.second_length_fraction <= 1.0)) {
      return FailValidation(issue,
                            "second_length_fraction",
                            "the second band fraction must lie in (0, 1]");
    }
    if (!std::isfinite(m.amount_gradient_um)) {
      return FailValidation(
          issue, "amount_gradient_um", "the amount gradient must be finite");
    }
    if (!std::isfinite(m.second_amount_gradient_um)) {
      return FailValidation(issue,
                            "second_amount_gradient_um",
                            "the amount gradient must be finite");
    }
  }
  return true;
}

TargetCoordinates ComputeTargetCoordinates(const FlankGrid& grid,
                                           const GearData& gear,
                                           Flank flank) {
  const int n = grid.NumPoints();
  Eigen::VectorXd roll(n), x(n);
  for (int i = 0; i < n; ++i) {
    roll(i) = grid.points[i].roll_length_mm;
    x(i) = grid.points[i].x_mm;
  }
  TargetCoordinates c;
  c.xi = NormaliseToUnit(roll);
  // eta: centred on the middle of the grid's lead extent, +-1 at its ends.
  c.eta = NormaliseToUnit(x).array() * 2.0 - 1.0;
  // The contact line of the flat generating plane on a helical involute is
  // straight in the (L, x) plane, at the base helix angle. In the frames of
  // MODEL.md §3 (the engine's), the nominal contact roll phi1 is constant along
  // L + x tan(beta_b) on the right flank and along L - x tan(beta_b) on the
  // left flank (mirror z -> -z of the right flank of gear -beta), with phi1 = w
  // / r_b + const: the sign sigma of MODEL.md §7 (corrected text). The right
  // flank's L + x tan(beta_b) is also SHAVING.md §2's contact-line coordinate
  // ("the points (L - t tan beta_b, x + t) are collinear").
  // tests/engine/target_modification_test.cc follows the wheel's instantaneous
  // contact line and checks that w stays put on both flanks.
  const double sign = flank == Flank::kRight ? 1.0 : -1.0;
  const double tan_beta_b = gear.TanBaseHelixAngle();
  c.w = NormaliseToUnit(roll + sign * tan_beta_b * x);
  return c;
}

double EvaluateTargetModification(const TargetModification& m,
                                  double xi,
                                  double eta,
                                  double w) {
  const double e = Exponent(m.shape);
  const double l = m.length_fraction;
  switch (m.kind) {
    case ModificationKind::kProfileCrowning:
      return -m.amount_um * (2.0 * xi - 1.0) * (2.0 * xi - 1.0);
    case ModificationKind::kLeadCrowning:
      return -m.amount_um * eta * eta;
    case ModificationKind::kProfileSlope:
      return m.amount_um * (xi - 0.5);
    case ModificationKind::kHelixSlope:
      return m.amount_um * eta / 2.0;
    case ModificationKind::kTipRelief:
      return -m.amount_um * Ramp((xi - (1.0 - l)) / l, e);
    case ModificationKind::kRootRelief:
      return -m.amount_um * Ramp((l - xi) / l, e);
    case ModificationKind::kEndRelief:
      return -m.amount_um * Ramp((std::abs(eta) - (1.0 - l)) / l, e);
    case ModificationKind::kFlankTwist:
      return m.amount_um * (xi - 0.5) * eta;
    case ModificationKind::kDiagonalEndRelief: {
      const double l2 = m.second_length_fraction;
      const double c1 = m.amount_um + m.amount_gradient_um * eta;
      const double c2 = m.second_amount_um + m.second_amount_gradient_um * eta;
      return -c1 * Ramp((l - w) / l, e) - c2 * Ramp((w - (1.0 - l2)) / l2, e);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

Eigen::VectorXd EvaluateTargetModifications(
    const std::vector<TargetModification>& modifications,
    const FlankGrid& grid,
    const GearData& gear,
    Flank flank) {
  const TargetCoordinates c = ComputeTargetCoordinates(grid, gear, flank);
  Eigen::VectorXd t = Eigen::VectorXd::Zero(grid.NumPoints());
  for (const TargetModification& m : modifications) {
    for (int i = 0; i < t.size(); ++i)
      t(i) += EvaluateTargetModification(m, c.xi(i), c.eta(i), c.w(i));
  }
  return t;
}

}  // namespace gearloop
