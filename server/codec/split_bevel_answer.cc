// The 200 answer of POST /api/v1/bevel/split-trajectory as JSON text
// (server/codec/split_bevel_codec.h): 40 000 points are a million numbers, so
// the text is written straight into one string, each number with 17
// significant digits (server/codec/decimal17.h), instead of through a JSON
// tree. Keys in each object in the order nlohmann-json writes them (sorted), so
// the answer reads like the API's others.
#include <algorithm>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/core/units.h"
#include "server/codec/decimal17.h"
#include "server/codec/split_bevel_codec.h"

namespace gearloop {
namespace {

// Room for one point: 13 keys and punctuation (< 300 characters) and 21
// numbers of at most kDecimal17MaxChars.
constexpr size_t kPointMaxChars = 300 + 21 * kDecimal17MaxChars;
// The text of an average point (BENCHMARKS.md: ~610 characters), to reserve.
constexpr size_t kPointReserveChars = 640;

template <size_t N>
char* Put(char* p, const char (&text)[N]) {
  std::memcpy(p, text, N - 1);
  return p + N - 1;
}

char* PutVector(char* p, const Eigen::Vector3d& v) {
  *p++ = '[';
  p = WriteDecimal17(v.x(), p);
  *p++ = ',';
  p = WriteDecimal17(v.y(), p);
  *p++ = ',';
  p = WriteDecimal17(v.z(), p);
  *p++ = ']';
  return p;
}

// The parts of a point's text that the depth levels of a flank share (the
// same station gives the same arc length, cone distance, spiral angle, pitch
// point and tool axis, and A and B follow the tool axis), as offsets into the
// text: the same point of the next pass copies them when its numbers are the
// same bits instead of writing them again (about half of the answer's
// numbers). From, to: {"A_deg":..,"B_deg":..;
// ,"arc_mm":..,"cone_distance_mm":..;
// ,"pitch_point_mm":[..],"spiral_angle_deg":..,"tool_axis":[..].
struct TextSpan {
  size_t from = 0, to = 0;
};
struct SharedText {
  TextSpan angles, cone, line;
};

// The numbers behind each part of SharedText.
bool SameBits(const double* a, const double* b, size_t n) {
  return std::memcmp(a, b, n * sizeof(double)) == 0;
}
bool SameAngles(const SplitBevelPoint& a, const SplitBevelPoint& b) {
  return SameBits(&a.axes.a_rad, &b.axes.a_rad, 1) &&
         SameBits(&a.axes.b_rad, &b.axes.b_rad, 1);
}
bool SameCone(const SplitBevelPoint& a, const SplitBevelPoint& b) {
  return SameBits(&a.arc_mm, &b.arc_mm, 1) &&
         SameBits(&a.cone_distance_mm, &b.cone_distance_mm, 1);
}
bool SameLine(const SplitBevelPoint& a, const SplitBevelPoint& b) {
  return SameBits(a.pitch_point_mm.data(), b.pitch_point_mm.data(), 3) &&
         SameBits(&a.spiral_angle_rad, &b.spiral_angle_rad, 1) &&
         SameBits(a.tool_axis.data(), b.tool_axis.data(), 3);
}

// The same point of the pass before and where its shared parts are in the
// text, if there is one.
struct PointBefore {
  const SplitBevelPoint* point = nullptr;
  const SharedText* text = nullptr;
};

// Copies the text `copy` of `base` to p when there is one (the point before
// had the same numbers), else writes it with `write`; records where it now is
// in `now`.
template <typename Write>
char* PutShared(
    char* base, char* p, const TextSpan* copy, TextSpan* now, Write write) {
  now->from = static_cast<size_t>(p - base);
  if (copy != nullptr) {
    std::memcpy(p, base + copy->from, copy->to - copy->from);
    p += copy->to - copy->from;
  } else {
    p = write(p);
  }
  now->to = static_cast<size_t>(p - base);
  return p;
}

// {"A_deg",...,"tool_centre_mm"}: SPLIT_BEVEL.md §8's point, at p in the text
// that starts at `base`; `shared` gets where its shared parts are.
char* PutPoint(char* base,
               char* p,
               const SplitBevelPoint& point,
               const PointBefore& before,
               SharedText* shared) {
  const SplitBevelPoint* b = before.point;
  const SharedText* t = before.text;
  p = PutShared(base,
                p,
                b != nullptr && SameAngles(point, *b) ? &t->angles : nullptr,
                &shared->angles,
                [&](char* q) {
                  q = WriteDecimal17(RadToDeg(point.axes.a_rad),
                                     Put(q, "{\"A_deg\":"));
                  return WriteDecimal17(RadToDeg(point.axes.b_rad),
                                        Put(q, ",\"B_deg\":"));
                });
  p = WriteDecimal17(point.axes.x_mm, Put(p, ",\"X_mm\":"));
  p = WriteDecimal17(point.axes.y_mm, Put(p, ",\"Y_mm\":"));
  p = WriteDecimal17(point.axes.z_mm, Put(p, ",\"Z_mm\":"));
  p = PutShared(base,
                p,
                b != nullptr && SameCone(point, *b) ? &t->cone : nullptr,
                &shared->cone,
                [&](char* q) {
                  q = WriteDecimal17(point.arc_mm, Put(q, ",\"arc_mm\":"));
                  return WriteDecimal17(point.cone_distance_mm,
                                        Put(q, ",\"cone_distance_mm\":"));
                });
  p = PutVector(Put(p, ",\"flank_normal\":"), point.flank_normal);
  p = PutVector(Put(p, ",\"flank_point_mm\":"), point.flank_point_mm);
  p = PutShared(base,
                p,
                b != nullptr && SameLine(point, *b) ? &t->line : nullptr,
                &shared->line,
                [&](char* q) {
                  q = PutVector(Put(q, ",\"pitch_point_mm\":"),
                                point.pitch_point_mm);
                  q = WriteDecimal17(RadToDeg(point.spiral_angle_rad),
                                     Put(q, ",\"spiral_angle_deg\":"));
                  return PutVector(Put(q, ",\"tool_axis\":"), point.tool_axis);
                });
  p = PutVector(Put(p, ",\"tool_centre_mm\":"), point.tool_centre_mm);
  *p++ = '}';
  return p;
}

// One growing string: Room(n) makes n characters writable at the end,
// Advance(end) keeps what was written up to `end`.
class TextWriter {
 public:
  explicit TextWriter(size_t reserve) { text_.resize(reserve); }

