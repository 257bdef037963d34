#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/metrology/trace_grid.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::FlankForms;
using testing::FormsAt;
using testing::FormsOnGrid;
using testing::SampleForms;
using testing::SampleGear;

// A profile trace at z (from the datum face at x = -b/2) over d_begin..d_end in
// equal roll-length steps, and a helix trace at d over z_begin..z_end, sampled
// from `forms`.
MeasuredTrace Profile(const GearData& gear,
                      const FlankForms& forms,
                      Flank flank,
                      double z,
                      int n = 48) {
  MeasuredTrace t;
  t.kind = TraceKind::kProfile;
  t.flank = flank;
  t.position_mm = z;
  t.begin_mm = 140.5;
  t.end_mm = 157.0;
  const double l0 = RollLengthOfDiameterMm(gear, t.begin_mm);
  const double l1 = RollLengthOfDiameterMm(gear, t.end_mm);
  for (int i = 0; i < n; ++i) {
    t.values_um.push_back(FormsAt(
        forms, gear, l0 + (l1 - l0) * i / (n - 1), z - gear.face_width_mm / 2));
  }
  return t;
}

MeasuredTrace Helix(const GearData& gear,
                    const FlankForms& forms,
                    Flank flank,
                    double d,
                    int n = 48) {
  MeasuredTrace t;
  t.kind = TraceKind::kHelix;
  t.flank = flank;
  t.position_mm = d;
  t.begin_mm = 1.0;
  t.end_mm = 39.0;
  for (int i = 0; i < n; ++i) {
    const double z = t.begin_mm + (t.end_mm - t.begin_mm) * i / (n - 1);
    t.values_um.push_back(FormsAt(forms,
                                  gear,
                                  RollLengthOfDiameterMm(gear, d),
                                  z - gear.face_width_mm / 2));
  }
  return t;
}

std::vector<MeasuredTrace> SampleNetwork(const GearData& gear,
                                         const FlankForms& forms,
                                         Flank flank) {
  std::vector<MeasuredTrace> traces;
  for (double z : {3.0, 11.5, 20.0, 28.5, 37.0})
    traces.push_back(Profile(gear, forms, flank, z));
  for (double d : {143.0, 147.0, 151.0, 155.0})
    traces.push_back(Helix(gear, forms, flank, d));
  return traces;
}

TEST(GridCoordinates, TheSampleGearsRowsAndColumns) {
  const GearData gear = SampleGear();
  EXPECT_NEAR(2 * gear.BaseRadiusMm(), 138.432, 5e-4);
  EXPECT_NEAR(gear.FormRollLengthMm(), 11.234, 5e-4);
  EXPECT_NEAR(gear.TipRollLengthMm(), 37.509, 5e-4);
  const std::vector<double> l = GridRollLengthsMm(gear, GridOptions{});
  const double expected[] = {16.489, 21.088, 25.686, 30.284, 34.882};
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(l[i], expected[i], 5e-4) << i;
  const std::vector<double> x = GridAxialPositionsMm(gear, GridOptions{});
  EXPECT_DOUBLE_EQ(x.front(), -16.0);
  EXPECT_DOUBLE_EQ(x.back(), 16.0);
  EXPECT_NEAR(
      DiameterOfRollLengthMm(gear, RollLengthOfDiameterMm(gear, 148.453)),
      148.453,
      1e-12);
}

TEST(InterpolateTraces, ExactForProfilePlusLeadFormsPlusTwist) {
  const GearData gear = SampleGear();
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    const FlankForms forms = SampleForms(flank);
    TraceGridOptions options;
    options.flank = flank;
    const TraceGridResult result = InterpolateTraces(
        options, gear, GridOptions{}, SampleNetwork(gear, forms, flank));
    ASSERT_TRUE(result.ok) << result.message;
    EXPECT_TRUE(result.not_measured.empty());
    EXPECT_EQ(result.profile_traces, 5);
    EXPECT_EQ(result.helix_traces, 4);
    EXPECT_LT(result.max_crossing_mismatch_um, 1e-9);
    const Eigen::VectorXd truth = FormsOnGrid(forms, gear);
    for (int p = 0; p < 45; ++p)
      EXPECT_NEAR(result.deviations_um[p], truth[p], /*tol_um=*/1e-9) << p;
  }
}

