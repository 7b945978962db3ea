#include "netkf/cli/relay/relay_app.hpp"

#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string_view>

#include <fastdds/rtps/participant/ParticipantDiscoveryInfo.h>
#include <fastdds/rtps/writer/WriterDiscoveryInfo.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/dashboard/dashboard_server.hpp"
#include "netkf/cli/live/channel_catalogue.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/cli/live/live_metrics.hpp"
#include "netkf/dds/dds.hpp"
#include "netkf/dds/raw_topic.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/relay/relay_config.hpp"  // relay_events_to_yaml
#include "netkf/support/release_queue.hpp"

namespace netkf::cli {

namespace fdds = eprosima::fastdds::dds;
namespace wire = netkf::wire;

class RelayApp::Impl : private fdds::DomainParticipantListener {
 public:
  explicit Impl(RelayOptions options)
      : options_(std::move(options)),
        links_(options_.topics, options_.seed, options_.timeline),
        release_timer_(io_),
        flush_timer_(io_) {
    if (options_.from_domain == options_.to_domain)
      throw std::invalid_argument("the relay's two domains must differ (it would relay its own samples again)");
    for (const auto& t : options_.topics) {
      counts_[t.name].topic = t.name;
      wanted_types_[t.name] = t.type;
    }
    if (options_.record) {
      // "x": created here or refused, never an existing file truncated.
      record_.reset(std::fopen(options_.record->c_str(), "wx"));
      if (!record_)
        throw std::runtime_error("cannot create " + options_.record->string() + ": " + std::strerror(errno) +
                                 (errno == EEXIST ? " (give another name)" : ""));
      std::fputs("topic,index,sequence,bytes,fate,delay_ms\n", record_.get());
      journal_file_ = relay_journal_file(*options_.record);
      // An empty journal too: a replay of a session without changes is valid.
      if (!write_journal()) throw std::runtime_error(journal_error_);
    }
    dds::ParticipantOptions to;
    to.domain = options_.to_domain;
    to.name = "netkf-relay-out";
    to.profile_file = options_.profile;
    to.naming = options_.naming;
    destination_ = std::make_unique<dds::Participant>(to);
    destination_prefix_ = destination_->get()->guid().guidPrefix;
    // Link changes (`netkf ctl set-link TOPIC ... --domain TO`) on the readers' domain.
    reply_.emplace(*destination_, dds::topics::link_control_reply);
    // Each topic's link as a channel's links report themselves (`netkf ctl status --domain TO`),
    // and its journal of changes.
    status_.emplace(*destination_, dds::topics::link_status);
    journal_.emplace(*destination_, dds::topics::link_change);
    control_.emplace(*destination_, dds::topics::link_control,
                     dds::post_to<wire::LinkControl>(io_.get_executor(), [this](wire::LinkControl c) { on_control(c); }));
    dds::ParticipantOptions from;
    from.domain = options_.from_domain;
    from.name = "netkf-relay-in";
    from.profile_file = options_.profile;
    from.discovery_listener = this;  // from its creation on: no writer is discovered unseen
    source_ = std::make_unique<dds::Participant>(from);
    if (options_.metrics_port) serve_metrics(*options_.metrics_port);
  }

  std::optional<unsigned short> metrics_port() const {
    return metrics_server_ ? std::optional<unsigned short>(metrics_server_->port()) : std::nullopt;
  }

  ~Impl() override {
    if (metrics_server_) metrics_server_->stop();
    // The readers first: no sample callback may run into what follows. Taken out under the lock,
    // deleted outside it (deleting a reader waits for its callback, which may wait for the lock).
    control_.reset();
    std::vector<std::unique_ptr<dds::RawReader>> readers;
    {
      const std::lock_guard lock(mutex_);
      for (auto& [name, r] : relayed_) readers.push_back(std::move(r->in));
    }
    readers.clear();
    if (const auto own = own_samples_.load(); own > 0)
      spdlog::info("{} of the relay's own samples came back on domain {} and were not relayed again", own,
                   options_.from_domain);
    source_.reset();
    write_record();  // the lines of the last samples
    publish_changes();  // the timeline's changes at the last samples
    publish_status();  // the final counts, for a reader still there
    relayed_.clear();
    journal_.reset();
    status_.reset();
    reply_.reset();
    destination_.reset();
  }

  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  void run() {
    work_.emplace(io_.get_executor());
    publish_status();  // every topic's link from the start, before its first writer is found
    schedule_flush();
    io_.run();
  }

