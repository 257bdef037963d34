// engine/bevel/kinematics.h: the templated kinematic chains of the two
// spiral-bevel machines (cradle-type hypoid generator and six-axis free-form
// generator) and the face-mill cutter surface, shared by
// engine/bevel/cradle_machine.cc and engine/bevel/freeform_generator.cc.
//
// INTERNAL to the engine: templated on the scalar type so that the .cc files
// can run them with ceres::Jet (forward-mode automatic differentiation) for
// Newton and for the implicit function theorem. It includes Eigen only. The
// frames, signs and units are stated in docs/bevel-machines.md and summarised
// in engine/bevel/cradle_machine.h.
#ifndef GEARLOOP_ENGINE_BEVEL_KINEMATICS_H_
#define GEARLOOP_ENGINE_BEVEL_KINEMATICS_H_

#include <Eigen/Core>
#include <cmath>

namespace gearloop {

struct BevelCutter;
struct CradleGeometry;
struct CradleMachineSettings;

namespace bevel_internal {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

// Active right-handed rotations: RotX(t) = [[1,0,0],[0,c,-s],[0,s,c]] and so
// on.
template <typename T>
Mat3<T> RotX(const T& angle) {
  using std::cos;
  using std::sin;
  const T c = cos(angle), s = sin(angle);
  Mat3<T> m;
  m << T(1.0), T(0.0), T(0.0), T(0.0), c, -s, T(0.0), s, c;
  return m;
}
template <typename T>
Mat3<T> RotY(const T& angle) {
  using std::cos;
  using std::sin;
  const T c = cos(angle), s = sin(angle);
  Mat3<T> m;
  m << c, T(0.0), s, T(0.0), T(1.0), T(0.0), -s, T(0.0), c;
  return m;
}
template <typename T>
Mat3<T> RotZ(const T& angle) {
  using std::cos;
  using std::sin;
  const T c = cos(angle), s = sin(angle);
  Mat3<T> m;
  m << c, -s, T(0.0), s, c, T(0.0), T(0.0), T(0.0), T(1.0);
  return m;
}

// The cutter: a surface of revolution about z_t (the cutter axis, pointing out
// of the cutter face toward the work), origin at the cutter centre in the blade
// tip plane. The blade profile in the axial half-plane (rho, z) is a straight
// line through the theoretical tip point (R_p, 0) that leans by the blade angle
// alpha from the axis, joined to the tip plane z = 0 by a circular edge radius
// r_e. One profile parameter u [mm], arc length:
//   u >= 0 (straight part, going back into the cutter body from the tangent
//   point T_L)
//     (rho, z) = T_L + u (sigma sin alpha, -cos alpha)
//   u < 0 (edge radius, toward the tip plane), gamma = alpha - u / r_e in
//   [alpha, pi/2]
//     (rho, z) = C + r_e (sigma cos gamma, sin gamma)
// with t_f = r_e cos alpha / (1 + sin alpha), T_L = (R_p + sigma t_f sin alpha,
// -t_f cos alpha), C = (R_p - sigma t_f, -r_e); sigma = +1 outside blade, -1
// inside blade. The unit normal (sigma cos gamma, sin gamma) (gamma = alpha on
// the straight part) points out of the volume the cutter sweeps, i.e. into the
// work material.
struct CutterConstants {
  double point_radius_mm = 0.0;
  double blade_angle_rad = 0.0;
  double edge_radius_mm = 0.0;
  double sigma = 1.0;
};

template <typename T>
void CutterPointAndNormal(const CutterConstants& c,
                          const T& u,
                          const T& theta,
                          Vec3<T>* point,
                          Vec3<T>* normal) {
  using std::cos;
  using std::sin;
  const double sa = std::sin(c.blade_angle_rad),
               ca = std::cos(c.blade_angle_rad);
  const double tangent_length = c.edge_radius_mm * ca / (1.0 + sa);
  T rho, z, n_rho, n_z;
  if (u >= 0.0 || c.edge_radius_mm <= 0.0) {
    rho =
        c.point_radius_mm + c.sigma * tangent_length * sa + u * (c.sigma * sa);
    z = -tangent_length * ca - u * ca;
    n_rho = T(c.sigma * ca);
    n_z = T(sa);
  } else {
    const T gamma = c.blade_angle_rad - u / c.edge_radius_mm;
    const T cg = cos(gamma), sg = sin(gamma);
    rho = c.point_radius_mm - c.sigma * tangent_length +
          c.edge_radius_mm * c.sigma * cg;
    z = -c.edge_radius_mm + c.edge_radius_mm * sg;
    n_rho = c.sigma * cg;
    n_z = sg;
  }
  const T ct = cos(theta), st = sin(theta);
  *point << rho * ct, rho * st, z;
  *normal << n_rho * ct, n_rho * st, n_z;
}

// The cradle machine chain, constants precomputed from the summary
// (bevel_cradle_machine.cc):
//   cutter in cradle      r_c = tilt r_t + centre_c
//   cradle in machine     m   = RotZ(cradle_sign t) r_c
//   machine in work head  h   = head_from_machine (m - apex_m)
//   work rotation         R1  = RotX(-work_rate t) h
// t is the cradle roll angle [rad] from the centre-roll position.
struct CradleChainConstants {
  Mat3<double> tilt = Mat3<double>::Identity();
  Vec3<double> centre_c = Vec3<double>::Zero();
  Mat3<double> head_from_machine = Mat3<double>::Identity();
  Vec3<double> apex_m = Vec3<double>::Zero();
  double cradle_sign = 1.0;
  double work_rate = 1.0;
};

// The cutter point r1 and unit normal n1 (into the work material) in the work
// frame S1 at (u, theta, t), and the meshing function f = n1 . v, v the
// velocity of the cutter point relative to the work per unit t [mm/rad].
template <typename T>
void CradleLocal(const CradleChainConstants& k,
                 const CutterConstants& c,
                 const T& u,
                 const T& theta,
                 const T& t,
                 Vec3<T>* r1,
                 Vec3<T>* n1,
                 T* f) {
  Vec3<T> rt, nt;
  CutterPointAndNormal(c, u, theta, &rt, &nt);
  const Mat3<T> cradle = RotZ<T>(T(k.cradle_sign) * t);
  const Mat3<T> work = RotX<T>(T(-k.work_rate) * t);
  const Vec3<T> rc = k.tilt.cast<T>() * rt + k.centre_c.cast<T>();
  const Vec3<T> m = cradle * rc;
  const Mat3<T> g = k.head_from_machine.cast<T>();
  *r1 = work * (g * (m - k.apex_m.cast<T>()));
  *n1 = work * (g * (cradle * (k.tilt.cast<T>() * nt)));
  // v = -work_rate e_x x R1 + work G (cradle_sign e_z x m).
  Vec3<T> ez_m;
  ez_m << -m(1), m(0), T(0.0);
  Vec3<T> ex_r1;
  ex_r1 << T(0.0), -(*r1)(2), (*r1)(1);
  const Vec3<T> v =
      T(-k.work_rate) * ex_r1 + work * (g * (T(k.cradle_sign) * ez_m));
  *f = n1->dot(v);
}

// The free-form machine chain (cutter to work), axes in the order A (psi, work
// spindle about x1, rad), B (phi, swing about y, rad), X, Y, Z [mm]:
//   R1 = RotX(-A) RotY(B) (r_t + [X, Y, -Z])
// (the cutter spindle C turns the cutter about its own axis and does not change
// the surface). `value` and `rate` hold the axis values and their derivatives
// with respect to t.
constexpr int kFreeFormA = 0;
constexpr int kFreeFormB = 1;
constexpr int kFreeFormX = 2;
constexpr int kFreeFormY = 3;
constexpr int kFreeFormZ = 4;

template <typename T>
void FreeFormLocal(const CutterConstants& c,
                   const T& u,
                   const T& theta,
                   const T* value,
                   const T* rate,
                   Vec3<T>* r1,
                   Vec3<T>* n1,
                   T* f) {
  Vec3<T> rt, nt;
  CutterPointAndNormal(c, u, theta, &rt, &nt);
  const Mat3<T> ra = RotX<T>(-value[kFreeFormA]);
  const Mat3<T> rb = RotY<T>(value[kFreeFormB]);
  Vec3<T> d, d_rate;
  d << value[kFreeFormX], value[kFreeFormY], -value[kFreeFormZ];
  d_rate << rate[kFreeFormX], rate[kFreeFormY], -rate[kFreeFormZ];
  const Vec3<T> w = rb * (rt + d);
  *r1 = ra * w;
  *n1 = ra * (rb * nt);
  // v = -A' e_x x R1 + RotX(-A) (B' e_y x w + RotY(B) d').
  Vec3<T> ex_r1, ey_w;
  ex_r1 << T(0.0), -(*r1)(2), (*r1)(1);
  ey_w << w(2), T(0.0), -w(0);
  const Vec3<T> v =
      -rate[kFreeFormA] * ex_r1 + ra * (rate[kFreeFormB] * ey_w + rb * d_rate);
  *f = n1->dot(v);
}

// Defined in bevel_cradle_machine.cc.
CutterConstants MakeCutterConstants(const BevelCutter& cutter);
// The profile parameter u where the edge radius meets the tip plane [mm] (< 0).
double EdgeRadiusEndU(const BevelCutter& cutter);
CradleChainConstants MakeCradleChainConstants(
    const CradleGeometry& geometry, const CradleMachineSettings& machine);

}  // namespace bevel_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_BEVEL_KINEMATICS_H_
