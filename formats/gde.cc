// formats/gde.cc: the GDE reader and writer. Both walk the element paths of
// GdeNames and nothing else, so a renamed element is a change of the table
// only.
#include "formats/gde.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <utility>

#include "engine/core/units.h"
#include "formats/xml.h"

namespace gearloop {
namespace {

constexpr double kMaxDeviationUm = 1e4;
constexpr double kMaxLengthMm = 1e5;
constexpr int kMaxNetPoints = 1000000;

std::vector<std::string> SplitPath(const std::string& path) {
  std::vector<std::string> out;
  size_t begin = 0;
  while (begin <= path.size()) {
    const size_t slash = path.find('/', begin);
    const std::string part = path.substr(
        begin, slash == std::string::npos ? std::string::npos : slash - begin);
    if (!part.empty()) out.push_back(part);
    if (slash == std::string::npos) break;
    begin = slash + 1;
  }
  return out;
}

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\n' || s[b] == '\r'))
    ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\n' ||
                   s[e - 1] == '\r'))
    --e;
  return s.substr(b, e - b);
}

enum class Quantity { kLength, kAngle, kDeviation, kCount };

// Factor to mm, deg or um; false for an unknown unit.
bool UnitFactor(Quantity q, const std::string& unit, double* factor) {
  const std::string u = Trim(unit);
  switch (q) {
    case Quantity::kLength:
      if (u == "mm")
        *factor = 1.0;
      else if (u == "um" || u == "\xC2\xB5m" || u == "\xCE\xBCm")
        *factor = 1e-3;
      else if (u == "m")
        *factor = 1e3;
      else if (u == "in" || u == "inch")
        *factor = 25.4;
      else
        return false;
      return true;
    case Quantity::kAngle:
      if (u == "deg" || u == "\xC2\xB0")
        *factor = 1.0;
      else if (u == "rad")
        *factor = kDegPerRad;
      else
        return false;
      return true;
    case Quantity::kDeviation:
      if (u == "um" || u == "\xC2\xB5m" || u == "\xCE\xBCm")
        *factor = 1.0;
      else if (u == "mm")
        *factor = 1e3;
      else if (u == "nm")
        *factor = 1e-3;
      else
        return false;
      return true;
    case Quantity::kCount:
      *factor = 1.0;
      return u.empty();
  }
  return false;
}

const char* QuantityUnits(Quantity q) {
  switch (q) {
    case Quantity::kLength:
      return "mm, um, m, in";
    case Quantity::kAngle:
      return "deg, rad";
    case Quantity::kDeviation:
      return "um, mm, nm";
    case Quantity::kCount:
      return "none";
  }
  return "";
}

class GdeReader {
 public:
  GdeReader(const GdeNames& names,
            const GdeReadOptions& options,
            MeasurementFile* file,
            FileError* error)
      : names_(names), options_(options), file_(file), error_(error) {}

  bool Read(std::string_view content) {
    std::string text;
    if (!DecodeMeasurementText(content, &text, error_)) return false;
    *file_ = MeasurementFile{};
    file_->format = MeasurementFormat::kGde;
    XmlError xml_error;
    if (!ParseXml(text, &root_, &xml_error)) {
      return Fail(FilePlace{xml_error.line, ""},
                  "XML not well-formed: " + xml_error.message);
    }
    if (root_.name != names_.root) {
      return Fail(
          FilePlace{root_.line, "/" + root_.name},
          "root element <" + root_.name + ">, expected <" + names_.root + ">");
    }
    return ReadGearValues() && ReadHelixDirection() && ReadDatumFace() &&
           ReadDeviationSign() && ReadEvaluationRanges() && ReadNets();
  }

