#include "netkf/dds/presence.hpp"

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <set>

#include <spdlog/spdlog.h>

#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>

namespace netkf::dds {

namespace fdds = eprosima::fastdds::dds;

std::string PresenceRecord::who() const {
  std::string name = role;
  if (!sensor_ids.empty()) {
    name += " ";
    for (std::size_t i = 0; i < sensor_ids.size(); ++i) name += (i ? "," : "") + std::to_string(sensor_ids[i]);
  }
  return name + " (pid " + std::to_string(pid) + " on " + host + ")";
}

std::uint64_t scenario_hash(const Scenario& scenario) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a offset basis
  for (const unsigned char c : scenario_to_yaml(scenario)) {
    h ^= c;
    h *= 1099511628211ULL;  // FNV prime
  }
  return h;
}

std::string this_host() {
  char name[HOST_NAME_MAX + 1] = {};
  if (::gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "localhost";
  return name;
}

PresenceAnnouncer::PresenceAnnouncer(Participant& participant, std::string role, std::vector<int> sensor_ids,
                                     std::uint64_t scenario_hash, std::string detail)
    : writer_(participant, topics::presence) {
  sample_.host(this_host());
  sample_.pid(static_cast<std::int32_t>(::getpid()));
  sample_.role(std::move(role));
  sample_.sensor_ids(std::vector<std::int32_t>(sensor_ids.begin(), sensor_ids.end()));
  sample_.scenario_hash(scenario_hash);
  sample_.run_id(participant.run());
  sample_.state("running");
  sample_.detail(std::move(detail));
  writer_.write(sample_);
}

void PresenceAnnouncer::end(const std::string& why) {
  if (sample_.state() == "ended") return;
  sample_.state("ended");
  sample_.detail(why);
  writer_.write(sample_);
  // The others must learn it before this process leaves (its writer's history goes with it).
  writer_.wait_for_acknowledgments(std::chrono::milliseconds(500));
}

PresenceWatcher::PresenceWatcher(Participant& participant) : participant_(participant) {
  reader_ = participant_.subscriber()->create_datareader(participant_.topic(topics::presence),
                                                        reader_qos(participant_.topic_qos(topics::presence.qos)), nullptr,
                                                        fdds::StatusMask::none());
  if (reader_ == nullptr)
    throw DdsError("cannot create a DDS reader for topic " + std::string(topics::presence.name) + refused_hint(participant));
}

PresenceWatcher::~PresenceWatcher() { participant_.subscriber()->delete_datareader(reader_); }

int PresenceWatcher::announcers() const {
  fdds::SubscriptionMatchedStatus status;
  if (reader_->get_subscription_matched_status(status) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) return 0;
  return status.current_count;
}

std::vector<PresenceRecord> PresenceWatcher::processes() const {
  const std::lock_guard lock(mutex_);
  fdds::LoanableSequence<wire::Presence> samples;
  fdds::SampleInfoSeq infos;
  std::vector<PresenceRecord> records;
  if (reader_->read(samples, infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE, fdds::ANY_VIEW_STATE,
                    fdds::ANY_INSTANCE_STATE) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK)
    return records;
  for (fdds::LoanableCollection::size_type i = 0; i < samples.length(); ++i) {
    if (!infos[i].valid_data) continue;
    const wire::Presence& sample = samples[i];
    PresenceRecord r;
    r.host = sample.host();
    r.pid = sample.pid();
    r.role = sample.role();
    r.sensor_ids.assign(sample.sensor_ids().begin(), sample.sensor_ids().end());
    r.scenario_hash = sample.scenario_hash();
    r.run = sample.run_id();
    r.ended = sample.state() == "ended";
    r.alive = infos[i].instance_state == fdds::ALIVE_INSTANCE_STATE;
    r.detail = sample.detail();
    records.push_back(std::move(r));
  }
  reader_->return_loan(samples, infos);
  return records;
}

std::string PresenceRecord::other_scenario_text(std::uint64_t our_hash, const std::string& ours) const {
  char text[160];
  std::snprintf(text, sizeof text, "loaded another scenario (hash %016llx; %s's %016llx)",
                static_cast<unsigned long long>(scenario_hash), ours.c_str(), static_cast<unsigned long long>(our_hash));
  return text;
}

namespace {
bool same_run(const PresenceRecord& p, std::uint64_t run) { return p.run == run || p.run == 0 || run == 0; }
}  // namespace

Readiness assess_readiness(const std::vector<PresenceRecord>& processes, const std::vector<int>& sensor_ids,
                           std::uint64_t run, std::uint64_t hash) {
  Readiness r;
  std::set<int> sensors_present;
  bool channel = false, estimator = false;
  for (const auto& p : processes) {
    if (!p.running() || !same_run(p, run)) continue;
    if (p.scenario_hash != 0 && hash != 0 && p.scenario_hash != hash && !r.conflict) {
      r.conflict = p.who() + " " + p.other_scenario_text(hash, "this process") +
                   ": every host must run the same scenario file";
      continue;
    }
    if (p.role == presence_role::sensors) sensors_present.insert(p.sensor_ids.begin(), p.sensor_ids.end());
    channel = channel || p.role == presence_role::channel;
    estimator = estimator || p.role == presence_role::estimator;
    if (p.role == presence_role::sensors || p.role == presence_role::launch || p.role == presence_role::record)
      ++r.truth_readers;
  }
  // Missing sensors as runs of consecutive ids ("sensor 3", "sensors 129-256"): a grouped
  // process that never came names its whole range in a line one can read.
  std::vector<int> absent;
  for (int id : sensor_ids)
    if (!sensors_present.count(id)) absent.push_back(id);
  for (std::size_t i = 0; i < absent.size();) {
    std::size_t j = i;
    while (j + 1 < absent.size() && absent[j + 1] == absent[j] + 1) ++j;
    r.missing.push_back(i == j ? "sensor " + std::to_string(absent[i])
                               : "sensors " + std::to_string(absent[i]) + "-" + std::to_string(absent[j]));
    i = j + 1;
  }
  if (!channel) r.missing.push_back("the channel emulator");
  if (!estimator) r.missing.push_back("the estimator");
  r.ready = r.missing.empty() && !r.conflict;
  return r;
}

std::vector<PresenceRecord> other_runs(const std::vector<PresenceRecord>& processes, std::uint64_t run) {
  std::vector<PresenceRecord> others;
  for (const auto& p : processes)
    if (p.running() && !same_run(p, run)) others.push_back(p);
  return others;
}

}  // namespace netkf::dds
