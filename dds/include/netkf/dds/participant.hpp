#pragma once
// Participant creation with the project's DDS profile.
// Default: localhost only, set IN CODE (so a forgotten environment variable can never
// make a launch multicast): builtin transports off; shared memory + UDPv4 whitelisted
// to 127.0.0.1 (maxInitialPeersRange 128); metatraffic unicast 127.0.0.1, no multicast;
// initial peers 127.0.0.1 (docs/dds-notes.md, "Keeping discovery on loopback").
// A user picks another profile (e.g. deploy/dds/discovery-server.xml) with a file:
// --dds-profile FILE or NETKF_DDS_PROFILE, never by editing code.
// DDS Security (--secure DIR or NETKF_SECURE, security.hpp) adds the builtin plugins'
// properties on top of whichever QoS is in effect (built-in or profile): it never replaces it.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "netkf/dds/participant_slot.hpp"
#include "netkf/dds/security.hpp"
#include "netkf/dds/topics.hpp"

namespace netkf::dds {

/// Any failure of the DDS layer (bad profile file, participant not created, ...).
class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Environment variables read by resolve_domain / resolve_profile.
inline constexpr const char* kDomainEnv = "NETKF_DOMAIN";
inline constexpr const char* kProfileEnv = "NETKF_DDS_PROFILE";
inline constexpr const char* kSecureEnv = "NETKF_SECURE";
/// Participant profile a profile file may define; otherwise its default participant profile is used.
inline constexpr const char* kProfileName = "netkf_participant";

/// A Fast DDS Discovery Server's listening locator (IPv4 address and UDP port).
struct DiscoveryServerAddress {
  std::string address;  // dotted IPv4, e.g. "10.0.0.1"
  std::uint16_t port = 11811;
  std::string text() const { return address + ":" + std::to_string(port); }
};

/// "ADDR:PORT" (PORT optional: 11811, Fast DDS's default) -> the address; throws DdsError for
/// anything else (a host name, a port outside 1-65535, an address that is not IPv4).
DiscoveryServerAddress parse_discovery_server(std::string_view text);

/// The address of this host's interface that reaches `server` (the kernel's route, asked with
/// a UDP socket that sends nothing); 127.0.0.1 for a server on loopback. Throws DdsError.
std::string local_address_towards(const DiscoveryServerAddress& server);

struct ParticipantOptions {
  int domain = 0;
  /// XML profile file; empty = the built-in localhost-only configuration.
  std::optional<std::filesystem::path> profile_file;
  std::string name = "netkf";
  /// DDS Security: the directory of `netkf security init` and this process's role in it;
  /// nullopt = no security.
  struct Security {
    std::filesystem::path dir;
    Role role = Role::observer;
  };
  std::optional<Security> security;
  /// The run this process belongs to (`netkf launch` makes one per launch; 0 = none). Writers
  /// stamp it on every per-period sample (truth, tick, measurement, estimate, control) and
  /// readers drop samples of another run, so two networks that share a domain by mistake
  /// cannot corrupt each other (each drop is counted and logged). Samples without a run id
  /// (0: a process started by hand) are not dropped for it.
  std::uint64_t run = 0;
  /// Discovery through a Fast DDS Discovery Server instead of the localhost profile: this
  /// participant is its client (or, with serve_discovery, the server itself). Its own address
  /// (the interface that reaches the server), whitelist and locators are derived at start
  /// (discovery_client_qos). A profile file still overrides everything.
  std::optional<DiscoveryServerAddress> discovery_server;
  bool serve_discovery = false;
  /// Told of every participant, writer and reader discovered (on Fast DDS's discovery thread),
  /// from the participant's creation on, so none is missed (`netkf relay`). Not owned.
  eprosima::fastdds::dds::DomainParticipantListener* discovery_listener = nullptr;
  /// netkf's topic and type names, or ROS 2's (topics.hpp, dds_topic_name): every process of a
  /// network must use the same.
  TopicNaming naming = TopicNaming::netkf;
};

/// Domain id: the flag when given, else $NETKF_DOMAIN, else 0. Throws DdsError when
/// the value is not an integer in [0, 232].
int resolve_domain(std::optional<int> flag);
/// Profile file: the flag when given (non-empty), else $NETKF_DDS_PROFILE (if set and
/// non-empty), else nullopt (built-in localhost-only configuration).
std::optional<std::filesystem::path> resolve_profile(const std::optional<std::string>& flag);
/// Security directory: the flag when given (non-empty), else $NETKF_SECURE (if set and
/// non-empty), else nullopt (no security). Made absolute (Fast DDS wants file:// URIs).
std::optional<std::filesystem::path> resolve_secure(const std::optional<std::string>& flag);

/// Add the builtin security plugins' properties for `files` to `qos` (replacing any dds.sec.*
/// property it already had); everything else in `qos` stays.
void add_security_properties(eprosima::fastdds::dds::DomainParticipantQos& qos, const SecurityFiles& files);

/// The built-in localhost-only participant QoS (exposed for tests and tools).
eprosima::fastdds::dds::DomainParticipantQos localhost_participant_qos(const std::string& name);
/// A client of the Discovery Server at `server`: shared memory plus UDPv4 on the one interface
/// that reaches the server (whitelisted), no multicast, no initial peers; everything it knows of
/// the others comes from the server. Throws DdsError when no interface reaches the server.
eprosima::fastdds::dds::DomainParticipantQos discovery_client_qos(const std::string& name,
                                                                  const DiscoveryServerAddress& server);
/// The Discovery Server itself (Fast DDS's SERVER protocol, the well-known prefix of server id
/// 0, which clients expect), listening on `server` only.
eprosima::fastdds::dds::DomainParticipantQos discovery_server_qos(const std::string& name,
                                                                  const DiscoveryServerAddress& server);

/// Environment variable of the naming (as --naming).
inline constexpr const char* kNamingEnv = "NETKF_NAMING";
/// The naming: the flag when given (non-empty), else $NETKF_NAMING (if set and non-empty), else
/// the scenario's `naming:`. Throws DdsError for a word other than netkf or ros2.
TopicNaming resolve_naming(const std::optional<std::string>& flag, TopicNaming scenario_naming);

/// One DDS participant with one publisher and one subscriber. Topics are created on
/// first use (the type is registered then). Not copyable; destroying it deletes all
/// entities it created and leaves the domain cleanly (writers/readers must be
/// destroyed first: they hold a reference to the participant).
class Participant {
 public:
  /// Throws DdsError with a clear message (bad profile file, creation failure).
  explicit Participant(const ParticipantOptions& options);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  int domain() const { return domain_; }
  const std::string& name() const { return name_; }
  TopicNaming naming() const { return naming_; }
  /// `qos` as this participant's naming has it (naming_qos).
  TopicQos topic_qos(const TopicQos& qos) const { return naming_qos(qos, naming_); }
  std::uint64_t run() const { return run_; }
  /// A sample of another run arrived on `topic` and was dropped (counted; logged, throttled).
  void count_foreign_sample(const std::string& topic, std::uint64_t their_run);
  std::uint64_t foreign_samples() const { return foreign_samples_.load(); }
  /// True when DDS Security is on (endpoint errors then mention the permissions).
  bool secure() const { return secure_; }
  /// The Fast DDS participant id netkf chose (participant_slot.hpp); -1 = Fast DDS chose (a
  /// profile file, or no free slot).
  int participant_id() const { return slot_ ? slot_->id() : -1; }
  eprosima::fastdds::dds::DomainParticipant* get() const { return participant_; }
  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }

