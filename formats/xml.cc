// formats/xml.cc: a recursive-descent XML reader (depth-limited) and an
// indenting writer.
#include "formats/xml.h"

#include <cctype>

namespace gearloop {
namespace {

bool IsNameStart(unsigned char c) {
  return std::isalpha(c) || c == '_' || c == ':' || c >= 0x80;
}
bool IsNameChar(unsigned char c) {
  return IsNameStart(c) || std::isdigit(c) || c == '-' || c == '.';
}
bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

void AppendUtf8(unsigned int cp, std::string* out) {
  if (cp < 0x80) {
    out->push_back(static_cast<char>(cp));
  } else if (cp < 0x800) {
    out->push_back(static_cast<char>(0xC0 | (cp >> 6)));
    out->push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else if (cp < 0x10000) {
    out->push_back(static_cast<char>(0xE0 | (cp >> 12)));
    out->push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else {
    out->push_back(static_cast<char>(0xF0 | (cp >> 18)));
    out->push_back(static_cast<char>(0x80 | ((cp >> 12) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  }
}

class Parser {
 public:
  explicit Parser(std::string_view text) : s_(text) {}

  bool Parse(XmlElement* root, XmlError* error) {
    error_ = error;
    SkipMisc(/*prolog=*/true);
    if (failed_) return false;
    if (AtEnd() || s_[pos_] != '<') return Fail("no root element");
    if (!ParseElement(root, 1)) return false;
    SkipMisc(/*prolog=*/false);
    if (failed_) return false;
    if (!AtEnd()) return Fail("content after the root element");
    return true;
  }

 private:
  bool AtEnd() const { return pos_ >= s_.size(); }
  bool StartsWith(std::string_view what) const {
    return s_.substr(pos_, what.size()) == what;
  }

  void Advance(size_t n) {
    for (size_t k = 0; k < n && pos_ < s_.size(); ++k) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  bool Fail(const std::string& message) {
    if (!failed_) {
      error_->line = line_;
      error_->message = message;
      failed_ = true;
    }
    return false;
  }

  void SkipSpace() {
    while (!AtEnd() && IsSpace(s_[pos_])) Advance(1);
  }

  // Skips from the current "<!--" / "<?" to past its end.
  bool SkipUntil(std::string_view end, const char* what) {
    const size_t found = s_.find(end, pos_);
    if (found == std::string_view::npos)
      return Fail(std::string("unterminated ") + what);
    Advance(found + end.size() - pos_);
    return true;
  }

  // Whitespace, comments and processing instructions around the root element.
  void SkipMisc(bool prolog) {
    while (!AtEnd() && !failed_) {
      if (IsSpace(s_[pos_])) {
        Advance(1);
      } else if (StartsWith("<!--")) {
        SkipUntil("-->", "comment");
      } else if (StartsWith("<?")) {
        SkipUntil("?>", "processing instruction");
      } else if (StartsWith("<!DOCTYPE") || StartsWith("<!")) {
        Fail(prolog ? "a DOCTYPE (DTD) is not accepted"
                    : "markup after the root element");
      } else {
        return;
      }
    }
  }

  bool ParseName(std::string* name) {
    if (AtEnd() || !IsNameStart(static_cast<unsigned char>(s_[pos_])))
      return Fail("expected a name");
    const size_t begin = pos_;
    while (!AtEnd() && IsNameChar(static_cast<unsigned char>(s_[pos_])))
      Advance(1);
    name->assign(s_.substr(begin, pos_ - begin));
    return true;
  }

  // A reference after '&'; appends its character.
  bool ParseReference(std::string* out) {
    const size_t semi = s_.find(';', pos_);
    if (semi == std::string_view::npos || semi - pos_ > 12)
      return Fail("'&' that starts no reference (write &amp;)");
    const std::string_view ref = s_.substr(pos_ + 1, semi - pos_ - 1);
    if (ref == "lt") {
      out->push_back('<');
    } else if (ref == "gt") {
      out->push_back('>');
    } else if (ref == "amp") {
      out->push_back('&');
    } else if (ref == "quot") {
      out->push_back('"');
    } else if (ref == "apos") {
      out->push_back('\'');
    } else if (ref.size() >= 2 && ref[0] == '#') {
      const bool hex = ref[1] == 'x';
      const std::string_view digits = ref.substr(hex ? 2 : 1);
      if (digits.empty()) return Fail("empty character reference");
      unsigned long cp = 0;
      for (char c : digits) {
        const int d =
            std::isdigit(static_cast<unsigned char>(c)) ? c - '0'
            : (hex && std::isxdigit(static_cast<unsigned char>(c)))
                ? std::tolower(static_cast<unsigned char>(c)) - 'a' + 10
                : -1;
        if (d < 0)
          return Fail("bad character reference &" + std::string(ref) + ";");
        cp = cp * (hex ? 16 : 10) + static_cast<unsigned long>(d);
        if (cp > 0x10FFFF) return Fail("character reference out of range");
      }
      if (cp == 0 || (cp >= 0xD800 && cp <= 0xDFFF) ||
          (cp < 0x20 && cp != 9 && cp != 10 && cp != 13)) {
        return Fail("character reference to a character XML does not allow");
      }
      AppendUtf8(static_cast<unsigned int>(cp), out);
    } else {
      return Fail("unknown entity &" + std::string(ref) +
                  "; (a DTD is not read)");
    }
    Advance(semi + 1 - pos_);
    return true;
  }

  bool ParseElement(XmlElement* element, int depth) {
    if (depth > kMaxXmlDepth)
      return Fail("elements nested deeper than " +
                  std::to_string(kMaxXmlDepth));
    element->line = line_;
    Advance(1);  // '<'
    if (!ParseName(&element->name)) return false;
    bool empty = false;
    if (!ParseAttributes(element, &empty)) return false;
    if (empty) return true;
    return ParseContent(element, depth);
  }

  // The attributes of a start tag up to its '>' (or "/>": *empty).
  bool ParseAttributes(XmlElement* element, bool* empty) {
    while (true) {
      const size_t before = pos_;
      SkipSpace();
      if (AtEnd())
        return Fail("unterminated start tag <" + element->name + ">");
      if (StartsWith("/>")) {
        Advance(2);
        *empty = true;
        return true;
      }
      if (s_[pos_] == '>') {
        Advance(1);
        return true;
      }
      if (pos_ == before)
        return Fail("expected whitespace before an attribute in <" +
                    element->name + ">");
      if (!ParseAttribute(element)) return false;
    }
  }

  // One name="value" attribute; a repeated name is refused.
  bool ParseAttribute(XmlElement* element) {
    std::string name;
    if (!ParseName(&name)) return false;
    SkipSpace();
    if (AtEnd() || s_[pos_] != '=')
      return Fail("attribute " + name + " without '='");
    Advance(1);
    SkipSpace();
    if (AtEnd() || (s_[pos_] != '"' && s_[pos_] != '\''))
      return Fail("attribute " + name + " value not quoted");
    const char quote = s_[pos_];
    Advance(1);
    std::string value;
    while (true) {
      if (AtEnd()) return Fail("unterminated attribute value of " + name);
      const char c = s_[pos_];
      if (c == quote) {
        Advance(1);
        break;
      }
      if (c == '<') return Fail("'<' in the value of attribute " + name);
      if (c == '&') {
        if (!ParseReference(&value)) return false;
        continue;
      }
      value.push_back(c);
      Advance(1);
    }
    for (const auto& [existing, unused] : element->attributes) {
      if (existing == name)
        return Fail("attribute " + name + " repeated in <" + element->name +
                    ">");
    }
    element->attributes.emplace_back(std::move(name), std::move(value));
    return true;
  }

  // The content of an element up to and including its end tag.
  bool ParseContent(XmlElement* element, int depth) {
    while (true) {
      if (AtEnd()) return Fail("element <" + element->name + "> is not closed");
      const char c = s_[pos_];
      if (c == '<') {
        if (StartsWith("</")) return ParseEndTag(*element);
        if (!ParseMarkup(element, depth)) return false;
      } else if (c == '&') {
        if (!ParseReference(&element->text)) return false;
      } else {
        element->text.push_back(c);
        Advance(1);
      }
    }
  }

  // The end tag of `element`, at "</".
  bool ParseEndTag(const XmlElement& element) {
    Advance(2);
    std::string name;
    if (!ParseName(&name)) return false;
    SkipSpace();
    if (AtEnd() || s_[pos_] != '>') return Fail("malformed end tag </" + name);
    if (name != element.name) {
      return Fail("end tag </" + name + "> does not match <" + element.name +
                  "> of line " + std::to_string(element.line));
    }
    Advance(1);
    return true;
  }

  // Markup inside an element other than its end tag: a comment, CDATA, a
  // processing instruction or a child element.
  bool ParseMarkup(XmlElement* element, int depth) {
    if (StartsWith("<!--")) {
      if (!SkipUntil("-->", "comment")) return false;
    } else if (StartsWith("<![CDATA[")) {
      Advance(9);
      const size_t end = s_.find("]]>", pos_);
      if (end == std::string_view::npos)
        return Fail("unterminated CDATA section");
      element->text.append(s_.substr(pos_, end - pos_));
      Advance(end + 3 - pos_);
    } else if (StartsWith("<?")) {
      if (!SkipUntil("?>", "processing instruction")) return false;
    } else if (StartsWith("<!")) {
      return Fail("a DOCTYPE or declaration inside an element");
    } else {
      element->children.emplace_back();
      if (!ParseElement(&element->children.back(), depth + 1)) return false;
    }
    return true;
  }

  std::string_view s_;
  size_t pos_ = 0;
  int line_ = 1;
  bool failed_ = false;
  XmlError* error_ = nullptr;
};

void Escape(std::string_view in, bool attribute, std::string* out) {
  for (char c : in) {
    switch (c) {
      case '<':
        *out += "&lt;";
        break;
      case '>':
        *out += "&gt;";
        break;
      case '&':
        *out += "&amp;";
        break;
      case '"':
        if (attribute) {
          *out += "&quot;";
        } else {
          *out += c;
        }
        break;
      default:
        *out += c;
    }
  }
}

void Write(const XmlElement& e, int indent, std::string* out) {
  out->append(static_cast<size_t>(indent) * 2, ' ');
  *out += '<' + e.name;
  for (const auto& [name, value] : e.attributes) {
    *out += ' ' + name + "=\"";
    Escape(value, true, out);
    *out += '"';
  }
  if (e.children.empty() && e.text.empty()) {
    *out += "/>\n";
    return;
  }
  *out += '>';
  if (e.children.empty()) {
    Escape(e.text, false, out);
  } else {
    *out += '\n';
    for (const XmlElement& child : e.children) Write(child, indent + 1, out);
    out->append(static_cast<size_t>(indent) * 2, ' ');
  }
  *out += "</" + e.name + ">\n";
}

}  // namespace

const std::string* XmlElement::Attribute(
    std::string_view attribute_name) const {
  for (const auto& [name, value] : attributes) {
    if (name == attribute_name) return &value;
  }
  return nullptr;
}

bool ParseXml(std::string_view text, XmlElement* root, XmlError* error) {
  *root = XmlElement{};
  Parser parser(text);
  return parser.Parse(root, error);
}

std::string WriteXml(const XmlElement& root) {
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  Write(root, 0, &out);
  return out;
}

}  // namespace gearloop
