#pragma once
// The dashboard page's files, embedded in the binary at build time (cmake/EmbedAssets.cmake
// writes dashboard_assets.cpp from dashboard/web/ and uPlot's dist files in node_modules),
// so the page works offline and from any install location.
#include <string_view>

#include "netkf/cli/dashboard/request_policy.hpp"  // Asset

namespace netkf::cli::dashboard {

/// nullptr when no asset has that path.
const Asset* find_asset(std::string_view path);

}  // namespace netkf::cli::dashboard