  void stop() {
    boost::asio::post(io_, [this] {
      flush_timer_.cancel();
      release_timer_.cancel();
      work_.reset();
      io_.stop();
    });
  }

  std::vector<RelayTopicCounts> counts() const {
    const std::lock_guard lock(mutex_);
    std::vector<RelayTopicCounts> out;
    for (const auto& [name, c] : counts_) {
      out.push_back(c);
      if (const auto statistics = links_.statistics(name)) {
        out.back().lifetime = statistics->lifetime;
        out.back().since_change = statistics->since_change;
      }
    }
    return out;
  }

 private:
  // One topic being relayed: the writer on the destination domain, the reader on the source.
  struct Relayed {
    int index = 0;  // its link's id in the release queue
    bool per_writer = false;  // each writer its own link (RelayTopic::per_writer)
    dds::DiscoveredWriter writer;
    std::unique_ptr<dds::RawWriter> out;
    std::unique_ptr<dds::RawReader> in;
    std::atomic<bool> warned_no_key{false};
  };

  // Fast DDS's discovery thread: only the topics asked for; the endpoints are made on the
  // relay's thread (creating them inside a discovery callback would wait on discovery itself).
  void on_publisher_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    if (info.status == eprosima::fastrtps::rtps::WriterDiscoveryInfo::REMOVED_WRITER)
      forget_writers([&](const auto& guid) { return guid == info.info.guid(); });
    if (info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    dds::DiscoveredWriter writer = dds::discovered_writer(info);
    if (!wanted_types_.contains(writer.topic)) return;  // wanted_types_' keys never change after construction
    if (writer.participant == destination_prefix_) return;  // its own (see on_sample)
    if (const auto& wanted = wanted_types_.at(writer.topic); wanted && *wanted != writer.type) {
      spdlog::warn("a writer of {} with type {} is not relayed (the relay file asks for {})", writer.topic, writer.type,
                   *wanted);
      return;
    }
    // A per-writer topic: the writer's link from now on (in the status before its first sample).
    {
      const std::lock_guard lock(mutex_);
      writer_link_locked(writer.topic, info.info.guid(), writer.type);
    }
    boost::asio::post(io_, [this, writer = std::move(writer)] {
      start_relaying(writer);
      publish_changes();  // a writer's link made after a live change of its topic is journaled
    });
  }

  // Discovery thread: the participants' names as discovery announces them (a writer's link is
  // named after its participant's).
  void on_participant_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info)
      override {
    using Info = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
    const auto prefix = info.info.m_guid.guidPrefix;
    const bool gone = info.status == Info::REMOVED_PARTICIPANT || info.status == Info::DROPPED_PARTICIPANT;
    {
      const std::lock_guard lock(mutex_);
      if (gone)
        participant_names_.erase(prefix);
      else
        participant_names_[prefix] = info.info.m_participantName.to_string();
    }
    // A participant that leaves (or whose lease expires) takes its writers with it.
    if (gone) forget_writers([&](const auto& guid) { return guid.guidPrefix == prefix; });
  }

  // Discovery thread: writers that are gone free their links' names (the links stay), so the next
  // writer of such a name (a robot that restarted) continues its link.
  template <class Gone>
  void forget_writers(Gone gone) {
    std::vector<std::string> names;
    {
      const std::lock_guard lock(mutex_);
      for (auto it = writer_links_.begin(); it != writer_links_.end();)
        if (gone(it->first)) {
          names.push_back(it->second);
          it = writer_links_.erase(it);
        } else {
          ++it;
        }
    }
    for (const auto& name : names)
      spdlog::info("the writer of {} is gone (the next writer of its name continues the link)", name);
  }

