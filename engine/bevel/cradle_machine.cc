#include "engine/bevel/cradle_machine.h"

#include <ceres/jet.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "engine/bevel/kinematics.h"
#include "engine/core/damped_newton.h"
#include "engine/core/units.h"

namespace gearloop {
namespace {

using bevel_internal::CradleChainConstants;
using bevel_internal::CradleLocal;
using bevel_internal::CutterConstants;

double DegMin(double degrees, double minutes) {
  const double sign =
      degrees < 0.0 || (degrees == 0.0 && minutes < 0.0) ? -1.0 : 1.0;
  return sign * (std::abs(degrees) + std::abs(minutes) / 60.0) * kRadPerDeg;
}

bool Fail(const char* field,
          const std::string& text,
          std::string* out_field,
          std::string* message) {
  if (out_field != nullptr) *out_field = field;
  if (message != nullptr) *message = text;
  return false;
}

}  // namespace

namespace bevel_internal {

CutterConstants MakeCutterConstants(const BevelCutter& cutter) {
  CutterConstants c;
  c.point_radius_mm = cutter.point_radius_mm;
  c.blade_angle_rad = cutter.blade_angle_rad;
  c.edge_radius_mm = cutter.edge_radius_mm;
  c.sigma = cutter.blade == BevelBlade::kOutside ? 1.0 : -1.0;
  return c;
}

// The profile parameter where the edge radius meets the tip plane (gamma =
// pi/2).
double EdgeRadiusEndU(const BevelCutter& cutter) {
  return -cutter.edge_radius_mm * (0.5 * kPi - cutter.blade_angle_rad);
}

CradleChainConstants MakeCradleChainConstants(const CradleGeometry& g,
                                              const CradleMachineSettings& m) {
  CradleChainConstants k;
  k.tilt = g.cradle_from_cutter;
  k.centre_c = g.cutter_centre_c_mm;
  k.head_from_machine = g.head_from_machine;
  k.apex_m = g.apex_m_mm;
  k.cradle_sign = 1.0;
  k.work_rate = m.ratio_of_roll;
  return k;
}

}  // namespace bevel_internal

const char* BevelFlankSideName(BevelFlankSide side) {
  return side == BevelFlankSide::kConvex ? "convex" : "concave";
}

namespace {

// The cutter checks of BevelPinionJob::IsValid.
bool CheckCutter(const BevelCutter& cutter,
                 std::string* field,
                 std::string* message) {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!(cutter.point_radius_mm > 0.0) || !finite(cutter.point_radius_mm))
    return Fail("cutter.point_radius_mm", "must be > 0", field, message);
  if (!(cutter.blade_angle_rad > 0.0 &&
        cutter.blade_angle_rad < 45.0 * kRadPerDeg))
    return Fail(
        "cutter.blade_angle_rad", "must lie in (0, 45 deg)", field, message);
  if (!(cutter.edge_radius_mm >= 0.0 &&
        cutter.edge_radius_mm < 0.5 * cutter.point_radius_mm))
    return Fail("cutter.edge_radius_mm",
                "must lie in [0, point radius / 2)",
                field,
                message);
  return true;
}

// The machine setting checks of BevelPinionJob::IsValid.
bool CheckMachineSettings(const CradleMachineSettings& machine,
                          std::string* field,
                          std::string* message) {
  auto finite = [](double v) { return std::isfinite(v); };
  const double settings[] = {machine.blank_offset_mm,
                             machine.horizontal_offset_mm,
                             machine.sliding_base_mm,
                             machine.machine_root_angle_rad,
                             machine.eccentric_angle_rad,
                             machine.cradle_angle_rad,
                             machine.tilt_rotation_rad};
  const char* names[] = {"machine.blank_offset_mm",
                         "machine.horizontal_offset_mm",
                         "machine.sliding_base_mm",
                         "machine.machine_root_angle_rad",
                         "machine.eccentric_angle_rad",
                         "machine.cradle_angle_rad",
                         "machine.tilt_rotation_rad"};
  for (int i = 0; i < 7; ++i) {
    if (!finite(settings[i]))
      return Fail(names[i], "must be finite", field, message);
  }
  if (std::abs(machine.machine_root_angle_rad) >= 0.5 * kPi)
    return Fail("machine.machine_root_angle_rad",
                "must lie in (-90, 90) deg",
                field,
                message);
  if (!(machine.eccentric_mm > 0.0) || !finite(machine.eccentric_mm))
    return Fail("machine.eccentric_mm", "must be > 0", field, message);
  if (!(machine.tilt_axis_inclination_rad >= 0.0 &&
        machine.tilt_axis_inclination_rad < 0.25 * kPi))
    return Fail("machine.tilt_axis_inclination_rad",
                "must lie in [0, 45 deg)",
                field,
                message);
  if (!finite(machine.tilt_axis_mounting_rad))
    return Fail(
        "machine.tilt_axis_mounting_rad", "must be finite", field, message);
  if (!(machine.ratio_of_roll > 0.0) || !finite(machine.ratio_of_roll))
    return Fail("machine.ratio_of_roll", "must be > 0", field, message);
  return true;
}

// The blank checks of BevelPinionJob::IsValid.
bool CheckBlank(const BevelBlank& blank,
                std::string* field,
                std::string* message) {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!(blank.inner_cone_distance_mm > 0.0))
    return Fail("blank.inner_cone_distance_mm", "must be > 0", field, message);
  if (!(blank.outer_cone_distance_mm > blank.inner_cone_distance_mm) ||
      !finite(blank.outer_cone_distance_mm))
    return Fail("blank.outer_cone_distance_mm",
                "must exceed the inner cone distance",
                field,
                message);
  if (!(blank.root_angle_rad > 0.0 && blank.root_angle_rad < 0.5 * kPi))
    return Fail(
        "blank.root_angle_rad", "must lie in (0, 90) deg", field, message);
  if (!(blank.face_angle_rad > blank.root_angle_rad &&
        blank.face_angle_rad < 0.5 * kPi))
    return Fail("blank.face_angle_rad",
                "must lie between the root angle and 90 deg",
                field,
                message);
  return true;
}

