#include "engine/grinder/flat_wheel_grinder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "engine/core/units.h"
#include "tests/engine/flat_wheel_reference_values.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

using testing::CutterSetup;
using testing::Deg;
using testing::RightHandSetup;
using testing::SpurSetup;

// MODEL.md / issue 2: nominal settings generate the exact involute helicoid.
constexpr double kExactInvoluteTolUm = 1e-6;
// Issue 2: every column of S agrees with central differences of the exact
// model.
constexpr double kFiniteDifferenceRelTol = 1e-5;

struct NamedSetup {
  std::string name;
  GrindingSetup setup;
};

std::vector<NamedSetup> ExactInvoluteCases() {
  std::vector<NamedSetup> cases;
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    const std::string side = flank == Flank::kRight ? "right" : "left";
    cases.push_back({"spur/" + side, SpurSetup(flank)});
    cases.push_back({"left-hand cutter/" + side, CutterSetup(flank)});
    cases.push_back({"right-hand helical/" + side, RightHandSetup(flank)});
    GrindingSetup with_constants = CutterSetup(flank);
    with_constants.machine.k1_mm = 120.0;
    with_constants.machine.k2_mm = -40.0;
    cases.push_back({"cutter K1 K2/" + side, with_constants});
    GrindingSetup traversing = RightHandSetup(flank);
    traversing.machine.k1_mm = 85.0;
    traversing.machine.k2_mm = 30.0;
    traversing.machine.traverse_mm_per_rad = -8.0;
    cases.push_back({"right-hand K1 K2 traverse/" + side, traversing});
    GrindingSetup spur_constants = SpurSetup(flank);
    spur_constants.machine.k1_mm = -60.0;
    spur_constants.machine.k2_mm = 25.0;
    spur_constants.machine.traverse_mm_per_rad = 5.0;
    cases.push_back({"spur K1 K2 traverse/" + side, spur_constants});
  }
  return cases;
}

TEST(FlatWheelGrinder, NominalSettingsGenerateExactInvoluteHelicoid) {
  for (const NamedSetup& c : ExactInvoluteCases()) {
    SCOPED_TRACE(c.name);
    ValidationIssue issue;
    ASSERT_TRUE(ValidateSetup(c.setup, &issue))
        << issue.field << ": " << issue.message;
    const FlatWheelGrinder grinder(c.setup);
    ModelEvaluation eval;
    grinder.Evaluate(grinder.nominal().ToVector(), false, &eval);
    ASSERT_EQ(eval.deviations_um.size(), 45);
    EXPECT_TRUE(eval.AllReached()) << eval.NumReached() << " of 45 reached";
    for (int i = 0; i < 45; ++i) {
      if (eval.status[i] != PointStatus::kOk) continue;
      EXPECT_LT(std::abs(eval.deviations_um(i)), kExactInvoluteTolUm)
          << "point " << i;
    }
  }
}

TEST(FlatWheelGrinder, NominalContactsSpanThePublishedRollRange) {
  // MODEL.md §6: [-0.25, +0.13] rad on the default cutter.
  const FlatWheelGrinder grinder(CutterSetup());
  EXPECT_NEAR(grinder.roll_min_rad(), -0.25, 0.005);
  EXPECT_NEAR(grinder.roll_max_rad(), 0.13, 0.005);
}

TEST(FlatWheelGrinder, ContactSatisfiesMeshingEquationAndLiesOnTheFlank) {
  GrindingSetup setup = RightHandSetup(Flank::kLeft);
  setup.machine.k1_mm = 50.0;
  const FlatWheelGrinder grinder(setup);
  MachineSettings settings = grinder.nominal();
  settings.axes[static_cast<int>(Axis::kC)][2] = 2e-4;
  settings.wheel.parabola_coefficient_per_mm = 2e-5;
  settings.wheel.parabola_vertex_mm = 4.0;
  for (const FlankGridPoint& point : grinder.grid().points) {
    const EnvelopeContact contact = grinder.SolveContact(settings, point);
    ASSERT_EQ(contact.status, PointStatus::kOk);
    EXPECT_LE(contact.iterations, 10);
    double meshing = 1.0;
    const Eigen::Vector3d r1 = grinder.SurfacePoint(settings,
                                                    contact.wheel_u_mm,
                                                    contact.wheel_phi_rad,
                                                    contact.roll_rad,
                                                    &meshing);
    // The wheel point lies on the flank normal through the grid point, at
    // distance lambda.
    EXPECT_LT(
        (r1 - point.position_mm - contact.deviation_mm * point.normal).norm(),
        1e-10);
    // Meshing function relative to |N| |v| ~ R_w (R_w + r_j).
    EXPECT_LT(std::abs(meshing) / (300.0 * 350.0), 1e-12);
  }
}