 private:
  // The gear data of the header: teeth, module, angles, widths, diameters.
  bool ReadGearValues() {
    MeasurementFileHeader& h = file_->header;
    if (!Value(names_.teeth, Quantity::kCount, "number of teeth", &h.teeth) ||
        !Value(names_.normal_module,
               Quantity::kLength,
               "normal module",
               &h.normal_module_mm) ||
        !Value(names_.normal_pressure_angle,
               Quantity::kAngle,
               "normal pressure angle",
               &h.normal_pressure_angle_deg) ||
        !Value(names_.helix_angle,
               Quantity::kAngle,
               "helix angle",
               &h.helix_angle_deg) ||
        !Value(names_.face_width,
               Quantity::kLength,
               "face width",
               &h.face_width_mm) ||
        !Value(names_.tip_diameter,
               Quantity::kLength,
               "tip diameter",
               &h.tip_diameter_mm) ||
        !Value(names_.root_diameter,
               Quantity::kLength,
               "root diameter",
               &h.root_diameter_mm)) {
      return false;
    }
    if (h.teeth &&
        (h.teeth->value != std::floor(h.teeth->value) || h.teeth->value < 1)) {
      return Fail(h.teeth->place, "number of teeth is not a whole number >= 1");
    }
    return true;
  }

  // The helix direction, when given.
  bool ReadHelixDirection() {
    MeasurementFileHeader& h = file_->header;
    std::string path;
    const XmlElement* e = nullptr;
    if (!Find(names_.helix_direction, &e, &path)) return false;
    if (e != nullptr) {
      const std::string v = Trim(e->text);
      if (v == names_.hand_right)
        h.helix_hand = "right";
      else if (v == names_.hand_left)
        h.helix_hand = "left";
      else if (v == names_.hand_spur)
        h.helix_hand = "spur";
      else
        return Fail(Place(e, path),
                    "unknown helix direction '" + v.substr(0, 40) + "'");
      h.helix_hand_place = Place(e, path);
    }
    return true;
  }

  // The datum face, when given.
  bool ReadDatumFace() {
    MeasurementFileHeader& h = file_->header;
    std::string path;
    const XmlElement* e = nullptr;
    if (!Find(names_.datum_face, &e, &path)) return false;
    if (e != nullptr) {
      const std::string v = Trim(e->text);
      if (v == names_.datum_x_negative)
        h.datum_face = DatumFace::kXNegative;
      else if (v == names_.datum_x_positive)
        h.datum_face = DatumFace::kXPositive;
      else
        return Fail(Place(e, path),
                    "unknown datum face '" + v.substr(0, 40) + "' (expected " +
                        names_.datum_x_negative + " or " +
                        names_.datum_x_positive + ")");
    }
    return true;
  }

  // The sign convention of the deviations, when given.
  bool ReadDeviationSign() {
    std::string path;
    const XmlElement* e = nullptr;
    if (!Find(names_.deviation_sign, &e, &path)) return false;
    if (e != nullptr) {
      const std::string v = Trim(e->text);
      if (v == names_.sign_material_negative)
        sign_ = -1.0;
      else if (v != names_.sign_material_positive)
        return Fail(Place(e, path),
                    "unknown deviation sign '" + v.substr(0, 40) + "'");
    }
    return true;
  }

  // The profile and helix evaluation ranges, when given.
  bool ReadEvaluationRanges() {
    MeasurementFileHeader& h = file_->header;
    std::string path;
    const XmlElement* e = nullptr;
    if (!Find(names_.profile_evaluation_range, &e, &path)) return false;
    if (e != nullptr) {
      std::optional<HeaderValue> from, to;
      if (!RangeAttribute(e, path, names_.range_from, &from) ||
          !RangeAttribute(e, path, names_.range_to, &to))
        return false;
      if (!from || !to)
        return Fail(Place(e, path),
                    "evaluation range needs both " + names_.range_from +
                        " and " + names_.range_to);
      if (!(from->value < to->value))
        return Fail(Place(e, path),
                    "evaluation range the wrong way (from >= to)");
      h.profile_evaluation_begin_diameter_mm = from;
      h.profile_evaluation_end_diameter_mm = to;
    }
    if (!Find(names_.helix_evaluation_range, &e, &path)) return false;
    if (e != nullptr) {
      std::optional<HeaderValue> from, to;
      if (!RangeAttribute(e, path, names_.range_from, &from) ||
          !RangeAttribute(e, path, names_.range_to, &to))
        return false;
      if (from && to && !(from->value < to->value)) {
        return Fail(Place(e, path),
                    "evaluation range the wrong way (from >= to)");
      }
    }
    return true;
  }

