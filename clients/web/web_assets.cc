// clients/web/web_assets.cc: request paths to embedded files. The dashboard's
// pages are few and fixed, so the routing is a handful of comparisons, not a
// router.
#include "clients/web/web_assets.h"

#include <cctype>
#include <cstring>

#include "clients/web/web_assets_table.h"

namespace gearloop {
namespace {

const char* ContentType(const std::string& path) {
  const size_t dot = path.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".json") return "application/json";
  return "application/octet-stream";
}

// "/jobs/123/report" (digits only).
bool IsReportPath(const std::string& path) {
  const std::string prefix = "/jobs/";
  const std::string suffix = "/report";
  if (path.size() <= prefix.size() + suffix.size()) return false;
  if (path.compare(0, prefix.size(), prefix) != 0) return false;
  if (path.compare(path.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  for (size_t i = prefix.size(); i < path.size() - suffix.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(path[i]))) return false;
  }
  return true;
}

}  // namespace

bool FindWebAsset(const std::string& path,
                  std::string* body,
                  std::string* content_type) {
  std::string file = path;
  if (path == "/" || path == "/index.html") {
    file = "/static/index.html";
  } else if (IsReportPath(path)) {
    file = "/static/report.html";
  } else if (path.compare(0, 8, "/static/") != 0) {
    return false;
  }
  for (const EmbeddedWebAsset* asset = kEmbeddedWebAssets;
       asset->path != nullptr;
       ++asset) {
    if (file == asset->path) {
      body->assign(reinterpret_cast<const char*>(asset->bytes), asset->size);
      *content_type = ContentType(file);
      return true;
    }
  }
  return false;
}

}  // namespace gearloop