// The right-hand gear with machine constants and a traversing wheel, so that
// no term of the chain is idle.
GrindingSetup EveryTermSetup(Flank flank) {
  GrindingSetup setup = RightHandSetup(flank);
  setup.machine.k1_mm = 85.0;
  setup.machine.k2_mm = 30.0;
  setup.machine.traverse_mm_per_rad = -8.0;
  return setup;
}

// The grinder's nominal settings with every axis coefficient moved by up to
// `linear` (X, Y, Z) or `angular` (A, B, C) per power of the roll (seeded).
Eigen::VectorXd MovedAxes(const FlatWheelGrinder& grinder,
                          unsigned seed,
                          double linear,
                          double angular) {
  Eigen::VectorXd zeta = grinder.nominal().ToVector();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int j = 0; j < kNumAxisCoefficients; ++j) {
    const int axis = j / kCoefficientsPerAxis;
    zeta(j) += unit(rng) * (axis < 3 ? linear : angular);
  }
  return zeta;
}

// The contact Newton's derivatives of (R1, f) by u_w, phi_w and phi1, written
// out by hand (SurfaceDerivatives), against five-point central differences of
// SurfacePoint, with every term of the chain at work: machine constants, a
// traversing wheel, cone angle and parabola, and every axis coefficient moved
// (fixed seed; A and B by up to 0.02 rad per power of the roll, so that their
// rates and accelerations turn the wheel visibly). At the nominal contacts
// and 1 mm / 0.01 rad / 0.02 rad of roll away from them.
constexpr double kSurfaceDerivativeRelTol = 1e-6;

TEST(FlatWheelGrinder, SurfaceDerivativesMatchCentralDifferences) {
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    SCOPED_TRACE(flank == Flank::kRight ? "right" : "left");
    const FlatWheelGrinder grinder(EveryTermSetup(flank));
    Eigen::VectorXd zeta = MovedAxes(grinder, 20261130, 0.5, 0.02);
    zeta(kConeAngleIndex) = Deg(0.5);
    zeta(kParabolaCoefficientIndex) = 3e-4;
    zeta(kParabolaVertexIndex) = 3.0;
    const MachineSettings settings = MachineSettings::FromVector(zeta);
    // Steps: u_w [mm], phi_w [rad], phi1 [rad].
    const double steps[3] = {1e-3, 1e-5, 1e-5};
    int compared = 0;
    for (const FlankGridPoint& point : grinder.grid().points) {
      const EnvelopeContact nominal =
          grinder.SolveContact(grinder.nominal(), point);
      ASSERT_EQ(nominal.status, PointStatus::kOk);
      for (const Eigen::Vector3d& offset :
           {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(1.0, 0.01, 0.02)}) {
        const double at[3] = {nominal.wheel_u_mm + offset(0),
                              nominal.wheel_phi_rad + offset(1),
                              nominal.roll_rad + offset(2)};
        const Eigen::Matrix<double, 4, 3> analytic =
            grinder.SurfaceDerivatives(settings, at[0], at[1], at[2]);
        Eigen::Matrix<double, 4, 3> fd;
        for (int k = 0; k < 3; ++k) {
          const auto value = [&](double shift) {
            double x[3] = {at[0], at[1], at[2]};
            x[k] += shift;
            Eigen::Vector4d v;
            double f = 0.0;
            v.head<3>() = grinder.SurfacePoint(settings, x[0], x[1], x[2], &f);
            v(3) = f;
            return v;
          };
          const double h = steps[k];
          fd.col(k) = (8.0 * (value(h) - value(-h)) -
                       (value(2.0 * h) - value(-2.0 * h))) /
                      (12.0 * h);
        }
        for (int k = 0; k < 3; ++k) {
          const double position_scale = fd.col(k).head<3>().norm();
          for (int i = 0; i < 4; ++i) {
            const double scale = i < 3 ? position_scale : std::abs(fd(3, k));
            EXPECT_NEAR(
                analytic(i, k), fd(i, k), kSurfaceDerivativeRelTol * scale)
                << "row " << i << ", column " << k << ", grid point "
                << point.row << "/" << point.column;
            ++compared;
          }
        }
      }
    }
    EXPECT_EQ(compared, 45 * 2 * 12);
  }
}