// The grid checks of BevelPinionJob::IsValid.
bool CheckGrid(const BevelGridOptions& grid,
               std::string* field,
               std::string* message) {
  if (grid.profile_points < 1 || grid.profile_points > 50)
    return Fail("grid.profile_points", "must lie in [1, 50]", field, message);
  if (grid.lengthwise_points < 1 || grid.lengthwise_points > 50)
    return Fail(
        "grid.lengthwise_points", "must lie in [1, 50]", field, message);
  if (!(grid.profile_min_fraction >= 0.0 &&
        grid.profile_min_fraction <= grid.profile_max_fraction &&
        grid.profile_max_fraction <= 1.0))
    return Fail("grid.profile_min_fraction",
                "need 0 <= min <= max <= 1",
                field,
                message);
  if (!(grid.lengthwise_min_fraction >= 0.0 &&
        grid.lengthwise_min_fraction <= grid.lengthwise_max_fraction &&
        grid.lengthwise_max_fraction <= 1.0))
    return Fail("grid.lengthwise_min_fraction",
                "need 0 <= min <= max <= 1",
                field,
                message);
  return true;
}

}  // namespace

bool BevelPinionJob::IsValid(std::string* field, std::string* message) const {
  return CheckCutter(cutter, field, message) &&
         CheckMachineSettings(machine, field, message) &&
         CheckBlank(blank, field, message) && CheckGrid(grid, field, message);
}