  char* Room(size_t n) {
    if (size_ + n > text_.size())
      text_.resize(std::max(2 * text_.size(), size_ + n));
    return text_.data() + size_;
  }
  void Advance(const char* end) {
    size_ = static_cast<size_t>(end - text_.data());
  }
  void Raw(std::string_view text) {
    std::memcpy(Room(text.size()), text.data(), text.size());
    size_ += text.size();
  }
  // "key": as JSON, then the number (no separator).
  void Key(std::string_view key) {
    Raw("\"");
    Raw(key);
    Raw("\":");
  }
  void Number(double x) {
    Advance(WriteDecimal17(x, Room(kDecimal17MaxChars)));
  }
  void Member(std::string_view key, double x, bool last = false) {
    Key(key);
    Number(x);
    if (!last) Raw(",");
  }
  void Integer(std::string_view key, long long value) {
    Key(key);
    Raw(std::to_string(value));
    Raw(",");
  }
  void Point(const SplitBevelPoint& point,
             const PointBefore& before,
             SharedText* shared) {
    char* p = Room(kPointMaxChars);
    Advance(PutPoint(text_.data(), p, point, before, shared));
  }
  std::string Finish() {
    text_.resize(size_);
    return std::move(text_);
  }

 private:
  std::string text_;
  size_t size_ = 0;
};

void WriteDerived(const SplitBevelGearData& d, TextWriter* w) {
  w->Raw("{");
  w->Member("addendum_mm", d.addendum_mm);
  w->Member("base_radius_mm", d.base_radius_mm);
  w->Member("crown_teeth", d.crown_teeth);
  w->Member("dedendum_mm", d.dedendum_mm);
  w->Member("inner_cone_distance_mm", d.inner_cone_distance_mm);
  w->Member("inner_spiral_angle_deg", RadToDeg(d.inner_spiral_angle_rad));
  w->Member("mean_cone_distance_mm", d.mean_cone_distance_mm);
  w->Member("mean_spiral_angle_deg", RadToDeg(d.mean_spiral_angle_rad));
  w->Member("normal_module_mm", d.normal_module_mm);
  w->Member("outer_cone_distance_mm", d.outer_cone_distance_mm);
  w->Member("outer_spiral_angle_deg", RadToDeg(d.outer_spiral_angle_rad));
  w->Member("slot_width_mm", d.slot_width_mm, /*last=*/true);
  w->Raw("}");
}

// The passes' shared point texts (SharedText): of the pass before and of this
// one.
struct PassTexts {
  const SplitBevelPass* before = nullptr;
  std::vector<SharedText> before_text, text;
};

// {"flank","level","points"|"point_count","side_deviation_mm","slot",
// "tip_height_mm"}. With the points, `texts` has the pass before (its points'
// shared parts are copied where they are the same) and gets this one.
void WritePass(const SplitBevelPass& pass,
               bool with_points,
               PassTexts* texts,
               TextWriter* w) {
  w->Raw("{\"flank\":\"");
  w->Raw(SplitBevelFlankName(pass.flank));
  w->Raw("\",");
  w->Integer("level", pass.level);
  if (with_points) {
    const SplitBevelPass* before = texts->before;
    const bool aligned = before != nullptr && before->flank == pass.flank &&
                         before->points.size() == pass.points.size();
    texts->text.resize(pass.points.size());
    w->Raw("\"points\":[");
    for (size_t i = 0; i < pass.points.size(); ++i) {
      if (i > 0) w->Raw(",");
      PointBefore point_before;
      if (aligned) {
        point_before.point = &before->points[i];
        point_before.text = &texts->before_text[i];
      }
      w->Point(pass.points[i], point_before, &texts->text[i]);
    }
    w->Raw("],");
    texts->before = &pass;
    std::swap(texts->before_text, texts->text);
  } else {
    w->Integer("point_count", static_cast<long long>(pass.points.size()));
  }
  w->Key("side_deviation_mm");
  w->Raw("{");
  w->Member("max", pass.side_deviation_mm.max_mm);
  w->Member("min", pass.side_deviation_mm.min_mm, /*last=*/true);
  w->Raw("},");
  w->Integer("slot", pass.slot);
  w->Member("tip_height_mm", pass.tip_height_mm, /*last=*/true);
  w->Raw("}");
}

void WriteSetup(const SplitBevelResult& result, TextWriter* w) {
  w->Raw("{\"blank_to_machine\":[");
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      if (i + j > 0) w->Raw(",");
      w->Number(result.blank_to_machine(i, j));
    }
  }
  w->Raw("],");
  w->Member("segment_mid_deg", RadToDeg(result.segment_mid_rad), true);
  w->Raw("}");
}

