#pragma once
// The live commands' window on the DDS network: one participant, the readers a command
// needs, and the link-control writer. Samples are converted from the wire (validated by
// the DDS library's conversions) and handed to the command's handlers on its own
// io_context thread (netkf::dds::post_to), never on a DDS listener thread.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "netkf/dds/presence.hpp"
#include "netkf/dds/security.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_reply.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::wire {
class LinkStatus;
}  // namespace netkf::wire

namespace netkf::cli {

struct BusOptions {
  std::optional<int> domain;           // --domain (else $NETKF_DOMAIN, else 0)
  std::optional<std::string> profile;  // --dds-profile (else $NETKF_DDS_PROFILE, else localhost-only)
  std::string name = "netkf-cli";
  std::optional<std::string> secure;   // --secure DIR (else $NETKF_SECURE, else no DDS Security)
  dds::Role role = dds::Role::observer;  // the identity used with security
  std::uint64_t run = 0;               // the launch's run id (samples of another run dropped); 0: any
  std::optional<std::string> discovery_server;  // --discovery-server ADDR:PORT (else $NETKF_DISCOVERY_SERVER)
  std::optional<std::string> naming;   // --naming netkf|ros2 (else $NETKF_NAMING, else scenario_naming)
  TopicNaming scenario_naming = TopicNaming::netkf;  // the scenario's naming, for a command that has one
  /// Announce this process on netkf/presence (as a launch or a recorder, which read the truth:
  /// the plant waits for them) and watch everyone's presence (LiveBus::processes).
  struct Presence {
    std::string role;  // dds::presence_role::launch or ::record; empty: only watch the others
    std::uint64_t scenario_hash = 0;
    std::string detail;  // a launch: the roles it runs
  };
  std::optional<Presence> presence;
  /// Also receive the estimates a writer published before this reader matched it (the launch:
  /// a restarted estimator's first estimates; dds::topics::estimate). Off: from the next one on.
  bool estimate_history = false;
};

/// The DDS settings every live command shares (--domain, --dds-profile, --secure,
/// --discovery-server, --naming; each falls back to its NETKF_* variable, then the localhost default).
struct NetworkSettings {
  std::optional<int> domain;
  std::optional<std::string> profile;
  std::optional<std::string> secure;
  std::optional<std::string> discovery_server;
  std::optional<std::string> naming;
  BusOptions bus(const std::string& name, dds::Role role) const {
    BusOptions b;
    b.domain = domain;
    b.profile = profile;
    b.name = name;
    b.secure = secure;
    b.role = role;
    b.discovery_server = discovery_server;
    b.naming = naming;
    return b;
  }
};

struct BusHandlers {
  std::function<void(Truth&&)> truth;
  std::function<void(Estimate&&)> estimate;
  std::function<void(DeliveredMeasurement&&)> delivered;
  std::function<void(LinkStatus&&)> link_status;
  std::function<void(LinkChange&&)> link_change;
  std::function<void(LinkReply&&)> link_reply;
  /// Called with a message when a sample failed validation (counted, not used).
  std::function<void(const std::string&)> invalid;
};

class LiveBus {
 public:
  /// Throws netkf::dds::DdsError (bad profile, participant failure).
  LiveBus(boost::asio::io_context& io, const BusOptions& options, BusHandlers handlers, bool link_control_writer);
  ~LiveBus();
  LiveBus(const LiveBus&) = delete;
  LiveBus& operator=(const LiveBus&) = delete;

  int domain() const;
  /// Publish a link change (the keys to change); false when DDS refused it.
  bool send_link_control(std::uint64_t request_id, int sensor_id, const LinkKeys& keys);
  /// Readers of the link-control topic (the channel emulator) currently matched.
  int link_control_readers() const;
  /// Writers matched on the link-reply topic.
  int link_reply_writers() const;
  /// Writers matched on the network's data topics (truth, estimate, delivered, link status), by
  /// topic: before a launch starts its nodes, any is another network on the domain.
  std::vector<std::pair<std::string, int>> network_writers() const;
  /// Every process whose presence was seen (empty without BusOptions::presence).
  std::vector<dds::PresenceRecord> processes() const;
  /// Processes announcing their presence that this bus has discovered (0 without BusOptions::presence).
  int presence_announcers() const;
  /// Tell the others that this process has ended its part (a launch without the plant that
  /// stops, a recorder); no-op without BusOptions::presence.
  void end_presence(const std::string& why);
  /// Samples of another run dropped (BusOptions::run).
  std::uint64_t foreign_samples() const;
  std::uint64_t invalid_samples() const { return invalid_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint64_t invalid_ = 0;
};

}  // namespace netkf::cli