// Central differences of the exact model (the five-point central formula,
// truncation error O(h^4)), with steps chosen per parameter so that each moves
// the wheel by about 10 nm at the ends of the roll range used: the
// pressure-angle and helix axes are strongly nonlinear.
Eigen::MatrixXd CentralDifferences(const FlatWheelGrinder& grinder,
                                   const Eigen::VectorXd& zeta) {
  const double roll_extent = std::max(std::abs(grinder.roll_min_rad()),
                                      std::abs(grinder.roll_max_rad()));
  const double r_j = grinder.setup().gear.PitchRadiusMm();
  const double motion_mm = 1e-5;
  Eigen::MatrixXd fd(45, 45);
  for (int j = 0; j < 45; ++j) {
    double step = 0.0;
    if (j < kNumAxisCoefficients) {
      const int axis = j / kCoefficientsPerAxis;
      const int order = j % kCoefficientsPerAxis;
      step = (axis < 3 ? motion_mm : motion_mm / r_j) /
             std::pow(roll_extent, order);
    } else if (j == kConeAngleIndex) {
      step = motion_mm / grinder.setup().wheel.radius_mm;
    } else if (j == kParabolaCoefficientIndex) {
      step = 1e-9;
    } else {
      step = 1e-3;
    }
    Eigen::VectorXd deviations[4];
    const double offsets[4] = {-2.0, -1.0, 1.0, 2.0};
    for (int s = 0; s < 4; ++s) {
      Eigen::VectorXd shifted = zeta;
      shifted(j) += offsets[s] * step;
      ModelEvaluation e;
      grinder.Evaluate(shifted, false, &e);
      deviations[s] = e.deviations_um;
    }
    fd.col(j) = (deviations[0] - 8.0 * deviations[1] + 8.0 * deviations[2] -
                 deviations[3]) /
                (12.0 * step);
  }
  return fd;
}

void ExpectJacobianMatchesCentralDifferences(const FlatWheelGrinder& grinder,
                                             const Eigen::VectorXd& zeta) {
  ModelEvaluation eval;
  grinder.Evaluate(zeta, true, &eval);
  ASSERT_TRUE(eval.AllReached());
  const Eigen::MatrixXd fd = CentralDifferences(grinder, zeta);
  for (int j = 0; j < 45; ++j) {
    const double column_size = eval.jacobian_um.col(j).cwiseAbs().maxCoeff();
    // A column without effect (d_w while a_w = 0) must be zero in both.
    const double tolerance = kFiniteDifferenceRelTol * column_size + 1e-9;
    for (int i = 0; i < 45; ++i) {
      EXPECT_NEAR(eval.jacobian_um(i, j), fd(i, j), tolerance)
          << "row " << i << " column " << j << " (" << GrinderParameterName(j)
          << ")";
    }
  }
}

// The reference cases of the faster Evaluate: three gears (left-hand cutter,
// right flank; right-hand helical with K1, K2 and a traverse, left flank; spur,
// right flank), every parameter away from nominal (fixed seed), the wheel
// profile too, so that every term of the chain and of its derivatives works.
std::vector<NamedSetup> ReferenceCases() {
  GrindingSetup helical = RightHandSetup(Flank::kLeft);
  helical.machine.k1_mm = 85.0;
  helical.machine.k2_mm = 30.0;
  helical.machine.traverse_mm_per_rad = -8.0;
  return {{"cutter/right", CutterSetup(Flank::kRight)},
          {"right-hand K1 K2 traverse/left", helical},
          {"spur/right", SpurSetup(Flank::kRight)}};
}

Eigen::VectorXd ReferenceSettings(const FlatWheelGrinder& grinder) {
  Eigen::VectorXd zeta = grinder.nominal().ToVector();
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int j = 0; j < kNumAxisCoefficients; ++j) {
    const int axis = j / kCoefficientsPerAxis;
    zeta(j) += unit(rng) * (axis < 3 ? 2e-3 : 2e-5);
  }
  zeta(kConeAngleIndex) = Deg(0.01);
  zeta(kParabolaCoefficientIndex) = 2e-5;
  zeta(kParabolaVertexIndex) = 2.0;
  return zeta;
}

// A direction touching every parameter, each by its block's default scale
// (fixed seed): the Jacobian is compared through J d.
Eigen::VectorXd ReferenceDirection(const FlatWheelGrinder& grinder) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(grinder.NumParameters());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const ParameterBlock& block : grinder.ParameterBlocks()) {
    const double scale = block.fixed_by_default ? 1e-3 : block.default_scale;
    for (int k = 0; k < block.num_coefficients; ++k)
      d(block.first_index + k) = unit(rng) * scale;
  }
  return d;
}