BevelPinionJob PublishedPinionJob(BevelFlankSide side) {
  BevelPinionJob job;
  job.side = side;
  job.cutter.edge_radius_mm = 2.59;
  job.machine.eccentric_mm = 111.125;
  job.machine.tilt_axis_inclination_rad = 7.5 * kRadPerDeg;
  job.machine.tilt_axis_mounting_rad = 25.0 * kRadPerDeg;
  if (side == BevelFlankSide::kConvex) {
    job.cutter.blade = BevelBlade::kInside;
    job.cutter.point_radius_mm = 164.47;
    job.cutter.blade_angle_rad = 25.0 * kRadPerDeg;
    job.machine.blank_offset_mm = 42.62;      // down
    job.machine.horizontal_offset_mm = 9.76;  // out
    job.machine.sliding_base_mm = 22.61;      // out
    job.machine.machine_root_angle_rad = DegMin(-3, 59);
    job.machine.eccentric_angle_rad = DegMin(102, 6);
    job.machine.cradle_angle_rad = DegMin(104, 56);
    job.machine.tilt_rotation_rad = DegMin(-126, 7);
    job.machine.ratio_of_roll = 7.26721;
  } else {
    job.cutter.blade = BevelBlade::kOutside;
    job.cutter.point_radius_mm = 142.76;
    job.cutter.blade_angle_rad = 20.0 * kRadPerDeg;
    job.machine.blank_offset_mm = 29.12;       // down
    job.machine.horizontal_offset_mm = -7.98;  // in
    job.machine.sliding_base_mm = 17.08;       // out
    job.machine.machine_root_angle_rad = DegMin(-2, 0);
    job.machine.eccentric_angle_rad = DegMin(81, 54);
    job.machine.cradle_angle_rad = DegMin(112, 12);
    job.machine.tilt_rotation_rad = DegMin(-115, 39);
    job.machine.ratio_of_roll = 6.33912;
  }
  job.blank.outer_cone_distance_mm = 210.0;
  job.blank.inner_cone_distance_mm = 140.0;
  job.blank.face_angle_rad = DegMin(13, 43);
  job.blank.root_angle_rad = DegMin(9, 38);
  return job;
}

CradleGeometry ComputeCradleGeometry(const CradleMachineSettings& m) {
  CradleGeometry g;
  const double q_cradle = m.cradle_angle_rad;
  const double beta = m.eccentric_angle_rad;
  const double k2 = m.eccentric_mm;
  // Double eccentric: the eccentric drum's centre sits at K2 from the cradle
  // axis in the direction Q, the cutter centre at K2 from the drum centre in
  // the direction Q + beta + 180 deg. Angles clockwise seen from the work: (cos
  // a, -sin a) in (x_m, y_m).
  g.cutter_centre_c_mm =
      Eigen::Vector3d(k2 * (std::cos(q_cradle) - std::cos(q_cradle + beta)),
                      -k2 * (std::sin(q_cradle) - std::sin(q_cradle + beta)),
                      0.0);
  g.radial_distance_mm = 2.0 * k2 * std::abs(std::sin(0.5 * beta));
  g.cutter_azimuth_rad =
      std::atan2(-g.cutter_centre_c_mm.y(), g.cutter_centre_c_mm.x());

  // Tilt mechanism (docs/bevel-machines.md): the cutter head turns by I_x
  // (right-handed) about the tilt axis, inclined by kappa to the cradle axis
  // and carried by the eccentric drum, its lean pointing at the azimuth Q +
  // beta + 180 deg + mounting angle (the drum's direction toward the cutter
  // centre plus a machine constant). The cutter axis is parallel to the cradle
  // axis at I_x = 0, so the tilt is i = 2 asin(sin kappa |sin(I_x / 2)|) and
  // the swivel is the one the same rotation produces.
  const double kappa = m.tilt_axis_inclination_rad;
  const double az = q_cradle + beta + kPi + m.tilt_axis_mounting_rad;
  g.tilt_axis_c = Eigen::Vector3d(std::sin(kappa) * std::cos(az),
                                  -std::sin(kappa) * std::sin(az),
                                  std::cos(kappa));
  g.cradle_from_cutter =
      Eigen::AngleAxisd(m.tilt_rotation_rad, g.tilt_axis_c).toRotationMatrix();
  const Eigen::Vector3d axis = g.cradle_from_cutter.col(2);
  g.tilt_rad = std::acos(std::clamp(axis.z(), -1.0, 1.0));
  g.tilt_azimuth_rad = std::atan2(-axis.y(), axis.x());
  g.swivel_rad =
      std::remainder(g.cutter_azimuth_rad - g.tilt_azimuth_rad, 2.0 * kPi);

  const double gm = m.machine_root_angle_rad;
  const Eigen::Vector3d xh(std::cos(gm), 0.0, std::sin(gm));
  const Eigen::Vector3d yh = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d zh = xh.cross(yh);
  g.head_from_machine.row(0) = xh.transpose();
  g.head_from_machine.row(1) = yh.transpose();
  g.head_from_machine.row(2) = zh.transpose();
  g.apex_m_mm = Eigen::Vector3d(0.0, -m.blank_offset_mm, m.sliding_base_mm) +
                m.horizontal_offset_mm * xh;
  return g;
}