  bool Fail(const FilePlace& place, const std::string& message) {
    error_->place = place;
    error_->message = message;
    error_->too_large = false;
    return false;
  }

  static FilePlace Place(const XmlElement* e, const std::string& path) {
    return FilePlace{e != nullptr ? e->line : 0, path};
  }

  // The single element at `relative` (nullptr when absent); a repeated one is
  // refused.
  bool Find(const std::string& relative,
            const XmlElement** found,
            std::string* path) {
    const XmlElement* at = &root_;
    *path = "/" + root_.name;
    for (const std::string& part : SplitPath(relative)) {
      const XmlElement* next = nullptr;
      int count = 0;
      for (const XmlElement& child : at->children) {
        if (child.name != part) continue;
        if (++count == 2) {
          return Fail(FilePlace{child.line, *path + "/" + part + "[2]"},
                      "element <" + part + "> repeated (expected one)");
        }
        next = &child;
      }
      *path += "/" + part;
      if (next == nullptr) {
        *found = nullptr;
        return true;
      }
      at = next;
    }
    *found = at;
    return true;
  }

  bool Number(const std::string& text,
              const FilePlace& place,
              const std::string& what,
              double* value) {
    std::string why;
    if (!ParseDecimalNumber(Trim(text), value, &why))
      return Fail(place, what + ": " + why);
    return true;
  }

  bool Factor(const XmlElement* e,
              const std::string& path,
              const std::string& attribute,
              Quantity q,
              double* factor) {
    const std::string* unit = e->Attribute(attribute);
    *factor = 1.0;
    if (unit == nullptr) return true;
    if (!UnitFactor(q, *unit, factor)) {
      return Fail(FilePlace{e->line, path + "/@" + attribute},
                  "unknown unit '" + unit->substr(0, 20) +
                      "' (known: " + QuantityUnits(q) + ")");
    }
    return true;
  }

  bool Value(const std::string& relative,
             Quantity q,
             const std::string& name,
             std::optional<HeaderValue>* out) {
    const XmlElement* e = nullptr;
    std::string path;
    if (!Find(relative, &e, &path)) return false;
    if (e == nullptr) return true;
    double factor = 1.0;
    if (q != Quantity::kCount &&
        !Factor(e, path, names_.unit_attribute, q, &factor))
      return false;
    double v = 0.0;
    if (!Number(e->text, Place(e, path), name, &v)) return false;
    v *= factor;
    if (std::abs(v) > kMaxLengthMm)
      return Fail(Place(e, path), name + " out of range");
    const size_t slash = relative.rfind('/');
    *out = HeaderValue{
        v,
        Place(e, path),
        relative.substr(slash == std::string::npos ? 0 : slash + 1)};
    return true;
  }

  bool RangeAttribute(const XmlElement* e,
                      const std::string& path,
                      const std::string& attribute,
                      std::optional<HeaderValue>* out) {
    const std::string* text = e->Attribute(attribute);
    if (text == nullptr) return true;
    double factor = 1.0;
    if (!Factor(e, path, names_.unit_attribute, Quantity::kLength, &factor))
      return false;
    double v = 0.0;
    const FilePlace place{e->line, path + "/@" + attribute};
    if (!Number(*text, place, attribute, &v)) return false;
    if (std::abs(v * factor) > kMaxLengthMm)
      return Fail(place, attribute + " out of range");
    *out = HeaderValue{v * factor, place, attribute};
    return true;
  }

