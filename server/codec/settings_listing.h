// server/codec/settings_listing.h: the machine-ready listing of a correction's
// settings (GET /api/v1/corrections/{id}/settings, docs/settings-listing.md):
// every coefficient of every axis block absolute and changed, with its unit,
// and each polynomial axis's position and its change sampled over the roll
// range, written as CSV, as an aligned table or as a parameter listing a
// controller or a setup sheet can take ("nc"). Pure text rendering of numbers
// the service computed.
//
//   SettingsListing listing;   // filled by services/settings_service.cc
//   res.set_content(SettingsListingCsv(listing), "text/csv");
#ifndef GEARLOOP_SERVER_CODEC_SETTINGS_LISTING_H_
#define GEARLOOP_SERVER_CODEC_SETTINGS_LISTING_H_

#include <cstdint>
#include <string>
#include <vector>

namespace gearloop {

struct SettingsListing {
  int64_t job_id = 0;
  std::string machine_kind;
  // The part, when the job's trace names it ("" otherwise).
  std::string part_number;
  std::string serial;

  // One coefficient of one block: `power` k of a polynomial block multiplies
  // phi1^k (phi1 the roll angle in rad); a scalar block has power 0.
  struct Coefficient {
    std::string block;  // "X", "cone_angle", ...
    bool is_polynomial = false;
    int power = 0;
    std::string unit;  // "mm", "mm/rad^2", "rad", "1/mm"
    double absolute = 0.0;
    double change = 0.0;
  };
  std::vector<Coefficient> coefficients;

  // The roll angles [rad] the polynomial axes are sampled at.
  std::vector<double> roll_rad;
  // A polynomial axis over the roll range: its position (in `unit`) and its
  // change (in `change_unit`: um for mm, urad for rad).
  struct Motion {
    std::string block;
    std::string unit;
    std::string change_unit;
    std::vector<double> absolute;
    std::vector<double> change;
  };
  std::vector<Motion> motions;
};

// "csv", "table" and "nc": the formats written.
bool IsSettingsListingFormat(const std::string& format);

// The header line and one record per line (RFC 4180, no quoting needed):
//   record,block,power,roll_rad,unit,absolute,change,change_unit
//   coefficient,X,2,,mm/rad^2,-1.25e-05,3.5e-07,mm/rad^2
//   motion,X,,0.1234,mm,201.0234,1.234,um
std::string SettingsListingCsv(const SettingsListing& listing);
// Coefficients, then the motions, in aligned columns for a person.
std::string SettingsListingTable(const SettingsListing& listing);
// The parameter listing of docs/settings-listing.md: "; " comment lines and
// "NAME = VALUE" lines, NAME = <block>_A<k> (coefficient) or <block> (scalar),
// each with its unit and change in a comment.
std::string SettingsListingNc(const SettingsListing& listing);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_SETTINGS_LISTING_H_
