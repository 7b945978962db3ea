#pragma once
// Typed publish/subscribe helpers over a Participant.
//
// Reader callbacks run on a Fast DDS receive thread, which also serves the participant's
// other readers: they must never block or take long. Short per-sample work may run there
// directly — a sensor's y = C x + v, the channel's drop decision and relay, the estimator's
// bookkeeping and fused update (microseconds) — because handing each sample to another
// thread costs a context switch: on the 2-core VM about 15 % of a sensor's CPU time per period,
// and a wake-up on every hop. Anything slower, or anything that owns timers, goes to the
// node's io_context: netkf::dds::post_to() moves the sample there.
#include <atomic>
#include <chrono>
#include <concepts>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <utility>

#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "netkf/dds/participant.hpp"
#include "netkf/dds/topics.hpp"

namespace netkf::dds {

/// Wire types that carry the run id (the per-period data; see ParticipantOptions::run).
template <class T>
concept CarriesRun = requires(T t, std::uint64_t r) {
  { t.run() } -> std::convertible_to<std::uint64_t>;
  t.run(r);
};

namespace detail {
/// Poll `count` until it reaches `n` or `timeout` passes (discovery waits in tools/tests).
template <class F>
bool wait_until(F count, int n, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (count() < n) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}
}  // namespace detail

/// What to add to "cannot create a writer/reader": under DDS Security the usual cause is the
/// role's permissions (e.g. a sensor identity asking for link control).
inline std::string refused_hint(const Participant& p) {
  return p.secure() ? " (DDS Security: the permissions of this process's role do not allow it)" : std::string();
}

/// Publishes samples of one topic.
template <class T>
class Writer : private eprosima::fastdds::dds::DataWriterListener {
 public:
  /// Throws DdsError when the writer cannot be created. `samples_per_second`: the rate this
  /// writer will publish at, when it can exceed what the topic's depth was sized for (its
  /// history then holds three heartbeat periods, see history_depth_for_rate).
  Writer(Participant& participant, const Topic<T>& spec, double samples_per_second = 0.0)
      : Writer(participant, spec, WriterOptions{.samples_per_second = samples_per_second}) {}
  Writer(Participant& participant, const Topic<T>& spec, const WriterOptions& options)
      : participant_(participant), topic_name_(spec.name) {
    TopicQos qos = participant_.topic_qos(spec.qos);
    qos.depth = history_depth_for_rate(options.samples_per_second, qos.depth);
    asserts_liveliness_ = qos.exclusive_ownership;
    writer_ = participant_.publisher()->create_datawriter(participant_.topic(spec), writer_qos(qos, options), this,
                                                          eprosima::fastdds::dds::StatusMask::publication_matched());
    if (writer_ == nullptr) throw DdsError("cannot create a DDS writer for topic " + topic_name_ + refused_hint(participant));
  }
  ~Writer() override {
    writer_->set_listener(nullptr);
    participant_.publisher()->delete_datawriter(writer_);
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Publish one sample, stamped with this process's run id; false when DDS refused it (e.g.
  /// history full and blocking timed out).
  bool write(T&& sample) {
    if constexpr (CarriesRun<T>) sample.run(participant_.run());
    return writer_->write(&sample);
  }
  bool write(const T& sample) {
    if constexpr (CarriesRun<T>) {
      if (sample.run() != participant_.run()) return write(T(sample));
    }
    // DataWriter::write takes a non-const void*; the sample is only read.
    return writer_->write(const_cast<T*>(&sample));
  }

  /// Number of readers currently matched.
  int matched() const { return matched_.load(); }
  /// Exclusive-ownership topics: tell the readers this writer is alive without writing (within
  /// every kOwnershipLease, see topics.hpp). Nothing on a shared topic (e.g. under ROS 2 naming),
  /// whose liveliness Fast DDS asserts itself (and refuses to be asked, with an error logged).
  void assert_liveliness() {
    if (asserts_liveliness_) writer_->assert_liveliness();
  }
  /// Wait until at least `n` readers are matched; false on timeout.
  bool wait_for_matched(int n, std::chrono::milliseconds timeout) const {
    return detail::wait_until([this] { return matched(); }, n, timeout);
  }
  /// Wait until every matched reader acknowledged what was written (reliable topics).
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) {
    eprosima::fastrtps::Duration_t d(static_cast<double>(timeout.count()) / 1000.0);
    return writer_->wait_for_acknowledgments(d) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }
  const std::string& topic_name() const { return topic_name_; }
  eprosima::fastdds::dds::DataWriter* get() const { return writer_; }