  bool ReadNets() {
    const XmlElement* results = nullptr;
    std::string results_path;
    if (!Find(names_.measurement_results, &results, &results_path))
      return false;
    if (results == nullptr) {
      return Fail(FilePlace{root_.line, results_path},
                  "no measurement results (element missing)");
    }
    int index = 0;
    int used = 0;
    for (const XmlElement& net : results->children) {
      if (net.name != names_.topography) continue;
      ++index;
      const std::string path = results_path + "/" + names_.topography + "[" +
                               std::to_string(index) + "]";
      const std::string* kind = net.Attribute(names_.topography_kind);
      if ((kind != nullptr ? *kind : std::string("measured")) !=
          options_.topography_kind)
        continue;
      ++used;
      if (!ReadNet(net, path)) return false;
    }
    if (used == 0) {
      return Fail(FilePlace{results->line, results_path},
                  "no " + names_.topography + " net of kind '" +
                      options_.topography_kind + "'");
    }
    return true;
  }

  bool IntAttribute(const XmlElement& e,
                    const std::string& path,
                    const std::string& attribute,
                    int low,
                    int high,
                    std::optional<int>* out) {
    const std::string* text = e.Attribute(attribute);
    if (text == nullptr) return true;
    double v = 0.0;
    const FilePlace place{e.line, path + "/@" + attribute};
    if (!Number(*text, place, attribute, &v)) return false;
    if (v != std::floor(v) || v < low || v > high) {
      return Fail(place,
                  attribute + " = " + text->substr(0, 20) +
                      " is not a whole number in " + std::to_string(low) +
                      ".." + std::to_string(high));
    }
    *out = static_cast<int>(v);
    return true;
  }

  // The attributes of a net: tooth, declared size, flank and units.
  struct NetAttributes {
    std::optional<int> tooth, rows, columns;
    Flank flank = Flank::kRight;
    double length_factor = 1.0, deviation_factor = 1.0;
  };

  // The points of a net keyed by (d, z) in nanometres, with the diameters and
  // axial positions they lie on.
  struct NetPoints {
    std::map<std::pair<long long, long long>, std::pair<int, double>>
        points;  // -> (P index, dev)
    std::map<long long, double> diameters, positions;
  };

  static long long NanometreKey(double mm) {
    return static_cast<long long>(std::llround(mm * 1e6));
  }

  bool ReadNet(const XmlElement& net, const std::string& path) {
    const FilePlace place{net.line, path};
    NetAttributes a;
    NetPoints points;
    if (!ReadNetAttributes(net, path, place, &a) ||
        !ReadNetPoints(net, path, place, a, &points) ||
        !CheckNetShape(net, path, place, a, points))
      return false;
    AddNetTraces(a, points, place);
    return true;
  }

  bool ReadNetAttributes(const XmlElement& net,
                         const std::string& path,
                         const FilePlace& place,
                         NetAttributes* a) {
    if (!IntAttribute(
            net, path, names_.topography_tooth, 1, 10000, &a->tooth) ||
        !IntAttribute(
            net, path, names_.topography_rows, 1, kMaxNetPoints, &a->rows) ||
        !IntAttribute(net,
                      path,
                      names_.topography_columns,
                      1,
                      kMaxNetPoints,
                      &a->columns)) {
      return false;
    }
    const std::string* flank_text = net.Attribute(names_.topography_flank);
    if (flank_text == nullptr)
      return Fail(place,
                  "net without a " + names_.topography_flank + " attribute");
    if (*flank_text == names_.flank_right)
      a->flank = Flank::kRight;
    else if (*flank_text == names_.flank_left)
      a->flank = Flank::kLeft;
    else
      return Fail(FilePlace{net.line, path + "/@" + names_.topography_flank},
                  "unknown flank '" + flank_text->substr(0, 20) + "'");
    if (!Factor(&net,
                path,
                names_.length_unit_attribute,
                Quantity::kLength,
                &a->length_factor) ||
        !Factor(&net,
                path,
                names_.deviation_unit_attribute,
                Quantity::kDeviation,
                &a->deviation_factor)) {
      return false;
    }
    return true;
  }