// The faster Evaluate (the sensitivity by Jets of the 8 local variables that
// enter non-linearly, the profile held in Newton) against the algorithm it
// replaced, on three gears away from nominal: every deviation within 1e-9 mm,
// every entry of J d within 1e-9 of the largest.
constexpr double kReferenceDeviationTolUm = 1e-6;
constexpr double kReferenceJacobianRelTol = 1e-9;

TEST(FlatWheelGrinder, FasterEvaluateAgreesWithThePreviousAlgorithm) {
  const std::vector<NamedSetup> cases = ReferenceCases();
  for (size_t c = 0; c < cases.size(); ++c) {
    SCOPED_TRACE(cases[c].name);
    const testing::FlatWheelReference& reference =
        testing::kFlatWheelReferences[c];
    const FlatWheelGrinder grinder(cases[c].setup);
    ModelEvaluation eval;
    grinder.Evaluate(ReferenceSettings(grinder), true, &eval);
    ASSERT_TRUE(eval.AllReached());
    ASSERT_EQ(eval.deviations_um.size(), 45);
    const Eigen::VectorXd jd = eval.jacobian_um * ReferenceDirection(grinder);
    const Eigen::Map<const Eigen::VectorXd> jd_reference(
        reference.jacobian_times_direction_um, 45);
    const double jd_tol_um =
        kReferenceJacobianRelTol * jd_reference.cwiseAbs().maxCoeff();
    for (int i = 0; i < 45; ++i) {
      EXPECT_NEAR(eval.deviations_um(i),
                  reference.deviations_um[i],
                  kReferenceDeviationTolUm)
          << "point " << i;
      EXPECT_NEAR(jd(i), jd_reference(i), jd_tol_um) << "point " << i;
    }
  }
}

// Evaluate answers the same with and without the Jacobian: both solve each
// contact by the same Newton from the same first guess (exactly equal).
TEST(FlatWheelGrinder, EvaluateWithAndWithoutJacobianAgreeExactly) {
  for (const NamedSetup& c : ReferenceCases()) {
    SCOPED_TRACE(c.name);
    const FlatWheelGrinder grinder(c.setup);
    for (const Eigen::VectorXd& zeta :
         {grinder.nominal().ToVector(), ReferenceSettings(grinder)}) {
      ModelEvaluation with, without;
      grinder.Evaluate(zeta, true, &with);
      grinder.Evaluate(zeta, false, &without);
      EXPECT_EQ(without.jacobian_um.size(), 0);
      ASSERT_EQ(with.deviations_um.size(), without.deviations_um.size());
      for (int i = 0; i < with.deviations_um.size(); ++i) {
        EXPECT_EQ(with.status[i], without.status[i]) << "point " << i;
        EXPECT_EQ(with.deviations_um(i), without.deviations_um(i))
            << "point " << i;
        const bool both_nan = std::isnan(with.contact_roll_rad[i]) &&
                              std::isnan(without.contact_roll_rad[i]);
        if (!both_nan) {
          EXPECT_EQ(with.contact_roll_rad[i], without.contact_roll_rad[i]);
          EXPECT_EQ(with.contact_margin_mm[i], without.contact_margin_mm[i]);
        }
      }
    }
  }
}

// SolveContact and Evaluate start every point's Newton at its contact at the
// nominal settings and follow it there the same way (SolveGroundContact):
// the same contact, bit for bit, at the reference settings and at settings
// far enough off (the wheel 0.3 mm deeper, the work axis' quadratic term 50
// times the reference's) that contacts leave their nominal roll.
TEST(FlatWheelGrinder, SolveContactAndEvaluateFindTheSameContacts) {
  for (const NamedSetup& c : ReferenceCases()) {
    SCOPED_TRACE(c.name);
    const FlatWheelGrinder grinder(c.setup);
    MachineSettings far =
        MachineSettings::FromVector(ReferenceSettings(grinder));
    far.axes[static_cast<int>(Axis::kY)][0] -= 0.3;
    far.axes[static_cast<int>(Axis::kC)][2] *= 50.0;
    for (const Eigen::VectorXd& zeta :
         {ReferenceSettings(grinder), far.ToVector()}) {
      ModelEvaluation eval;
      grinder.Evaluate(zeta, false, &eval);
      const MachineSettings settings = MachineSettings::FromVector(zeta);
      for (int i = 0; i < eval.deviations_um.size(); ++i) {
        const EnvelopeContact contact =
            grinder.SolveContact(settings, grinder.grid().points[i]);
        ASSERT_EQ(contact.status, eval.status[i]) << "point " << i;
        if (contact.status != PointStatus::kOk) continue;
        EXPECT_EQ(contact.deviation_mm * 1e3, eval.deviations_um(i))
            << "point " << i;
        EXPECT_EQ(contact.roll_rad, eval.contact_roll_rad[i]) << "point " << i;
      }
    }
  }
}

