#pragma once
// The channel catalogue: every channel netkf publishes as JSON (the dashboard's live channels
// and a recording's extra ones), with its JSON schema and the one function that makes each
// message. The dashboard (Foxglove WebSocket) and MCAP recordings both speak it, so a
// recording shows in Foxglove as the live run does. docs/dashboard.md lists the channels.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli::catalogue {

/// The channels every connection is offered (ids are fixed: a reconnecting client may cache them).
enum class ChannelId : std::uint32_t { scenario = 1, estimate = 2, truth = 3, link_status = 4, theory = 5, network = 6,
  // Recordings only (netkf launch --record FILE.mcap), not offered by the dashboard:
  delivered = 7, link_change = 8, events = 9 };

struct Channel {
  ChannelId id;
  std::string topic;
  std::string schema_name;
  nlohmann::json schema;  // JSON schema of the messages
};
const std::vector<Channel>& channels();
const Channel* find_channel(std::uint32_t id);
/// Any channel by id: the dashboard's and the recordings' own (delivered, link_change).
/// The topic is the DDS topic the messages come from (netkf/truth, netkf/estimate, ...).
const Channel& channel(ChannelId id);

/// A link by its scenario keys (link.hpp); a Gilbert-Elliott link also in the user's form
/// (loss, mean_burst). Non-finite numbers are null (JSON has no NaN).
nlohmann::json link_json(const LinkSpec& link);

// ---- channel messages
nlohmann::json scenario_message(const Scenario& scenario);
nlohmann::json estimate_message(const Estimate& estimate);
nlohmann::json truth_message(const Truth& truth);
/// The one link-status JSON shape (docs/cli.md, "Link status keys"): a link as its channel
/// reported it, with the observed arrival rate since change; `netkf ctl status --json` prints
/// it. The dashboard's and the recording's message adds what needs the earlier reports or the
/// estimator side (late_total, late_fraction, the observed arrival rate over the window).
nlohmann::json link_status_json(const LinkStatus& link);
/// A link's recent-samples fit (`recent_fit` of the link status keys, docs/cli.md).
nlohmann::json recent_fit_json(const fit::RecentLossFit& fit);
nlohmann::json link_status_message(const LinkView& link);
/// Recordings: a delivered measurement, and one entry of the channel's link journal (the
/// link after the change, keys as in link_status_message).
nlohmann::json delivered_message(const DeliveredMeasurement& sample);
nlohmann::json link_change_message(const LinkChange& change);
/// Recordings: an event of the live model (the dashboard's event log) as Foxglove's
/// well-known foxglove.Log, so Foxglove's Log panel lists it; `time_ns` on the run's clock.
nlohmann::json log_message(const LiveEvent& event, std::uint64_t time_ns);
nlohmann::json theory_message(const TheoryView& theory);
nlohmann::json network_message(const LiveSnapshot& snapshot);

}  // namespace netkf::cli::catalogue
