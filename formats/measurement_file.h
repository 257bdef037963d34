// formats/measurement_file.h: what the measuring-machine file readers
// (mka_reader.h, gde.h) return, where a refusal points, and the text rules they
// share.
//
//   MeasurementFile file;
//   FileError error;
//   if (!ReadMkaFile(content, &file, &error)) {
//     // error.ToString(): "file:line 37: 47 values, the trace head at line 33
//     says 48 Werte"
//     // error.too_large: the upload limit (413), otherwise a content error
//     (422)
//   }
//
// Tolerant where files differ harmlessly (UTF-8 with or without byte-order
// mark, Latin-1 umlauts, CRLF or LF), strict about anything that would change a
// number (METROLOGY.md §5): every refusal names the file line (mka) or the
// element path (GDE).
#ifndef GEARLOOP_FORMATS_MEASUREMENT_FILE_H_
#define GEARLOOP_FORMATS_MEASUREMENT_FILE_H_

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/metrology/trace_grid.h"

namespace gearloop {

// Largest measuring-machine file accepted [bytes] (the upload limit, HTTP 413
// above it). A P-series topography of 480 values x 5 traces x 2 flanks is ~60
// kB; 4 MiB leaves room for many teeth and 915-value helix traces.
inline constexpr size_t kMaxMeasurementFileBytes = 4 * 1024 * 1024;
// Largest `n Werte` of one trace, and of a GDE net's points: more is refused
// before reading on.
inline constexpr int kMaxTraceValues = 100000;

enum class MeasurementFormat { kMka, kGde };

// A place in a file: a 1-based line (mka; 0 = the file as a whole) or an
// element path (GDE,
// "/GDE/GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS/TOPOGRAPHY[1]/P[12]", an
// attribute as "/@dev").
struct FilePlace {
  int line = 0;
  std::string element_path;

  // "file:line 37", the element path, or "file" when neither is known.
  std::string ToString() const;
};

struct FileError {
  FilePlace place;
  std::string message;
  // The file exceeds kMaxMeasurementFileBytes (413), not a content error (422).
  bool too_large = false;

  // "file:line 37: <message>" / "/GDE/...: <message>".
  std::string ToString() const;
};

// A header value with the place it came from (to name it when it contradicts
// the request).
struct HeaderValue {
  double value = 0.0;
  FilePlace place;
  std::string name;  // "code 21 (m_n)", "normal_module"
};

// Gear data as the file states it; the request's gear is authoritative
// (METROLOGY.md §1).
struct MeasurementFileHeader {
  std::optional<HeaderValue> normal_module_mm;
  std::optional<HeaderValue> teeth;
  std::optional<HeaderValue> helix_angle_deg;  // as written (sign conventions
                                               // differ: |beta| is compared)
  std::optional<HeaderValue> normal_pressure_angle_deg;
  std::optional<HeaderValue> face_width_mm;
  std::optional<HeaderValue> tip_diameter_mm;
  std::optional<HeaderValue> root_diameter_mm;
  // Profile evaluation length L_alpha [mm] (mka code 45).
  std::optional<HeaderValue> profile_evaluation_length_mm;
  // Profile evaluation range d1..d2 [mm] (mka codes 42/43, GDE), when L_alpha
  // is not given.
  std::optional<HeaderValue> profile_evaluation_begin_diameter_mm;
  std::optional<HeaderValue> profile_evaluation_end_diameter_mm;
  // Helix hand as the file says it ("right"/"left"), when it does.
  std::optional<std::string> helix_hand;
  FilePlace helix_hand_place;
  // The datum face the file declares (GDE), when it does.
  std::optional<DatumFace> datum_face;
};

struct MeasurementFile {
  MeasurementFormat format = MeasurementFormat::kMka;
  MeasurementFileHeader header;
  std::vector<MeasuredTrace> traces;
  // Per trace: where it starts (trace head line, TOPOGRAPHY element) and where
  // its abscissa range comes from (mka code 41/61 line, the net itself for
  // GDE).
  std::vector<FilePlace> trace_places;
  std::vector<FilePlace> range_places;
  std::vector<std::string> warnings;
};

// Text decoding shared by the readers: refuses a file over the limit,
// UTF-16/32, NUL and other control characters (except tab, CR, LF); strips a
// UTF-8 byte-order mark; takes a file that is not valid UTF-8 as Latin-1
// (refusing the C1 range 0x80-0x9F, which no Latin-1 text uses) and converts it
// to UTF-8. Returns false with a located error.
bool DecodeMeasurementText(std::string_view bytes,
                           std::string* utf8,
                           FileError* error);

// Parses the whole of `text` as a decimal number:
// [+-]digits[.digits][e[+-]digits]. Refuses a decimal comma, NaN/inf in any
// spelling, anything left over, and values that overflow; `why` says which.
bool ParseDecimalNumber(std::string_view text, double* value, std::string* why);

}  // namespace gearloop

#endif  // GEARLOOP_FORMATS_MEASUREMENT_FILE_H_