TEST(InterpolateTraces, OneProfileAndOneHelixTraceIsTheSumModel) {
  const GearData gear = SampleGear();
  const FlankForms forms{
      3.0, 6.0, 4.0, 5.0, 0.0, 1.0};  // no twist: the sum model is exact
  const std::vector<MeasuredTrace> traces = {
      Profile(gear, forms, Flank::kRight, 20.0),
      Helix(gear, forms, Flank::kRight, 148.453)};
  const TraceGridResult result =
      InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  ASSERT_TRUE(result.ok) << result.message;
  const Eigen::VectorXd truth = FormsOnGrid(forms, gear);
  for (int p = 0; p < 45; ++p)
    EXPECT_NEAR(result.deviations_um[p], truth[p], 1e-9) << p;
}

TEST(InterpolateTraces,
     ExtrapolatesLinearlyAtMostATenthBeyondTheOutermostTrace) {
  const GearData gear = SampleGear();
  const FlankForms forms = SampleForms(Flank::kRight);
  const Eigen::VectorXd truth = FormsOnGrid(forms, gear);
  auto network = [&](std::vector<double> zs) {
    std::vector<MeasuredTrace> traces;
    for (double z : zs)
      traces.push_back(Profile(gear, forms, Flank::kRight, z));
    for (double d : {143.0, 147.0, 151.0, 155.0})
      traces.push_back(Helix(gear, forms, Flank::kRight, d));
    return traces;
  };
  // Outer columns at z = 4 and 36: 3.5 mm beyond traces at 7.5 and 32.5, within
  // 0.1 b = 4 mm, and exact (linear extrapolation across traces reproduces the
  // twist).
  TraceGridResult result = InterpolateTraces(
      TraceGridOptions{}, gear, GridOptions{}, network({7.5, 20.0, 32.5}));
  ASSERT_TRUE(result.ok) << result.message;
  for (int p = 0; p < 45; ++p)
    EXPECT_NEAR(result.deviations_um[p], truth[p], 1e-9) << p;
  // 6 mm beyond traces at 10 and 30: column 0 cannot be formed, and a grid
  // trace without 3 points is refused (METROLOGY.md §5).
  result = InterpolateTraces(
      TraceGridOptions{}, gear, GridOptions{}, network({10.0, 20.0, 30.0}));
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("grid column 0"), std::string::npos)
      << result.message;
  TraceGridOptions wider;
  wider.max_extrapolation_fraction = 0.2;
  result = InterpolateTraces(
      wider, gear, GridOptions{}, network({10.0, 20.0, 30.0}));
  ASSERT_TRUE(result.ok) << result.message;
  EXPECT_NEAR(result.deviations_um[0], truth[0], 1e-9);
}

TEST(InterpolateTraces, RefusesAGridRowWithFewerThanThreePoints) {
  const GearData gear = SampleGear();
  const FlankForms forms = SampleForms(Flank::kRight);
  std::vector<MeasuredTrace> traces = {
      Profile(gear, forms, Flank::kRight, 20.0)};
  traces.push_back(Helix(gear, forms, Flank::kRight, 143.0));
  traces.back().begin_mm = 19.0;
  traces.back().end_mm = 21.0;  // a helix trace over 2 mm of the face
  const TraceGridResult result =
      InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("figures need 3"), std::string::npos)
      << result.message;
}

TEST(InterpolateTraces, AveragesTeethAndReportsTheirSpread) {
  const GearData gear = SampleGear();
  FlankForms a = SampleForms(Flank::kRight);
  FlankForms b = a;
  b.offset += 2.0;
  std::vector<MeasuredTrace> traces = SampleNetwork(gear, a, Flank::kRight);
  for (MeasuredTrace t : SampleNetwork(gear, b, Flank::kRight)) {
    t.tooth = 7;
    traces.push_back(t);
  }
  TraceGridResult mean =
      InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  ASSERT_TRUE(mean.ok) << mean.message;
  EXPECT_EQ(mean.teeth, (std::vector<int>{1, 7}));
  const Eigen::VectorXd truth = FormsOnGrid(a, gear);
  for (int p = 0; p < 45; ++p) {
    EXPECT_NEAR(mean.deviations_um[p], truth[p] + 1.0, 1e-9);
    EXPECT_NEAR(mean.tooth_spread_um[p], 2.0, 1e-9);
  }
  TraceGridOptions only7;
  only7.tooth = 7;
  const TraceGridResult seven =
      InterpolateTraces(only7, gear, GridOptions{}, traces);
  ASSERT_TRUE(seven.ok);
  EXPECT_NEAR(seven.deviations_um[0], truth[0] + 2.0, 1e-9);
  only7.tooth = 3;
  const TraceGridResult none =
      InterpolateTraces(only7, gear, GridOptions{}, traces);
  EXPECT_FALSE(none.ok);
  EXPECT_EQ(none.message, "no trace of the right flank of tooth 3 in the file");
}

