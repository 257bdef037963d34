// server/http/openapi_document.h: GET /api/v1/openapi.yaml, the API's
// contract (api/openapi.yaml) as this server was built with it: embedded at
// build time (server/http/embed_text.cmake), so the document served always
// matches the routes compiled in.
//
//   Register("GET", "/api/v1/openapi.yaml", ..., ServeOpenApiDocument);
#ifndef GEARLOOP_SERVER_HTTP_OPENAPI_DOCUMENT_H_
#define GEARLOOP_SERVER_HTTP_OPENAPI_DOCUMENT_H_

#include <string>

#include "server/respond.h"

namespace gearloop {

// The embedded api/openapi.yaml.
std::string OpenApiDocument();

// 200 application/yaml with the document.
void ServeOpenApiDocument(const httplib::Request& req, httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_OPENAPI_DOCUMENT_H_