RigidTransform CradleWorkFromCutter(const CradleMachineSettings& m,
                                    double roll_rad) {
  const CradleGeometry g = ComputeCradleGeometry(m);
  const Eigen::Matrix3d work =
      bevel_internal::RotX(-m.ratio_of_roll * roll_rad);
  const Eigen::Matrix3d cradle = bevel_internal::RotZ(roll_rad);
  RigidTransform t;
  t.rotation = work * g.head_from_machine * cradle * g.cradle_from_cutter;
  t.translation_mm = work * (g.head_from_machine *
                             (cradle * g.cutter_centre_c_mm - g.apex_m_mm));
  return t;
}

CradleGenerator::CradleGenerator(const BevelPinionJob& job,
                                 const BevelEnvelopeOptions& options)
    : job_(job),
      options_(options),
      geometry_(ComputeCradleGeometry(job.machine)) {}

Eigen::Vector3d CradleGenerator::SurfacePoint(double blade_u_mm,
                                              double cutter_theta_rad,
                                              double roll_rad,
                                              Eigen::Vector3d* normal,
                                              double* meshing) const {
  const CutterConstants c = bevel_internal::MakeCutterConstants(job_.cutter);
  const CradleChainConstants k =
      bevel_internal::MakeCradleChainConstants(geometry_, job_.machine);
  Eigen::Vector3d r1, n1;
  double f = 0.0;
  CradleLocal<double>(
      k, c, blade_u_mm, cutter_theta_rad, roll_rad, &r1, &n1, &f);
  if (normal != nullptr) *normal = n1;
  if (meshing != nullptr) *meshing = f;
  return r1;
}

BevelContact CradleGenerator::SolveFlankPoint(
    double cone_distance_mm,
    double polar_angle_rad,
    const Eigen::Vector3d& start) const {
  using Jet3 = ceres::Jet<double, 3>;
  const CutterConstants c = bevel_internal::MakeCutterConstants(job_.cutter);
  const CradleChainConstants k =
      bevel_internal::MakeCradleChainConstants(geometry_, job_.machine);
  const double lever_mm = 0.5 * (job_.blank.inner_cone_distance_mm +
                                 job_.blank.outer_cone_distance_mm);
  const Eigen::Vector3d step_scale(1.0, job_.cutter.point_radius_mm, lever_mm);
  Eigen::Vector3d x = start;
  BevelContact contact;
  const engine_internal::DampedNewtonSummary newton =
      engine_internal::DampedNewton<3>(
          engine_internal::DampedNewtonOptions{options_.max_iterations,
                                               options_.step_tolerance_mm,
                                               options_.max_step_mm},
          step_scale,
          [&](const Eigen::Vector3d& x,
              Eigen::Vector3d* value,
              Eigen::Matrix3d* jacobian) {
            const Jet3 u(x(0), 0), theta(x(1), 1), t(x(2), 2);
            bevel_internal::Vec3<Jet3> r1, n1;
            Jet3 f;
            CradleLocal<Jet3>(k, c, u, theta, t, &r1, &n1, &f);
            const Jet3 radial = ceres::sqrt(r1(1) * r1(1) + r1(2) * r1(2));
            const Jet3 g[3] = {f,
                               r1.norm() - cone_distance_mm,
                               cone_distance_mm * (ceres::atan2(radial, r1(0)) -
                                                   polar_angle_rad)};
            for (int i = 0; i < 3; ++i) {
              (*value)(i) = g[i].a;
              jacobian->row(i) = g[i].v.transpose();
            }
          },
          &x);
  const bool converged = newton.converged;
  contact.iterations = newton.num_iterations;
  contact.blade_u_mm = x(0);
  contact.cutter_theta_rad = x(1);
  contact.roll_rad = x(2);
  if (!converged || !x.allFinite()) {
    contact.status = PointStatus::kNotConverged;
  } else if (x(0) < bevel_internal::EdgeRadiusEndU(job_.cutter)) {
    contact.status = PointStatus::kNotReached;
  } else {
    contact.status = PointStatus::kOk;
  }
  return contact;
}

