// clients/cli/report.cc: the report page of the dashboard (/static/report.html)
// with its stylesheet and scripts inlined and the job data put in front of
// them, so report.js draws from window.GEARLOOP_REPORT instead of fetching from
// a server.
#include "clients/cli/report.h"

#include "clients/web/web_assets.h"

namespace gearloop {
namespace {

bool Asset(const std::string& path, std::string* body, std::string* error) {
  std::string content_type;
  if (FindWebAsset(path, body, &content_type)) return true;
  *error = "the client was built without the web asset " + path;
  return false;
}

bool ReplaceOnce(const std::string& from,
                 const std::string& to,
                 std::string* text,
                 std::string* error) {
  const size_t at = text->find(from);
  if (at == std::string::npos) {
    *error = "the embedded report page lacks " + from;
    return false;
  }
  text->replace(at, from.size(), to);
  return true;
}

// Text placed inside <script> must not close it: "</" becomes "<\/", the same
// string to JSON and to JavaScript string literals.
std::string ScriptSafe(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '<' && i + 1 < text.size() && text[i + 1] == '/') {
      out += "<\\/";
      ++i;
    } else {
      out += text[i];
    }
  }
  return out;
}

}  // namespace

bool RenderJobReport(const nlohmann::json& job,
                     const nlohmann::json& lineage,
                     std::string* html,
                     std::string* error) {
  std::string page;
  std::string style;
  std::string plots;
  std::string report;
  if (!Asset("/static/report.html", &page, error) ||
      !Asset("/static/style.css", &style, error) ||
      !Asset("/static/plots.js", &plots, error) ||
      !Asset("/static/report.js", &report, error)) {
    return false;
  }
  const nlohmann::json data = {{"job", job}, {"lineage", lineage}};
  // dump() with error_handler replace: a stored string with broken UTF-8 must
  // not stop a report.
  const std::string data_text =
      data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (!ReplaceOnce("<link rel=\"stylesheet\" href=\"/static/style.css\">",
                   "<style>\n" + style + "</style>",
                   &page,
                   error) ||
      !ReplaceOnce("<script src=\"/static/plots.js\"></script>",
                   "<script>window.GEARLOOP_REPORT = " + ScriptSafe(data_text) +
                       ";</script>\n<script>\n" + ScriptSafe(plots) +
                       "</script>",
                   &page,
                   error) ||
      !ReplaceOnce("<script src=\"/static/report.js\"></script>",
                   "<script>\n" + ScriptSafe(report) + "</script>",
                   &page,
                   error)) {
    return false;
  }
  *html = std::move(page);
  return true;
}

}  // namespace gearloop
