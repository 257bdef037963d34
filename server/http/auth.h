// server/http/auth.h: the bearer tokens of issue 7. A token file holds "<role>
// <sha256-hex> [name]" per line ('#' comments); a request sends "Authorization:
// Bearer <token>", whose SHA-256 is compared in constant time with every entry.
// Without a token file the server listens on loopback only and every request is
// allowed.
//
//   std::vector<TokenEntry> tokens = LoadTokenFile("/etc/gearloop/tokens");
//   ApiError error;
//   if (!Authorize(tokens, req, Access::kWrite, &error)) return
//   RespondError(res, error);
#ifndef GEARLOOP_SERVER_HTTP_AUTH_H_
#define GEARLOOP_SERVER_HTTP_AUTH_H_

#include <string>
#include <vector>

#include "server/respond.h"

namespace gearloop {

// What a route needs: nothing (health, metrics, dashboard), a read token or a
// write token.
enum class Access { kOpen, kRead, kWrite };

struct TokenEntry {
  std::string role;  // "read" or "write"
  std::string sha256_hex;
  std::string name;
};

// Reads a token file; throws std::runtime_error naming the line of a malformed
// entry, or when the file cannot be read or holds no tokens.
std::vector<TokenEntry> LoadTokenFile(const std::string& path);

// "localhost", "::1" and 127.x.y.z.
bool IsLoopbackHost(const std::string& host);

// True when `req` may use a route of `access`: always without tokens or for
// kOpen; otherwise 401 (no or unknown token) or 403 (a read token on a write
// route) in `error`.
bool Authorize(const std::vector<TokenEntry>& tokens,
               const httplib::Request& req,
               Access access,
               ApiError* error);

// The name of the token an "Authorization: Bearer <token>" header carries, as
// the token file gives it; "" without tokens, for an unknown token or a token
// without a name. Stored with the jobs the token submits (traceability).
std::string TokenName(const std::vector<TokenEntry>& tokens,
                      const std::string& authorization_header);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_AUTH_H_
