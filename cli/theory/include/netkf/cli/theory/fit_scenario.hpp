#pragma once
// `netkf fit --scenario S.yaml --link ID -o OUT.yaml`: a copy of the scenario with one
// sensor's link replaced by a fitted one.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace netkf::cli {

/// The scenario a fit copies, read and checked before the fit runs: it loads, and it has the
/// link `link_id`. Throws std::runtime_error saying what is wrong (the loader's
/// FILE:LINE:COL, an unknown link with the scenario's links).
class ScenarioCopy {
 public:
  ScenarioCopy(const std::filesystem::path& scenario, int link_id);

  /// The copy's text: sensor `link_id`'s `link:` replaced by `link` (a flat object of link
  /// keys, as fitted_link_json() gives), a comment `note` above it. Checked by loading it
  /// (as `name`, in the loader's messages); throws std::runtime_error when it does not load.
  /// Re-emitted by yaml-cpp: the original's comments and layout are not kept.
  std::string with_link(const nlohmann::json& link, const std::string& note, const std::string& name) const;

 private:
  std::string path_;
  std::string text_;
  int link_id_;
};

}  // namespace netkf::cli
