#include "engine/grinder/grinding_setup.h"

#include <cmath>
#include <sstream>

#include "engine/core/units.h"

namespace gearloop {
namespace {
// Angles arrive in degrees through the API and are held in radians; a limit
// given in degrees is compared with this slack so that 45 deg or 60 deg
// converted to radians and back still counts as the limit itself.
constexpr double kAngleSlackDeg = 1e-9;

}  // namespace

bool FailValidation(ValidationIssue* issue,
                    const std::string& field,
                    const std::string& message) {
  if (issue != nullptr) {
    issue->field = field;
    issue->message = message;
  }
  return false;
}

std::string FormatValidationNumber(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

double Involute(double alpha_rad) { return std::tan(alpha_rad) - alpha_rad; }

double GearData::PitchRadiusMm() const {
  return teeth * normal_module_mm / (2.0 * std::cos(helix_angle_rad));
}

double GearData::TransversePressureAngleRad() const {
  return std::atan(std::tan(normal_pressure_angle_rad) /
                   std::cos(helix_angle_rad));
}

double GearData::BaseRadiusMm() const {
  return PitchRadiusMm() * std::cos(TransversePressureAngleRad());
}

double GearData::TanBaseHelixAngle() const {
  return std::tan(helix_angle_rad) * std::cos(TransversePressureAngleRad());
}

double GearData::FormRollLengthMm() const {
  const double r_j = PitchRadiusMm();
  const double alpha_t = TransversePressureAngleRad();
  return std::max(
      0.0,
      r_j * std::sin(alpha_t) - (r_j - root_radius_mm) / std::sin(alpha_t));
}

double GearData::TipRollLengthMm() const {
  const double r_b = BaseRadiusMm();
  return std::sqrt(std::max(0.0, tip_radius_mm * tip_radius_mm - r_b * r_b));
}

bool ValidateGear(const GearData& gear, ValidationIssue* issue) {
  if (gear.teeth < 5) {
    return FailValidation(
        issue,
        "gear.teeth",
        "a gear needs at least 5 teeth, got " + std::to_string(gear.teeth));
  }
  if (gear.teeth > 10000) {
    return FailValidation(
        issue,
        "gear.teeth",
        "at most 10000 teeth, got " + std::to_string(gear.teeth));
  }
  if (!std::isfinite(gear.normal_module_mm) || gear.normal_module_mm <= 0.0 ||
      gear.normal_module_mm > 100.0) {
    return FailValidation(issue,
                          "gear.normal_module_mm",
                          "normal module must be in (0, 100] mm, got " +
                              FormatValidationNumber(gear.normal_module_mm));
  }
  const double alpha_deg = gear.normal_pressure_angle_rad * kDegPerRad;
  if (!std::isfinite(alpha_deg) || alpha_deg <= kAngleSlackDeg ||
      alpha_deg >= 45.0 - kAngleSlackDeg) {
    return FailValidation(
        issue,
        "gear.normal_pressure_angle_rad",
        "normal pressure angle must be in (0, 45) degrees, got " +
            FormatValidationNumber(alpha_deg) + " degrees");
  }
  const double beta_deg = gear.helix_angle_rad * kDegPerRad;
  if (!std::isfinite(beta_deg) || std::abs(beta_deg) >= 60.0 - kAngleSlackDeg) {
    return FailValidation(issue,
                          "gear.helix_angle_rad",
                          "helix angle must be in [0, 60) degrees, got " +
                              FormatValidationNumber(std::abs(beta_deg)) +
                              " degrees");
  }
  if (!std::isfinite(gear.face_width_mm) || gear.face_width_mm <= 0.0 ||
      gear.face_width_mm > 5000.0) {
    return FailValidation(issue,
                          "gear.face_width_mm",
                          "face width must be in (0, 5000] mm, got " +
                              FormatValidationNumber(gear.face_width_mm));
  }
  const double r_j = gear.PitchRadiusMm();
  const double r_b = gear.BaseRadiusMm();
  if (!std::isfinite(gear.root_radius_mm) || gear.root_radius_mm <= 0.0 ||
      gear.root_radius_mm >= r_j) {
    return FailValidation(issue,
                          "gear.root_radius_mm",
                          "root radius must be in (0, pitch radius " +
                              FormatValidationNumber(r_j) + ") mm, got " +
                              FormatValidationNumber(gear.root_radius_mm));
  }
  if (!std::isfinite(gear.tip_radius_mm) || gear.tip_radius_mm <= r_j) {
    return FailValidation(issue,
                          "gear.tip_radius_mm",
                          "tip radius must exceed the pitch radius " +
                              FormatValidationNumber(r_j) + " mm, got " +
                              FormatValidationNumber(gear.tip_radius_mm));
  }
  if (gear.tip_radius_mm > r_j + 3.0 * gear.normal_module_mm) {
    return FailValidation(
        issue,
        "gear.tip_radius_mm",
        "tip radius " + FormatValidationNumber(gear.tip_radius_mm) +
            " mm is more than 3 modules above the pitch radius " +
            FormatValidationNumber(r_j) + " mm");
  }
  const double form_radius =
      std::sqrt(r_b * r_b + std::pow(gear.FormRollLengthMm(), 2));
  if (gear.tip_radius_mm <= form_radius) {
    return FailValidation(issue,
                          "gear.tip_radius_mm",
                          "tip radius " +
                              FormatValidationNumber(gear.tip_radius_mm) +
                              " mm must lie above the form radius " +
                              FormatValidationNumber(form_radius) + " mm");
  }
  return true;
}

bool ValidateGrid(const GridOptions& grid, ValidationIssue* issue) {
  if (grid.profile_points < 2 || grid.profile_points > 101) {
    return FailValidation(issue,
                          "grid.profile_points",
                          "profile points must be between 2 and 101, got " +
                              std::to_string(grid.profile_points));
  }
  if (grid.lead_points < 2 || grid.lead_points > 101) {
    return FailValidation(issue,
                          "grid.lead_points",
                          "lead points must be between 2 and 101, got " +
                              std::to_string(grid.lead_points));
  }
  if (!std::isfinite(grid.profile_begin) || grid.profile_begin < 0.0 ||
      grid.profile_begin >= 1.0) {
    return FailValidation(issue,
                          "grid.profile_begin",
                          "profile range must start in [0, 1), got " +
                              FormatValidationNumber(grid.profile_begin));
  }
  if (!std::isfinite(grid.profile_end) ||
      grid.profile_end <= grid.profile_begin || grid.profile_end > 1.0) {
    return FailValidation(issue,
                          "grid.profile_end",
                          "profile range must end in (start, 1], got [" +
                              FormatValidationNumber(grid.profile_begin) +
                              ", " + FormatValidationNumber(grid.profile_end) +
                              "]");
  }
  if (!std::isfinite(grid.lead_begin) || grid.lead_begin < -0.5 ||
      grid.lead_begin >= 0.5) {
    return FailValidation(issue,
                          "grid.lead_begin",
                          "lead range must start in [-0.5, 0.5), got " +
                              FormatValidationNumber(grid.lead_begin));
  }
  if (!std::isfinite(grid.lead_end) || grid.lead_end <= grid.lead_begin ||
      grid.lead_end > 0.5) {
    return FailValidation(issue,
                          "grid.lead_end",
                          "lead range must end in (start, 0.5], got [" +
                              FormatValidationNumber(grid.lead_begin) + ", " +
                              FormatValidationNumber(grid.lead_end) + "]");
  }
  return true;
}

bool ValidateSetup(const GrindingSetup& setup, ValidationIssue* issue) {
  if (!ValidateGear(setup.gear, issue)) return false;
  if (!ValidateGrid(setup.grid, issue)) return false;
  const GearData& gear = setup.gear;
  const double cos_alpha = std::cos(gear.normal_pressure_angle_rad);
  // The wheel generates the flank along the normal section of the rack: its
  // face must span the whole depth from the rim (at the root) to beyond the
  // tip, measured along the rack flank, and the traverse/lead must stay within
  // it.
  const double depth_mm =
      (gear.tip_radius_mm - gear.root_radius_mm) / cos_alpha;
  if (!std::isfinite(setup.wheel.radius_mm) || setup.wheel.radius_mm <= 0.0) {
    return FailValidation(issue,
                          "wheel.radius_mm",
                          "wheel radius must be positive, got " +
                              FormatValidationNumber(setup.wheel.radius_mm));
  }
  if (setup.wheel.radius_mm > 5000.0) {
    return FailValidation(issue,
                          "wheel.radius_mm",
                          "wheel radius must be at most 5000 mm, got " +
                              FormatValidationNumber(setup.wheel.radius_mm));
  }
  if (setup.wheel.radius_mm <= 2.0 * depth_mm) {
    return FailValidation(
        issue,
        "wheel.radius_mm",
        "wheel radius " + FormatValidationNumber(setup.wheel.radius_mm) +
            " mm is too small: it must exceed twice the tooth depth "
            "along the flank (" +
            FormatValidationNumber(2.0 * depth_mm) + " mm)");
  }
  const MachineConstants& m = setup.machine;
  if (!std::isfinite(m.k1_mm) || std::abs(m.k1_mm) > 10000.0) {
    return FailValidation(
        issue,
        "machine.k1_mm",
        "K1 must be finite and at most 10000 mm in size, got " +
            FormatValidationNumber(m.k1_mm));
  }
  if (!std::isfinite(m.k2_mm) || std::abs(m.k2_mm) > 10000.0) {
    return FailValidation(
        issue,
        "machine.k2_mm",
        "K2 must be finite and at most 10000 mm in size, got " +
            FormatValidationNumber(m.k2_mm));
  }
  if (!std::isfinite(m.traverse_mm_per_rad) ||
      std::abs(m.traverse_mm_per_rad) > 10000.0) {
    return FailValidation(
        issue,
        "machine.traverse_mm_per_rad",
        "wheel traverse must be finite and at most 10000 mm/rad in size, got " +
            FormatValidationNumber(m.traverse_mm_per_rad));
  }
  const double form_length = gear.FormRollLengthMm();
  const double tip_length = gear.TipRollLengthMm();
  if (form_length >= tip_length) {
    return FailValidation(
        issue,
        "gear.root_radius_mm",
        "the wheel rim at root radius " +
            FormatValidationNumber(gear.root_radius_mm) +
            " mm leaves no involute below the tip (form roll length " +
            FormatValidationNumber(form_length) + " mm >= tip roll length " +
            FormatValidationNumber(tip_length) + " mm)");
  }
  return true;
}

}  // namespace gearloop