  /// The DDS topic for `spec` under this participant's naming (created and its type registered
  /// on first use).
  template <class T>
  eprosima::fastdds::dds::Topic* topic(const Topic<T>& spec) {
    eprosima::fastdds::dds::TypeSupport type(new typename PubSubTypeOf<T>::type());
    type->setName(dds_type_name(type->getName(), naming_).c_str());
    return topic(dds_topic_name(spec.name, naming_), type);
  }
  /// The DDS topic `name` of any type (registered under its own name on first use).
  eprosima::fastdds::dds::Topic* topic(const std::string& name, eprosima::fastdds::dds::TypeSupport type);

 private:

  int domain_ = 0;
  std::string name_;
  std::uint64_t run_ = 0;
  TopicNaming naming_ = TopicNaming::netkf;
  std::atomic<std::uint64_t> foreign_samples_{0};
  bool secure_ = false;
  std::optional<ParticipantSlot> slot_;  // released after the participant is deleted
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
};

/// Map a topic's QoS to DDS writer / reader QoS (used by Writer/Reader).
eprosima::fastdds::dds::DataWriterQos writer_qos(const TopicQos& qos, const WriterOptions& options = {});
eprosima::fastdds::dds::DataReaderQos reader_qos(const TopicQos& qos);

}  // namespace netkf::dds
