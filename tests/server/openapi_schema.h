// tests/server/openapi_schema.h: reads api/openapi.yaml into JSON (libyaml) and
// checks a JSON answer against one of its schemas, for
// tests/server/openapi_test.cc.
//
//   std::string error;
//   const nlohmann::json spec = LoadYamlAsJson(path, &error);
//   SchemaValidator validator(spec);
//   std::vector<std::string> problems;
//   validator.Validate(validator.Schema("ClosedLoopResponse"), answer,
//   &problems);
//
// The validator knows the JSON Schema keywords the file uses: $ref (local JSON
// pointers), type (one or a list), enum, const, required, properties,
// additionalProperties, items, minItems, maxItems, minimum, maximum,
// exclusiveMinimum, exclusiveMaximum, allOf, anyOf, oneOf. Any other keyword
// (description, default, format) is ignored, as an annotation.
#ifndef GEARLOOP_TESTS_SERVER_OPENAPI_SCHEMA_H_
#define GEARLOOP_TESTS_SERVER_OPENAPI_SCHEMA_H_

#include <yaml.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

namespace gearloop {
namespace testing_util {

namespace internal {

// A plain (unquoted) scalar as YAML 1.2's core schema resolves it; quoted and
// block scalars stay strings.
inline nlohmann::json ResolvePlainScalar(const std::string& text) {
  static const std::regex null_re(R"(^(~|null|Null|NULL)?$)");
  static const std::regex true_re(R"(^(true|True|TRUE)$)");
  static const std::regex false_re(R"(^(false|False|FALSE)$)");
  static const std::regex int_re(R"(^[-+]?[0-9]+$)");
  static const std::regex float_re(
      R"(^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$)");
  if (std::regex_match(text, null_re)) return nullptr;
  if (std::regex_match(text, true_re)) return true;
  if (std::regex_match(text, false_re)) return false;
  if (std::regex_match(text, int_re)) return std::stoll(text);
  if (std::regex_match(text, float_re)) return std::stod(text);
  return text;
}

inline nlohmann::json NodeToJson(yaml_document_t* document,
                                 yaml_node_t* node,
                                 int depth) {
  if (node == nullptr || depth > 200) return nullptr;
  switch (node->type) {
    case YAML_SCALAR_NODE: {
      const std::string text(
          reinterpret_cast<const char*>(node->data.scalar.value),
          node->data.scalar.length);
      if (node->data.scalar.style == YAML_PLAIN_SCALAR_STYLE)
        return ResolvePlainScalar(text);
      return text;
    }
    case YAML_SEQUENCE_NODE: {
      nlohmann::json array = nlohmann::json::array();
      for (yaml_node_item_t* item = node->data.sequence.items.start;
           item < node->data.sequence.items.top;
           ++item) {
        array.push_back(NodeToJson(
            document, yaml_document_get_node(document, *item), depth + 1));
      }
      return array;
    }
    case YAML_MAPPING_NODE: {
      nlohmann::json object = nlohmann::json::object();
      for (yaml_node_pair_t* pair = node->data.mapping.pairs.start;
           pair < node->data.mapping.pairs.top;
           ++pair) {
        const nlohmann::json key = NodeToJson(
            document, yaml_document_get_node(document, pair->key), depth + 1);
        // Keys such as "200" are plain integers to YAML; JSON keys are strings.
        const std::string name =
            key.is_string() ? key.get<std::string>() : key.dump();
        object[name] = NodeToJson(
            document, yaml_document_get_node(document, pair->value), depth + 1);
      }
      return object;
    }
    default:
      return nullptr;
  }
}

}  // namespace internal

// The first document of a YAML file as JSON; null with *error set when it
// cannot be read.
inline nlohmann::json LoadYamlAsJson(const std::string& path,
                                     std::string* error) {
  FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) {
    *error = "cannot open " + path;
    return nullptr;
  }
  yaml_parser_t parser;
  yaml_document_t document;
  yaml_parser_initialize(&parser);
  yaml_parser_set_input_file(&parser, file);
  nlohmann::json result;
  if (!yaml_parser_load(&parser, &document)) {
    *error = path + ": " + (parser.problem ? parser.problem : "YAML error") +
             " at line " + std::to_string(parser.problem_mark.line + 1);
  } else {
    result = internal::NodeToJson(
        &document, yaml_document_get_root_node(&document), 0);
    yaml_document_delete(&document);
  }
  yaml_parser_delete(&parser);
  std::fclose(file);
  return result;
}

// Checks JSON values against the schemas of one OpenAPI document.
class SchemaValidator {
 public:
  explicit SchemaValidator(nlohmann::json spec) : spec_(std::move(spec)) {}