namespace {

// The grid's nominal points: rows from the root to the face angle, columns from
// the inner to the outer cone distance (BevelGridOptions), no contact yet.
BevelFlankGrid LayOutGrid(const BevelGridOptions& o, const BevelBlank& b) {
  BevelFlankGrid grid;
  grid.rows = o.profile_points;
  grid.columns = o.lengthwise_points;
  grid.points.resize(grid.rows * grid.columns);
  auto fraction = [](int i, int n, double lo, double hi) {
    return n == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * i / (n - 1);
  };
  for (int r = 0; r < grid.rows; ++r) {
    for (int col = 0; col < grid.columns; ++col) {
      BevelGridPoint& p = grid.points[r * grid.columns + col];
      p.row = r;
      p.column = col;
      const double depth = fraction(
          r, grid.rows, o.profile_min_fraction, o.profile_max_fraction);
      const double length = fraction(col,
                                     grid.columns,
                                     o.lengthwise_min_fraction,
                                     o.lengthwise_max_fraction);
      p.polar_angle_rad =
          b.root_angle_rad + depth * (b.face_angle_rad - b.root_angle_rad);
      p.cone_distance_mm =
          b.inner_cone_distance_mm +
          length * (b.outer_cone_distance_mm - b.inner_cone_distance_mm);
    }
  }
  return grid;
}

}  // namespace

// Seed: at the centre roll, a mid-depth circle of the blade; the root of the
// meshing function around the cutter whose point lies nearest the middle of the
// blank's flank region. False when the meshing function has no root there.
bool CradleGenerator::FindCentreSeed(double mid_distance,
                                     double mid_angle,
                                     Eigen::Vector3d* seed) const {
  const double seed_u = 5.0;
  const int kScan = 2880;
  double best_score = std::numeric_limits<double>::infinity();
  *seed = Eigen::Vector3d(seed_u, 0.0, 0.0);
  double previous_f = 0.0;
  for (int i = 0; i <= kScan; ++i) {
    const double theta = -kPi + 2.0 * kPi * i / kScan;
    double f = 0.0;
    SurfacePoint(seed_u, theta, 0.0, nullptr, &f);
    if (i > 0 && (f > 0.0) != (previous_f > 0.0)) {
      // Bisection on the bracket [theta - h, theta].
      double lo = theta - 2.0 * kPi / kScan, hi = theta, f_lo = previous_f;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        double f_mid = 0.0;
        SurfacePoint(seed_u, mid, 0.0, nullptr, &f_mid);
        if ((f_mid > 0.0) == (f_lo > 0.0)) {
          lo = mid;
          f_lo = f_mid;
        } else {
          hi = mid;
        }
      }
      const Eigen::Vector3d r1 =
          SurfacePoint(seed_u, 0.5 * (lo + hi), 0.0, nullptr, nullptr);
      const double nu = std::atan2(std::hypot(r1.y(), r1.z()), r1.x());
      const double score = std::abs(r1.norm() - mid_distance) +
                           mid_distance * std::abs(nu - mid_angle);
      if (score < best_score) {
        best_score = score;
        *seed = Eigen::Vector3d(seed_u, 0.5 * (lo + hi), 0.0);
      }
    }
    previous_f = f;
  }
  return std::isfinite(best_score);
}

