#include "netkf/cli/live/live_bus.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "netkf/dds/dds.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli {

namespace {

// The readers' conversions: the wire types' own (dds/conversions.hpp), named per topic.
LinkStatus to_link_status(const wire::LinkStatus& w) { return dds::from_wire(w); }
LinkChange to_link_change(const wire::LinkChange& w) { return dds::from_wire(w); }
LinkReply to_link_reply(const wire::LinkControlReply& w) { return dds::from_wire(w); }
Truth to_truth(const wire::Truth& w) { return dds::from_wire(w); }
Estimate to_estimate(const wire::Estimate& w) { return dds::from_wire(w); }
DeliveredMeasurement to_delivered(const wire::Measurement& w) { return dds::delivered_of(w); }

/// One sample converted and handed on; one that fails its conversion is reported as invalid
/// (`what` + why) instead.
template <typename Wire, typename Record>
void convert_and_handle(const Wire& w, Record (*convert)(const Wire&), const std::function<void(Record&&)>& handler,
                        const std::function<void(const std::string&)>& invalid, const std::string& what) {
  std::optional<Record> record;
  try {
    record = convert(w);
  } catch (const std::exception& e) {
    return invalid(what + e.what());
  }
  handler(std::move(*record));
}

/// A reader of `topic` when the command handles it: each sample is converted on the command's
/// io thread (convert_and_handle).
template <typename Wire, typename Record>
std::unique_ptr<dds::Reader<Wire>> open_reader(dds::Participant& participant, const dds::Topic<Wire>& topic,
                                               boost::asio::io_context::executor_type ex,
                                               Record (*convert)(const Wire&),
                                               const std::function<void(Record&&)>& handler,
                                               const std::function<void(const std::string&)>& invalid,
                                               const std::string& what) {
  if (!handler) return nullptr;
  return std::make_unique<dds::Reader<Wire>>(participant, topic, dds::post_to<Wire>(ex, [=](Wire w) {
                                               convert_and_handle(w, convert, handler, invalid, what);
                                             }));
}

/// The delivered batches (sensor processes of several sensors): each sample is converted and
/// handled as if it had come alone on the delivered topic.
std::unique_ptr<dds::Reader<wire::MeasurementBatch>> open_batch_reader(
    dds::Participant& participant, boost::asio::io_context::executor_type ex,
    const std::function<void(DeliveredMeasurement&&)>& handler, const std::function<void(const std::string&)>& invalid) {
  if (!handler) return nullptr;
  return std::make_unique<dds::Reader<wire::MeasurementBatch>>(
      participant, dds::topics::delivered_measurement_batch,
      dds::post_to<wire::MeasurementBatch>(ex, [=](wire::MeasurementBatch batch) {
        for (const auto& m : batch.samples()) convert_and_handle(m, to_delivered, handler, invalid, "");
      }));
}

}  // namespace

struct LiveBus::Impl {
  dds::Participant participant;
  std::unique_ptr<dds::Reader<wire::Truth>> truth;
  std::unique_ptr<dds::Reader<wire::Estimate>> estimate;
  std::unique_ptr<dds::Reader<wire::Measurement>> delivered;
  std::unique_ptr<dds::Reader<wire::MeasurementBatch>> delivered_batch;
  std::unique_ptr<dds::Reader<wire::LinkStatus>> link_status;
  std::unique_ptr<dds::Reader<wire::LinkChange>> link_change;
  std::unique_ptr<dds::Reader<wire::LinkControlReply>> link_reply;
  std::unique_ptr<dds::Writer<wire::LinkControl>> link_control;
  std::unique_ptr<dds::PresenceWatcher> presence_watch;
  std::unique_ptr<dds::PresenceAnnouncer> presence;

  explicit Impl(const dds::ParticipantOptions& o) : participant(o) {}
  ~Impl() {
    // Endpoints hold a reference to the participant: destroy them first.
    presence.reset();
    presence_watch.reset();
    link_control.reset();
    link_reply.reset();
    link_status.reset();
    link_change.reset();
    delivered_batch.reset();
    delivered.reset();
    estimate.reset();
    truth.reset();
  }
};

