#pragma once
// `netkf fit --scenario S.yaml --link ID -o OUT.yaml`: a copy of the scenario with one
// sensor's link replaced by a fitted one.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace netkf::cli {

/// Writes `scenario` to `out` with sensor `link_id`'s `link:` replaced by `link` (a flat
/// object of link keys, as fitted_link_json() gives), a comment `note` above the file's
/// text. The copy is checked by loading it; on any error nothing is left at `out` and
/// std::runtime_error says why (unknown link id, `out` is the scenario itself, ...).
/// The copy is re-emitted by yaml-cpp: the original's comments and layout are not kept.
void write_scenario_with_link(const std::filesystem::path& scenario, int link_id, const nlohmann::json& link,
                              const std::string& note, const std::filesystem::path& out);

}  // namespace netkf::cli