TEST(InterpolateTraces, DatumFaceAtPlusXSwapsFlanksAndMirrorsTheFace) {
  const GearData gear = SampleGear();
  const FlankForms forms = SampleForms(Flank::kRight);
  // The file's LEFT flank seen from a datum face at x = +b/2 is the grid's
  // right flank; its z runs from +b/2 towards -b/2. Build its traces from the
  // mirrored truth.
  FlankForms mirrored = forms;
  mirrored.slope_beta = -forms.slope_beta;
  mirrored.twist = -forms.twist;
  TraceGridOptions options;
  options.datum_face = DatumFace::kXPositive;
  const TraceGridResult result =
      InterpolateTraces(options,
                        gear,
                        GridOptions{},
                        SampleNetwork(gear, mirrored, Flank::kLeft));
  ASSERT_TRUE(result.ok) << result.message;
  const Eigen::VectorXd truth = FormsOnGrid(forms, gear);
  for (int p = 0; p < 45; ++p)
    EXPECT_NEAR(result.deviations_um[p], truth[p], 1e-9) << p;
}

TEST(InterpolateTraces, SignFactorsAndCrossingMismatch) {
  const GearData gear = SampleGear();
  const FlankForms forms = SampleForms(Flank::kRight);
  std::vector<MeasuredTrace> traces = SampleNetwork(gear, forms, Flank::kRight);
  for (MeasuredTrace& t : traces) {
    if (t.kind == TraceKind::kHelix) {
      for (double& v : t.values_um)
        v = -v;  // raw helix curves of the "other" generation
    }
  }
  const TraceGridResult wrong =
      InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  ASSERT_TRUE(wrong.ok);
  EXPECT_GT(wrong.max_crossing_mismatch_um, 2.0);
  ASSERT_EQ(wrong.warnings.size(), 1u);
  TraceGridOptions options;
  options.sign.helix_right = -1.0;
  const TraceGridResult right =
      InterpolateTraces(options, gear, GridOptions{}, traces);
  ASSERT_TRUE(right.ok);
  EXPECT_LT(right.max_crossing_mismatch_um, 1e-9);
  EXPECT_TRUE(right.warnings.empty());
}

TEST(InterpolateTraces, BadInputIsAResultNamingTheTrace) {
  const GearData gear = SampleGear();
  const FlankForms forms = SampleForms(Flank::kRight);
  std::vector<MeasuredTrace> traces = SampleNetwork(gear, forms, Flank::kRight);
  traces[6].position_mm = 120.0;  // a helix trace inside the base circle
  TraceGridResult result =
      InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.trace_index, 6);
  EXPECT_NE(result.message.find("inside the base circle"), std::string::npos);

  traces = SampleNetwork(gear, forms, Flank::kRight);
  for (size_t i = 2; i < traces[2].values_um.size(); ++i)
    traces[2].values_um[i] = std::nan("");
  result = InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.trace_index, 2);

  traces = SampleNetwork(gear, forms, Flank::kRight);
  traces[1].position_mm = traces[0].position_mm;
  result = InterpolateTraces(TraceGridOptions{}, gear, GridOptions{}, traces);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("same position"), std::string::npos);

  TraceGridOptions options;
  options.sign.profile_left = 2.0;
  EXPECT_FALSE(InterpolateTraces(options, gear, GridOptions{}, traces).ok);
  EXPECT_FALSE(
      InterpolateTraces(TraceGridOptions{}, GearData{}, GridOptions{}, traces)
          .ok);
}

}  // namespace
}  // namespace gearloop
