#pragma once
// The terminal views of the live snapshot: the status of `netkf launch` (period, Tr P,
// error, per-link configured and observed arrival rates, theory) and the link table of
// `netkf ctl status`. Text only, no state: a function of the snapshot.
#include <string>
#include <vector>

#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/records/link_status.hpp"

namespace netkf::cli {

/// Table of links (used by `ctl status`).
std::string render_link_table(const std::vector<LinkStatus>& links);
/// One line: the model a link's recent samples show (LinkStatus::recent_fit).
std::string describe_recent_fit(const fit::RecentLossFit& fit);

/// Multi-line status text. `theory_pending`: an assessment is being computed.
std::string render_status(const LiveSnapshot& snapshot, bool theory_pending);

/// The launch status redrawn in place on a terminal (like top): clears the screen, draws
/// `header`, the status and the most recent `events` (newest last).
std::string render_status_screen(const std::string& header, const LiveSnapshot& snapshot, bool theory_pending,
                                 const std::vector<std::string>& events);

}  // namespace netkf::cli
