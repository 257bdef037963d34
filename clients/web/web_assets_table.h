// clients/web/web_assets_table.h: the table the generated source fills
// (internal to gearloop_web_assets; users include web_assets.h).
#ifndef GEARLOOP_CLIENTS_WEB_WEB_ASSETS_TABLE_H_
#define GEARLOOP_CLIENTS_WEB_WEB_ASSETS_TABLE_H_

#include <cstddef>

namespace gearloop {

struct EmbeddedWebAsset {
  const char* path;            // "/static/index.html"
  const unsigned char* bytes;  // the file's bytes
  size_t size;                 // bytes in the file
};

// Ends with {nullptr, nullptr, 0}.
extern const EmbeddedWebAsset kEmbeddedWebAssets[];

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_WEB_WEB_ASSETS_TABLE_H_