  // components.schemas.<name>, or null.
  nlohmann::json Schema(const std::string& name) const {
    const nlohmann::json::json_pointer pointer("/components/schemas/" + name);
    return spec_.contains(pointer) ? spec_.at(pointer)
                                   : nlohmann::json(nullptr);
  }

  // The schema of an operation's answer with this status (application/json), or
  // null.
  nlohmann::json ResponseSchema(const std::string& method,
                                const std::string& path,
                                int status) const {
    std::string lower = method;
    for (char& c : lower)
      c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (!spec_.contains("paths") || !spec_["paths"].contains(path))
      return nullptr;
    const nlohmann::json& operation = spec_["paths"][path];
    if (!operation.contains(lower) || !operation[lower].contains("responses"))
      return nullptr;
    nlohmann::json response = operation[lower]["responses"].value(
        std::to_string(status), nlohmann::json(nullptr));
    if (response.is_object() && response.contains("$ref"))
      response = Resolve(response["$ref"].get<std::string>());
    const nlohmann::json::json_pointer schema(
        "/content/application~1json/schema");
    return response.is_object() && response.contains(schema)
               ? response.at(schema)
               : nlohmann::json(nullptr);
  }

  // True when value matches schema; otherwise appends what did not, with the
  // JSON path.
  bool Validate(const nlohmann::json& schema,
                const nlohmann::json& value,
                std::vector<std::string>* problems,
                const std::string& where = "$") const {
    const size_t before = problems->size();
    Check(schema, value, where, problems, 0);
    return problems->size() == before;
  }

 private:
  nlohmann::json Resolve(const std::string& ref) const {
    if (ref.rfind("#/", 0) != 0) return nullptr;
    const nlohmann::json::json_pointer pointer(ref.substr(1));
    return spec_.contains(pointer) ? spec_.at(pointer)
                                   : nlohmann::json(nullptr);
  }

  static bool HasType(const nlohmann::json& value, const std::string& type) {
    if (type == "null") return value.is_null();
    if (type == "boolean") return value.is_boolean();
    if (type == "string") return value.is_string();
    if (type == "array") return value.is_array();
    if (type == "object") return value.is_object();
    if (type == "number") return value.is_number();
    if (type == "integer") {
      return value.is_number_integer() ||
             (value.is_number_float() &&
              std::floor(value.get<double>()) == value.get<double>());
    }
    return false;
  }

