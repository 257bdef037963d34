// engine/split_bevel/head_kinematics.h: the segment setup on the table and the
// head-head 5-axis machine (X, Y, Z, A, B) of SPLIT_BEVEL.md §6: forward
// kinematics, and the inverse with its two branches, the branch choice and the
// unwrapping of B.
//
//   const Eigen::Matrix4d machine_from_blank =
//   SplitBevelBlankToMachine(psi_mid_rad, apex_mm); HeadAngles angles;
//   ChooseHeadAngles(axis_m, &previous, limits, &angles);            // false:
//   out of the limits const HeadAxes axes = HeadPivot(centre_m, angles,
//   pivot_length_mm); const ToolPose pose = HeadForward(axes, pivot_length_mm);
//   // centre and axis, machine
//
// Setup: machine point = apex_mm + M (blank point), machine vector = M v,
// M = RotX(pi) RotZ(-psi_mid): the gear axis points down (-Z), the back face
// lies on the table, and the pitch point at azimuth psi_mid lies in the XZ
// half-plane X > 0 with its outward cone normal toward +Z. All rotations are
// active and right-handed. Head: B turns about machine Y and carries A, which
// turns about X. At A = B = 0 the tool points +Z:
//   a_m = RotY(B) RotX(A) z = (sin B cos A, -sin A, cos A cos B),
//   pivot (X, Y, Z) = O_m + P a_m     (O_m the tool centre, P the pivot length;
//   P = 0: TCP mode).
#ifndef GEARLOOP_ENGINE_SPLIT_BEVEL_HEAD_KINEMATICS_H_
#define GEARLOOP_ENGINE_SPLIT_BEVEL_HEAD_KINEMATICS_H_

#include <Eigen/Core>
#include <array>

namespace gearloop {

// blank_to_machine as a homogeneous 4 x 4 [M, apex_mm; 0, 1].
Eigen::Matrix4d SplitBevelBlankToMachine(double segment_mid_rad,
                                         const Eigen::Vector3d& apex_mm);

struct HeadAngles {
  double a_rad = 0.0;
  double b_rad = 0.0;
};

struct HeadAxes {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double z_mm = 0.0;
  double a_rad = 0.0;
  double b_rad = 0.0;
};

// The tool centre (centre of the end face) and the unit tool axis (tip ->
// spindle).
struct ToolPose {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
};

// a_m = RotY(B) RotX(A) z.
Eigen::Vector3d HeadToolAxis(double a_rad, double b_rad);
// Forward kinematics in machine coordinates: axis a_m(A, B) and centre = pivot
// - P a_m.
ToolPose HeadForward(const HeadAxes& axes, double pivot_length_mm);
// The same, carried into the blank frame Si by the inverse of blank_to_machine.
ToolPose HeadForwardInBlank(const HeadAxes& axes,
                            double pivot_length_mm,
                            const Eigen::Matrix4d& blank_to_machine);
// Pivot = centre + P a_m(A, B).
HeadAxes HeadPivot(const Eigen::Vector3d& centre_m_mm,
                   const HeadAngles& angles,
                   double pivot_length_mm);

// The two solutions of a_m(A, B) = axis (unit, machine frame):
//   branch 1: A = atan2(-a_y, sqrt(a_x^2 + a_z^2)) in [-90, 90] deg, B =
//   atan2(a_x, a_z) in (-180, 180]; branch 2: (pi - A, B + pi), A brought into
//   (-180, 180] deg (the same head position: it keeps
//             the mirror property A -> -A of §7 e on this branch as well).
// Where sqrt(a_x^2 + a_z^2) < 1e-9 (tool along Y) B is undetermined;
// `b_when_vertical_rad` is used (the previous point's B).
std::array<HeadAngles, 2> HeadInverseBranches(const Eigen::Vector3d& axis_m,
                                              double b_when_vertical_rad);
// True where HeadInverseBranches leaves B undetermined (the tool along Y):
// only then do its branches depend on `b_when_vertical_rad`.
bool HeadAxisAlongY(const Eigen::Vector3d& axis_m);

struct HeadLimits {
  double a_min_rad = -1.7453292519943295;  // -100 deg
  double a_max_rad = 1.7453292519943295;   // +100 deg
  double b_min_rad = -6.283185307179586;   // -360 deg
  double b_max_rad = 6.283185307179586;    // +360 deg
};

// The angles for a tool axis, chosen as SPLIT_BEVEL.md §6 says. With previous
// == nullptr (first point of the program): branch 1 with B in (-180, 180] (B =
// 0 if the tool lies along Y), and false if that is outside the limits: §6
// fixes the first point's branch and offers no other. Otherwise, among both
// branches and B + 360 deg m within the limits, the candidate nearest the
// previous point by max(|dA|, |dB|), ties to branch 1. Returns false when no
// candidate lies within the limits.
bool ChooseHeadAngles(const Eigen::Vector3d& axis_m,
                      const HeadAngles* previous,
                      const HeadLimits& limits,
                      HeadAngles* chosen);
// The same choice from the axis's branches found already: `branches` =
// HeadInverseBranches(axis_m, previous ? previous->b_rad : 0) (a caller that
// meets the same axis again, as the depth levels of a station do, finds them
// once where the axis is not along Y).
bool ChooseHeadAnglesFrom(const std::array<HeadAngles, 2>& branches,
                          const HeadAngles* previous,
                          const HeadLimits& limits,
                          HeadAngles* chosen);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SPLIT_BEVEL_HEAD_KINEMATICS_H_