TEST(FlatWheelGrinder, SensitivityMatchesCentralDifferencesAtNominal) {
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    SCOPED_TRACE(flank == Flank::kRight ? "right" : "left");
    const FlatWheelGrinder grinder(CutterSetup(flank));
    ExpectJacobianMatchesCentralDifferences(grinder,
                                            grinder.nominal().ToVector());
  }
}

TEST(FlatWheelGrinder, SensitivityMatchesCentralDifferencesAwayFromNominal) {
  // Every parameter away from its nominal value (fixed seed), with machine
  // constants and a traversing wheel, so that no term of the chain is idle.
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    SCOPED_TRACE(flank == Flank::kRight ? "right" : "left");
    const FlatWheelGrinder grinder(EveryTermSetup(flank));
    Eigen::VectorXd zeta = MovedAxes(grinder, 20261122, 5e-3, 5e-5);
    zeta(kConeAngleIndex) = Deg(0.02);
    zeta(kParabolaCoefficientIndex) = 3e-5;
    zeta(kParabolaVertexIndex) = 3.0;
    ExpectJacobianMatchesCentralDifferences(grinder, zeta);
  }
}

TEST(FlatWheelGrinder, ConeAngleRemovesMaterialInProportionToDistanceFromRim) {
  const FlatWheelGrinder grinder(CutterSetup());
  MachineSettings settings = grinder.nominal();
  const double cone_rad = 1e-4;
  settings.wheel.cone_angle_rad = cone_rad;
  for (const FlankGridPoint& point : grinder.grid().points) {
    const EnvelopeContact contact = grinder.SolveContact(settings, point);
    ASSERT_EQ(contact.status, PointStatus::kOk);
    const double expected_mm = -contact.wheel_u_mm * cone_rad;
    // First order in theta_w: the rest is of relative order theta_w and the
    // profile slope.
    EXPECT_NEAR(contact.deviation_mm, expected_mm, 2e-3 * std::abs(expected_mm))
        << "point " << point.row << "," << point.column;
    EXPECT_LT(contact.deviation_mm, 0.0);
  }
}

// MODEL.md §3: the same wheel profile on the left flank of gear beta and on the
// right flank of gear -beta gives identical grids, row for row and column for
// column.
TEST(FlatWheelGrinder, LeftFlankMirrorsRightFlankOfOppositeHelix) {
  for (GrindingSetup left :
       {CutterSetup(Flank::kLeft), RightHandSetup(Flank::kLeft)}) {
    left.machine.k1_mm = 40.0;
    left.machine.k2_mm = -15.0;
    GrindingSetup right = left;
    right.flank = Flank::kRight;
    right.gear.helix_angle_rad = -left.gear.helix_angle_rad;
    const FlatWheelGrinder left_grinder(left);
    const FlatWheelGrinder right_grinder(right);
    MachineSettings left_settings = left_grinder.nominal();
    MachineSettings right_settings = right_grinder.nominal();
    for (MachineSettings* s : {&left_settings, &right_settings}) {
      s->wheel.cone_angle_rad = Deg(0.03);
      s->wheel.parabola_coefficient_per_mm = 4e-5;
      s->wheel.parabola_vertex_mm = 6.0;
    }
    ModelEvaluation left_eval, right_eval;
    left_grinder.Evaluate(left_settings.ToVector(), true, &left_eval);
    right_grinder.Evaluate(right_settings.ToVector(), true, &right_eval);
    ASSERT_TRUE(left_eval.AllReached());
    ASSERT_TRUE(right_eval.AllReached());
    EXPECT_GT(left_eval.deviations_um.cwiseAbs().maxCoeff(),
              1.0);  // the profile does something
    for (int i = 0; i < 45; ++i) {
      EXPECT_NEAR(left_eval.deviations_um(i), right_eval.deviations_um(i), 1e-7)
          << "point " << i;
    }
    // The wheel-profile sensitivities are the same too.
    for (int j = kNumAxisCoefficients; j < kNumGrinderParameters; ++j) {
      EXPECT_LT(
          (left_eval.jacobian_um.col(j) - right_eval.jacobian_um.col(j)).norm(),
          1e-6 * (1.0 + right_eval.jacobian_um.col(j).norm()))
          << GrinderParameterName(j);
    }
  }
}

