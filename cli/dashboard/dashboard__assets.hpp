#pragma once
// The dashboard page's files, embedded in the binary at build time (cmake/EmbedAssets.cmake
// writes dashboard_assets.cpp from dashboard/web/ and uPlot's dist files in node_modules),
// so the page works offline and from any install location.
#include <string_view>

namespace netkf::cli::dashboard {

struct Asset {
  std::string_view path;          // URL path, e.g. "/index.html"
  std::string_view content_type;
  std::string_view body;
};

/// nullptr when no asset has that path.
const Asset* find_asset(std::string_view path);

}  // namespace netkf::cli::dashboard
