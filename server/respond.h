// server/respond.h: how every answer of the HTTP API is written (API.md): a
// JSON body with its status, the error body of api/openapi.yaml, and the
// numeric id of a resource path. Below both server/http/ and server/services/,
// so neither has to reach up to the other to answer.
//
//   ApiError error;
//   if (!ParseJsonBody(req.body, &body, &error)) return RespondError(res,
//   error); RespondJson(res, 200, answer);
#ifndef GEARLOOP_SERVER_RESPOND_H_
#define GEARLOOP_SERVER_RESPOND_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "server/codec/json_read.h"

// cpp-httplib's <httplib.h> pulls in <resolv.h>, whose `_res` macro breaks
// Eigen's headers that come after it; headers name its types only, and .cc
// files include it last.
namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace gearloop {

// `body` as compact JSON. Messages may quote request bytes: an invalid UTF-8
// byte is replaced, never turned into an exception (and a 500).
std::string Dump(const nlohmann::json& body);

// Sets the status and the body (application/json).
void RespondJson(httplib::Response& res,
                 int status,
                 const nlohmann::json& body);
// {"error": {"code", "message", "field"}} with the error's status.
void RespondError(httplib::Response& res, const ApiError& error);

// A path id ("/api/v1/corrections/17"): digits only (the route's regex), and
// small enough; false for 0 or an id of more than 18 digits.
bool ParseId(const std::string& text, int64_t* id);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_RESPOND_H_