TEST(FlatWheelGrinder, MirroredAxisMotionsGiveTheSameGrid) {
  // The mapping stated in engine/grinder/flat_wheel_grinder.h: X_L(phi) =
  // X_R(-phi), Y_L(phi) = Y_R(-phi), Z_L(phi) = -Z_R(-phi), A, B, C_L(phi) =
  // -A, -B, -C_R(-phi).
  GrindingSetup right = CutterSetup(Flank::kRight);
  right.gear.helix_angle_rad = -right.gear.helix_angle_rad;
  GrindingSetup left = CutterSetup(Flank::kLeft);
  const FlatWheelGrinder right_grinder(right);
  const FlatWheelGrinder left_grinder(left);
  MachineSettings right_settings = right_grinder.nominal();
  right_settings.axes[0][1] += 3e-3;  // X drift
  right_settings.axes[2][2] += 5e-3;  // Z parabola
  right_settings.axes[3][1] += 4e-5;  // A drift
  right_settings.axes[5][3] += 1e-4;  // C cubic
  MachineSettings left_settings;
  const double sign[kNumAxes] = {1.0, 1.0, -1.0, -1.0, -1.0, -1.0};
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k) {
      left_settings.axes[i][k] =
          sign[i] * right_settings.axes[i][k] * (k % 2 == 0 ? 1.0 : -1.0);
    }
  }
  // The nominal right/left settings must map onto each other exactly (checks
  // NominalSettings).
  MachineSettings mapped_nominal;
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k) {
      mapped_nominal.axes[i][k] = sign[i] * right_grinder.nominal().axes[i][k] *
                                  (k % 2 == 0 ? 1.0 : -1.0);
      EXPECT_NEAR(
          mapped_nominal.axes[i][k], left_grinder.nominal().axes[i][k], 1e-12)
          << i << "," << k;
    }
  }
  ModelEvaluation right_eval, left_eval;
  right_grinder.Evaluate(right_settings.ToVector(), false, &right_eval);
  left_grinder.Evaluate(left_settings.ToVector(), false, &left_eval);
  EXPECT_GT(right_eval.deviations_um.cwiseAbs().maxCoeff(), 1.0);
  for (int i = 0; i < 45; ++i) {
    ASSERT_EQ(right_eval.status[i], left_eval.status[i]);
    EXPECT_NEAR(right_eval.deviations_um(i), left_eval.deviations_um(i), 1e-7)
        << "point " << i;
  }
}

// A wide spur gear on a small fixed wheel: the rim rises toward the face ends
// by about s^2 / (2 R_w), so the root corners are lost, the middle column is
// not.
GrindingSetup WideGearOnASmallWheel() {
  GrindingSetup setup = SpurSetup();
  setup.gear.face_width_mm = 160.0;
  setup.wheel.radius_mm = 60.0;
  setup.grid.profile_begin = 0.0;
  setup.grid.lead_begin = -0.5;
  setup.grid.lead_end = 0.5;
  return setup;
}

TEST(FlatWheelGrinder, PointsBeyondTheRimAreNotReachedNeverNumbers) {
  const GrindingSetup setup = WideGearOnASmallWheel();
  ValidationIssue issue;
  ASSERT_TRUE(ValidateSetup(setup, &issue)) << issue.message;
  const FlatWheelGrinder grinder(setup);
  ModelEvaluation eval;
  grinder.Evaluate(grinder.nominal().ToVector(), true, &eval);
  EXPECT_EQ(eval.status[0], PointStatus::kNotReached);  // root row, x = -b/2
  EXPECT_EQ(eval.status[8], PointStatus::kNotReached);  // root row, x = +b/2
  EXPECT_LT(eval.NumReached(), 45);
  for (int row = 0; row < 5; ++row)
    EXPECT_EQ(eval.status[row * 9 + 4], PointStatus::kOk) << "row " << row;
  for (int i = 0; i < 45; ++i) {
    if (eval.status[i] == PointStatus::kOk) {
      EXPECT_LT(std::abs(eval.deviations_um(i)), kExactInvoluteTolUm);
    } else {
      EXPECT_EQ(eval.deviations_um(i), 0.0);
      EXPECT_TRUE(std::isnan(eval.contact_roll_rad[i]));
      EXPECT_EQ(eval.jacobian_um.row(i).norm(), 0.0);
    }
  }
}

