// formats/measurement_import.cc: the import pipeline. The request's gear is
// authoritative; the file's header is only checked against it (METROLOGY.md
// §1).
#include "formats/measurement_import.h"

#include <cmath>
#include <sstream>

#include "engine/core/units.h"
#include "formats/mka_reader.h"

namespace gearloop {
namespace {

std::string Num(double value) {
  std::ostringstream out;
  out.precision(7);
  out << value;
  return out.str();
}

bool Refuse(const FilePlace& place,
            const std::string& message,
            MeasurementImportResult* result) {
  result->ok = false;
  result->error = FileError{place, message, false};
  return false;
}

// Refuses a header value that differs from the request's by more than
// `tolerance`.
bool Check(const std::optional<HeaderValue>& header,
           double request,
           double tolerance,
           const char* unit,
           MeasurementImportResult* result) {
  if (!header) return true;
  if (std::abs(header->value - request) <= tolerance) return true;
  return Refuse(header->place,
                header->name + " is " + Num(header->value) + unit +
                    " in the file, " + Num(request) + unit +
                    " in the request (the request's gear is authoritative: is "
                    "this the right file?)",
                result);
}

// The file's header against the request's gear: module, teeth, pressure
// angle, face width and helix angle must agree.
bool CheckHeader(const MeasurementImportOptions& options,
                 const GearData& gear,
                 const MeasurementFileHeader& h,
                 MeasurementImportResult* result) {
  if (!Check(h.normal_module_mm,
             gear.normal_module_mm,
             options.length_tolerance_mm,
             " mm",
             result) ||
      !Check(h.teeth, gear.teeth, 0.0, "", result) ||
      !Check(h.normal_pressure_angle_deg,
             RadToDeg(gear.normal_pressure_angle_rad),
             options.angle_tolerance_deg,
             " deg",
             result) ||
      !Check(h.face_width_mm,
             gear.face_width_mm,
             options.length_tolerance_mm,
             " mm",
             result)) {
    return false;
  }
  if (h.helix_angle_deg) {
    HeaderValue beta = *h.helix_angle_deg;
    beta.value = std::abs(beta.value);
    beta.name += " |beta|";
    if (!Check(beta,
               std::abs(RadToDeg(gear.helix_angle_rad)),
               options.angle_tolerance_deg,
               " deg",
               result)) {
      return false;
    }
  }
  return true;
}

// Warns of header values that differ from the request's but are not used
// (diameters, hand, datum face); returns the datum face to use.
DatumFace WarnOfHeader(const MeasurementImportOptions& options,
                       const GearData& gear,
                       const MeasurementFileHeader& h,
                       MeasurementImportResult* result) {
  // Warnings only: the tip and root diameters and the hand.
  for (const auto& [value, request] :
       {std::make_pair(h.tip_diameter_mm, 2.0 * gear.tip_radius_mm),
        std::make_pair(h.root_diameter_mm, 2.0 * gear.root_radius_mm)}) {
    if (value && std::abs(value->value - request) > 0.01) {
      result->warnings.push_back(value->name + " is " + Num(value->value) +
                                 " mm in the file (" + value->place.ToString() +
                                 "), " + Num(request) + " mm in the request");
    }
  }
  if (h.helix_hand && gear.helix_angle_rad != 0.0) {
    const std::string request_hand =
        gear.helix_angle_rad > 0.0 ? "left" : "right";
    if (*h.helix_hand != request_hand && *h.helix_hand != "spur") {
      result->warnings.push_back(
          "the file says a " + *h.helix_hand + "-hand helix (" +
          h.helix_hand_place.ToString() + "), the request a " + request_hand +
          "-hand one");
    }
  }
  DatumFace datum = h.datum_face.value_or(DatumFace::kXNegative);
  if (options.datum_face) {
    if (h.datum_face && *h.datum_face != *options.datum_face) {
      result->warnings.push_back(
          "the file declares the other datum face; the request's is used");
    }
    datum = *options.datum_face;
  }
  return datum;
}

// Refuses a trace inside the base circle.
bool CheckBaseCircle(const GearData& gear, MeasurementImportResult* result) {
  // A diameter inside the base circle, named at the header code or point it
  // comes from.
  const double d_b = 2.0 * gear.BaseRadiusMm();
  for (size_t i = 0; i < result->file.traces.size(); ++i) {
    const MeasuredTrace& t = result->file.traces[i];
    if (t.kind == TraceKind::kProfile &&
        t.spacing == TraceSpacing::kEqualSteps && !(t.begin_mm >= d_b)) {
      Refuse(result->file.range_places[i],
             "profile measuring range starts at d = " + Num(t.begin_mm) +
                 " mm, inside the base circle d_b = " + Num(d_b) + " mm",
             result);
      return false;
    }
    if (t.kind == TraceKind::kHelix && !(t.position_mm >= d_b)) {
      Refuse(result->file.trace_places[i],
             "helix trace at d = " + Num(t.position_mm) +
                 " mm, inside the base circle d_b = " + Num(d_b) + " mm",
             result);
      return false;
    }
  }
  return true;
}

// Interpolates the traces onto the request's grid.
bool InterpolateOntoGrid(const MeasurementImportOptions& options,
                         const GearData& gear,
                         DatumFace datum,
                         MeasurementImportResult* result) {
  TraceGridOptions grid_options;
  grid_options.flank = options.flank;
  grid_options.tooth = options.tooth;
  grid_options.datum_face = datum;
  grid_options.sign = options.sign;
  result->grid =
      InterpolateTraces(grid_options, gear, options.grid, result->file.traces);
  if (!result->grid.ok) {
    const FilePlace place =
        result->grid.trace_index >= 0 &&
                result->grid.trace_index <
                    static_cast<int>(result->file.trace_places.size())
            ? result->file.trace_places[result->grid.trace_index]
            : FilePlace{};
    Refuse(place, result->grid.message, result);
    return false;
  }
  for (const std::string& w : result->grid.warnings)
    result->warnings.push_back(w);
  return true;
}

// The ISO 1328 figures and classes of the interpolated flank.
bool EvaluateFlank(const MeasurementImportOptions& options,
                   const GearData& gear,
                   const MeasurementFileHeader& h,
                   MeasurementImportResult* result) {
  // L_alpha: the file's (code 45), else its evaluation range d1..d2 in roll
  // length, else the default of METROLOGY.md §4.
  result->iso_options.class_resolution_um = options.class_resolution_um;
  if (h.profile_evaluation_length_mm &&
      h.profile_evaluation_length_mm->value > 0.0) {
    result->iso_options.profile_evaluation_length_mm =
        h.profile_evaluation_length_mm->value;
  } else if (h.profile_evaluation_begin_diameter_mm &&
             h.profile_evaluation_end_diameter_mm) {
    const double l1 = RollLengthOfDiameterMm(
        gear, h.profile_evaluation_begin_diameter_mm->value);
    const double l2 = RollLengthOfDiameterMm(
        gear, h.profile_evaluation_end_diameter_mm->value);
    if (std::isfinite(l1) && std::isfinite(l2) && l2 > l1)
      result->iso_options.profile_evaluation_length_mm = l2 - l1;
  }
  result->figures = ComputeFlankFigures(
      result->iso_options, gear, options.grid, result->grid.deviations_um);
  if (!result->figures.ok) {
    Refuse(FilePlace{}, result->figures.message, result);
    return false;
  }
  result->classes = ClassifyFlank(result->iso_options, gear, result->figures);
  for (const std::string& w : result->classes.warnings)
    result->warnings.push_back(w);
  return true;
}

}  // namespace

MeasurementImportResult ImportMeasurementFile(
    const MeasurementImportOptions& options,
    const GearData& gear,
    std::string_view content) {
  MeasurementImportResult result;
  ValidationIssue issue;
  if (!ValidateGear(gear, &issue) || !ValidateGrid(options.grid, &issue)) {
    Refuse(FilePlace{},
           "the request: " + issue.field + ": " + issue.message,
           &result);
    return result;
  }
  FileError error;
  const bool read =
      options.format == MeasurementFormat::kMka
          ? ReadMkaFile(content, &result.file, &error)
          : ReadGdeFile(content,
                        GdeReadOptions{options.gde_topography_kind},
                        &result.file,
                        &error);
  if (!read) {
    result.error = error;
    return result;
  }
  const MeasurementFileHeader& h = result.file.header;
  if (!CheckHeader(options, gear, h, &result)) return result;
  const DatumFace datum = WarnOfHeader(options, gear, h, &result);
  if (!CheckBaseCircle(gear, &result) ||
      !InterpolateOntoGrid(options, gear, datum, &result) ||
      !EvaluateFlank(options, gear, h, &result))
    return result;
  result.ok = true;
  return result;
}

}  // namespace gearloop