  // mutex_ held (discovery or receive thread: in memory only). The name of the link a sample of
  // `topic` from `writer` goes through: the topic's own, or on a per-writer topic the writer's,
  // added on its first call: topic@NAME, NAME its participant's name as discovery announced it
  // (else its GUID prefix in hex), NAME#2, NAME#3, ... when live writers of the topic have it.
  std::string writer_link_locked(const std::string& topic, const eprosima::fastrtps::rtps::GUID_t& writer,
                                 const std::string& type) {
    if (!links_.per_writer(topic)) return topic;
    if (const auto it = writer_links_.find(writer); it != writer_links_.end()) return it->second;
    const auto participant = participant_names_.find(writer.guidPrefix);
    const std::string base = link_word(participant == participant_names_.end() || participant->second.empty()
                                           ? hex(writer.guidPrefix)
                                           : participant->second);
    const auto own = links_.writer_links(topic);
    for (int n = 1;; ++n) {
      const std::string candidate = n == 1 ? base : base + "#" + std::to_string(n);
      const std::string name = relay_writer_link_name(topic, candidate);
      const bool live =
          std::any_of(writer_links_.begin(), writer_links_.end(), [&](const auto& w) { return w.second == name; });
      const bool a_topic = links_.link(name) && std::find(own.begin(), own.end(), name) == own.end();
      if (live || a_topic) continue;
      links_.add_writer_link(topic, candidate);
      writer_links_.emplace(writer, name);
      if (link_index_.emplace(name, next_link_index_).second) ++next_link_index_;
      auto& c = counts_[name];
      c.topic = name;
      c.type = type;
      spdlog::info("{}: the writer of participant {} has its own link {}", topic, hex(writer.guidPrefix), name);
      return name;
    }
  }

  static std::string hex(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix) {
    std::string out;
    for (const auto octet : prefix.value) out += fmt::format("{:02x}", octet);
    return out;
  }