  void Check(const nlohmann::json& schema,
             const nlohmann::json& value,
             const std::string& where,
             std::vector<std::string>* problems,
             int depth) const {
    if (depth > 64) {
      problems->push_back(where + ": schema nests too deep");
      return;
    }
    if (schema.is_boolean()) {
      if (!schema.get<bool>())
        problems->push_back(where + ": no value is allowed here");
      return;
    }
    if (!schema.is_object()) return;
    if (schema.contains("$ref")) {
      const std::string ref = schema["$ref"].get<std::string>();
      const nlohmann::json target = Resolve(ref);
      if (target.is_null()) {
        problems->push_back(where + ": unresolved $ref " + ref);
      } else {
        Check(target, value, where, problems, depth + 1);
      }
    }
    if (schema.contains("type")) {
      const nlohmann::json& type = schema["type"];
      bool ok = false;
      if (type.is_string()) ok = HasType(value, type.get<std::string>());
      if (type.is_array()) {
        for (const nlohmann::json& t : type)
          ok = ok || (t.is_string() && HasType(value, t.get<std::string>()));
      }
      if (!ok) {
        problems->push_back(where + ": " + value.dump().substr(0, 80) +
                            " is not of type " + type.dump());
        return;
      }
    }
    if (schema.contains("const") && value != schema["const"]) {
      problems->push_back(where + ": " + value.dump().substr(0, 80) +
                          " is not " + schema["const"].dump());
    }
    if (schema.contains("enum")) {
      bool found = false;
      for (const nlohmann::json& option : schema["enum"])
        found = found || option == value;
      if (!found)
        problems->push_back(where + ": " + value.dump().substr(0, 80) +
                            " is not one of " + schema["enum"].dump());
    }
    if (value.is_number()) {
      const double x = value.get<double>();
      if (schema.contains("minimum") && x < schema["minimum"].get<double>())
        problems->push_back(where + ": below minimum");
      if (schema.contains("maximum") && x > schema["maximum"].get<double>())
        problems->push_back(where + ": above maximum");
      if (schema.contains("exclusiveMinimum") &&
          schema["exclusiveMinimum"].is_number() &&
          x <= schema["exclusiveMinimum"].get<double>()) {
        problems->push_back(where + ": not above exclusiveMinimum");
      }
      if (schema.contains("exclusiveMaximum") &&
          schema["exclusiveMaximum"].is_number() &&
          x >= schema["exclusiveMaximum"].get<double>()) {
        problems->push_back(where + ": not below exclusiveMaximum");
      }
    }
    if (value.is_array()) {
      if (schema.contains("minItems") &&
          value.size() < schema["minItems"].get<size_t>()) {
        problems->push_back(where + ": fewer than minItems items");
      }
      if (schema.contains("maxItems") &&
          value.size() > schema["maxItems"].get<size_t>()) {
        problems->push_back(where + ": more than maxItems items");
      }
      if (schema.contains("items")) {
        for (size_t i = 0; i < value.size(); ++i) {
          Check(schema["items"],
                value[i],
                where + "[" + std::to_string(i) + "]",
                problems,
                depth + 1);
        }
      }
    }
    if (value.is_object()) {
      if (schema.contains("required")) {
        for (const nlohmann::json& name : schema["required"]) {
          if (!value.contains(name.get<std::string>())) {
            problems->push_back(where + ": required property \"" +
                                name.get<std::string>() + "\" is missing");
          }
        }
      }
      const nlohmann::json properties =
          schema.value("properties", nlohmann::json::object());
      for (auto it = value.begin(); it != value.end(); ++it) {
        const std::string at = where + "." + it.key();
        if (properties.contains(it.key())) {
          Check(properties[it.key()], it.value(), at, problems, depth + 1);
        } else if (schema.contains("additionalProperties")) {
          Check(schema["additionalProperties"],
                it.value(),
                at,
                problems,
                depth + 1);
        }
      }
    }
    if (schema.contains("allOf")) {
      for (const nlohmann::json& part : schema["allOf"])
        Check(part, value, where, problems, depth + 1);
    }
    if (schema.contains("anyOf") || schema.contains("oneOf")) {
      const bool one = schema.contains("oneOf");
      const nlohmann::json& options = one ? schema["oneOf"] : schema["anyOf"];
      int matches = 0;
      std::vector<std::string> reasons;
      for (size_t i = 0; i < options.size(); ++i) {
        std::vector<std::string> attempt;
        Check(options[i], value, where, &attempt, depth + 1);
        if (attempt.empty()) {
          ++matches;
        } else {
          reasons.push_back(
              "option " + std::to_string(i) + ": " + attempt.front() +
              (attempt.size() > 1
                   ? " (and " + std::to_string(attempt.size() - 1) + " more)"
                   : ""));
        }
      }
      if (matches == 0) {
        std::string text = where + ": matches none of the " +
                           std::string(one ? "oneOf" : "anyOf") + " options";
        for (const std::string& reason : reasons) text += "; " + reason;
        problems->push_back(text);
      } else if (one && matches > 1) {
        problems->push_back(where + ": matches " + std::to_string(matches) +
                            " of the oneOf options, not one");
      }
    }
  }

  nlohmann::json spec_;
};

}  // namespace testing_util
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_SERVER_OPENAPI_SCHEMA_H_
