#pragma once
// The estimator's checkpoint (docs/architecture.md, "estimator_node", Restart).
#include <string>

#include "netkf/records/estimate.hpp"

namespace netkf {

/// Where a restarted estimator continues: the checkpoint is the last estimate its previous
/// life published (k, t, x̂_{k|k}, P_{k|k} and the run's counters), so the estimates after
/// the restart stay the MMSE estimate given the samples fused (the periods it missed are
/// fused with nothing: open-loop predictions with the inputs the plant acknowledged).
/// The file is JSON (doubles written so that they read back bit-identical); read_checkpoint
/// throws std::runtime_error naming the file on any problem.
void write_checkpoint(const std::string& path, const Estimate& last_published);
Estimate read_checkpoint(const std::string& path);

}  // namespace netkf
