// formats/xml.h: a small, strict XML reader and writer for the GDE files
// (internal to formats/).
//
//   XmlElement root;
//   XmlError error;
//   if (!ParseXml(text, &root, &error)) { /* error.line, error.message */ }
//   std::string out = WriteXml(root);
//
// Reads well-formed XML 1.0 without a DTD: elements, attributes, text,
// comments, CDATA, processing instructions (skipped) and the predefined and
// numeric character references. A DOCTYPE is refused (no entity expansion, so
// no "billion laughs"), and so is nesting deeper than kMaxXmlDepth: the input
// comes from uploads. Errors carry the 1-based line.
#ifndef GEARLOOP_FORMATS_XML_H_
#define GEARLOOP_FORMATS_XML_H_

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace gearloop {

inline constexpr int kMaxXmlDepth = 64;

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>>
      attributes;    // in document order
  std::string text;  // the character data, concatenated
  std::vector<XmlElement> children;
  int line = 0;

  // The attribute's value, or nullptr.
  const std::string* Attribute(std::string_view attribute_name) const;
};

struct XmlError {
  int line = 0;
  std::string message;
};

// `text` is UTF-8 (formats/measurement_file.h decodes the upload first).
bool ParseXml(std::string_view text, XmlElement* root, XmlError* error);

// Indented XML with an XML declaration; text and attribute values escaped.
std::string WriteXml(const XmlElement& root);

}  // namespace gearloop

#endif  // GEARLOOP_FORMATS_XML_H_
