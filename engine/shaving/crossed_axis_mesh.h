// engine/shaving/crossed_axis_mesh.h: the crossed-axis mesh of the work gear
// and the plunge-shaving cutter (SHAVING.md §3): frames, the cutter rotation,
// the relative velocity and the meshing function, with closed-form derivatives;
// and the 4 x 4 conjugate-point system of SHAVING.md §4.
//
//   const CrossedAxisMesh mesh(flank, cutter.teeth,
//   /*crossed_axes_angle_rad=*/0.0888, /*a=*/172.779); const MeshEvaluation m =
//   mesh.Evaluate(/*L=*/25.0, /*x=*/0.0, /*theta1=*/0.1);
//   // m.cutter_point_mm (P_s), m.meshing (f) and their derivatives in (L, x,
//   theta1)
//
// Frames (all rotations active and right-handed, Rot_x(t) =
// [[1,0,0],[0,c,-s],[0,s,c]]):
//   Sf  fixed frame of gear 1 (= S1 at theta1 = 0): x_f = gear-1 axis, y_f
//   toward the cutter. St  fixed frame of the cutter: origin (0, a, 0) in Sf,
//   axes (columns, in Sf)
//       R = Rot_y(gamma) Rot_x(pi), so at gamma = 0 its y axis points back at
//       gear 1.
//   Ss  the cutter's own frame (its S1 of MODEL.md §3), turned by theta_s about
//   x_t.
// Gear 1 turns theta1 about x_f; the cutter turns theta_s(theta1) = -pi/z_s -
// (z1/z_s) theta1 about x_t = R e_x (the half pitch puts a cutter space
// opposite the gear-1 tooth 0). For a work flank point R1r(L, x) with normal
// N1r:
//   P_f = Rot_x(theta1) R1r                     N_f = Rot_x(theta1) N1r
//   P_s = Rot_x(-theta_s) R^T (P_f - a e_y)      (the point in the cutter frame
//   Ss) v   = e_x x P_f + (z1/z_s) x_t x (P_f - a e_y)   (velocity of gear 1
//   minus cutter, per unit theta1) f   = N_f . v (meshing equation, f = 0 on
//   the envelope)
// Derivatives (columns L, x, theta1):
//   dP_s/dL = Rot_x(-theta_s) R^T Rot_x(theta1) dR1r/dL            (x alike)
//   dP_s/dtheta1 = (z1/z_s) e_x x P_s + Rot_x(-theta_s) R^T (e_x x P_f)
//   df/dL = (Rot_x(theta1) dN1r/dL) . v + N_f . (e_x x P_fL + (z1/z_s) x_t x
//   P_fL),  P_fL = Rot_x(theta1) dR1r/dL df/dtheta1 = (e_x x N_f) . v + N_f .
//   (e_x x (e_x x P_f) + (z1/z_s) x_t x (e_x x P_f))
#ifndef GEARLOOP_ENGINE_SHAVING_CROSSED_AXIS_MESH_H_
#define GEARLOOP_ENGINE_SHAVING_CROSSED_AXIS_MESH_H_

#include <Eigen/Core>

#include "engine/shaving/diagonal_modification.h"

namespace gearloop {

// The mesh at one work point (L, x) and work angle theta1.
struct MeshEvaluation {
  Eigen::Vector3d work_point_mm = Eigen::Vector3d::Zero();  // P_f (in Sf)
  Eigen::Vector3d work_normal =
      Eigen::Vector3d::Zero();  // N_f (in Sf, not unit)
  Eigen::Vector3d velocity_mm =
      Eigen::Vector3d::Zero();  // v (in Sf, per unit theta1)
  Eigen::Vector3d cutter_point_mm = Eigen::Vector3d::Zero();  // P_s (in Ss)
  double meshing = 0.0;                                       // f = N_f . v
  // Columns d/dL, d/dx, d/dtheta1.
  Eigen::Matrix3d d_cutter_point = Eigen::Matrix3d::Zero();
  Eigen::RowVector3d d_meshing = Eigen::RowVector3d::Zero();
  double relief_um = 0.0;  // delta1 at (L, x)
};

class CrossedAxisMesh {
 public:
  // `work_flank` is copied. gamma = beta1 + beta_s (signed, SHAVING.md §1); a
  // the centre distance.
  CrossedAxisMesh(const DiagonallyModifiedFlank& work_flank,
                  int cutter_teeth,
                  double crossed_axes_angle_rad,
                  double centre_distance_mm);

  const DiagonallyModifiedFlank& work_flank() const { return work_flank_; }
  double crossed_axes_angle_rad() const { return gamma_rad_; }
  double centre_distance_mm() const { return centre_distance_mm_; }
  // z1 / z_s.
  double ratio() const { return ratio_; }
  // theta_s(theta1) = -pi/z_s - (z1/z_s) theta1 [rad].
  double CutterAngleRad(double work_angle_rad) const;
  // x_t = R e_x, the cutter axis in Sf.
  Eigen::Vector3d CutterAxis() const { return frame_.col(0); }

  // P_s, f and their derivatives at (L, x, theta1).
  MeshEvaluation Evaluate(double roll_length_mm,
                          double x_mm,
                          double work_angle_rad) const;

  // P_s and its derivatives in L and x only (columns of `d_cutter_point`), for
  // the 3 x 3 intersection of the global start: no normal, no meshing function.
  void CutterPoint(double roll_length_mm,
                   double x_mm,
                   double work_angle_rad,
                   Eigen::Vector3d* cutter_point_mm,
                   Eigen::Matrix<double, 3, 2>* d_cutter_point) const;

  // A point given in the cutter frame Ss, expressed in the work frame S1 at
  // work angle theta1 (inverse of the P_s map).
  Eigen::Vector3d CutterToWork(const Eigen::Vector3d& cutter_point_mm,
                               double work_angle_rad) const;

 private:
  DiagonallyModifiedFlank work_flank_;
  double gamma_rad_ = 0.0;
  double centre_distance_mm_ = 0.0;
  double ratio_ = 0.0;
  double cutter_phase_rad_ = 0.0;                        // -pi / z_s
  Eigen::Matrix3d frame_ = Eigen::Matrix3d::Identity();  // R
};

// The conjugate-point system of SHAVING.md §4 for the cutter grid point Q (in
// Ss) with outward unit normal m, at unknowns u = (L1, x1, theta1, lambda):
//   g = [P_s(L1, x1, theta1) - Q - lambda m;  f(L1, x1, theta1)]
// and its analytic Jacobian dg/du (4 x 4). `jacobian` may be null.
void ConjugatePointSystem(const CrossedAxisMesh& mesh,
                          const Eigen::Vector3d& cutter_point_mm,
                          const Eigen::Vector3d& cutter_normal,
                          const Eigen::Vector4d& unknowns,
                          Eigen::Vector4d* residual,
                          Eigen::Matrix4d* jacobian);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SHAVING_CROSSED_AXIS_MESH_H_
