// formats/mka_reader.cc: a line-by-line state machine over the decoded text.
// Every line is either understood or refused; the number of values read is
// bounded by the trace head, which is bounded by kMaxTraceValues, so a hostile
// count cannot make it allocate.
#include "formats/mka_reader.h"

#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace gearloop {
namespace {

constexpr double kDefaultUndefined = -2147483.648;
// |deviation| above this [um] is no deviation but a broken file (10 mm).
constexpr double kMaxDeviationUm = 1e4;
// A position or diameter above this [mm] is no gear of this world.
constexpr double kMaxLengthMm = 1e5;

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())))
    s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())))
    s.remove_suffix(1);
  return s;
}

bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

std::vector<std::string_view> Tokens(std::string_view s) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const size_t begin = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > begin) out.push_back(s.substr(begin, i - begin));
  }
  return out;
}

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

struct HeaderLine {
  int line = 0;
  std::string label;
  std::string values;
};

struct OpenTrace {
  bool open = false;
  int head_line = 0;
  int expected = 0;
  size_t index = 0;  // into file->traces
};

class MkaReader {
 public:
  MkaReader(MeasurementFile* file, FileError* error)
      : file_(file), error_(error) {}

  bool Read(std::string_view content) {
    std::string text;
    if (!DecodeMeasurementText(content, &text, error_)) return false;
    *file_ = MeasurementFile{};
    file_->format = MeasurementFormat::kMka;
    size_t pos = 0;
    int number = 0;
    while (pos <= text.size()) {
      size_t end = text.find('\n', pos);
      if (end == std::string::npos) end = text.size();
      std::string_view line(text.data() + pos, end - pos);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++number;
      if (!ReadLine(number, line)) return false;
      if (end == text.size()) break;
      pos = end + 1;
    }
    if (number == 1 && !seen_header_)
      return Fail(1, "empty file: expected HEADER KS.MK.FILE");
    if (trace_.open) {
      const MeasuredTrace& t = file_->traces[trace_.index];
      return Fail(number,
                  "end of file after " + std::to_string(t.values_um.size()) +
                      " values; the trace head at line " +
                      std::to_string(trace_.head_line) + " says " +
                      std::to_string(trace_.expected) + " Werte");
    }
    return Finish();
  }

 private:
  bool Fail(int line, const std::string& message) {
    error_->place = FilePlace{line, ""};
    error_->message = message;
    error_->too_large = false;
    return false;
  }

  bool Number(int line,
              std::string_view token,
              double* value,
              const std::string& what) {
    std::string why;
    if (!ParseDecimalNumber(token, value, &why))
      return Fail(line, what + ": " + why);
    return true;
  }

  bool ReadLine(int number, std::string_view raw) {
    const std::string_view line = Trim(raw);
    if (number == 1) return ReadFirstLine(line);
    if (line.empty()) return true;
    const bool block_start =
        StartsWith(line, "TOPOGRAFIE:") || StartsWith(line, "Profil:") ||
        StartsWith(line, "Flankenlinie:") || StartsWith(line, "Zahn-Nr.");
    if (skipping_) {
      if (!block_start) return true;
      skipping_ = false;
    }
    // Values of the open trace.
    const unsigned char first = static_cast<unsigned char>(line.front());
    const bool numeric =
        std::isdigit(first) || first == '-' || first == '+' || first == '.';
    // Inside an open trace every line that is no header line or block start is
    // a values line, so that "nan" or "x8.5" are refused as values.
    if ((numeric || (trace_.open && !block_start)) && !IsHeaderLine(line))
      return ReadValues(number, line);
    if (trace_.open) {
      const MeasuredTrace& t = file_->traces[trace_.index];
      return Fail(number,
                  "only " + std::to_string(t.values_um.size()) +
                      " values before this line; the trace head at line " +
                      std::to_string(trace_.head_line) + " says " +
                      std::to_string(trace_.expected) + " Werte");
    }
    if (IsHeaderLine(line)) return ReadHeaderLine(number, line);
    if (StartsWith(line, "TOPOGRAFIE:"))
      return ReadTopographyHead(number, line);
    if (line == "Profil:" || line == "Flankenlinie:" ||
        StartsWith(line, "Profil: ") || StartsWith(line, "Flankenlinie: ")) {
      return ReadPlainBlockLine(number, line);
    }
    if (StartsWith(line, "Zahn-Nr.")) {
      if (!plain_kind_) {
        return Fail(number,
                    "trace head 'Zahn-Nr.' outside a Profil: / Flankenlinie: / "
                    "TOPOGRAFIE: block");
      }
      return ReadPlainHead(number, line);
    }
    if (StartsWith(line, "Verschr") || StartsWith(line, "Teilung") ||
        StartsWith(line, "TEILUNG") || StartsWith(line, "Rundlauf")) {
      skipping_ = true;  // twist, pitch and runout sections: not used for the
                         // flank grid
      plain_kind_.reset();
      return true;
    }
    return ReadOtherLine(number, line);
  }