  // A participant's name as a word of a link's name (the recording's CSV, a shell's argument):
  // letters, digits and _-./: kept, anything else `_`.
  static std::string link_word(std::string name) {
    for (char& ch : name)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && std::string_view("_-./:").find(ch) == std::string_view::npos)
        ch = '_';
    return name;
  }

  // Relay thread.
  void start_relaying(const dds::DiscoveredWriter& writer) {
    {
      const std::lock_guard lock(mutex_);
      if (const auto it = relayed_.find(writer.topic); it != relayed_.end()) {
        const auto& first = it->second->writer;
        if (first.type != writer.type || first.reliable != writer.reliable ||
            first.transient_local != writer.transient_local)
          spdlog::warn("another writer of {} offers type {} ({}, {}): the relay keeps what it matched first, {} ({}, "
                       "{})",
                       writer.topic, writer.type, writer.reliable ? "reliable" : "best effort",
                       writer.transient_local ? "transient local" : "volatile", first.type,
                       first.reliable ? "reliable" : "best effort",
                       first.transient_local ? "transient local" : "volatile");
        return;
      }
    }
    auto relayed = std::make_unique<Relayed>();
    relayed->writer = writer;
    {
      const std::lock_guard lock(mutex_);
      relayed->index = next_link_index_++;
      relayed->per_writer = links_.per_writer(writer.topic);
    }
    try {
      relayed->out = std::make_unique<dds::RawWriter>(*destination_, writer, options_.depth);
      Relayed* r = relayed.get();
      relayed->in = std::make_unique<dds::RawReader>(*source_, writer, options_.depth,
                                                     [this, r](dds::RawSample&& s) { on_sample(*r, std::move(s)); });
    } catch (const std::exception& e) {
      spdlog::error("{} is not relayed: {}", writer.topic, e.what());
      return;
    }
    spdlog::info("relaying {} (type {}, {}, {}) from domain {} to domain {}", writer.topic, writer.type,
                 writer.reliable ? "reliable" : "best effort", writer.transient_local ? "transient local" : "volatile",
                 options_.from_domain, options_.to_domain);
    // Discovery announces reliability and durability, not history: the relay's own (--depth).
    spdlog::info("{}: history keep-last {}{} (--depth; a writer's history is not announced in discovery)",
                 writer.topic, options_.depth, writer.keyed ? " per instance" : "");
    for (const auto& what : writer.not_mirrored)
      spdlog::warn("{}: the relay does not mirror {}", writer.topic, what);
    const std::lock_guard lock(mutex_);
    counts_[writer.topic].type = writer.type;
    relayed_.emplace(writer.topic, std::move(relayed));
  }

  // DDS receive thread: the link decides under the lock; the write happens outside it (now, or
  // on the relay's thread when the link delays the sample).
  void on_sample(Relayed& r, dds::RawSample&& sample) {
    // Its own samples coming back: Fast DDS 2.9's built-in localhost profile lets a participant of
    // domain d discover those of domain d + 1 (the initial peers' port range of one domain
    // reaches the next one's first ports; docs/relay.md), and the relay would loop.
    if (sample.writer_participant == destination_prefix_) {
      own_samples_.fetch_add(1);
      return;
    }
    // A keyed sample without its key hash (a writer that sends none, e.g. Cyclone DDS by default):
    // the relay cannot compute the key from a payload it does not understand.
    if (r.writer.keyed && !sample.key.isDefined() && !r.warned_no_key.exchange(true))
      spdlog::warn("a writer of keyed topic {} sends no key hash: its instances are relayed as one (docs/relay.md)",
                   r.writer.topic);
    RelayFate fate;
    bool rearm = false;  // a new earliest held sample: the release timer must move
    bool changed = false;  // the timeline changed the link at this sample: journaled on the relay's thread
    {
      const std::lock_guard lock(mutex_);
      // The topic's link, or on a per-writer topic the writer's (made here if discovery has not).
      const std::string link = r.per_writer ? writer_link_locked(r.writer.topic, sample.writer, r.writer.type)
                                            : r.writer.topic;
      fate = *links_.on_sample(link);
      changed = links_.has_changes();
      for (auto* c : {&counts_[r.writer.topic], link == r.writer.topic ? nullptr : &counts_[link]}) {
        if (!c) continue;  // a per-writer topic's own line counts all its writers' samples
        ++c->samples;
        ++(fate.delivered ? c->delivered : c->dropped);
      }
      // Into memory here; the relay's thread writes the file (no disk I/O on a DDS thread).
      if (record_)
        fmt::format_to(std::back_inserter(unwritten_), "{},{},{},{},{},{:.6g}\n", link, fate.index,
                       sample.sequence, sample.payload.size(), fate.delivered ? "delivered" : "dropped", fate.delay_ms);
      if (fate.delivered && fate.delay_ms > 0.0) {
        const auto release = std::chrono::steady_clock::now() +
                             std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                 std::chrono::duration<double, std::milli>(fate.delay_ms));
        rearm = held_.hold(release, r.per_writer ? link_index_.at(link) : r.index, Held{&r, std::move(sample)});
      }
    }
    if (rearm) boost::asio::post(io_, [this] { release_due(); });
    if (changed) boost::asio::post(io_, [this] { publish_changes(); });
    if (fate.delivered && fate.delay_ms <= 0.0) send(r, sample);
  }

  // Relay thread: write what is due, then sleep until the next release; re-armed (posted) from
  // the receive thread when a new earliest sample is held.
  void release_due() {
    std::vector<Held> due;
    std::optional<std::chrono::steady_clock::time_point> next;
    {
      const std::lock_guard lock(mutex_);
      due = held_.take_due(std::chrono::steady_clock::now());
      next = held_.next_release();
    }
    for (auto& h : due) send(*h.relayed, h.sample);
    if (next) {
      release_timer_.expires_at(*next);
      release_timer_.async_wait([this](const boost::system::error_code& ec) {
        if (!ec) release_due();
      });
    }
  }

  // Relay thread: a change of one of its topics' links, from its next sample on. A request for a
  // topic it does not relay is another relay's: no answer.
  void on_control(const wire::LinkControl& c) {
    if (!is_relay_topic_link_id(c.sensor_id())) return;
    LinkKeys keys = dds::link_keys_of(c);
    if (keys.empty() || keys.front().name != kRelayTopicKey || !std::holds_alternative<std::string>(keys.front().value))
      return;  // not the relay's form (docs/relay.md)
    const std::string topic = std::get<std::string>(keys.front().value);
    if (c.sensor_id() != relay_topic_link_id(topic)) return;  // the id is the topic's, or the request is not ours
    keys.erase(keys.begin());
    std::optional<LinkSpec> current;
    {
      const std::lock_guard lock(mutex_);
      current = links_.link(topic);
    }
    if (!current) {
      spdlog::debug("request {}: {} is not relayed here", c.request_id(), topic);
      return;
    }
    std::string reason;
    try {
      // Outside the lock: a trace named here is read now, never on the sample path.
      apply_change(topic, apply_link_keys(*current, keys), c.request_id());
    } catch (const std::exception& e) {
      reason = e.what();
      {
        const std::lock_guard lock(mutex_);
        links_.note_request(topic, c.request_id(), reason);
      }
      spdlog::warn("request {}: {} link change rejected: {}", c.request_id(), topic, reason);
    }
    reply_->write(dds::to_wire(LinkReply{c.request_id(), c.sensor_id(), reason.empty(), reason}));
    publish_status();  // acknowledges the request
  }

  // Relay thread: a valid link for a topic, from its next sample on, and its journal entry (the
  // sample it applies from: the link decides under the lock, so no sample of the topic falls
  // between the change and this index). request_id 0: a change from the WebSocket.
  // A per-writer topic's change is each of its writers' links' (an entry each) and the model of
  // the writers to come.
  void apply_change(const std::string& topic, const LinkSpec& next, std::uint64_t request_id) {
    bool per_writer = false;
    {
      const std::lock_guard lock(mutex_);
      links_.set_link(topic, next, request_id);  // throws on an invalid model (nothing changes)
      links_.note_request(topic, request_id, "");
      per_writer = links_.per_writer(topic);
    }
    if (per_writer)
      spdlog::info("request {}: {} has a {} link for each of its writers to come", request_id, topic, link_kind(next));
    publish_changes();  // each changed link's journal entry, with the sample it applies from
  }

  // Relay thread (and the end): the links' changes since, each on DDS (netkf/link/change) and,
  // with --record, in the journal file as the event a replay makes at the same sample.
  void publish_changes() {
    std::vector<RelayLinkChange> changes;
    {
      const std::lock_guard lock(mutex_);
      changes = links_.take_changes();
    }
    bool journaled = false;
    for (const auto& c : changes) {
      if (!c.failure.empty()) {
        spdlog::warn("timeline: {} event at its sample {} not applied: {}", c.topic, c.at_period, c.failure);
        continue;
      }
      if (c.origin == LinkChange::Origin::timeline)
        spdlog::info("timeline: {} from its sample {}: {}", c.topic, c.at_period, describe_link(c.link));
      else
        spdlog::info("request {}: {} now has a {} link (from its sample {} on)", c.request_id, c.topic,
                     link_kind(c.link), c.at_period);
      journal_->write(dds::to_wire(c, dds::steady_now_ns()));
      if (c.replay && journal_file_) {
        journal_events_.push_back(*c.replay);
        journaled = true;
      }
    }
    if (journaled && !write_journal() && !journal_warned_) {
      journal_warned_ = true;
      spdlog::error("{}", journal_error_);
    }
  }

  // The journal file whole (it is small: one entry per change), renamed in place, so it is
  // complete whenever the relay stops.
  bool write_journal() {
    try {
      write_output_file({"--record's journal", journal_file_->string()},
                        "# Link changes of a netkf relay, with the topic's sample each applied from.\n"
                        "# Replay: netkf relay RELAY_FILE --events THIS_FILE (same relay file and seed, same samples).\n" +
                            relay_events_to_yaml(journal_events_),
                        /*sync=*/false);
    } catch (const std::exception& e) {
      journal_error_ = e.what();
      return false;
    }
    return true;
  }

  // Relay thread: a WebSocket client's setParameters (link.ID.KEY, ID a topic's link id), checked
  // as the launch's dashboard checks them; the answer is the link's parameters after it.
  void on_set_parameters(DashboardServer::ClientId client, const dashboard::SetParameters& request) {
    const auto views = link_views(statuses());
    for (const auto& change : dashboard::link_changes(request, views)) {
      const auto view = std::find_if(views.begin(), views.end(), [&](const LinkView& v) { return v.sensor_id == change.sensor_id; });
      if (change.keys && view != views.end()) {
        try {
          apply_change(view->topic, change.link, 0);
        } catch (const std::exception& e) {
          metrics_server_->send_to(client, dashboard::status_message(LiveEvent::Level::error, e.what()));
        }
      } else {
        metrics_server_->send_to(client, dashboard::status_message(LiveEvent::Level::error, change.refusal));
      }
    }
    publish_status();
    for (const auto& v : link_views(statuses()))
      if (request.id) metrics_server_->send_to(client, dashboard::link_parameter_values(v, request.id));
  }

  // GET /metrics, the Foxglove WebSocket (netkf/link/status) and the relay's page (a card per
  // relayed topic: dashboard/web/relay.html) on 127.0.0.1, served on the relay's thread; the
  // topics' links as a launch's links are (netkf_link_*{link="TOPIC"}).
  void serve_metrics(unsigned short port) {
    DashboardOptions o;
    o.page = DashboardPage::relay;
    o.port = port;
    o.max_connections = 16;
    DashboardServer::Hooks hooks;
    hooks.metrics = [this] { return metrics_text(); };
    hooks.set_parameters = [this](DashboardServer::ClientId c, const dashboard::SetParameters& r) {
      on_set_parameters(c, r);
    };
    hooks.get_parameters = [this](const dashboard::GetParameters& r) {
      return dashboard::parameter_values(link_views(statuses()), r.names, r.id);
    };
    hooks.refused = [](const std::string& what) { spdlog::debug("metrics: {}", what); };
    const nlohmann::json info{{"op", "serverInfo"}, {"name", "netkf relay"}, {"capabilities", {"parameters"}}};
    metrics_server_ = std::make_unique<DashboardServer>(io_, o, info, std::move(hooks));
    spdlog::info("the relayed topics' links: page http://127.0.0.1:{}/, http://127.0.0.1:{}/metrics, Foxglove "
                 "ws://127.0.0.1:{}/",
                 metrics_server_->port(), metrics_server_->port(), metrics_server_->port());
  }

  std::string metrics_text() {
    LiveSnapshot snapshot;
    snapshot.links = link_views(statuses());
    metrics_.update(snapshot);
    return metrics_.serialize();
  }

  // The links as the launch's live views hold them.
  static std::vector<LinkView> link_views(const std::vector<LinkStatus>& statuses) {
    std::vector<LinkView> views;
    for (const auto& status : statuses) {
      LinkView view;
      static_cast<LinkStatus&>(view) = status;
      view.observed_rate_since_change = observed_rate_since_change(view);
      views.push_back(std::move(view));
    }
    return views;
  }

  static std::uint64_t wall_ns() {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::system_clock::now().time_since_epoch())
                                          .count());
  }

  // Relay thread (and the end): every topic's link as a LinkStatus, keyed by its topic's id.
  // There is no estimator's deadline here: P(in time) is 1 and nothing is past a deadline.
  void publish_status() {
    const auto all = statuses();
    const auto now = dds::steady_now_ns();
    for (const auto& status : all) status_->write(dds::to_wire(status, now));
    // The same on the Foxglove WebSocket (--dashboard), latched per link, with the topic's type
    // as discovered (the page shows it; the DDS status has no field for it).
    if (metrics_server_)
      for (const auto& v : link_views(all)) {
        auto message = catalogue::link_status_message(v);
        if (auto type = discovered_type(v.topic); !type.empty()) message["type"] = std::move(type);
        metrics_server_->publish(catalogue::ChannelId::link_status, message, wall_ns(), v.sensor_id);
      }
  }

  // The type name of the topic's first discovered writer ("" while none was seen).
  std::string discovered_type(const std::string& topic) const {
    const std::lock_guard lock(mutex_);
    const auto c = counts_.find(topic);
    return c == counts_.end() ? std::string() : c->second.type;
  }

  std::vector<LinkStatus> statuses() const {
    std::vector<LinkStatus> out;
    const std::lock_guard lock(mutex_);
    for (auto& r : links_.reports()) {
      const auto relayed = relayed_.find(r.topic);
      const auto writer = link_index_.find(r.topic);  // a writer's link
      r.held = writer != link_index_.end() ? held_.held(writer->second)
               : relayed == relayed_.end() ? 0
                                           : held_.held(relayed->second->index);
      out.push_back(std::move(r));
    }
    return out;
  }

  void send(Relayed& r, dds::RawSample& sample) {
    if (r.out->write(sample)) return;
    const std::lock_guard lock(mutex_);
    ++counts_[r.writer.topic].refused;
  }

  void schedule_flush() {
    flush_timer_.expires_after(std::chrono::seconds(1));
    flush_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      write_record();
      publish_status();
      schedule_flush();
    });
  }

  // Relay thread (and the end): the record lines gathered since, written outside the lock.
  void write_record() {
    if (!record_) return;
    std::string lines;
    {
      const std::lock_guard lock(mutex_);
      lines.swap(unwritten_);
    }
    std::fwrite(lines.data(), 1, lines.size(), record_.get());
    std::fflush(record_.get());
  }

  RelayOptions options_;
  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  mutable std::mutex mutex_;  // links_, counts_, relayed_, the record file
  RelayLinks links_;
  std::map<std::string, RelayTopicCounts> counts_;
  std::map<std::string, std::optional<std::string>> wanted_types_;  // per topic; never changed after construction
  // Per-writer topics (mutex_): each live writer's link, the participants' names, each writer's
  // link's id in the release queue (the topics' links take theirs from the same count).
  std::map<eprosima::fastrtps::rtps::GUID_t, std::string> writer_links_;
  std::map<eprosima::fastrtps::rtps::GuidPrefix_t, std::string> participant_names_;
  std::map<std::string, int> link_index_;
  int next_link_index_ = 0;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> record_{nullptr, &std::fclose};
  std::string unwritten_;  // record lines not yet written (mutex_)
  // The journal file (--record's) and what it holds; the relay's thread's.
  std::optional<std::filesystem::path> journal_file_;
  std::vector<RelayEvent> journal_events_;
  std::string journal_error_;
  bool journal_warned_ = false;
  // A delivered sample its link delays, until its release (mutex_).
  struct Held {
    Relayed* relayed = nullptr;
    dds::RawSample sample;
  };
  ReleaseQueue<Held> held_;
  boost::asio::steady_timer release_timer_;
  boost::asio::steady_timer flush_timer_;
  std::unique_ptr<dds::Participant> destination_;
  eprosima::fastrtps::rtps::GuidPrefix_t destination_prefix_;
  std::optional<dds::Writer<wire::LinkControlReply>> reply_;
  std::optional<dds::Reader<wire::LinkControl>> control_;
  std::optional<dds::Writer<wire::LinkStatus>> status_;
  std::optional<dds::Writer<wire::LinkChange>> journal_;
  LiveMetrics metrics_{LiveMetrics::Scope::links};
  std::unique_ptr<DashboardServer> metrics_server_;
  std::atomic<std::uint64_t> own_samples_{0};  // its own samples that came back, not relayed
  std::map<std::string, std::unique_ptr<Relayed>> relayed_;
  std::unique_ptr<dds::Participant> source_;  // last made, first gone: its discovery uses all of the above
};

RelayApp::RelayApp(RelayOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}
RelayApp::~RelayApp() = default;
void RelayApp::run() { impl_->run(); }
void RelayApp::stop() { impl_->stop(); }
std::optional<unsigned short> RelayApp::metrics_port() const { return impl_->metrics_port(); }
std::vector<RelayTopicCounts> RelayApp::counts() const { return impl_->counts(); }

}  // namespace netkf::cli
