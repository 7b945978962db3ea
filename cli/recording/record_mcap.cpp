#include "record_mcap.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include "netkf/cli/live/channel_catalogue.hpp"

namespace netkf::cli {

namespace {

std::uint64_t seconds_to_ns(double s) {
  if (!std::isfinite(s) || s <= 0.0) return 0;
  return static_cast<std::uint64_t>(std::llround(s * 1e9));
}

std::uint16_t add_channel(McapWriter& w, catalogue::ChannelId id) {
  const auto& c = catalogue::channel(id);
  const auto schema = w.add_schema(c.schema_name, "jsonschema", c.schema.dump());
  return w.add_channel(schema, c.topic, "json");
}

}  // namespace

bool is_mcap_path(const std::string& path) {
  if (path.size() < 5) return false;
  std::string ext = path.substr(path.size() - 5);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  return ext == ".mcap";
}

McapRecorder::McapRecorder(std::ostream& out, const Scenario& scenario, bool with_delivered, McapOptions options)
    : McapRecorder(out, std::make_unique<LiveModel>(scenario), nullptr, with_delivered, std::move(options)) {}

McapRecorder::McapRecorder(std::ostream& out, LiveModel& model, bool with_delivered, McapOptions options)
    : McapRecorder(out, nullptr, &model, with_delivered, std::move(options)) {}

McapRecorder::McapRecorder(std::ostream& out, std::unique_ptr<LiveModel> own_model, LiveModel* shared,
                           bool with_delivered, McapOptions options)
    : options_(std::move(options)),
      writer_(out, "netkf", ros2() ? "ros2" : "", /*with_summary=*/ros2()),
      own_model_(std::move(own_model)),
      model_(own_model_ ? *own_model_ : *shared),
      reader_(own_model_ ? LiveModel::kFirstReader : model_.subscribe()),
      period_s_(model_.scenario().period_ms / 1000.0),
      with_delivered_(with_delivered),
      max_delay_periods_(model_.scenario().estimator.fusable_delay_periods()) {
  try {
    add_channels();
  } catch (...) {
    if (!own_model_) model_.unsubscribe(reader_);  // no destructor runs: the model keeps no events for it
    throw;
  }
}

McapRecorder::~McapRecorder() {
  if (!own_model_) model_.unsubscribe(reader_);
}

void McapRecorder::add_channels() {
  if (ros2()) {
    add_ros2_channels();
    return;
  }
  using catalogue::ChannelId;
  truth_ = add_channel(writer_, ChannelId::truth);
  estimate_ = add_channel(writer_, ChannelId::estimate);
  if (with_delivered_) delivered_ = add_channel(writer_, ChannelId::delivered);
  link_status_ = add_channel(writer_, ChannelId::link_status);
  link_change_ = add_channel(writer_, ChannelId::link_change);
  events_ = add_channel(writer_, ChannelId::events);
}

// The channels in rosbag2's layout: one schema per type, its definition with dependencies.
void McapRecorder::add_ros2_channels() {
  if (!options_.codec) throw std::invalid_argument("the ros2 MCAP profile needs a CDR codec");
  using ros2::Channel;
  std::vector<Channel> channels{Channel::truth, Channel::estimate};
  if (with_delivered_) channels.push_back(Channel::delivered);
  channels.insert(channels.end(), {Channel::link_status, Channel::link_change, Channel::rosout});
  for (const Channel c : channels) {
    const auto info = ros2::topic_info(c);
    const auto schema =
        writer_.add_schema(info.schema_name(), "ros2msg", ros2::message_definition(info.package, info.type));
    ros2_channels_[c] = writer_.add_channel(
        schema, info.topic, "cdr",
        {{"offered_qos_profiles", ros2::offered_qos_profiles(options_.codec->qos(c))}, {"topic_type_hash", ""}});
  }
  truth_ = ros2_channels_[Channel::truth];
  estimate_ = ros2_channels_[Channel::estimate];
  if (with_delivered_) delivered_ = ros2_channels_[Channel::delivered];
  link_status_ = ros2_channels_[Channel::link_status];
  link_change_ = ros2_channels_[Channel::link_change];
  events_ = ros2_channels_[Channel::rosout];
}

// rosbag2 writes its metadata record when the bag is closed: the counts are then known.
void McapRecorder::write_bag_metadata() {
  std::vector<ros2::BagTopic> topics;
  for (const auto& [c, channel] : ros2_channels_) {
    const auto info = ros2::topic_info(c);
    topics.push_back({std::string(info.topic), info.schema_name(), options_.codec->qos(c),
                      writer_.channel_messages(channel)});
  }
  writer_.add_metadata("rosbag2", {{"serialized_metadata", ros2::bag_metadata_yaml(topics, options_.file_name,
                                                                                   writer_.first_log_time(),
                                                                                   writer_.last_log_time())},
                                   {"ROS_DISTRO", std::string(ros2::kRosDistro)}});
}

std::uint64_t McapRecorder::period_time_ns(std::int64_t k) const {
  return seconds_to_ns(static_cast<double>(k) * period_s_);
}

void McapRecorder::note_time(double t) { latest_ns_ = std::max(latest_ns_, seconds_to_ns(t)); }

void McapRecorder::write(std::uint16_t channel, std::uint64_t time_ns, const std::string& data) {
  writer_.add_message(channel, time_ns, time_ns, data);
}

void McapRecorder::write_events() {
  for (auto& event : model_.take_events(reader_)) {
    if (!event.from_records) continue;  // the theory's: the recording keeps what the records raise
    if (!event.unattributed_text.empty()) event.text = std::move(event.unattributed_text);
    if (ros2()) {
      const std::uint8_t level = event.level == LiveEvent::Level::error     ? ros2::kLogError
                                 : event.level == LiveEvent::Level::warning ? ros2::kLogWarn
                                                                            : ros2::kLogInfo;
      write(events_, latest_ns_, options_.codec->log(latest_ns_, level, "netkf", event.text));
    } else {
      write(events_, latest_ns_, catalogue::log_message(event, latest_ns_).dump());
    }
    ++events_written_;
  }
}

void McapRecorder::drop_events() { model_.take_events(reader_); }

void McapRecorder::truth(const Truth& t) {
  if (finished()) return;
  if (own_model_) own_model_->add_truth(t);
  note_time(t.t);
  write(truth_, seconds_to_ns(t.t), ros2() ? options_.codec->truth(t) : catalogue::truth_message(t).dump());
}

// late_policy fuse_within: the estimate channel keeps the first (revision 0, written at once)
// and the final estimate of each period (its newest revision, held until the in-time estimate
// of k + D + 1 is out: k is not revised after that, see record_csv.hpp), so a period has one or
// two messages.
void McapRecorder::estimate(const Estimate& e) {
  if (finished()) return;
  if (e.revision > 0) {
    auto f = finals_.find(static_cast<std::int64_t>(e.k));
    if (f == finals_.end()) finals_.emplace(static_cast<std::int64_t>(e.k), e);
    else if (e.revision >= f->second.revision) f->second = e;
    return;
  }
  if (own_model_) own_model_->add_estimate(e);  // counts late samples per link for the link status messages
  note_time(e.t);
  write_estimate(e);
  ++estimates_;
  if (max_delay_periods_ > 0) write_finals(static_cast<std::int64_t>(e.k) - max_delay_periods_ - 1);
  write_events();
}

void McapRecorder::write_estimate(const Estimate& e) {
  write(estimate_, seconds_to_ns(e.t), ros2() ? options_.codec->estimate(e) : catalogue::estimate_message(e).dump());
}

void McapRecorder::write_finals(std::int64_t last_final) {
  while (!finals_.empty() && finals_.begin()->first <= last_final) {
    write_estimate(finals_.begin()->second);
    finals_.erase(finals_.begin());
  }
}

void McapRecorder::finish() {
  if (finished()) return;
  if (!finals_.empty()) write_finals(finals_.rbegin()->first);
  if (ros2()) write_bag_metadata();
  writer_.finish();
  if (!own_model_) model_.unsubscribe(reader_);  // writes nothing more: keeps no events
}

void McapRecorder::delivered(const DeliveredMeasurement& d) {
  if (finished() || !with_delivered_) return;
  write(delivered_, period_time_ns(d.k), ros2() ? options_.codec->delivered(d) : catalogue::delivered_message(d).dump());
}

void McapRecorder::link_status(const LinkStatus& l) {
  if (finished()) return;
  if (own_model_) own_model_->add_link_status(l);
  write_events();
  if (ros2()) {
    write(link_status_, latest_ns_, options_.codec->link_status(l));
    return;
  }
  for (const auto& view : model_.snapshot().links)
    if (view.sensor_id == l.sensor_id) write(link_status_, latest_ns_, catalogue::link_status_message(view).dump());
}

void McapRecorder::link_change(const LinkChange& c) {
  if (finished()) return;
  std::string json = catalogue::link_change_message(c).dump();
  // A repeat is not recorded twice, nor the event it raised again in a model fed before us.
  if (!changes_seen_.insert(json).second) return drop_events();
  write(link_change_, period_time_ns(c.at_period), ros2() ? options_.codec->link_change(c) : json);
  if (own_model_) own_model_->add_link_change(c);  // a timeline step is an event too
  write_events();
}

}  // namespace netkf::cli