  // Line 1: the header of a curve file.
  bool ReadFirstLine(std::string_view line) {
    const auto tokens = Tokens(line);
    if (tokens.size() >= 2 && tokens[0] == "HEADER" &&
        tokens[1] == "KS.MW.FILE") {
      return Fail(1,
                  "a KS.MW.FILE is a value file (printed figures only); "
                  "export the curves (KS.MK.FILE)");
    }
    if (tokens.size() != 2 || tokens[0] != "HEADER" ||
        tokens[1] != "KS.MK.FILE") {
      return Fail(1,
                  "the first line must be 'HEADER KS.MK.FILE' (a "
                  "Klingelnberg curve file)");
    }
    seen_header_ = true;
    return true;
  }

  // A 'Profil:' or 'Flankenlinie:' block line, maybe with its trace head.
  bool ReadPlainBlockLine(int number, std::string_view line) {
    const std::string_view rest = Trim(line.substr(line.find(':') + 1));
    if (StartsWith(rest, "Zahn-Nr.")) {
      plain_kind_ =
          StartsWith(line, "Profil") ? TraceKind::kProfile : TraceKind::kHelix;
      return ReadPlainHead(number, rest);
    }
    if (!rest.empty())
      return Fail(number,
                  "a block line 'Profil:' / 'Flankenlinie:' followed by '" +
                      std::string(rest) + "'");
    plain_kind_ =
        StartsWith(line, "Profil") ? TraceKind::kProfile : TraceKind::kHelix;
    return true;
  }

  // A preamble line before the first header code; anything else is refused.
  bool ReadOtherLine(int number, std::string_view line) {
    if (!seen_code_ && ReadPreamble(number, line)) return true;
    if (error_->place.line == number) return false;  // ReadPreamble refused it
    if (line.find("Werte") != std::string_view::npos) {
      return Fail(number,
                  "trace head does not match 'TOPOGRAFIE: Zahn-Nr.: <tooth> "
                  "/Profil:<k> rechts|links / <n> Werte / z= <mm>'");
    }
    return Fail(
        number,
        "line not understood: '" + std::string(line.substr(0, 60)) + "'");
  }