  bool ReadNetPoints(const XmlElement& net,
                     const std::string& path,
                     const FilePlace& place,
                     const NetAttributes& a,
                     NetPoints* net_points) {
    int p_index = 0;
    for (const XmlElement& p : net.children) {
      if (p.name != names_.point) {
        return Fail(FilePlace{p.line, path + "/" + p.name},
                    "unexpected element <" + p.name + "> in a net");
      }
      ++p_index;
      if (p_index > kMaxNetPoints)
        return Fail(place,
                    "more than " + std::to_string(kMaxNetPoints) + " points");
      const std::string p_path =
          path + "/" + names_.point + "[" + std::to_string(p_index) + "]";
      double d = 0.0, z = 0.0, dev = 0.0;
      if (!ReadPoint(p, p_path, a, &d, &z, &dev) ||
          !AddPoint(p, p_path, p_index, d, z, dev, net_points))
        return false;
    }
    return true;
  }

  // The position and deviation of one point, in mm and um.
  bool ReadPoint(const XmlElement& p,
                 const std::string& p_path,
                 const NetAttributes& a,
                 double* d,
                 double* z,
                 double* dev) {
    double v[3];
    const std::string* attributes[3] = {
        &names_.point_diameter, &names_.point_axial, &names_.point_deviation};
    for (int k = 0; k < 3; ++k) {
      const std::string* text = p.Attribute(*attributes[k]);
      const FilePlace a_place{p.line, p_path + "/@" + *attributes[k]};
      if (text == nullptr)
        return Fail(FilePlace{p.line, p_path},
                    "point without " + *attributes[k]);
      if (!Number(*text, a_place, *attributes[k], &v[k])) return false;
    }
    *d = v[0] * a.length_factor;
    *z = v[1] * a.length_factor;
    *dev = v[2] * a.deviation_factor * sign_;
    if (std::abs(*d) > kMaxLengthMm || std::abs(*z) > kMaxLengthMm) {
      return Fail(FilePlace{p.line, p_path}, "point position out of range");
    }
    if (std::abs(*dev) > kMaxDeviationUm) {
      return Fail(FilePlace{p.line, p_path + "/@" + names_.point_deviation},
                  "deviation above 10 mm is no deviation");
    }
    return true;
  }

  // Adds a point to the net; a second point at the same (d, z) is refused.
  bool AddPoint(const XmlElement& p,
                const std::string& p_path,
                int p_index,
                double d,
                double z,
                double dev,
                NetPoints* net) {
    const auto k = std::make_pair(NanometreKey(d), NanometreKey(z));
    const auto [it, inserted] =
        net->points.emplace(k, std::make_pair(p_index, dev));
    if (!inserted) {
      return Fail(
          FilePlace{p.line, p_path},
          "duplicate point d = " + Trim(*p.Attribute(names_.point_diameter)) +
              ", z = " + Trim(*p.Attribute(names_.point_axial)) +
              " (first as " + names_.point + "[" +
              std::to_string(it->second.first) + "])");
    }
    net->diameters.emplace(k.first, d);
    net->positions.emplace(k.second, z);
    return true;
  }

  // The points must fill the declared rows x columns grid.
  bool CheckNetShape(const XmlElement& xml,
                     const std::string& path,
                     const FilePlace& place,
                     const NetAttributes& a,
                     const NetPoints& net) {
    if (net.points.empty()) return Fail(place, "a net without points");
    if (a.rows && *a.rows != static_cast<int>(net.diameters.size())) {
      return Fail(FilePlace{xml.line, path + "/@" + names_.topography_rows},
                  std::to_string(*a.rows) +
                      " rows declared, the points lie on " +
                      std::to_string(net.diameters.size()) + " diameters");
    }
    if (a.columns && *a.columns != static_cast<int>(net.positions.size())) {
      return Fail(
          FilePlace{xml.line, path + "/@" + names_.topography_columns},
          std::to_string(*a.columns) + " columns declared, the points lie at " +
              std::to_string(net.positions.size()) + " axial positions");
    }
    if (net.points.size() != net.diameters.size() * net.positions.size()) {
      for (const auto& [dk, d] : net.diameters) {
        for (const auto& [zk, z] : net.positions) {
          if (net.points.count({dk, zk}) == 0) {
            char buffer[96];
            std::snprintf(buffer,
                          sizeof(buffer),
                          "net not full: no point at d = %.3f, z = %.3f",
                          d,
                          z);
            return Fail(
                place,
                std::string(buffer) + " (" + std::to_string(net.points.size()) +
                    " points on " + std::to_string(net.diameters.size()) +
                    " diameters x " + std::to_string(net.positions.size()) +
                    " positions)");
          }
        }
      }
    }
    return true;
  }

