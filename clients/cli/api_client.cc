// clients/cli/api_client.cc: cpp-httplib underneath. A 5xx counts as a
// transport failure, not as an API error: the contract promises 4xx for
// anything the request did wrong, so a 5xx says the server is broken, and
// scripts retry those, not fix their input.
#include "clients/cli/api_client.h"

#include <httplib.h>

namespace gearloop {

std::string ApiResponse::ErrorText() const {
  if (!transport_error.empty()) return transport_error;
  std::string text = std::to_string(status);
  const nlohmann::json* error =
      body.is_object() && body.contains("error") ? &body["error"] : nullptr;
  if (error != nullptr && error->is_object()) {
    const std::string code = error->value("code", "");
    const std::string message = error->value("message", "");
    const std::string field = error->value("field", "");
    if (!code.empty()) text += " " + code;
    if (!field.empty()) text += " at " + field;
    text += ": " + message;
  } else {
    text += ": " + this->text;
  }
  return text;
}

ApiClient::ApiClient(const std::string& server,
                     const std::string& token,
                     int timeout_seconds)
    : server_(server), token_(token) {
  while (!server_.empty() && server_.back() == '/') server_.pop_back();
  if (server_.rfind("http://", 0) != 0 && server_.rfind("https://", 0) != 0) {
    url_error_ =
        "--server must start with http:// or https:// (got \"" + server + "\")";
    return;
  }
  const size_t path_start = server_.find('/', server_.find("//") + 2);
  if (path_start != std::string::npos) {
    url_error_ =
        "--server takes scheme, host and port only (got \"" + server + "\")";
    return;
  }
  http_ = std::make_unique<httplib::Client>(server_);
  if (!http_->is_valid()) {
    url_error_ = "cannot use server address \"" + server + "\"";
    return;
  }
  http_->set_connection_timeout(timeout_seconds, 0);
  http_->set_read_timeout(timeout_seconds, 0);
  http_->set_write_timeout(timeout_seconds, 0);
  http_->set_keep_alive(true);
  if (!token_.empty()) http_->set_bearer_token_auth(token_);
}

ApiClient::~ApiClient() = default;

bool ApiClient::IsValid(std::string* error) const {
  if (url_error_.empty()) return true;
  *error = url_error_;
  return false;
}

ApiResponse ApiClient::Finish(int status,
                              const std::string& body,
                              const std::string& transport_error) const {
  ApiResponse response;
  response.status = status;
  response.text = body;
  response.transport_error = transport_error;
  if (!transport_error.empty()) return response;
  response.body =
      nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (response.body.is_discarded()) response.body = nullptr;
  if (status >= 500) {
    std::string message;
    if (response.body.is_object() && response.body.contains("error") &&
        response.body["error"].is_object()) {
      message = response.body["error"].value("message", "");
    }
    response.transport_error = "server error " + std::to_string(status) +
                               (message.empty() ? "" : ": " + message);
  }
  return response;
}

namespace {

// What failed and what to do about it, for a request that got no answer.
std::string UnreachableMessage(const std::string& server,
                               httplib::Error error) {
  const std::string base = "cannot reach " + server + ": ";
  if (error == httplib::Error::Connection) {
    return base +
           "no connection (Connection). Is the server running? Start it with "
           "`gearloop-server --port PORT`, or give its URL with --server URL "
           "or GEARLOOP_SERVER.";
  }
  if (error == httplib::Error::Read || error == httplib::Error::Write) {
    return base + httplib::to_string(error) +
           " (no answer in time: a long solve or batch may need a larger "
           "--timeout S; or the server stopped)";
  }
  return base + httplib::to_string(error) +
         " (is the server running at this URL? --server URL or "
         "GEARLOOP_SERVER)";
}

}  // namespace

ApiResponse ApiClient::Get(const std::string& path) {
  if (!url_error_.empty()) return Finish(0, "", url_error_);
  httplib::Result result = http_->Get(
      path.c_str(), httplib::Headers{{"Accept", "application/json"}});
  if (!result) {
    return Finish(0, "", UnreachableMessage(server_, result.error()));
  }
  return Finish(result->status, result->body, "");
}

ApiResponse ApiClient::Post(const std::string& path,
                            const nlohmann::json& body) {
  if (!url_error_.empty()) return Finish(0, "", url_error_);
  httplib::Result result =
      http_->Post(path.c_str(),
                  httplib::Headers{{"Accept", "application/json"}},
                  body.dump(),
                  "application/json");
  if (!result) {
    return Finish(0, "", UnreachableMessage(server_, result.error()));
  }
  return Finish(result->status, result->body, "");
}

}  // namespace gearloop
