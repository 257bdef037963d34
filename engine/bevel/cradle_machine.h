// engine/bevel/cradle_machine.h: the spiral-bevel pinion job on a cradle-type
// hypoid generator (Gleason No. 116 style, with tilt mechanism): the face-mill
// cutter, the machine summary, the blank, the cradle machine's cutter-to-work
// transform, the generated flank as an exact envelope and the 5 x 9 measurement
// grid on it.
//
//   BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);   // Tang
//   2011, Table 1 CradleGenerator cradle(job); BevelFlankGrid grid =
//   cradle.BuildGrid();          // grid.points[i].position_mm, .normal
//   RigidTransform work_from_cutter = CradleWorkFromCutter(job.machine,
//   /*roll_rad=*/0.1);
//
// Frames (all right-handed, all rotations active; docs/bevel-machines.md has
// the full note):
//   S_t  cutter: origin at the cutter centre in the blade tip plane, z_t =
//   cutter axis pointing
//        out of the cutter face toward the work. The cutter is a surface of
//        revolution about z_t (engine/bevel/kinematics.h gives the blade
//        profile), so its spin never matters.
//   S_c  cradle: rotates with the cradle about z_m; coincides with S_m at the
//   centre roll. S_m  machine: origin at the machine centre (cradle axis in the
//   cutter reference plane),
//        z_m = cradle axis pointing toward the work, y_m vertically up, x_m =
//        y_m x z_m (to the right seen from the work). Angles in the cradle
//        plane (cradle angle Q, eccentric angle beta, tilt azimuth) are
//        measured CLOCKWISE seen from the work, i.e. about -z_m, so that "down"
//        settings are at negative y_m (see the note).
//   S_h  work head (fixed): x_h = work axis = (cos gm, 0, sin gm) in S_m (gm
//   the machine root
//        angle), y_h = y_m, z_h = x_h x y_h; origin at the pinion apex
//        apex_m = (0, -E1, XB) + X1 x_h  (E1 down, XB out along the cradle
//        axis, X1 out along the work axis are positive).
//   S1   work: rotates with the pinion about x_h; coincides with S_h at the
//   centre roll.
// Chain, t the cradle roll angle [rad] from the centre roll (positive
// counter-clockwise seen from the work):
//   r_c = Tilt r_t + c_c,   c_c = K2 [cos Q - cos(Q+beta), -(sin Q -
//   sin(Q+beta)), 0] m   = RotZ(t) r_c R1  = RotX(-i0 t) H (m - apex_m),     H
//   the rows x_h, y_h, z_h,  i0 the ratio of roll
// Tilt = rotation by I_x about the tilt axis (see
// CradleMachineSettings::tilt_rotation_rad). With these signs the work turns
// with the cradle in the sense that generates the flank with the straight
// blade, and the published pinion comes out LEFT-hand, offset below centre.
#ifndef GEARLOOP_ENGINE_BEVEL_CRADLE_MACHINE_H_
#define GEARLOOP_ENGINE_BEVEL_CRADLE_MACHINE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"

