// engine/bevel/freeform_machine.h: the six-axis free-form spiral-bevel
// generator (Phoenix style): its kinematic chain and its axis motions as
// polynomials of the roll variable.
//
//   FreeFormMotion motion = conversion.motion;             //
//   engine/bevel/conversion.h FreeFormAxisValues axes =
//   motion.At(/*roll_rad=*/0.05); RigidTransform work_from_cutter =
//   FreeFormWorkFromCutter(axes);
//
// Chain (cutter to work, Tang 2011 eq. 7 with its damaged matrices re-derived;
// all rotations active and right-handed, docs/bevel-machines.md):
//   R1 = RotX(-A) RotY(B) ( [X, Y, -Z] + RotZ(C) r_t )
// S_t is the cutter frame of engine/bevel/cradle_machine.h (z_t = cutter axis
// toward the work), S1 the pinion's work frame (x1 = pinion axis, origin at the
// pinion apex).
//   A [rad]  work spindle: the pinion turns by A about x1 (points fixed in the
//   machine appear
//            turned by -A in S1);
//   B [rad]  swing about y, the angle between the cutter axis and the plane
//   normal to the
//            pinion axis (sin B = cutter axis . x1); it carries the Z slide;
//   X, Y [mm] the cutter centre across, Z [mm] along the cutter axis (Z counts
//   away from the
//            work, hence -Z), in the swing frame;
//   C [rad]  cutter spindle: turns the cutter about its own axis. The cutter is
//   a surface of
//            revolution, so C does not change the flank and takes no part in
//            the generating interpolation (Tang 2011 does not fit it either);
//            it is reported, never corrected.
// (The issue text labels C as the work axis; on the machine the paper
// describes, A is the work spindle whose rate is about the ratio of roll, and C
// the cutter. The chain is the same.) The roll variable t is the cradle roll
// angle of the cradle machine being reproduced [rad].
#ifndef GEARLOOP_ENGINE_BEVEL_FREEFORM_MACHINE_H_
#define GEARLOOP_ENGINE_BEVEL_FREEFORM_MACHINE_H_

#include <Eigen/Core>
#include <array>
#include <string>

#include "engine/bevel/cradle_machine.h"

namespace gearloop {

// The five axes that move the flank, in parameter order.
enum class FreeFormAxis { kA = 0, kB = 1, kX = 2, kY = 3, kZ = 4 };
constexpr int kNumFreeFormAxes = 5;
// "A", "B", "X", "Y", "Z".
const char* FreeFormAxisName(FreeFormAxis axis);
// "rad" for A and B, "mm" for X, Y, Z.
const char* FreeFormAxisUnit(FreeFormAxis axis);

struct FreeFormAxisValues {
  double a_rad = 0.0;
  double b_rad = 0.0;
  double x_mm = 0.0;
  double y_mm = 0.0;
  double z_mm = 0.0;
  double c_rad = 0.0;  // cutter spindle phase (no effect on the flank)

  double Get(FreeFormAxis axis) const;
  void Set(FreeFormAxis axis, double value);
};

// work_from_cutter of the free-form machine at the given axis positions (C
// included).
RigidTransform FreeFormWorkFromCutter(const FreeFormAxisValues& axes);

// Axis motions: axis i at roll t is sum_k coefficients[i](k) t^k, degree 0..12.
struct FreeFormMotion {
  int degree = 0;
  std::array<Eigen::VectorXd, kNumFreeFormAxes> coefficients;
  // The cutter spindle phase polynomial (reported, not part of the parameters);
  // may be empty.
  Eigen::VectorXd c_coefficients;

  // A motion of `degree` with all coefficients 0.
  static FreeFormMotion Zero(int degree);
  int NumParameters() const { return kNumFreeFormAxes * (degree + 1); }
  double Value(FreeFormAxis axis, double roll_rad) const;
  double Rate(FreeFormAxis axis, double roll_rad) const;
  FreeFormAxisValues At(double roll_rad) const;
  // Parameter vector: A0..A_d, B0..B_d, X0..X_d, Y0..Y_d, Z0..Z_d.
  Eigen::VectorXd ToVector() const;
  // Inverse of ToVector (keeps c_coefficients empty); `parameters` must have
  // kNumFreeFormAxes * (degree + 1) entries.
  static FreeFormMotion FromVector(int degree,
                                   const Eigen::VectorXd& parameters);
};

// Index of coefficient `order` of `axis` in the parameter vector of a motion of
// `degree`.
inline int FreeFormParameterIndex(FreeFormAxis axis, int order, int degree) {
  return static_cast<int>(axis) * (degree + 1) + order;
}
// "A0".."Z<degree>".
std::string FreeFormParameterName(int index, int degree);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_BEVEL_FREEFORM_MACHINE_H_
