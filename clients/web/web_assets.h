// clients/web/web_assets.h: the dashboard's files (clients/web/*.html, *.js,
// *.css), embedded in the binary at build time (target gearloop_web_assets), so
// the server serves them without any file on disk and the CLI can inline them
// into a report.
//
//   std::string body, content_type;
//   if (FindWebAsset(req.path, &body, &content_type)) {
//     res.set_content(body, content_type.c_str());
//   }
//
// Paths served:
//   /                      the dashboard (index.html): job history and job
//   views /jobs/{id}/report      the printable report of one job (report.html,
//   drawn in the browser
//                          from /api/v1/corrections/{id})
//   /static/<file>         the files themselves (style.css, plots.js, app.js,
//   report.js, ...)
// Anything else (including every /api/ path) is not found.
#ifndef GEARLOOP_CLIENTS_WEB_WEB_ASSETS_H_
#define GEARLOOP_CLIENTS_WEB_WEB_ASSETS_H_

#include <string>

namespace gearloop {

// Fills `body` and `content_type` ("text/html; charset=utf-8", ...) for a
// request path (no query string) and returns true, or returns false when the
// path is not a dashboard page.
bool FindWebAsset(const std::string& path,
                  std::string* body,
                  std::string* content_type);

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_WEB_WEB_ASSETS_H_
