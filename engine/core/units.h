// engine/core/units.h: pi and the degree/radian conversions, defined once for
// the whole project (as COLMAP's math/math.h does). Inside the engine every
// angle is in radians; degrees appear only at the API (the server's codecs).
//
//   const double helix_rad = DegToRad(15.0);
//   const double shown_deg = roll_rad * kDegPerRad;
#ifndef GEARLOOP_ENGINE_CORE_UNITS_H_
#define GEARLOOP_ENGINE_CORE_UNITS_H_

namespace gearloop {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadPerDeg = kPi / 180.0;
constexpr double kDegPerRad = 180.0 / kPi;

constexpr double DegToRad(double degrees) { return degrees * kRadPerDeg; }
constexpr double RadToDeg(double radians) { return radians * kDegPerRad; }

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORE_UNITS_H_
