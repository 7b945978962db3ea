#pragma once
// What a sweep runs (`netkf sweep`, docs/experiments.md "Sweeps"): the varied scenario keys and
// their values, the grid (their product), the seeds of each point, and how a scenario file's
// YAML tree gets one point's values before the normal loader validates it.
#include <cstdint>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace netkf::cli::sweep {

/// One `--vary KEY=V1,V2,...` or `--vary KEY=FROM:TO:N`: the key and its values as text (the
/// YAML scalars written into the scenario).
struct Vary {
  std::string key;
  std::vector<std::string> values;
};

/// Parses one --vary argument. FROM:TO:N gives N ≥ 2 evenly spaced values from FROM to TO
/// (both included; N = 1 gives FROM), written with up to 12 significant digits. Throws
/// std::invalid_argument saying what is wrong (no '=', an empty key or value, a bad range).
Vary parse_vary(const std::string& text);

/// One grid point: its index (0-based, the last --vary varying fastest) and one value per
/// varied key, in --vary order.
struct Point {
  int index = 0;
  std::vector<std::string> values;
};

/// The most runs (points x seeds) one sweep takes; a larger grid is refused before anything is
/// expanded (docs/experiments.md, "Sweeps").
inline constexpr std::uint64_t kMaxRuns = 100000;

/// Refuses (std::invalid_argument, with the count: "A x B = P points x S seeds = R runs") a grid
/// of more than kMaxRuns runs. Computed from the list sizes, without expanding the grid.
void check_grid_size(const std::vector<Vary>& vary, int seeds);

/// The product of the --vary lists, the last one varying fastest. No --vary: one point with no
/// values (the scenario as it is, over the seeds). Throws std::invalid_argument when a key is
/// varied twice.
std::vector<Point> expand_grid(const std::vector<Vary>& vary);

/// The scenario seed of run `seed_index` (1..N): derive_seed(scenario seed, "sweep", index).
/// It depends on the seed index and the scenario's own seed only, not on the point, so the
/// points of one seed index share their random numbers (common random numbers: a difference
/// between two points is the key's effect, not another draw), and a rerun is identical.
std::uint64_t run_seed(std::uint64_t scenario_seed, int seed_index);

/// Sets KEY (dotted path) to the scalar `value` in the scenario's YAML tree. A segment after
/// `sensors` is a sensor id (`sensors.2` is the sensor with id 2, the link.2.* of the summary)
/// or `*` (every sensor); a segment into any other list is a 0-based index (`plant.A.0.1`); a
/// missing mapping key is created (the loader then says whether it belongs there). Throws
/// std::invalid_argument naming the key: an unknown sensor id, an index out of range, a path
/// through a scalar.
void apply_key(YAML::Node root, const std::string& key, const std::string& value);

/// `key=value, key=value` (the point as messages name it), or "the scenario" with no keys.
std::string point_label(const std::vector<Vary>& vary, const Point& point);

}  // namespace netkf::cli::sweep