  // `  <code> :<label>: values`
  static bool IsHeaderLine(std::string_view line) {
    size_t i = 0;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i])))
      ++i;
    if (i == 0 || i > 5) return false;
    while (i < line.size() && line[i] == ' ') ++i;
    return i < line.size() && line[i] == ':';
  }

  bool ReadHeaderLine(int number, std::string_view line) {
    size_t i = 0;
    int code = 0;
    while (std::isdigit(static_cast<unsigned char>(line[i])))
      code = code * 10 + (line[i++] - '0');
    const size_t label_begin = line.find(':', i) + 1;
    const size_t label_end = line.find(':', label_begin);
    if (label_end == std::string_view::npos) {
      return Fail(number,
                  "header line of code " + std::to_string(code) +
                      " has no ':' after its label");
    }
    if (codes_.count(code) != 0) {
      return Fail(number,
                  "header code " + std::to_string(code) +
                      " repeated (first at line " +
                      std::to_string(codes_[code].line) + ")");
    }
    seen_code_ = true;
    codes_[code] = HeaderLine{
        number,
        std::string(Trim(line.substr(label_begin, label_end - label_begin))),
        std::string(Trim(line.substr(label_end + 1)))};
    return true;
  }

  // `KEY value ! comment`; returns false without an error for a line that is no
  // preamble line.
  bool ReadPreamble(int number, std::string_view line) {
    size_t i = 0;
    while (
        i < line.size() &&
        (std::isupper(static_cast<unsigned char>(line[i])) || line[i] == '_'))
      ++i;
    if (i < 2 || (i < line.size() && line[i] != ' ' && line[i] != '\t'))
      return false;
    const std::string_view key = line.substr(0, i);
    std::string_view rest = line.substr(i);
    const size_t bang = rest.find('!');
    if (bang != std::string_view::npos) rest = rest.substr(0, bang);
    rest = Trim(rest);
    if (key == "UNDEFINED") {
      double value = 0.0;
      if (!Number(number, rest, &value, "UNDEFINED")) return false;
      undefined_ = value;
    }
    return true;
  }

  bool ParseFlank(std::string_view word, Flank* flank) const {
    const std::string w = Lower(word);
    if (w == "rechts" || w == "right") {
      *flank = Flank::kRight;
      return true;
    }
    if (w == "links" || w == "left") {
      *flank = Flank::kLeft;
      return true;
    }
    return false;
  }

  // "Zahn-Nr.: <tooth>" -> tooth.
  bool ParseTooth(int number,
                  std::string_view part,
                  int* tooth,
                  std::string_view* rest) {
    part = Trim(part);
    if (!StartsWith(part, "Zahn-Nr.:"))
      return Fail(number, "trace head: expected 'Zahn-Nr.: <tooth>'");
    part = Trim(part.substr(9));
    size_t i = 0;
    long value = 0;
    while (i < part.size() &&
           std::isdigit(static_cast<unsigned char>(part[i])) && i < 6)
      value = value * 10 + (part[i++] - '0');
    if (i == 0 || value < 1 || value > 10000 ||
        (i < part.size() && part[i] != ' ')) {
      return Fail(number,
                  "trace head: tooth number '" +
                      std::string(part.substr(0, 12)) + "' is not 1..10000");
    }
    *tooth = static_cast<int>(value);
    *rest = Trim(part.substr(i));
    return true;
  }

  bool ParseCount(int number, std::string_view part, int* count) {
    const auto tokens = Tokens(part);
    if (tokens.size() != 2 || tokens[1] != "Werte")
      return Fail(number, "trace head: expected '<n> Werte'");
    double n = 0.0;
    if (!Number(number, tokens[0], &n, "trace head value count")) return false;
    if (n != std::floor(n))
      return Fail(number,
                  "trace head: value count " + std::string(tokens[0]) +
                      " is not whole");
    if (n < 2)
      return Fail(number,
                  "trace head: " + std::string(tokens[0]) +
                      " Werte; a trace needs at least 2");
    if (n > kMaxTraceValues) {
      return Fail(number,
                  "trace head: " + std::string(tokens[0]) +
                      " Werte, more than " + std::to_string(kMaxTraceValues));
    }
    *count = static_cast<int>(n);
    return true;
  }

  std::vector<std::string_view> SplitSlash(std::string_view line) {
    std::vector<std::string_view> parts;
    size_t begin = 0;
    while (true) {
      const size_t slash = line.find('/', begin);
      parts.push_back(Trim(line.substr(begin,
                                       slash == std::string_view::npos
                                           ? std::string_view::npos
                                           : slash - begin)));
      if (slash == std::string_view::npos) break;
      begin = slash + 1;
    }
    return parts;
  }

  // TOPOGRAFIE: Zahn-Nr.: 1 /Profil:2 rechts / 48 Werte  / z= 11.500
  bool ReadTopographyHead(int number, std::string_view line) {
    plain_kind_.reset();
    const auto parts = SplitSlash(Trim(line.substr(11)));
    const char* shape =
        "trace head does not match 'TOPOGRAFIE: Zahn-Nr.: <tooth> /Profil:<k> "
        "rechts|links / <n> Werte / z= <mm>'";
    if (parts.size() != 4) return Fail(number, shape);
    MeasuredTrace trace;
    std::string_view rest;
    if (!ParseTooth(number, parts[0], &trace.tooth, &rest)) return false;
    if (!rest.empty()) return Fail(number, shape);
    std::string_view kind = parts[1];
    std::string position_key;
    if (StartsWith(kind, "Profil:")) {
      trace.kind = TraceKind::kProfile;
      kind.remove_prefix(7);
      position_key = "z=";
    } else if (StartsWith(kind, "Flankenlinie:")) {
      trace.kind = TraceKind::kHelix;
      kind.remove_prefix(13);
      position_key = "d=";
    } else {
      return Fail(
          number,
          "trace head: expected 'Profil:<k>' or 'Flankenlinie:<k>', got '" +
              std::string(kind.substr(0, 30)) + "'");
    }
    const auto kind_tokens = Tokens(kind);
    if (kind_tokens.size() != 2 || !ParseFlank(kind_tokens[1], &trace.flank)) {
      return Fail(number,
                  "trace head: expected '<k> rechts' or '<k> links' after the "
                  "trace kind");
    }
    int count = 0;
    if (!ParseCount(number, parts[2], &count)) return false;
    const auto position_tokens = Tokens(parts[3]);
    std::string_view value_token;
    if (position_tokens.size() == 2 && position_tokens[0] == position_key) {
      value_token = position_tokens[1];
    } else if (position_tokens.size() == 1 &&
               StartsWith(position_tokens[0], position_key)) {
      value_token = position_tokens[0].substr(2);
    } else {
      return Fail(
          number,
          "trace head: expected '" + position_key + " <mm>' as the " +
              (trace.kind == TraceKind::kProfile ? "profile's axial position"
                                                 : "helix trace's diameter"));
    }
    if (!Number(number, value_token, &trace.position_mm, "trace position"))
      return false;
    if (std::abs(trace.position_mm) > kMaxLengthMm)
      return Fail(number, "trace position out of range");
    return OpenNewTrace(number, std::move(trace), count);
  }

  // Zahn-Nr.: 1 rechts / 480 Werte  (in a plain Profil: / Flankenlinie: block)
  bool ReadPlainHead(int number, std::string_view line) {
    const auto parts = SplitSlash(line);
    if (parts.size() < 2)
      return Fail(number,
                  "trace head does not match 'Zahn-Nr.: <tooth> rechts|links / "
                  "<n> Werte'");
    MeasuredTrace trace;
    trace.kind = *plain_kind_;
    std::string_view rest;
    if (!ParseTooth(number, parts[0], &trace.tooth, &rest)) return false;
    if (!ParseFlank(rest, &trace.flank))
      return Fail(
          number,
          "trace head: expected 'rechts' or 'links' after the tooth number");
    int count = 0;
    if (!ParseCount(number, parts[1], &count)) return false;
    trace.position_mm = std::nan(
        "");  // placed in Finish(): mid face, or the diameter of code 46
    return OpenNewTrace(number, std::move(trace), count);
  }

  bool OpenNewTrace(int number, MeasuredTrace trace, int count) {
    trace.spacing = TraceSpacing::kEqualSteps;
    trace.values_um.reserve(static_cast<size_t>(std::min(count, 4096)));
    file_->traces.push_back(std::move(trace));
    file_->trace_places.push_back(FilePlace{number, ""});
    file_->range_places.push_back(FilePlace{number, ""});
    trace_ = OpenTrace{true, number, count, file_->traces.size() - 1};
    return true;
  }

  bool ReadValues(int number, std::string_view line) {
    if (!trace_.open) {
      if (file_->traces.empty())
        return Fail(number, "values before any trace head");
      return Fail(number,
                  "more values than the " +
                      std::to_string(file_->traces.back().values_um.size()) +
                      " Werte of the trace head at line " +
                      std::to_string(file_->trace_places.back().line));
    }
    MeasuredTrace& t = file_->traces[trace_.index];
    for (std::string_view token : Tokens(line)) {
      if (static_cast<int>(t.values_um.size()) >= trace_.expected) {
        return Fail(number,
                    "more values than the " + std::to_string(trace_.expected) +
                        " Werte of the trace head at line " +
                        std::to_string(trace_.head_line));
      }
      double v = 0.0;
      if (!Number(number,
                  token,
                  &v,
                  "value " + std::to_string(t.values_um.size() + 1)))
        return false;
      if (std::abs(v - undefined_) <= 1e-9 * std::abs(undefined_)) {
        t.values_um.push_back(std::nan(""));
        continue;
      }
      if (std::abs(v) > kMaxDeviationUm) {
        return Fail(number,
                    "value " + std::string(token) +
                        " um is no deviation (|value| above 10 mm)");
      }
      t.values_um.push_back(v);
    }
    if (static_cast<int>(t.values_um.size()) == trace_.expected)
      trace_.open = false;
    return true;
  }

  // The numbers of a header code: `count` values, or one value used for both
  // flanks.
  bool CodeNumbers(int code, const char* name, std::vector<double>* values) {
    const HeaderLine& h = codes_.at(code);
    const auto tokens = Tokens(h.values);
    if (tokens.empty())
      return Fail(h.line,
                  "header code " + std::to_string(code) + " (" + name +
                      ") has no value");
    values->clear();
    for (std::string_view token : tokens) {
      double v = 0.0;
      if (!Number(h.line,
                  token,
                  &v,
                  "header code " + std::to_string(code) + " (" + name + ")"))
        return false;
      if (std::abs(v) > kMaxLengthMm)
        return Fail(h.line,
                    "header code " + std::to_string(code) + " out of range");
      values->push_back(v);
      if (values->size() == 2) break;
    }
    return true;
  }

  bool Scalar(int code, const char* name, std::optional<HeaderValue>* out) {
    if (codes_.count(code) == 0) return true;
    const HeaderLine& h = codes_.at(code);
    const auto tokens = Tokens(h.values);
    if (tokens.empty())
      return Fail(h.line,
                  "header code " + std::to_string(code) + " (" + name +
                      ") has no value");
    double v = 0.0;
    if (!Number(h.line,
                tokens[0],
                &v,
                "header code " + std::to_string(code) + " (" + name + ")"))
      return false;
    *out = HeaderValue{v,
                       FilePlace{h.line, ""},
                       "code " + std::to_string(code) + " (" + name + ")"};
    return true;
  }

  // Range of codes (begin, end) for `flank`: values are (left, right) or one
  // for both.
  bool Range(int begin_code,
             int end_code,
             Flank flank,
             double* begin,
             double* end,
             int* line) {
    std::vector<double> a, b;
    if (!CodeNumbers(begin_code, "range start", &a) ||
        !CodeNumbers(end_code, "range end", &b))
      return false;
    const size_t k = flank == Flank::kLeft ? 0 : 1;
    *begin = a.size() > k ? a[k] : a[0];
    *end = b.size() > k ? b[k] : b[0];
    *line = codes_.at(begin_code).line;
    if (!(*begin < *end)) {
      return Fail(codes_.at(end_code).line,
                  "range the wrong way: code " + std::to_string(begin_code) +
                      " = " + std::to_string(*begin) +
                      " mm is not below code " + std::to_string(end_code) +
                      " = " + std::to_string(*end) + " mm (" +
                      (flank == Flank::kLeft ? "left" : "right") + " flank)");
    }
    return true;
  }

  bool Finish() {
    MeasurementFileHeader& h = file_->header;
    if (!Scalar(21, "m_n", &h.normal_module_mm) || !Scalar(22, "z", &h.teeth) ||
        !Scalar(23, "beta", &h.helix_angle_deg) ||
        !Scalar(24, "alpha_n", &h.normal_pressure_angle_deg) ||
        !Scalar(26, "b", &h.face_width_mm) ||
        !Scalar(27, "d_a", &h.tip_diameter_mm) ||
        !Scalar(272, "d_f", &h.root_diameter_mm) ||
        !Scalar(45, "L_alpha", &h.profile_evaluation_length_mm) ||
        !Scalar(42, "d1", &h.profile_evaluation_begin_diameter_mm) ||
        !Scalar(43, "d2", &h.profile_evaluation_end_diameter_mm)) {
      return false;
    }
    std::optional<HeaderValue> measuring_diameter;
    if (!Scalar(46, "measuring diameter", &measuring_diameter)) return false;
    if (codes_.count(8) != 0) {
      const std::string type = Lower(codes_.at(8).values);
      if (type.find("rechts") != std::string::npos) h.helix_hand = "right";
      if (type.find("links") != std::string::npos) h.helix_hand = "left";
      h.helix_hand_place = FilePlace{codes_.at(8).line, ""};
    }
    if (h.teeth &&
        (h.teeth->value != std::floor(h.teeth->value) || h.teeth->value < 1)) {
      return Fail(
          h.teeth->place.line,
          "header code 22 (z): number of teeth is not a whole number >= 1");
    }
    if (file_->traces.empty())
      return Fail(0,
                  "no trace (no 'TOPOGRAFIE:', 'Profil:' or 'Flankenlinie:' "
                  "block) in the file");
    for (size_t i = 0; i < file_->traces.size(); ++i) {
      MeasuredTrace& t = file_->traces[i];
      const int head = file_->trace_places[i].line;
      const bool profile = t.kind == TraceKind::kProfile;
      const int begin_code = profile ? 41 : 61;
      const int end_code = profile ? 44 : 64;
      for (int code : {begin_code, end_code}) {
        if (codes_.count(code) == 0) {
          return Fail(head,
                      std::string(profile ? "profile" : "helix") +
                          " trace, but header code " + std::to_string(code) +
                          " (" + (profile ? "profile" : "helix") +
                          " measuring range " +
                          (code == begin_code ? "start" : "end") +
                          ") is missing: the values have no abscissa");
        }
      }
      int line = 0;
      if (!Range(begin_code, end_code, t.flank, &t.begin_mm, &t.end_mm, &line))
        return false;
      file_->range_places[i] = FilePlace{line, ""};
      if (std::isnan(t.position_mm)) {
        if (profile) {
          if (!h.face_width_mm)
            return Fail(head,
                        "a plain Profil: trace lies at mid face, but header "
                        "code 26 (b) is missing");
          t.position_mm = h.face_width_mm->value / 2.0;
        } else {
          if (!measuring_diameter) {
            return Fail(head,
                        "a plain Flankenlinie: trace lies on the measuring "
                        "diameter, but header code 46 is missing");
          }
          t.position_mm = measuring_diameter->value;
        }
      }
    }
    return true;
  }

  MeasurementFile* file_;
  FileError* error_;
  bool seen_header_ = false;
  bool seen_code_ = false;
  bool skipping_ = false;
  double undefined_ = kDefaultUndefined;
  std::optional<TraceKind> plain_kind_;
  std::map<int, HeaderLine> codes_;
  OpenTrace trace_;
};

}  // namespace

bool ReadMkaFile(std::string_view content,
                 MeasurementFile* file,
                 FileError* error) {
  *error = FileError{};
  MkaReader reader(file, error);
  return reader.Read(content);
}

}  // namespace gearloop