// March outward from the centre of the grid, each point starting from its
// solved neighbour nearest the centre (continuation keeps Newton on the flank's
// branch).
void CradleGenerator::MarchGridFromCentre(const Eigen::Vector3d& centre_x,
                                          BevelFlankGrid* grid_out) const {
  BevelFlankGrid& grid = *grid_out;
  std::vector<int> order(grid.points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  const double rc = 0.5 * (grid.rows - 1), cc = 0.5 * (grid.columns - 1);
  auto distance = [&](int i) {
    const BevelGridPoint& p = grid.points[i];
    return std::hypot(p.row - rc, p.column - cc);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b2) {
    return distance(a) < distance(b2);
  });
  std::vector<bool> solved(grid.points.size(), false);
  grid.ok = true;
  grid.roll_min_rad = std::numeric_limits<double>::infinity();
  grid.roll_max_rad = -std::numeric_limits<double>::infinity();
  for (int index : order) {
    BevelGridPoint& p = grid.points[index];
    Eigen::Vector3d start = centre_x;
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < grid.points.size(); ++j) {
      if (!solved[j]) continue;
      const double d = std::hypot(grid.points[j].row - p.row,
                                  grid.points[j].column - p.column);
      if (d < nearest) {
        nearest = d;
        start = Eigen::Vector3d(grid.points[j].contact.blade_u_mm,
                                grid.points[j].contact.cutter_theta_rad,
                                grid.points[j].contact.roll_rad);
      }
    }
    p.contact = SolveFlankPoint(p.cone_distance_mm, p.polar_angle_rad, start);
    if (p.contact.status == PointStatus::kNotConverged) {
      grid.ok = false;
      std::ostringstream s;
      s << "grid point (" << p.row << ", " << p.column
        << ") was not found on the cradle flank";
      if (grid.message.empty()) grid.message = s.str();
      continue;
    }
    if (p.contact.status == PointStatus::kNotReached) {
      grid.ok = false;
      std::ostringstream s;
      s << "grid point (" << p.row << ", " << p.column
        << ") lies below the edge radius (on the root)";
      if (grid.message.empty()) grid.message = s.str();
    }
    solved[index] = true;
    Eigen::Vector3d n1;
    p.position_mm = SurfacePoint(p.contact.blade_u_mm,
                                 p.contact.cutter_theta_rad,
                                 p.contact.roll_rad,
                                 &n1,
                                 nullptr);
    p.normal = -n1;  // the cutter normal points into the work material
    grid.roll_min_rad = std::min(grid.roll_min_rad, p.contact.roll_rad);
    grid.roll_max_rad = std::max(grid.roll_max_rad, p.contact.roll_rad);
  }
}

BevelFlankGrid CradleGenerator::BuildGrid() const {
  const BevelBlank& b = job_.blank;
  BevelFlankGrid grid = LayOutGrid(job_.grid, b);
  const double mid_distance =
      0.5 * (b.inner_cone_distance_mm + b.outer_cone_distance_mm);
  const double mid_angle = 0.5 * (b.root_angle_rad + b.face_angle_rad);
  Eigen::Vector3d seed;
  if (!FindCentreSeed(mid_distance, mid_angle, &seed)) {
    grid.message =
        "the meshing equation has no root on the cutter at the centre roll";
    return grid;
  }
  const BevelContact centre = SolveFlankPoint(mid_distance, mid_angle, seed);
  if (centre.status == PointStatus::kNotConverged) {
    grid.message = "the flank point at the middle of the blank was not found";
    return grid;
  }
  MarchGridFromCentre(
      Eigen::Vector3d(
          centre.blade_u_mm, centre.cutter_theta_rad, centre.roll_rad),
      &grid);
  return grid;
}

}  // namespace gearloop
