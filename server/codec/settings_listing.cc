#include "server/codec/settings_listing.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace gearloop {
namespace {

// Full precision, shortest form: "%.12g" keeps 12 significant digits, which
// is below a nanometre on any axis a gear machine has.
std::string Number(double value) {
  if (!std::isfinite(value)) return "nan";
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.12g", value);
  return buffer;
}

std::string Fixed(double value, int digits) {
  if (!std::isfinite(value)) return "nan";
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

std::string Pad(const std::string& text, size_t width, bool left) {
  if (text.size() >= width) return text;
  const std::string fill(width - text.size(), ' ');
  return left ? text + fill : fill + text;
}

// "X_A2" for a polynomial coefficient, the block name for a scalar.
std::string ParameterName(const SettingsListing::Coefficient& c) {
  return c.is_polynomial ? c.block + "_A" + std::to_string(c.power) : c.block;
}

std::string HeaderComment(const SettingsListing& listing,
                          const std::string& prefix) {
  std::string text = prefix + "gearloop settings listing 1, job " +
                     std::to_string(listing.job_id) + ", machine " +
                     listing.machine_kind + "\n";
  if (!listing.part_number.empty() || !listing.serial.empty()) {
    text += prefix + "part " +
            (listing.part_number.empty() ? "-" : listing.part_number) +
            ", serial " + (listing.serial.empty() ? "-" : listing.serial) +
            "\n";
  }
  return text;
}

}  // namespace

bool IsSettingsListingFormat(const std::string& format) {
  return format == "csv" || format == "table" || format == "nc";
}

std::string SettingsListingCsv(const SettingsListing& listing) {
  std::ostringstream out;
  out << "record,block,power,roll_rad,unit,absolute,change,change_unit\n";
  for (const SettingsListing::Coefficient& c : listing.coefficients) {
    out << "coefficient," << c.block << "," << c.power << ",," << c.unit << ","
        << Number(c.absolute) << "," << Number(c.change) << "," << c.unit
        << "\n";
  }
  for (const SettingsListing::Motion& m : listing.motions) {
    for (size_t i = 0; i < listing.roll_rad.size(); ++i) {
      out << "motion," << m.block << ",," << Number(listing.roll_rad[i]) << ","
          << m.unit << "," << Number(m.absolute[i]) << ","
          << Number(m.change[i]) << "," << m.change_unit << "\n";
    }
  }
  return out.str();
}

std::string SettingsListingTable(const SettingsListing& listing) {
  std::ostringstream out;
  out << HeaderComment(listing, "");
  out << "\ncoefficients (coefficient k multiplies phi1^k, phi1 the roll angle "
         "in rad)\n";
  out << Pad("parameter", 22, true) << " " << Pad("unit", 10, true)
      << Pad("absolute", 20, false) << " " << Pad("change", 20, false) << "\n";
  for (const SettingsListing::Coefficient& c : listing.coefficients) {
    out << Pad(ParameterName(c), 22, true) << " " << Pad(c.unit, 10, true)
        << Pad(Number(c.absolute), 20, false) << " "
        << Pad(Number(c.change), 20, false) << "\n";
  }
  if (listing.motions.empty() || listing.roll_rad.empty()) return out.str();
  out << "\naxis motion over the roll range: position (change)\n";
  out << Pad("roll rad", 10, false);
  for (const SettingsListing::Motion& m : listing.motions)
    out << Pad(m.block + " " + m.unit + " (" + m.change_unit + ")", 26, false);
  out << "\n";
  for (size_t i = 0; i < listing.roll_rad.size(); ++i) {
    out << Pad(Fixed(listing.roll_rad[i], 5), 10, false);
    for (const SettingsListing::Motion& m : listing.motions) {
      out << Pad(Fixed(m.absolute[i], 6) + " (" + Fixed(m.change[i], 3) + ")",
                 26,
                 false);
    }
    out << "\n";
  }
  return out.str();
}

std::string SettingsListingNc(const SettingsListing& listing) {
  std::ostringstream out;
  out << HeaderComment(listing, "; ");
  out << "; NAME = VALUE ; unit, change. <axis>_A<k> multiplies phi1^k "
         "(phi1 roll angle, rad)\n";
  for (const SettingsListing::Coefficient& c : listing.coefficients) {
    out << ParameterName(c) << " = " << Number(c.absolute) << " ; " << c.unit
        << ", change " << Number(c.change) << "\n";
  }
  for (const SettingsListing::Motion& m : listing.motions) {
    out << "; " << m.block << " over phi1 [rad]: position " << m.unit
        << " (change " << m.change_unit << ")\n";
    for (size_t i = 0; i < listing.roll_rad.size(); ++i) {
      out << ";   " << Fixed(listing.roll_rad[i], 5) << "  "
          << Fixed(m.absolute[i], 6) << " (" << Fixed(m.change[i], 3) << ")\n";
    }
  }
  out << "; end\n";
  return out.str();
}

}  // namespace gearloop
