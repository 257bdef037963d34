// clients/cli/api_client.h: a thin HTTP client of the gearloop API
// (api/openapi.yaml) for the command-line tool: JSON in, JSON out, and every
// failure sorted into the two kinds a script must tell apart: the server could
// not be reached or answered nonsense (transport), or the server answered with
// an API error body {"error": {"code", "message", "field"}}.
//
//   ApiClient client("http://127.0.0.1:8080", /*token=*/"");
//   ApiResponse answer = client.Post("/api/v1/corrections", request);
//   if (!answer.transport_error.empty()) { ... exit 2 ... }
//   if (answer.IsApiError()) { std::cerr << answer.ErrorText(); ... exit 3 ...
//   } int64_t id = answer.body["id"];
#ifndef GEARLOOP_CLIENTS_CLI_API_CLIENT_H_
#define GEARLOOP_CLIENTS_CLI_API_CLIENT_H_

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

namespace httplib {
class Client;
}

namespace gearloop {

struct ApiResponse {
  // HTTP status; 0 when no answer arrived.
  int status = 0;
  // The parsed JSON body (null when the body was empty or not JSON).
  nlohmann::json body;
  // The raw body (text/plain answers such as /metrics).
  std::string text;
  // Set when the server could not be reached, timed out, or answered something
  // that is not the API (a 5xx, or a non-JSON body where JSON was expected).
  std::string transport_error;

  bool ok() const {
    return transport_error.empty() && status >= 200 && status < 300;
  }
  // A 4xx answer of the API (carries code, message, field).
  bool IsApiError() const {
    return transport_error.empty() && status >= 400 && status < 500;
  }
  // "422 invalid_value at gear.teeth: ..." for a person.
  std::string ErrorText() const;
};

class ApiClient {
 public:
  // `server` is "http://host:port" (a trailing "/" is dropped); `token` is sent
  // as "Authorization: Bearer <token>" when not empty. `timeout_seconds` bounds
  // connect, read and write each.
  ApiClient(const std::string& server,
            const std::string& token,
            int timeout_seconds = 120);
  ~ApiClient();
  ApiClient(const ApiClient&) = delete;
  ApiClient& operator=(const ApiClient&) = delete;

  // False (with a reason) when `server` is not an http:// URL this client can
  // use.
  bool IsValid(std::string* error) const;

  ApiResponse Get(const std::string& path);
  ApiResponse Post(const std::string& path, const nlohmann::json& body);

 private:
  ApiResponse Finish(int status,
                     const std::string& body,
                     const std::string& transport_error) const;

  std::string server_;
  std::string token_;
  std::string url_error_;
  std::unique_ptr<httplib::Client> http_;
};

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_API_CLIENT_H_