  void AddNetTraces(const NetAttributes& a,
                    const NetPoints& net,
                    const FilePlace& place) {
    // Columns (equal z) are profile traces, rows (equal d) helix traces.
    for (const auto& [zk, z] : net.positions) {
      MeasuredTrace t;
      t.kind = TraceKind::kProfile;
      t.tooth = a.tooth.value_or(1);
      t.flank = a.flank;
      t.position_mm = z;
      t.spacing = TraceSpacing::kListed;
      for (const auto& [dk, d] : net.diameters) {
        t.abscissa_mm.push_back(d);
        t.values_um.push_back(net.points.at({dk, zk}).second);
      }
      Add(std::move(t), place);
    }
    for (const auto& [dk, d] : net.diameters) {
      MeasuredTrace t;
      t.kind = TraceKind::kHelix;
      t.tooth = a.tooth.value_or(1);
      t.flank = a.flank;
      t.position_mm = d;
      t.spacing = TraceSpacing::kListed;
      for (const auto& [zk, z] : net.positions) {
        t.abscissa_mm.push_back(z);
        t.values_um.push_back(net.points.at({dk, zk}).second);
      }
      Add(std::move(t), place);
    }
  }

  void Add(MeasuredTrace trace, const FilePlace& place) {
    file_->traces.push_back(std::move(trace));
    file_->trace_places.push_back(place);
    file_->range_places.push_back(place);
  }

  const GdeNames& names_;
  const GdeReadOptions& options_;
  MeasurementFile* file_;
  FileError* error_;
  XmlElement root_;
  double sign_ = 1.0;
};

std::string Fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

// The element at `relative` under `root`, created with its parents when
// missing.
XmlElement* Ensure(XmlElement* root, const std::string& relative) {
  XmlElement* at = root;
  for (const std::string& part : SplitPath(relative)) {
    XmlElement* next = nullptr;
    for (XmlElement& child : at->children) {
      if (child.name == part) next = &child;
    }
    if (next == nullptr) {
      at->children.emplace_back();
      at->children.back().name = part;
      next = &at->children.back();
    }
    at = next;
  }
  return at;
}

void SetValue(XmlElement* root,
              const std::string& relative,
              const std::string& text,
              const std::string& unit_attribute,
              const std::string& unit) {
  XmlElement* e = Ensure(root, relative);
  e->text = text;
  if (!unit.empty()) e->attributes.emplace_back(unit_attribute, unit);
}

}  // namespace

const GdeNames& DefaultGdeNames() {
  static const GdeNames* names = new GdeNames();
  return *names;
}

bool ReadGdeFile(std::string_view content,
                 const GdeReadOptions& options,
                 MeasurementFile* file,
                 FileError* error,
                 const GdeNames& names) {
  *error = FileError{};
  GdeReader reader(names, options, file, error);
  return reader.Read(content);
}

