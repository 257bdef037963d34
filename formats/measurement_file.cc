// formats/measurement_file.cc: places, errors, text decoding and number syntax
// shared by the readers.
#include "formats/measurement_file.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace gearloop {
namespace {

// Length of the valid UTF-8 sequence at s[i], 0 when invalid (overlong,
// surrogate, > U+10FFFF).
size_t Utf8SequenceLength(std::string_view s, size_t i) {
  const unsigned char c = static_cast<unsigned char>(s[i]);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned int cp = 0;
  if ((c & 0xE0) == 0xC0) {
    n = 2;
    cp = c & 0x1F;
  } else if ((c & 0xF0) == 0xE0) {
    n = 3;
    cp = c & 0x0F;
  } else if ((c & 0xF8) == 0xF0) {
    n = 4;
    cp = c & 0x07;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    const unsigned char d = static_cast<unsigned char>(s[i + k]);
    if ((d & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (d & 0x3F);
  }
  if ((n == 2 && cp < 0x80) || (n == 3 && cp < 0x800) ||
      (n == 4 && cp < 0x10000))
    return 0;
  if (cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
  return n;
}

bool IsAllowedControl(unsigned char c) {
  return c == '\t' || c == '\n' || c == '\r';
}

bool Refuse(int line, const std::string& message, FileError* error) {
  error->place = FilePlace{line, ""};
  error->message = message;
  error->too_large = false;
  return false;
}

}  // namespace

std::string FilePlace::ToString() const {
  if (!element_path.empty()) return element_path;
  if (line > 0) return "file:line " + std::to_string(line);
  return "file";
}

std::string FileError::ToString() const {
  return place.ToString() + ": " + message;
}

bool DecodeMeasurementText(std::string_view bytes,
                           std::string* utf8,
                           FileError* error) {
  if (bytes.size() > kMaxMeasurementFileBytes) {
    error->place = FilePlace{};
    error->message = "the file has " + std::to_string(bytes.size()) +
                     " bytes, more than the limit of " +
                     std::to_string(kMaxMeasurementFileBytes);
    error->too_large = true;
    return false;
  }
  if (bytes.size() >= 2 && ((bytes[0] == '\xFF' && bytes[1] == '\xFE') ||
                            (bytes[0] == '\xFE' && bytes[1] == '\xFF'))) {
    return Refuse(
        1,
        "the file is UTF-16 (or UTF-32) text; save it as UTF-8 or Latin-1",
        error);
  }
  if (bytes.substr(0, 3) == "\xEF\xBB\xBF") bytes.remove_prefix(3);
  bool valid_utf8 = true;
  int line = 1;
  for (size_t i = 0; i < bytes.size();) {
    const unsigned char c = static_cast<unsigned char>(bytes[i]);
    if (c == '\n') ++line;
    if ((c < 0x20 && !IsAllowedControl(c)) || c == 0x7F) {
      return Refuse(line,
                    "control character 0x" +
                        std::string(1, "0123456789ABCDEF"[c >> 4]) +
                        std::string(1, "0123456789ABCDEF"[c & 15]) +
                        " in the text: not a text file",
                    error);
    }
    const size_t n = Utf8SequenceLength(bytes, i);
    if (n == 0) {
      valid_utf8 = false;
      break;
    }
    i += n;
  }
  if (valid_utf8) {
    utf8->assign(bytes.data(), bytes.size());
    return true;
  }
  // Latin-1: every byte is a character; 0x80-0x9F are C1 controls, which text
  // never holds.
  utf8->clear();
  utf8->reserve(bytes.size() + bytes.size() / 8);
  line = 1;
  for (const char ch : bytes) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '\n') ++line;
    if (c >= 0x80 && c < 0xA0) {
      return Refuse(line,
                    "byte 0x" + std::string(1, "0123456789ABCDEF"[c >> 4]) +
                        std::string(1, "0123456789ABCDEF"[c & 15]) +
                        " is neither UTF-8 nor Latin-1 text",
                    error);
    }
    if (c < 0x80) {
      utf8->push_back(ch);
    } else {
      utf8->push_back(static_cast<char>(0xC0 | (c >> 6)));
      utf8->push_back(static_cast<char>(0x80 | (c & 0x3F)));
    }
  }
  return true;
}

bool ParseDecimalNumber(std::string_view text,
                        double* value,
                        std::string* why) {
  auto fail = [&](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  const std::string shown =
      "'" + std::string(text.substr(0, 40)) + (text.size() > 40 ? "...'" : "'");
  if (text.empty()) return fail("an empty number");
  size_t i = 0;
  if (text[i] == '+' || text[i] == '-') ++i;
  size_t digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])))
    ++i, ++digits;
  if (i < text.size() && text[i] == ',') {
    return fail(shown +
                " has a decimal comma; the file must use a decimal point");
  }
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])))
      ++i, ++digits;
  }
  if (digits == 0) {
    std::string lower;
    for (char c : text)
      lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (lower.find("nan") != std::string::npos ||
        lower.find("inf") != std::string::npos) {
      return fail(shown + " is not a finite number");
    }
    return fail(shown + " is not a number");
  }
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    size_t exponent_digits = 0;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])))
      ++i, ++exponent_digits;
    if (exponent_digits == 0) return fail(shown + " is not a number");
  }
  if (i != text.size()) {
    if (text[i] == ',')
      return fail(shown +
                  " has a decimal comma; the file must use a decimal point");
    return fail(shown + " is not a number");
  }
  const std::string copy(text);
  errno = 0;
  const double v = std::strtod(copy.c_str(), nullptr);
  if (!std::isfinite(v) || errno == ERANGE) {
    if (std::isfinite(v) && std::abs(v) < 1.0) {
      *value = 0.0;  // underflow to zero is harmless
      return true;
    }
    return fail(shown + " is out of range");
  }
  *value = v;
  return true;
}

}  // namespace gearloop
