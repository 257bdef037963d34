#include "server/respond.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {

std::string Dump(const nlohmann::json& body) {
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void RespondJson(httplib::Response& res,
                 int status,
                 const nlohmann::json& body) {
  res.status = status;
  res.set_content(Dump(body), "application/json");
}

void RespondError(httplib::Response& res, const ApiError& error) {
  RespondJson(res, error.status, ErrorBody(error));
}

bool ParseId(const std::string& text, int64_t* id) {
  if (text.empty() || text.size() > 18) return false;
  *id = std::stoll(text);
  return *id > 0;
}

}  // namespace gearloop