 private:
  void on_publication_matched(eprosima::fastdds::dds::DataWriter*,
                              const eprosima::fastdds::dds::PublicationMatchedStatus& status) override {
    matched_.store(status.current_count);
  }

  Participant& participant_;
  std::string topic_name_;
  bool asserts_liveliness_ = false;  // MANUAL_BY_TOPIC liveliness: the exclusive-ownership topics
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::atomic<int> matched_{0};
};

/// Subscribes to one topic; `on_sample` is called (on the DDS listener thread) for every
/// valid sample taken. Keep it cheap (see the file comment).
template <class T>
class Reader : private eprosima::fastdds::dds::DataReaderListener {
 public:
  using Callback = std::function<void(T&&)>;

  /// Throws DdsError when the reader cannot be created.
  Reader(Participant& participant, const Topic<T>& spec, Callback on_sample)
      : participant_(participant), topic_name_(spec.name), on_sample_(std::move(on_sample)) {
    reader_ = participant_.subscriber()->create_datareader(
        participant_.topic(spec), reader_qos(participant_.topic_qos(spec.qos)), this,
        eprosima::fastdds::dds::StatusMask::data_available() << eprosima::fastdds::dds::StatusMask::subscription_matched());
    if (reader_ == nullptr) throw DdsError("cannot create a DDS reader for topic " + topic_name_ + refused_hint(participant));
  }
  ~Reader() override {
    reader_->set_listener(nullptr);
    participant_.subscriber()->delete_datareader(reader_);
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  /// Number of writers currently matched.
  int matched() const { return matched_.load(); }
  bool wait_for_matched(int n, std::chrono::milliseconds timeout) const {
    return detail::wait_until([this] { return matched(); }, n, timeout);
  }
  /// Samples delivered to the callback so far.
  std::uint64_t received() const { return received_.load(); }
  const std::string& topic_name() const { return topic_name_; }
  eprosima::fastdds::dds::DataReader* get() const { return reader_; }

 private:
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    T sample;
    eprosima::fastdds::dds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      if constexpr (CarriesRun<T>) {
        // Another launch's network on this domain: never let its samples into this run. A
        // sample without a run id (0: a process started by hand) goes on to the usual checks.
        if (participant_.run() != 0 && sample.run() != 0 && sample.run() != participant_.run()) {
          participant_.count_foreign_sample(topic_name_, sample.run());
          sample = T{};
          continue;
        }
      }
      received_.fetch_add(1);
      if (on_sample_) on_sample_(std::move(sample));
      sample = T{};
    }
  }
  void on_subscription_matched(eprosima::fastdds::dds::DataReader*,
                               const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
    matched_.store(status.current_count);
  }

  Participant& participant_;
  std::string topic_name_;
  Callback on_sample_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::atomic<int> matched_{0};
  std::atomic<std::uint64_t> received_{0};
};

// Compiled once in dds/src/endpoints.cpp.
extern template class Writer<wire::Truth>;
extern template class Writer<wire::Tick>;
extern template class Writer<wire::Measurement>;
extern template class Writer<wire::MeasurementBatch>;
extern template class Writer<wire::Estimate>;
extern template class Writer<wire::ControlInput>;
extern template class Writer<wire::LinkControl>;
extern template class Writer<wire::LinkControlReply>;
extern template class Writer<wire::LinkStatus>;
extern template class Writer<wire::LinkChange>;
extern template class Writer<wire::Presence>;
extern template class Reader<wire::Truth>;
extern template class Reader<wire::Tick>;
extern template class Reader<wire::Measurement>;
extern template class Reader<wire::MeasurementBatch>;
extern template class Reader<wire::Estimate>;
extern template class Reader<wire::ControlInput>;
extern template class Reader<wire::LinkControl>;
extern template class Reader<wire::LinkControlReply>;
extern template class Reader<wire::LinkStatus>;
extern template class Reader<wire::LinkChange>;
extern template class Reader<wire::Presence>;

/// A reader callback that moves each sample into `handler` on `executor` (an Asio
/// io_context executor or strand), so the node's logic runs on its own thread:
///   Reader<wire::Tick> r(p, topics::tick, post_to<wire::Tick>(io.get_executor(), [&](wire::Tick t){...}));
template <class T, class Executor, class Handler>
std::function<void(T&&)> post_to(Executor executor, Handler handler);

}  // namespace netkf::dds

#include "netkf/dds/detail/post_to.hpp"