// The contact margin is how far inside the wheel each contact lies: the
// nearer of the rim (u_w = 0) and the wheel centre (u_w = R), from the same
// contact SolveContact finds; negative exactly where the rim does not reach.
TEST(FlatWheelGrinder, ContactMarginIsTheDistanceInsideTheWheel) {
  const GrindingSetup setup = WideGearOnASmallWheel();
  ValidationIssue issue;
  ASSERT_TRUE(ValidateSetup(setup, &issue)) << issue.message;
  const FlatWheelGrinder grinder(setup);
  ModelEvaluation eval;
  grinder.Evaluate(grinder.nominal().ToVector(), false, &eval);
  ASSERT_EQ(eval.contact_margin_mm.size(), 45u);
  int reached = 0, not_reached = 0;
  for (int i = 0; i < 45; ++i) {
    const EnvelopeContact contact =
        grinder.SolveContact(grinder.nominal(), grinder.grid().points[i]);
    ASSERT_EQ(contact.status, eval.status[i]) << "point " << i;
    if (contact.status == PointStatus::kNotConverged) {
      EXPECT_TRUE(std::isnan(eval.contact_margin_mm[i])) << "point " << i;
      continue;
    }
    const double inside_mm = std::min(
        contact.wheel_u_mm, setup.wheel.radius_mm - contact.wheel_u_mm);
    // A reached contact on the rim itself (the grid begins at the form point)
    // may lie a rounding error beyond it: its margin is 0.
    const double expected_mm = contact.status == PointStatus::kOk
                                   ? std::max(inside_mm, 0.0)
                                   : inside_mm;
    EXPECT_EQ(eval.contact_margin_mm[i], expected_mm) << "point " << i;
    if (contact.status == PointStatus::kOk) {
      EXPECT_GE(eval.contact_margin_mm[i], 0.0) << "point " << i;
      ++reached;
    } else {
      EXPECT_LT(eval.contact_margin_mm[i], 0.0) << "point " << i;
      ++not_reached;
    }
  }
  EXPECT_GT(reached, 0);
  EXPECT_GT(not_reached, 0);  // the root corners lie beyond the rim
}

TEST(FlatWheelGrinder, FarBranchesOfTheEnvelopeAreNotReportedAsNumbers) {
  // Absurd settings (a correction gone wrong): the wheel 10 mm deeper (3.4 mm
  // into the flank) and the work axis running 30 % fast. Whatever Newton finds
  // there is never a number millimetres off.
  const FlatWheelGrinder grinder(SpurSetup());
  MachineSettings settings = grinder.nominal();
  settings.axes[static_cast<int>(Axis::kY)][0] -= 10.0;
  ModelEvaluation eval;
  grinder.Evaluate(settings.ToVector(), false, &eval);
  for (int i = 0; i < 45; ++i)
    EXPECT_NE(eval.status[i], PointStatus::kOk) << "point " << i;
  settings = grinder.nominal();
  settings.axes[static_cast<int>(Axis::kC)][1] = 1.3;
  grinder.Evaluate(settings.ToVector(), false, &eval);
  for (int i = 0; i < 45; ++i) {
    if (eval.status[i] == PointStatus::kOk) {
      EXPECT_LT(std::abs(eval.deviations_um(i)), 2000.0) << "point " << i;
      EXPECT_LT(std::abs(eval.contact_roll_rad[i]), 1.0) << "point " << i;
    }
  }
}

TEST(FlatWheelGrinder, ParameterBlocksCoverEveryParameterOnce) {
  const FlatWheelGrinder grinder(CutterSetup());
  std::vector<int> seen(grinder.NumParameters(), 0);
  for (const ParameterBlock& block : grinder.ParameterBlocks()) {
    for (int k = 0; k < block.num_coefficients; ++k)
      ++seen[block.first_index + k];
    EXPECT_GT(block.default_scale, 0.0) << block.name;
  }
  for (int j = 0; j < grinder.NumParameters(); ++j)
    EXPECT_EQ(seen[j], 1) << grinder.ParameterName(j);
  EXPECT_EQ(grinder.ParameterName(0), "X0");
  EXPECT_EQ(grinder.ParameterName(41), "C6");
  EXPECT_EQ(grinder.ParameterName(42), "cone_angle");
}

TEST(MachineSettings, VectorRoundTripAndPolynomials) {
  MachineSettings s;
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k)
      s.axes[i][k] = 0.1 * i + 0.01 * k + 1.0;
  }
  s.wheel = {0.001, 2e-5, 3.0};
  const MachineSettings back = MachineSettings::FromVector(s.ToVector());
  EXPECT_EQ(back.ToVector(), s.ToVector());
  const double roll = 0.3;
  double value = 0.0, rate = 0.0;
  for (int k = 0; k < kCoefficientsPerAxis; ++k) {
    value += s.axes[2][k] * std::pow(roll, k);
    if (k > 0) rate += k * s.axes[2][k] * std::pow(roll, k - 1);
  }
  EXPECT_NEAR(s.AxisValue(Axis::kZ, roll), value, 1e-14);
  EXPECT_NEAR(s.AxisRate(Axis::kZ, roll), rate, 1e-14);
}

