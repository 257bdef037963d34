#include "server/http/openapi_document.h"

#include <cstddef>

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {

// Defined in the source generated from api/openapi.yaml.
extern const unsigned char kOpenApiDocument[];
extern const std::size_t kOpenApiDocumentSize;

std::string OpenApiDocument() {
  return std::string(reinterpret_cast<const char*>(kOpenApiDocument),
                     kOpenApiDocumentSize);
}

void ServeOpenApiDocument(const httplib::Request&, httplib::Response& res) {
  res.status = 200;
  res.set_content(OpenApiDocument(), "application/yaml; charset=utf-8");
}

}  // namespace gearloop
