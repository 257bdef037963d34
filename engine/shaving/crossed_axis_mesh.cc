#include "engine/shaving/crossed_axis_mesh.h"

#include <Eigen/Geometry>
#include <cmath>

#include "engine/core/units.h"

namespace gearloop {
namespace {

// Rot_x(t) v, active.
Eigen::Vector3d RotX(double cos_t, double sin_t, const Eigen::Vector3d& v) {
  return Eigen::Vector3d(
      v.x(), cos_t * v.y() - sin_t * v.z(), sin_t * v.y() + cos_t * v.z());
}

}  // namespace

CrossedAxisMesh::CrossedAxisMesh(const DiagonallyModifiedFlank& work_flank,
                                 int cutter_teeth,
                                 double crossed_axes_angle_rad,
                                 double centre_distance_mm)
    : work_flank_(work_flank),
      gamma_rad_(crossed_axes_angle_rad),
      centre_distance_mm_(centre_distance_mm) {
  ratio_ = static_cast<double>(work_flank_.gear().teeth) / cutter_teeth;
  cutter_phase_rad_ = -kPi / cutter_teeth;
  // R = Rot_y(gamma) Rot_x(pi) = [[c, 0, -s], [0, -1, 0], [-s, 0, -c]].
  const double c = std::cos(gamma_rad_), s = std::sin(gamma_rad_);
  frame_ << c, 0.0, -s, 0.0, -1.0, 0.0, -s, 0.0, -c;
}

double CrossedAxisMesh::CutterAngleRad(double work_angle_rad) const {
  return cutter_phase_rad_ - ratio_ * work_angle_rad;
}

MeshEvaluation CrossedAxisMesh::Evaluate(double roll_length_mm,
                                         double x_mm,
                                         double work_angle_rad) const {
  const ModifiedFlankPoint p = work_flank_.At(roll_length_mm, x_mm);
  const double c1 = std::cos(work_angle_rad), s1 = std::sin(work_angle_rad);
  const double theta_s = CutterAngleRad(work_angle_rad);
  // Rot_x(-theta_s).
  const double cs = std::cos(theta_s), ss = -std::sin(theta_s);
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d xt = CutterAxis();
  const Eigen::Vector3d centre(0.0, centre_distance_mm_, 0.0);
  const Eigen::Matrix3d rt = frame_.transpose();
  auto to_cutter = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d {
    return RotX(cs, ss, rt * v);
  };

  MeshEvaluation m;
  m.relief_um = p.relief.value_um;
  m.work_point_mm = RotX(c1, s1, p.position_mm);
  m.work_normal = RotX(c1, s1, p.normal);
  const Eigen::Vector3d from_centre = m.work_point_mm - centre;
  m.velocity_mm = ex.cross(m.work_point_mm) + ratio_ * xt.cross(from_centre);
  m.cutter_point_mm = to_cutter(from_centre);
  m.meshing = m.work_normal.dot(m.velocity_mm);

  // Derivatives of P_f and N_f.
  const Eigen::Vector3d pf_l = RotX(c1, s1, p.d_roll);
  const Eigen::Vector3d pf_x = RotX(c1, s1, p.d_x);
  const Eigen::Vector3d pf_t = ex.cross(m.work_point_mm);
  const Eigen::Vector3d nf_l = RotX(c1, s1, p.d_normal_d_roll);
  const Eigen::Vector3d nf_x = RotX(c1, s1, p.d_normal_d_x);
  const Eigen::Vector3d nf_t = ex.cross(m.work_normal);
  // (Returns a Vector3d, not an expression: the expression would refer to dead
  // temporaries.)
  auto velocity_change = [&](const Eigen::Vector3d& dpf) -> Eigen::Vector3d {
    return ex.cross(dpf) + ratio_ * xt.cross(dpf);
  };

  m.d_cutter_point.col(0) = to_cutter(pf_l);
  m.d_cutter_point.col(1) = to_cutter(pf_x);
  m.d_cutter_point.col(2) =
      ratio_ * ex.cross(m.cutter_point_mm) + to_cutter(pf_t);
  m.d_meshing(0) =
      nf_l.dot(m.velocity_mm) + m.work_normal.dot(velocity_change(pf_l));
  m.d_meshing(1) =
      nf_x.dot(m.velocity_mm) + m.work_normal.dot(velocity_change(pf_x));
  m.d_meshing(2) =
      nf_t.dot(m.velocity_mm) + m.work_normal.dot(velocity_change(pf_t));
  return m;
}

void CrossedAxisMesh::CutterPoint(
    double roll_length_mm,
    double x_mm,
    double work_angle_rad,
    Eigen::Vector3d* cutter_point_mm,
    Eigen::Matrix<double, 3, 2>* d_cutter_point) const {
  const ModifiedFlankPoint p =
      work_flank_.At(roll_length_mm, x_mm, /*with_normal=*/false);
  const double c1 = std::cos(work_angle_rad), s1 = std::sin(work_angle_rad);
  const double theta_s = CutterAngleRad(work_angle_rad);
  const double cs = std::cos(theta_s), ss = -std::sin(theta_s);
  const Eigen::Matrix3d rt = frame_.transpose();
  const Eigen::Vector3d centre(0.0, centre_distance_mm_, 0.0);
  *cutter_point_mm = RotX(cs, ss, rt * (RotX(c1, s1, p.position_mm) - centre));
  d_cutter_point->col(0) = RotX(cs, ss, rt * RotX(c1, s1, p.d_roll));
  d_cutter_point->col(1) = RotX(cs, ss, rt * RotX(c1, s1, p.d_x));
}

Eigen::Vector3d CrossedAxisMesh::CutterToWork(
    const Eigen::Vector3d& cutter_point_mm, double work_angle_rad) const {
  const double theta_s = CutterAngleRad(work_angle_rad);
  const Eigen::Vector3d in_st =
      RotX(std::cos(theta_s), std::sin(theta_s), cutter_point_mm);
  const Eigen::Vector3d in_sf =
      frame_ * in_st + Eigen::Vector3d(0.0, centre_distance_mm_, 0.0);
  return RotX(std::cos(work_angle_rad), -std::sin(work_angle_rad), in_sf);
}

void ConjugatePointSystem(const CrossedAxisMesh& mesh,
                          const Eigen::Vector3d& cutter_point_mm,
                          const Eigen::Vector3d& cutter_normal,
                          const Eigen::Vector4d& unknowns,
                          Eigen::Vector4d* residual,
                          Eigen::Matrix4d* jacobian) {
  const MeshEvaluation m = mesh.Evaluate(unknowns(0), unknowns(1), unknowns(2));
  residual->head<3>() =
      m.cutter_point_mm - cutter_point_mm - unknowns(3) * cutter_normal;
  (*residual)(3) = m.meshing;
  if (jacobian == nullptr) return;
  jacobian->topLeftCorner<3, 3>() = m.d_cutter_point;
  jacobian->topRightCorner<3, 1>() = -cutter_normal;
  jacobian->bottomLeftCorner<1, 3>() = m.d_meshing;
  (*jacobian)(3, 3) = 0.0;
}

}  // namespace gearloop