namespace gearloop {

// Which blade cuts the flank: the inside blade (smaller radius, blade leaning
// toward the cutter axis going back from the tip) cuts the convex side, the
// outside blade the concave side.
enum class BevelBlade { kInside, kOutside };
enum class BevelFlankSide { kConvex, kConcave };
const char* BevelFlankSideName(BevelFlankSide side);

// Face-mill cutter with straight-sided blades and an edge radius at the tip.
struct BevelCutter {
  // Radius of the blade's theoretical tip point (the straight blade line meets
  // the tip plane) [mm] (> 0).
  double point_radius_mm = 0.0;
  // Angle between the straight blade and the cutter axis [rad], in (0, 45 deg).
  double blade_angle_rad = 0.0;
  // Edge (tip) radius joining the blade to the tip plane [mm] (>= 0).
  double edge_radius_mm = 0.0;
  BevelBlade blade = BevelBlade::kInside;
};

// The machine summary of the cradle-type generator for one flank (Tang 2011,
// Table 1).
struct CradleMachineSettings {
  // Vertical offset E1 (blank offset) [mm], positive = work axis BELOW the
  // machine centre.
  double blank_offset_mm = 0.0;
  // Horizontal offset X1 (work-head setting) along the work axis [mm], positive
  // = out (the pinion apex moves away from the machine centre toward the work
  // head).
  double horizontal_offset_mm = 0.0;
  // Sliding base XB along the cradle axis [mm], positive = out (away from the
  // cradle).
  double sliding_base_mm = 0.0;
  // Machine root angle gm [rad]: the work axis turned from x_m toward z_m by
  // gm.
  double machine_root_angle_rad = 0.0;
  // Eccentric angle beta [rad] and eccentric arm K2 [mm]: radial distance 2 K2
  // sin(beta/2).
  double eccentric_angle_rad = 0.0;
  double eccentric_mm = 111.125;
  // Cradle angle Q [rad] at the centre roll.
  double cradle_angle_rad = 0.0;
  // Tilt-mechanism rotation I_x [rad]: the cutter head turns by I_x about the
  // tilt axis. The tilt axis is inclined by tilt_axis_inclination_rad to the
  // cradle axis (7.5 deg: we read the published "15 deg" as the mechanism's
  // range of tilt, twice it), and is carried by the eccentric drum, leaning
  // toward the azimuth Q + beta + 180 deg + tilt_axis_mounting_rad (a machine
  // constant; 25 deg makes the root line cut on both published sides parallel
  // to the blank's root cone, see docs/bevel-machines.md). Tilt i = 2
  // asin(sin(inclination) |sin(I_x / 2)|).
  double tilt_rotation_rad = 0.0;
  double tilt_axis_inclination_rad = 0.1308996938995747;
  double tilt_axis_mounting_rad = 0.4363323129985824;
  // Ratio of roll i0: the work turns i0 rad per rad of cradle roll (> 0).
  double ratio_of_roll = 1.0;
};

// The pinion blank; the cones share their apex with the work frame origin (the
// pinion apex).
struct BevelBlank {
  double outer_cone_distance_mm = 0.0;  // > inner
  double inner_cone_distance_mm = 0.0;  // > 0
  double face_angle_rad = 0.0;          // face cone half angle, > root angle
  double root_angle_rad = 0.0;          // root cone half angle, > 0
};

// The measurement grid on the flank: rows (profile) at fractions of the depth
// between the root cone (0) and the face cone (1), measured as the polar angle
// nu = atan(r / x) of the point seen from the apex; columns (lengthwise) at
// fractions of [inner, outer] cone distance, measured as the distance |P| from
// the apex. Row 0 at the root, column 0 at the inner end (toe).
struct BevelGridOptions {
  int profile_points = 5;
  int lengthwise_points = 9;
  double profile_min_fraction = 0.15;
  double profile_max_fraction = 0.85;
  double lengthwise_min_fraction = 0.1;
  double lengthwise_max_fraction = 0.9;
};

struct BevelPinionJob {
  BevelFlankSide side = BevelFlankSide::kConvex;
  BevelCutter cutter;
  CradleMachineSettings machine;
  BevelBlank blank;
  BevelGridOptions grid;