LiveBus::LiveBus(boost::asio::io_context& io, const BusOptions& options, BusHandlers h, bool link_control_writer) {
  dds::ParticipantOptions po;
  po.domain = dds::resolve_domain(options.domain);
  po.profile_file = dds::resolve_profile(options.profile);
  po.name = options.name;
  po.run = options.run;
  if (auto dir = dds::resolve_secure(options.secure)) po.security = dds::ParticipantOptions::Security{*dir, options.role};
  po.discovery_server = dds::resolve_discovery_server(options.discovery_server);
  po.naming = dds::resolve_naming(options.naming, options.scenario_naming);
  impl_ = std::make_unique<Impl>(po);
  if (options.presence) {
    impl_->presence_watch = std::make_unique<dds::PresenceWatcher>(impl_->participant);
    if (!options.presence->role.empty())
      impl_->presence = std::make_unique<dds::PresenceAnnouncer>(impl_->participant, options.presence->role,
                                                                 std::vector<int>{}, options.presence->scenario_hash,
                                                                 options.presence->detail);
  }
  const auto ex = io.get_executor();
  const std::function<void(const std::string&)> invalid = [this, cb = h.invalid](const std::string& what) {
    ++invalid_;
    if (cb) cb(what);
  };
  auto& p = impl_->participant;
  impl_->truth = open_reader(p, dds::topics::truth, ex, to_truth, h.truth, invalid, "");
  impl_->estimate = open_reader(p, options.estimate_history ? dds::topics::estimate : dds::topics::estimate_from_now, ex,
                                to_estimate, h.estimate, invalid, "estimate rejected: ");
  impl_->delivered = open_reader(p, dds::topics::delivered_measurement, ex, to_delivered, h.delivered, invalid, "");
  impl_->delivered_batch = open_batch_reader(p, ex, h.delivered, invalid);
  impl_->link_status = open_reader(p, dds::topics::link_status, ex, to_link_status, h.link_status, invalid,
                                   "link status rejected: ");
  impl_->link_change = open_reader(p, dds::topics::link_change, ex, to_link_change, h.link_change, invalid,
                                   "link change rejected: ");
  impl_->link_reply = open_reader(p, dds::topics::link_control_reply, ex, to_link_reply, h.link_reply, invalid, "");
  if (link_control_writer)
    impl_->link_control = std::make_unique<dds::Writer<wire::LinkControl>>(impl_->participant, dds::topics::link_control);
}

LiveBus::~LiveBus() = default;

int LiveBus::domain() const { return impl_->participant.domain(); }

bool LiveBus::send_link_control(std::uint64_t request_id, int sensor_id, const LinkKeys& keys) {
  if (!impl_->link_control) return false;
  return impl_->link_control->write(dds::make_link_control(request_id, sensor_id, keys));
}

int LiveBus::link_control_readers() const { return impl_->link_control ? impl_->link_control->matched() : 0; }
int LiveBus::link_reply_writers() const { return impl_->link_reply ? impl_->link_reply->matched() : 0; }

std::vector<std::pair<std::string, int>> LiveBus::network_writers() const {
  std::vector<std::pair<std::string, int>> out;
  auto add = [&out](const auto& reader) {
    if (reader && reader->matched() > 0) out.emplace_back(reader->topic_name(), reader->matched());
  };
  add(impl_->truth);
  add(impl_->estimate);
  add(impl_->delivered);
  add(impl_->delivered_batch);
  add(impl_->link_status);
  return out;
}

std::uint64_t LiveBus::foreign_samples() const { return impl_->participant.foreign_samples(); }

int LiveBus::presence_announcers() const {
  return impl_->presence_watch ? impl_->presence_watch->announcers() : 0;
}

std::vector<dds::PresenceRecord> LiveBus::processes() const {
  return impl_->presence_watch ? impl_->presence_watch->processes() : std::vector<dds::PresenceRecord>{};
}

void LiveBus::end_presence(const std::string& why) {
  if (impl_->presence) impl_->presence->end(why);
}

}  // namespace netkf::cli