// `c` escaped at p as nlohmann-json writes it.
char* PutEscaped(char* p, char c) {
  *p++ = '\\';
  switch (c) {
    case '"':
      *p++ = '"';
      break;
    case '\\':
      *p++ = '\\';
      break;
    case '\b':
      *p++ = 'b';
      break;
    case '\f':
      *p++ = 'f';
      break;
    case '\n':
      *p++ = 'n';
      break;
    case '\r':
      *p++ = 'r';
      break;
    case '\t':
      *p++ = 't';
      break;
    default: {
      static constexpr char kHex[] = "0123456789abcdef";
      const unsigned char u = static_cast<unsigned char>(c);
      p = Put(p, "u00");
      *p++ = kHex[u >> 4];
      *p++ = kHex[u & 0xf];
    }
  }
  return p;
}

// The bytes nlohmann-json escapes: '"', '\\' and the control characters.
struct EscapeTable {
  bool escape[256] = {};
};
constexpr EscapeTable MakeEscapeTable() {
  EscapeTable table;
  for (int c = 0; c < 0x20; ++c) table.escape[c] = true;
  table.escape[static_cast<unsigned char>('"')] = true;
  table.escape[static_cast<unsigned char>('\\')] = true;
  return table;
}
constexpr EscapeTable kEscapeTable = MakeEscapeTable();

bool NeedsEscape(char c) {
  return kEscapeTable.escape[static_cast<unsigned char>(c)];
}

// A JSON string of `text` as nlohmann-json writes it (escapes '"', '\\' and
// the control characters; other bytes as they are), for the NC listing: the
// runs between escapes (its lines) copied whole.
void WriteString(std::string_view text, TextWriter* w) {
  w->Raw("\"");
  size_t start = 0;
  while (start < text.size()) {
    size_t end = start;
    while (end < text.size() && !NeedsEscape(text[end])) ++end;
    w->Raw(text.substr(start, end - start));
    if (end == text.size()) break;
    w->Advance(PutEscaped(w->Room(6), text[end]));
    start = end + 1;
  }
  w->Raw("\"");
}

// The options' members and listing, then the closing brace.
void WriteTail(const SplitBevelTextOptions& options, TextWriter* w) {
  for (const auto& item : options.members.items()) {
    w->Raw(",");
    w->Raw(nlohmann::json(item.key()).dump());
    w->Raw(":");
    w->Raw(item.value().dump(
        -1, ' ', false, nlohmann::json::error_handler_t::replace));
  }
  if (options.nc_program != nullptr) {
    w->Raw(",\"nc_program\":");
    WriteString(*options.nc_program, w);
  }
  w->Raw("}");
}

}  // namespace

std::string SplitBevelResultJsonText(const SplitBevelResult& result,
                                     const SplitBevelTextOptions& options) {
  size_t points = 0;
  for (const SplitBevelPass& pass : result.passes) points += pass.points.size();
  size_t reserve = 4096 + 256 * result.passes.size();
  if (options.points) reserve += kPointReserveChars * points;
  if (options.nc_program != nullptr) reserve += options.nc_program->size() + 64;
  TextWriter w(reserve);
  w.Raw("{\"derived\":");
  WriteDerived(result.derived, &w);
  w.Raw(",\"passes\":[");
  PassTexts texts;
  for (size_t i = 0; i < result.passes.size(); ++i) {
    if (i > 0) w.Raw(",");
    WritePass(result.passes[i], options.points, &texts, &w);
  }
  w.Raw("],\"setup\":");
  WriteSetup(result, &w);
  WriteTail(options, &w);
  return w.Finish();
}

}  // namespace gearloop