namespace {

// The gear data, datum face and tolerance class.
void WriteGdeHeader(const GdeExport& data,
                    const GdeNames& names,
                    XmlElement* root) {
  const GearData& g = data.gear;
  const std::string& unit = names.unit_attribute;
  if (!data.drawing_number.empty())
    SetValue(root, names.drawing_number, data.drawing_number, unit, "");
  SetValue(root, names.teeth, std::to_string(g.teeth), unit, "");
  SetValue(root, names.normal_module, Fixed(g.normal_module_mm, 6), unit, "mm");
  SetValue(root,
           names.normal_pressure_angle,
           Fixed(RadToDeg(g.normal_pressure_angle_rad), 6),
           unit,
           "deg");
  SetValue(root,
           names.helix_angle,
           Fixed(std::abs(RadToDeg(g.helix_angle_rad)), 6),
           unit,
           "deg");
  // MODEL.md §1: beta > 0 is a left-hand helix.
  SetValue(root,
           names.helix_direction,
           g.helix_angle_rad > 0.0
               ? names.hand_left
               : (g.helix_angle_rad < 0.0 ? names.hand_right : names.hand_spur),
           unit,
           "");
  SetValue(root, names.face_width, Fixed(g.face_width_mm, 6), unit, "mm");
  SetValue(
      root, names.tip_diameter, Fixed(2.0 * g.tip_radius_mm, 6), unit, "mm");
  SetValue(
      root, names.root_diameter, Fixed(2.0 * g.root_radius_mm, 6), unit, "mm");
  SetValue(root,
           names.datum_face,
           data.datum_face == DatumFace::kXNegative ? names.datum_x_negative
                                                    : names.datum_x_positive,
           unit,
           "");
  SetValue(root, names.tolerance_standard, "ISO 1328-1:2013", unit, "");
  if (data.classes && data.classes->overall) {
    SetValue(root,
             names.tolerance_class,
             std::to_string(*data.classes->overall),
             unit,
             "");
  }
}

// The evaluation ranges and the deviation sign.
void WriteGdeRanges(const GdeExport& data,
                    const GdeNames& names,
                    XmlElement* root) {
  const GearData& g = data.gear;
  const std::string& unit = names.unit_attribute;
  // Evaluation ranges: L_form .. L_form + L_alpha (as P-series files state
  // d1/d2) and the face width less the ISO end zones, b/2 -+ L_beta/2.
  const double b = g.face_width_mm;
  const double l_alpha =
      data.figures ? data.figures->profile_evaluation_length_mm
                   : 0.95 * (g.TipRollLengthMm() - g.FormRollLengthMm());
  const double l_beta = data.figures
                            ? data.figures->helix_evaluation_length_mm
                            : b - 2.0 * std::min(0.05 * b, g.normal_module_mm);
  XmlElement* profile_range = Ensure(root, names.profile_evaluation_range);
  profile_range->attributes = {
      {unit, "mm"},
      {names.range_from,
       Fixed(DiameterOfRollLengthMm(g, g.FormRollLengthMm()), 6)},
      {names.range_to,
       Fixed(DiameterOfRollLengthMm(g, g.FormRollLengthMm() + l_alpha), 6)}};
  XmlElement* helix_range = Ensure(root, names.helix_evaluation_range);
  helix_range->attributes = {{unit, "mm"},
                             {names.range_from, Fixed((b - l_beta) / 2.0, 6)},
                             {names.range_to, Fixed((b + l_beta) / 2.0, 6)}};
  SetValue(root, names.deviation_sign, names.sign_material_positive, unit, "");
}

// The topography nets.
void WriteGdeNets(const GdeExport& data,
                  const GdeNames& names,
                  XmlElement* root) {
  const GearData& g = data.gear;
  const double b = g.face_width_mm;
  // The nets. With the datum face at x = +b/2 the grid's flank is the file's
  // other flank.
  const std::vector<double> l = GridRollLengthsMm(g, data.grid);
  const std::vector<double> x = GridAxialPositionsMm(g, data.grid);
  const bool swap = data.datum_face == DatumFace::kXPositive;
  const Flank file_flank =
      swap ? (data.flank == Flank::kRight ? Flank::kLeft : Flank::kRight)
           : data.flank;
  XmlElement* results = Ensure(root, names.measurement_results);
  for (const GdeTopography& net : data.topographies) {
    XmlElement t;
    t.name = names.topography;
    t.attributes = {
        {names.topography_kind, net.kind},
        {names.topography_tooth, std::to_string(net.tooth)},
        {names.topography_flank,
         file_flank == Flank::kRight ? names.flank_right : names.flank_left},
        {names.length_unit_attribute, "mm"},
        {names.deviation_unit_attribute, "um"},
        {names.topography_rows, std::to_string(l.size())},
        {names.topography_columns, std::to_string(x.size())}};
    for (size_t i = 0; i < l.size(); ++i) {
      for (size_t j = 0; j < x.size(); ++j) {
        const size_t index = i * x.size() + j;
        if (index >= static_cast<size_t>(net.deviations_um.size()) ||
            !std::isfinite(net.deviations_um[index]))
          continue;
        XmlElement p;
        p.name = names.point;
        const double z = swap ? b / 2.0 - x[j] : x[j] + b / 2.0;
        p.attributes = {
            {names.point_diameter, Fixed(DiameterOfRollLengthMm(g, l[i]), 9)},
            {names.point_axial, Fixed(z, 9)},
            {names.point_deviation, Fixed(net.deviations_um[index], 6)}};
        t.children.push_back(std::move(p));
      }
    }
    results->children.push_back(std::move(t));
  }
}

// The ISO 1328 figures and classes, when evaluated.
void WriteGdeResults(const GdeExport& data,
                     const GdeNames& names,
                     XmlElement* root) {
  const std::string& unit = names.unit_attribute;
  if (data.figures && data.figures->ok) {
    const FlankFigures& f = *data.figures;
    XmlElement* r = Ensure(root, names.results);
    r->attributes = {
        {"flank",
         data.flank == Flank::kRight ? names.flank_right : names.flank_left},
        {"standard", "ISO 1328-1:2013"},
        {names.deviation_unit_attribute, "um"}};
    const std::pair<const char*, double> figures[] = {
        {"fHa_mean", f.fHa_mean},
        {"fHa_mean_grid", f.fHa_mean_grid},
        {"fHa_max_abs", f.fHa_max_abs},
        {"ffa_max", f.ffa_max_abs},
        {"Fa_max", f.Fa_max_abs},
        {"Ca_mean", f.Ca_mean},
        {"Ca_mean_grid", f.Ca_mean_grid},
        {"fHb_mean", f.fHb_mean},
        {"fHb_mean_grid", f.fHb_mean_grid},
        {"fHb_max_abs", f.fHb_max_abs},
        {"ffb_max", f.ffb_max_abs},
        {"Fb_max", f.Fb_max_abs},
        {"Cb_mean", f.Cb_mean},
        {"Cb_mean_grid", f.Cb_mean_grid},
        {"twist_alpha_grid", f.twist_alpha_grid},
        {"twist_beta_grid", f.twist_beta_grid}};
    for (const auto& [name, value] : figures)
      SetValue(r, name, Fixed(value, 3), unit, "");
    if (data.classes) {
      const std::pair<const char*, std::optional<int>> classes[] = {
          {"class_fHa", data.classes->fHa},
          {"class_ffa", data.classes->ffa},
          {"class_Fa", data.classes->Fa},
          {"class_fHb", data.classes->fHb},
          {"class_ffb", data.classes->ffb},
          {"class_Fb", data.classes->Fb},
          {"class_overall", data.classes->overall}};
      for (const auto& [name, value] : classes) {
        SetValue(r,
                 name,
                 value ? std::to_string(*value) : std::string("none"),
                 unit,
                 "");
      }
    }
  }
}

}  // namespace

std::string WriteGde(const GdeExport& data, const GdeNames& names) {
  XmlElement root;
  root.name = names.root;
  root.attributes.emplace_back(names.version_attribute, "3.4");
  WriteGdeHeader(data, names, &root);
  WriteGdeRanges(data, names, &root);
  WriteGdeNets(data, names, &root);
  WriteGdeResults(data, names, &root);
  return WriteXml(root);
}

}  // namespace gearloop
