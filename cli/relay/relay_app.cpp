#include "relay_app.hpp"

#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>

#include <fastdds/rtps/writer/WriterDiscoveryInfo.h>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/raw_topic.hpp"

namespace netkf::cli {

namespace fdds = eprosima::fastdds::dds;
namespace wire = netkf::wire;

class RelayApp::Impl : private fdds::DomainParticipantListener {
 public:
  explicit Impl(RelayOptions options)
      : options_(std::move(options)), links_(options_.topics, options_.seed), flush_timer_(io_) {
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
    }
    dds::ParticipantOptions to;
    to.domain = options_.to_domain;
    to.name = "netkf-relay-out";
    to.profile_file = options_.profile;
    destination_ = std::make_unique<dds::Participant>(to);
    destination_prefix_ = destination_->get()->guid().guidPrefix;
    // Link changes (`netkf ctl set-link TOPIC ... --domain TO`) on the readers' domain.
    reply_.emplace(*destination_, dds::topics::link_control_reply);
    control_.emplace(*destination_, dds::topics::link_control,
                     dds::post_to<wire::LinkControl>(io_.get_executor(), [this](wire::LinkControl c) { on_control(c); }));
    dds::ParticipantOptions from;
    from.domain = options_.from_domain;
    from.name = "netkf-relay-in";
    from.profile_file = options_.profile;
    from.discovery_listener = this;  // from its creation on: no writer is discovered unseen
    source_ = std::make_unique<dds::Participant>(from);
  }

  ~Impl() override {
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
    relayed_.clear();
    reply_.reset();
    destination_.reset();
  }

  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  void run() {
    work_.emplace(io_.get_executor());
    schedule_flush();
    io_.run();
  }

  void stop() {
    boost::asio::post(io_, [this] {
      flush_timer_.cancel();
      work_.reset();
      io_.stop();
    });
  }

  std::vector<RelayTopicCounts> counts() const {
    const std::lock_guard lock(mutex_);
    std::vector<RelayTopicCounts> out;
    for (const auto& [name, c] : counts_) out.push_back(c);
    return out;
  }

 private:
  // One topic being relayed: the writer on the destination domain, the reader on the source.
  struct Relayed {
    dds::DiscoveredWriter writer;
    std::unique_ptr<dds::RawWriter> out;
    std::unique_ptr<dds::RawReader> in;
  };

  // Fast DDS's discovery thread: only the topics asked for; the endpoints are made on the
  // relay's thread (creating them inside a discovery callback would wait on discovery itself).
  void on_publisher_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    dds::DiscoveredWriter writer = dds::discovered_writer(info);
    if (!counts_.contains(writer.topic)) return;  // counts_' keys never change after construction
    if (writer.participant == destination_prefix_) return;  // its own (see on_sample)
    if (const auto& wanted = wanted_types_.at(writer.topic); wanted && *wanted != writer.type) {
      spdlog::warn("a writer of {} with type {} is not relayed (the relay file asks for {})", writer.topic, writer.type,
                   *wanted);
      return;
    }
    boost::asio::post(io_, [this, writer = std::move(writer)] { start_relaying(writer); });
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
    RelayFate fate;
    {
      const std::lock_guard lock(mutex_);
      fate = *links_.on_sample(r.writer.topic);
      auto& c = counts_[r.writer.topic];
      ++c.samples;
      ++(fate.delivered ? c.delivered : c.dropped);
      if (record_)
        std::fprintf(record_.get(), "%s,%llu,%lld,%zu,%s,%.6g\n", r.writer.topic.c_str(),
                     static_cast<unsigned long long>(fate.index), static_cast<long long>(sample.sequence),
                     sample.payload.size(), fate.delivered ? "delivered" : "dropped", fate.delay_ms);
    }
    if (!fate.delivered) return;
    if (fate.delay_ms <= 0.0) {
      send(r, sample);
      return;
    }
    auto timer = std::make_shared<boost::asio::steady_timer>(
        io_, std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                 std::chrono::duration<double, std::milli>(fate.delay_ms)));
    auto held = std::make_shared<dds::RawSample>(std::move(sample));
    timer->async_wait([this, &r, timer, held](const boost::system::error_code& ec) {
      if (!ec) send(r, *held);
    });
  }

  // Relay thread: a change of one of its topics' links, from its next sample on. A request for a
  // topic it does not relay is another relay's: no answer.
  void on_control(const wire::LinkControl& c) {
    if (c.sensor_id() != kRelayTopicLinkId) return;
    LinkKeys keys = dds::link_keys_of(c);
    if (keys.empty() || keys.front().name != kRelayTopicKey || !std::holds_alternative<std::string>(keys.front().value))
      return;  // not the relay's form (docs/relay.md)
    const std::string topic = std::get<std::string>(keys.front().value);
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
      const LinkSpec next = apply_link_keys(*current, keys);
      const std::lock_guard lock(mutex_);
      links_.set_link(topic, next);
    } catch (const std::exception& e) {
      reason = e.what();
    }
    if (reason.empty())
      spdlog::info("request {}: {} now has a {} link (from its next sample on)", c.request_id(), topic,
                   link_kind(*links_link(topic)));
    else
      spdlog::warn("request {}: {} link change rejected: {}", c.request_id(), topic, reason);
    reply_->write(dds::make_link_control_reply(c.request_id(), kRelayTopicLinkId, reason.empty(), reason));
  }

  std::optional<LinkSpec> links_link(const std::string& topic) const {
    const std::lock_guard lock(mutex_);
    return links_.link(topic);
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
      {
        const std::lock_guard lock(mutex_);
        if (record_) std::fflush(record_.get());
      }
      schedule_flush();
    });
  }

  RelayOptions options_;
  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  mutable std::mutex mutex_;  // links_, counts_, relayed_, the record file
  RelayLinks links_;
  std::map<std::string, RelayTopicCounts> counts_;
  std::map<std::string, std::optional<std::string>> wanted_types_;  // per topic; never changed after construction
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> record_{nullptr, &std::fclose};
  boost::asio::steady_timer flush_timer_;
  std::unique_ptr<dds::Participant> destination_;
  eprosima::fastrtps::rtps::GuidPrefix_t destination_prefix_;
  std::optional<dds::Writer<wire::LinkControlReply>> reply_;
  std::optional<dds::Reader<wire::LinkControl>> control_;
  std::atomic<std::uint64_t> own_samples_{0};  // its own samples that came back, not relayed
  std::map<std::string, std::unique_ptr<Relayed>> relayed_;
  std::unique_ptr<dds::Participant> source_;  // last made, first gone: its discovery uses all of the above
};

RelayApp::RelayApp(RelayOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}
RelayApp::~RelayApp() = default;
void RelayApp::run() { impl_->run(); }
void RelayApp::stop() { impl_->stop(); }
std::vector<RelayTopicCounts> RelayApp::counts() const { return impl_->counts(); }

}  // namespace netkf::cli