TEST(MachineSettings, NominalRightFlankMatchesModelFormulas) {
  // MODEL.md §2 evaluated by hand for the cutter: s_y = R_w cos a - r_j + r_f,
  // s_z = pi m/4 - s_y tan a.
  const GrindingSetup setup = CutterSetup();
  const MachineSettings s = NominalSettings(setup);
  const double r_j = setup.gear.PitchRadiusMm();
  const double s_y = 350.0 * std::cos(Deg(20)) - r_j + 107.1569;
  const double s_z = kPi * 6.0 / 4.0 - s_y * std::tan(Deg(20));
  EXPECT_NEAR(s.axes[1][0], r_j + s_y, 1e-12);
  EXPECT_NEAR(s.axes[0][0], -s_z * std::sin(Deg(15)), 1e-12);
  EXPECT_NEAR(s.axes[2][0], -s_z * std::cos(Deg(15)), 1e-12);
  EXPECT_NEAR(s.axes[2][1], -r_j, 1e-12);
  EXPECT_NEAR(s.axes[3][0], Deg(20), 1e-15);
  EXPECT_NEAR(s.axes[4][0], Deg(15), 1e-15);
  EXPECT_EQ(s.axes[5][1], 1.0);
  // The published nominal settings of the same cutter (Jiang 2015, Table 4, cut
  // to 4 decimals).
  EXPECT_NEAR(s.axes[0][0], 29.0319, 1e-4);
  EXPECT_NEAR(s.axes[1][0], 436.0493, 1e-4);
  EXPECT_NEAR(s.axes[2][0], 108.3485, 1e-4);
  EXPECT_NEAR(s.axes[2][1], -114.9156, 1e-4);
}

}  // namespace
// The correction's evaluation memo asks for the Jacobian of an evaluation made
// without it (AddJacobian): it must be Evaluate's with the Jacobian, number
// for number, also where points are not reached (zero rows) and when the
// evaluation kept no contacts (then the model evaluates again).
void ExpectAddJacobianIsEvaluatesJacobian(const FlatWheelGrinder& grinder,
                                          const Eigen::VectorXd& zeta) {
  ModelEvaluation with, added, refilled;
  grinder.Evaluate(zeta, true, &with);
  grinder.Evaluate(zeta, false, &added);
  ASSERT_EQ(added.contact_unknowns.rows(), 45);
  grinder.AddJacobian(zeta, &added);
  grinder.Evaluate(zeta, false, &refilled);
  refilled.contact_unknowns.resize(0, 0);
  grinder.AddJacobian(zeta, &refilled);
  for (const ModelEvaluation* other : {&added, &refilled}) {
    ASSERT_EQ(other->jacobian_um.rows(), with.jacobian_um.rows());
    ASSERT_EQ(other->jacobian_um.cols(), with.jacobian_um.cols());
    for (int i = 0; i < with.jacobian_um.rows(); ++i) {
      EXPECT_EQ(other->status[i], with.status[i]) << "point " << i;
      EXPECT_EQ(other->deviations_um(i), with.deviations_um(i))
          << "point " << i;
      for (int j = 0; j < with.jacobian_um.cols(); ++j)
        EXPECT_EQ(other->jacobian_um(i, j), with.jacobian_um(i, j))
            << "point " << i << ", parameter " << j;
    }
  }
}

TEST(FlatWheelGrinder, AddJacobianIsEvaluatesJacobianExactly) {
  for (const NamedSetup& c : ReferenceCases()) {
    SCOPED_TRACE(c.name);
    const FlatWheelGrinder grinder(c.setup);
    ExpectAddJacobianIsEvaluatesJacobian(grinder, grinder.nominal().ToVector());
    ExpectAddJacobianIsEvaluatesJacobian(grinder, ReferenceSettings(grinder));
  }
  SCOPED_TRACE("points beyond the rim");
  const FlatWheelGrinder wide(WideGearOnASmallWheel());
  ModelEvaluation eval;
  wide.Evaluate(wide.nominal().ToVector(), false, &eval);
  ASSERT_LT(eval.NumReached(), 45);
  ExpectAddJacobianIsEvaluatesJacobian(wide, wide.nominal().ToVector());
}

}  // namespace gearloop