  // False with the offending field ("machine.ratio_of_roll") and a message on
  // bad input.
  bool IsValid(std::string* field, std::string* message) const;
};

// The published pinion of Tang, Wang and Li (2011), Table 1: convex side
// (inside blade) or concave side (outside blade), outer/inner cone distance
// 210/140 mm, face angle 13 deg 43', root angle 9 deg 38', edge radius 2.59 mm,
// K2 = 111.125 mm, tilt range 15 deg (axis inclined 7.5 deg, mounting 25 deg).
BevelPinionJob PublishedPinionJob(BevelFlankSide side);

// A rigid transform b_from_a: x_b = rotation x_a + translation_mm.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

// Derived quantities of a cradle setup, for reports and the note.
struct CradleGeometry {
  double radial_distance_mm = 0.0;  // S_r = 2 K2 sin(beta / 2)
  double cutter_azimuth_rad =
      0.0;  // q = Q + beta/2 - 90 deg, clockwise from x_m seen from the work
  double tilt_rad = 0.0;  // angle between cutter axis and cradle axis
  double tilt_azimuth_rad =
      0.0;  // direction of the tilted axis in the cradle plane (clockwise)
  double swivel_rad =
      0.0;  // tilt azimuth measured from the radial line, q - azimuth
  Eigen::Vector3d cutter_centre_c_mm = Eigen::Vector3d::Zero();  // c_c in S_c
  Eigen::Vector3d tilt_axis_c =
      Eigen::Vector3d::UnitZ();  // the tilt mechanism's axis in S_c
  Eigen::Matrix3d cradle_from_cutter = Eigen::Matrix3d::Identity();  // Tilt
  Eigen::Vector3d apex_m_mm = Eigen::Vector3d::Zero();  // pinion apex in S_m
  Eigen::Matrix3d head_from_machine = Eigen::Matrix3d::Identity();  // H
};
CradleGeometry ComputeCradleGeometry(const CradleMachineSettings& machine);

// work_from_cutter (S1 from S_t) of the cradle machine at cradle roll
// `roll_rad`.
RigidTransform CradleWorkFromCutter(const CradleMachineSettings& machine,
                                    double roll_rad);

struct BevelEnvelopeOptions {
  int max_iterations = 40;
  // Converged when a full Newton step moves every unknown by less than this
  // [mm] (angles counted as arcs: cutter angle on the point radius, roll on the
  // mean cone distance).
  double step_tolerance_mm = 1e-11;
  // Newton steps longer than this [mm] are shortened to it.
  double max_step_mm = 10.0;
};

// A contact of the cutter with the flank: blade profile parameter u [mm] (< 0
// on the edge radius), cutter angle theta [rad], roll t [rad], and (for a grid
// point) the normal deviation lambda [mm] of the generated flank from the
// point, positive = material left on.
struct BevelContact {
  PointStatus status = PointStatus::kNotConverged;
  double blade_u_mm = 0.0;
  double cutter_theta_rad = 0.0;
  double roll_rad = 0.0;
  double deviation_mm = 0.0;
  int iterations = 0;
};

struct BevelGridPoint {
  int row = 0;
  int column = 0;
  double cone_distance_mm = 0.0;  // |P|
  double polar_angle_rad = 0.0;   // nu = atan2(sqrt(y^2 + z^2), x)
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // in S1
  Eigen::Vector3d normal =
      Eigen::Vector3d::Zero();  // unit, out of the material
  BevelContact contact;         // on the cradle machine (deviation 0)
};

struct BevelFlankGrid {
  int rows = 0;
  int columns = 0;
  std::vector<BevelGridPoint> points;  // row-major
  bool ok = false;                     // every point found on the cradle flank
  std::string message;                 // why not, when !ok
  double roll_min_rad = 0.0;           // span of the contacts' roll t
  double roll_max_rad = 0.0;
  int NumPoints() const { return rows * columns; }
};

// The flank generated on the cradle machine: the envelope of the cutter surface
// under the cradle motion, meshing equation f = n . v = 0 (n the cutter normal,
// v the velocity of the cutter point relative to the work per unit roll).
class CradleGenerator {
 public:
  // `job` must pass IsValid.
  explicit CradleGenerator(
      const BevelPinionJob& job,
      const BevelEnvelopeOptions& options = BevelEnvelopeOptions());

  const BevelPinionJob& job() const { return job_; }
  const CradleGeometry& geometry() const { return geometry_; }

  // The cutter point in S1 at (u, theta, t), its unit normal (into the work
  // material) and the meshing function f [mm/rad].
  Eigen::Vector3d SurfacePoint(double blade_u_mm,
                               double cutter_theta_rad,
                               double roll_rad,
                               Eigen::Vector3d* normal,
                               double* meshing) const;

  // The flank point at cone distance L [mm] and polar angle nu [rad], by Newton
  // on (f = 0, |R1| = L, nu(R1) = nu) from `start` (u, theta, t). Status
  // kNotReached when the contact lies beyond the edge radius (on the tip
  // plane).
  BevelContact SolveFlankPoint(double cone_distance_mm,
                               double polar_angle_rad,
                               const Eigen::Vector3d& start) const;

  // The grid of the job's grid options on the cradle flank (BevelGridOptions).
  BevelFlankGrid BuildGrid() const;

 private:
  // BuildGrid's steps: the seed of the meshing function at the centre roll,
  // then the march of Newton solves outward from the grid's centre.
  bool FindCentreSeed(double mid_distance_mm,
                      double mid_angle_rad,
                      Eigen::Vector3d* seed) const;
  void MarchGridFromCentre(const Eigen::Vector3d& centre_start,
                           BevelFlankGrid* grid) const;

  BevelPinionJob job_;
  BevelEnvelopeOptions options_;
  CradleGeometry geometry_;
};

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_BEVEL_CRADLE_MACHINE_H_
