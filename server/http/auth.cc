#include "server/http/auth.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

// Last: see server/respond.h.
#include <httplib.h>
#include <openssl/crypto.h>
#include <openssl/sha.h>

namespace gearloop {
namespace {

std::string Sha256Hex(const std::string& text) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(
      reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  static const char* kHex = "0123456789abcdef";
  std::string hex;
  for (unsigned char b : digest) {
    hex += kHex[b >> 4];
    hex += kHex[b & 15];
  }
  return hex;
}

}  // namespace

bool IsLoopbackHost(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

// The token file of issue 7: "<role> <sha256-hex-of-token> [name]" per line,
// '#' comments.
std::vector<TokenEntry> LoadTokenFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read token file " + path);
  std::vector<TokenEntry> tokens;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream fields(line);
    TokenEntry entry;
    if (!(fields >> entry.role) || entry.role[0] == '#') continue;
    fields >> entry.sha256_hex;
    std::getline(fields >> std::ws, entry.name);
    std::transform(entry.sha256_hex.begin(),
                   entry.sha256_hex.end(),
                   entry.sha256_hex.begin(),
                   ::tolower);
    const bool hex_ok = entry.sha256_hex.size() == 64 &&
                        entry.sha256_hex.find_first_not_of(
                            "0123456789abcdef") == std::string::npos;
    if ((entry.role != "read" && entry.role != "write") || !hex_ok) {
      throw std::runtime_error(
          "token file " + path + " line " + std::to_string(line_number) +
          ": expected \"<read|write> <sha256-hex> [name]\"");
    }
    tokens.push_back(entry);
  }
  if (tokens.empty())
    throw std::runtime_error("token file " + path + " holds no tokens");
  return tokens;
}

bool Authorize(const std::vector<TokenEntry>& tokens,
               const httplib::Request& req,
               Access access,
               ApiError* error) {
  if (tokens.empty() || access == Access::kOpen) return true;
  const std::string header = req.get_header_value("Authorization");
  const std::string prefix = "Bearer ";
  if (header.size() <= prefix.size() ||
      header.compare(0, prefix.size(), prefix) != 0) {
    *error = ApiError{401,
                      "unauthorized",
                      "send a token as \"Authorization: Bearer <token>\"",
                      ""};
    return false;
  }
  const std::string hash = Sha256Hex(header.substr(prefix.size()));
  const TokenEntry* match = nullptr;
  // Compare with every entry, in constant time each, so timing tells nothing
  // about the hashes.
  for (const TokenEntry& entry : tokens) {
    if (CRYPTO_memcmp(entry.sha256_hex.data(), hash.data(), hash.size()) == 0)
      match = &entry;
  }
  if (match == nullptr) {
    *error = ApiError{401, "unauthorized", "unknown token", ""};
    return false;
  }
  if (access == Access::kWrite && match->role != "write") {
    *error =
        ApiError{403, "forbidden", "this token may read but not submit", ""};
    return false;
  }
  return true;
}

std::string TokenName(const std::vector<TokenEntry>& tokens,
                      const std::string& authorization_header) {
  const std::string prefix = "Bearer ";
  if (tokens.empty() || authorization_header.size() <= prefix.size() ||
      authorization_header.compare(0, prefix.size(), prefix) != 0)
    return std::string();
  const std::string hash =
      Sha256Hex(authorization_header.substr(prefix.size()));
  std::string name;
  for (const TokenEntry& entry : tokens) {
    if (CRYPTO_memcmp(entry.sha256_hex.data(), hash.data(), hash.size()) == 0)
      name = entry.name;
  }
  return name;
}

}  // namespace gearloop
