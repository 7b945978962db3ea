// Participant creation with the project's DDS profile (see participant.hpp).
#include "netkf/dds/participant.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <set>
#include <system_error>

#include <spdlog/spdlog.h>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <fastdds/dds/topic/qos/TopicQos.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastrtps/utils/IPLocator.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <charconv>
#include <sstream>

namespace netkf::dds {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

// The participant ids of this process's live participants, whatever their domain: Fast DDS
// refuses a second participant with the same id in one process (RTPSDomain), e.g. the two
// participants of `netkf relay`.
std::mutex& process_ids_mutex() {
  static std::mutex m;
  return m;
}
std::set<int>& process_ids() {
  static std::set<int> ids;
  return ids;
}
void forget_process_id(const std::optional<ParticipantSlot>& slot) {
  if (!slot) return;
  const std::lock_guard lock(process_ids_mutex());
  process_ids().erase(slot->id());
}
std::mutex& factory_mutex() {
  static std::mutex m;
  return m;
}

/// The name Fast DDS gets: it keeps at most 255 characters of a participant's name, and a
/// participant whose name it cut there was never discovered by its peers (integration test
/// AParticipantWithAVeryLongNameIsDiscovered). Long names are cut well below that.
std::string name_for_fast_dds(const std::string& name) {
  constexpr std::size_t kMaxName = 200;
  return name.size() <= kMaxName ? name : name.substr(0, kMaxName - 3) + "...";
}

/// A UDPv4 locator; port 0 = automatic (expands to the well-known participant ports).
eprosima::fastrtps::rtps::Locator_t udp_locator(const std::string& address, std::uint16_t port = 0) {
  eprosima::fastrtps::rtps::Locator_t loc;
  loc.kind = LOCATOR_KIND_UDPv4;
  eprosima::fastrtps::rtps::IPLocator::setIPv4(loc, address);
  loc.port = port;
  return loc;
}

eprosima::fastrtps::rtps::Locator_t loopback_locator() { return udp_locator("127.0.0.1"); }

/// Shared memory plus UDPv4 on `address` only (builtin transports off: they would add every
/// interface and multicast). Returns the UDP transport for further settings.
std::shared_ptr<eprosima::fastdds::rtps::UDPv4TransportDescriptor> use_transports_on(fdds::DomainParticipantQos& qos,
                                                                                     const std::string& address) {
  qos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.emplace_back(address);
  qos.transport().user_transports.push_back(std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>());
  qos.transport().user_transports.push_back(udp);
  return udp;
}
}  // namespace

DiscoveryServerAddress parse_discovery_server(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return DdsError("discovery server '" + std::string(text) + "': " + why + " (give ADDR:PORT, e.g. 10.0.0.1:11811)");
  };
  DiscoveryServerAddress server;
  const auto colon = text.rfind(':');
  server.address = std::string(text.substr(0, colon));
  if (colon != std::string_view::npos) {
    const auto port_text = text.substr(colon + 1);
    unsigned port = 0;
    const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
    if (ec != std::errc() || end != port_text.data() + port_text.size() || port == 0 || port > 65535)
      throw bad("the port must be a number in 1-65535");
    server.port = static_cast<std::uint16_t>(port);
  }
  in_addr parsed{};
  if (inet_pton(AF_INET, server.address.c_str(), &parsed) != 1) throw bad("the address must be a dotted IPv4 address");
  if (parsed.s_addr == htonl(INADDR_ANY)) throw bad("0.0.0.0 is not an address a client can reach");
  return server;
}

std::string local_address_towards(const DiscoveryServerAddress& server) {
  in_addr target{};
  if (inet_pton(AF_INET, server.address.c_str(), &target) != 1)
    throw DdsError("discovery server address '" + server.address + "' is not IPv4");
  if ((ntohl(target.s_addr) >> 24) == 127) return "127.0.0.1";
  // connect() on a UDP socket only asks the kernel for the route: nothing is sent.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) throw DdsError(std::string("cannot open a UDP socket: ") + std::strerror(errno));
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(server.port);
  to.sin_addr = target;
  sockaddr_in local{};
  socklen_t len = sizeof local;
  const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &len) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok) throw DdsError("no interface of this host reaches the discovery server " + server.text() + ": " + std::strerror(err));
  char buf[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &local.sin_addr, buf, sizeof buf);
  return buf;
}

TopicNaming resolve_naming(const std::optional<std::string>& flag, TopicNaming scenario_naming) {
  auto parse = [](const std::string& word, const std::string& where) {
    if (auto naming = topic_naming_from_string(word)) return *naming;
    throw DdsError(where + " '" + word + "' is not a naming: netkf or ros2");
  };
  if (flag && !flag->empty()) return parse(*flag, "--naming");
  if (const char* env = std::getenv(kNamingEnv); env != nullptr && *env != '\0')
    return parse(env, std::string(kNamingEnv));
  return scenario_naming;
}

int resolve_domain(std::optional<int> flag) {
  int domain = 0;
  if (flag) {
    domain = *flag;
  } else if (const char* env = std::getenv(kDomainEnv); env != nullptr && *env != '\0') {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(env, &end, 10);
    if (errno != 0 || end == env || *end != '\0' || v < std::numeric_limits<int>::min() ||
        v > std::numeric_limits<int>::max()) {
      throw DdsError(std::string(kDomainEnv) + "='" + env + "' is not an integer domain id");
    }
    domain = static_cast<int>(v);
  }
  // RTPS port mapping (7400 + 250 * domain + ...) must fit in 16 bits.
  if (domain < 0 || domain > 232) throw DdsError("DDS domain id " + std::to_string(domain) + " is outside [0, 232]");
  return domain;
}

std::optional<std::filesystem::path> resolve_profile(const std::optional<std::string>& flag) {
  if (flag && !flag->empty()) return std::filesystem::path(*flag);
  if (const char* env = std::getenv(kProfileEnv); env != nullptr && *env != '\0') return std::filesystem::path(env);
  return std::nullopt;
}

std::optional<std::filesystem::path> resolve_secure(const std::optional<std::string>& flag) {
  std::string dir;
  if (flag && !flag->empty()) dir = *flag;
  else if (const char* env = std::getenv(kSecureEnv); env != nullptr && *env != '\0') dir = env;
  if (dir.empty()) return std::nullopt;
  return std::filesystem::absolute(dir).lexically_normal();
}

void add_security_properties(fdds::DomainParticipantQos& qos, const SecurityFiles& files) {
  auto& props = qos.properties().properties();
  // A profile's own dds.sec.* settings would mix with ours into a half-configured plugin.
  props.erase(std::remove_if(props.begin(), props.end(),
                             [](const eprosima::fastrtps::rtps::Property& p) { return p.name().rfind("dds.sec.", 0) == 0; }),
              props.end());
  auto uri = [](const std::filesystem::path& p) { return "file://" + p.string(); };  // p is absolute
  auto add = [&props](const std::string& name, const std::string& value) { props.emplace_back(name, value); };
  add("dds.sec.auth.plugin", "builtin.PKI-DH");
  add("dds.sec.auth.builtin.PKI-DH.identity_ca", uri(files.ca_cert));
  add("dds.sec.auth.builtin.PKI-DH.identity_certificate", uri(files.identity_cert));
  add("dds.sec.auth.builtin.PKI-DH.private_key", uri(files.identity_key));
  add("dds.sec.access.plugin", "builtin.Access-Permissions");
  add("dds.sec.access.builtin.Access-Permissions.permissions_ca", uri(files.ca_cert));
  add("dds.sec.access.builtin.Access-Permissions.governance", uri(files.governance));
  add("dds.sec.access.builtin.Access-Permissions.permissions", uri(files.permissions));
  add("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

fdds::DomainParticipantQos localhost_participant_qos(const std::string& name) {
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  // How many participants per host find each other through the initial peers
  // (docs/dds-notes.md: >= 32; a launch with 64 sensors has ~70 participants).
  use_transports_on(qos, "127.0.0.1")->maxInitialPeersRange = 128;

  auto& builtin = qos.wire_protocol().builtin;
  // Announce this participant every second (Fast DDS default: 3 s). A participant that joins
  // late (a restarted estimator, a second launch checking the domain) is otherwise often seen
  // only at the others' next announcement, up to 3 s later; the cost is one more round of
  // announcements to the initial peers each second (BENCHMARKS.md, "Discovery announcements").
  builtin.discovery_config.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(1, 0);
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(loopback_locator());
  builtin.metatrafficMulticastLocatorList.clear();  // no multicast discovery
  builtin.initialPeersList.clear();
  builtin.initialPeersList.push_back(loopback_locator());
  return qos;
}

fdds::DomainParticipantQos discovery_client_qos(const std::string& name, const DiscoveryServerAddress& server) {
  const std::string own = local_address_towards(server);
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  use_transports_on(qos, own);
  auto& builtin = qos.wire_protocol().builtin;
  builtin.discovery_config.discoveryProtocol = eprosima::fastrtps::rtps::DiscoveryProtocol_t::CLIENT;
  eprosima::fastdds::rtps::RemoteServerAttributes remote;
  remote.ReadguidPrefix(eprosima::fastdds::rtps::DEFAULT_ROS2_SERVER_GUIDPREFIX);  // server id 0
  remote.metatrafficUnicastLocatorList.push_back(udp_locator(server.address, server.port));
  builtin.discovery_config.m_DiscoveryServers.push_back(remote);
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(udp_locator(own));
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.initialPeersList.clear();
  return qos;
}

fdds::DomainParticipantQos discovery_server_qos(const std::string& name, const DiscoveryServerAddress& server) {
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  use_transports_on(qos, server.address);
  auto& builtin = qos.wire_protocol().builtin;
  builtin.discovery_config.discoveryProtocol = eprosima::fastrtps::rtps::DiscoveryProtocol_t::SERVER;
  std::istringstream(eprosima::fastdds::rtps::DEFAULT_ROS2_SERVER_GUIDPREFIX) >> qos.wire_protocol().prefix;
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(udp_locator(server.address, server.port));
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.initialPeersList.clear();
  return qos;
}

Participant::Participant(const ParticipantOptions& options)
    : domain_(options.domain),
      name_(options.name),
      run_(options.run),
      naming_(options.naming),
      secure_(options.security.has_value()) {
  if (domain_ < 0 || domain_ > 232) throw DdsError("DDS domain id " + std::to_string(domain_) + " is outside [0, 232]");
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipantQos qos;
  {
    std::lock_guard lock(factory_mutex());
    if (options.profile_file) {
      const auto& file = *options.profile_file;
      std::error_code ec;
      if (!std::filesystem::is_regular_file(file, ec)) {
        throw DdsError("DDS profile file '" + file.string() + "' does not exist or is not a regular file");
      }
      if (factory->load_XML_profiles_file(file.string()) != ReturnCode_t::RETCODE_OK) {
        throw DdsError("DDS profile file '" + file.string() + "' is not a valid Fast DDS XML profile");
      }
      // The profile named netkf_participant, else the file's default participant profile.
      if (factory->get_participant_qos_from_profile(kProfileName, qos) != ReturnCode_t::RETCODE_OK) {
        qos = factory->get_default_participant_qos();
      }
    } else if (options.discovery_server && options.serve_discovery) {
      qos = discovery_server_qos(name_, *options.discovery_server);
    } else if (options.discovery_server) {
      qos = discovery_client_qos(name_, *options.discovery_server);
    } else {
      qos = localhost_participant_qos(name_);
    }
  }
  std::optional<SecurityFiles> security;
  if (options.security) {
    security = security_files(options.security->dir, options.security->role);
    check_security_files(*security);  // a missing file is named here, not in Fast DDS's log
    add_security_properties(qos, *security);
  }
  // The built-in configurations use shared memory: take an id no killed process left its
  // port on (participant_slot.hpp). A profile file's own id, if any, is the user's choice.
  if (!options.profile_file && qos.wire_protocol().participant_id < 0) {
    const std::lock_guard lock(process_ids_mutex());
    slot_ = ParticipantSlot::claim(domain_, kParticipantSlotDir, process_ids());
    if (slot_) {
      qos.wire_protocol().participant_id = slot_->id();
      process_ids().insert(slot_->id());
    }
  }
  qos.name(name_for_fast_dds(name_));
  participant_ = factory->create_participant(static_cast<fdds::DomainId_t>(domain_), qos, options.discovery_listener,
                                             fdds::StatusMask::none());
  if (participant_ == nullptr) {
    forget_process_id(slot_);
    std::string why = "cannot create DDS participant '" + name_ + "' on domain " + std::to_string(domain_) +
                      (options.profile_file ? " with profile " + options.profile_file->string() : std::string());
    if (security)
      why += " with DDS Security as role " + std::string(role_name(options.security->role)) + " (Fast DDS refused " +
             security->identity_cert.string() + " / " + security->identity_key.string() + " / " +
             security->permissions.string() + " / " + security->governance.string() +
             ": not signed by " + security->ca_cert.string() + ", expired, or not matching; see the log above)";
    throw DdsError(why);
  }
  publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher_ == nullptr || subscriber_ == nullptr) {
    participant_->delete_contained_entities();
    factory->delete_participant(participant_);
    forget_process_id(slot_);
    throw DdsError("cannot create DDS publisher/subscriber for participant '" + name_ + "'");
  }
}

Participant::~Participant() {
  if (participant_ == nullptr) return;
  participant_->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  forget_process_id(slot_);
}

fdds::Topic* Participant::topic(const std::string& name, fdds::TypeSupport type) {
  if (auto it = topics_.find(name); it != topics_.end()) return it->second;
  const std::string type_name = type.get_type_name();
  if (participant_->find_type(type_name).empty() && type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
    throw DdsError("cannot register DDS type " + type_name);
  }
  auto* topic = participant_->create_topic(name, type_name, fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw DdsError("cannot create DDS topic " + name + " (" + type_name + ")");
  topics_.emplace(name, topic);
  return topic;
}

namespace {
eprosima::fastrtps::Duration_t to_dds_duration(std::chrono::nanoseconds d) {
  return eprosima::fastrtps::Duration_t(static_cast<std::int32_t>(d.count() / 1000000000),
                                        static_cast<std::uint32_t>(d.count() % 1000000000));
}

template <class Q>
void apply_common(Q& q, const TopicQos& qos) {
  q.reliability().kind = qos.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
  q.durability().kind = qos.transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
  q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  q.history().depth = qos.depth;
  // Unkeyed topics have one instance, so the per-instance limit is the history depth.
  q.resource_limits().max_instances = qos.instances;
  q.resource_limits().max_samples_per_instance = qos.depth;
  q.resource_limits().max_samples = qos.depth * qos.instances;
  if (qos.size_payloads_by_sample)
    q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  // Writers and readers must agree on the kind (a SHARED reader does not match an EXCLUSIVE
  // writer): another vendor's reader asks for EXCLUSIVE too (docs/interop.md).
  q.ownership().kind = qos.exclusive_ownership ? fdds::EXCLUSIVE_OWNERSHIP_QOS : fdds::SHARED_OWNERSHIP_QOS;
  if (qos.exclusive_ownership) {
    // Fast DDS 2.9 tells a reader that a writer lost its liveliness only when the reader asks for
    // the same kind and lease as it tracks the writer with (WLP::sub_liveliness_changed): readers
    // and writers alike use kOwnershipLease, MANUAL_BY_TOPIC (asserted by each write and by
    // Writer::assert_liveliness).
    q.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
    q.liveliness().lease_duration = to_dds_duration(kOwnershipLease);
  }
}
}  // namespace

fdds::DataWriterQos writer_qos(const TopicQos& qos, const WriterOptions& options) {
  fdds::DataWriterQos q = fdds::DATAWRITER_QOS_DEFAULT;
  apply_common(q, qos);
  if (qos.exclusive_ownership) q.ownership_strength().value = options.ownership_strength;
  q.reliable_writer_qos().times.heartbeatPeriod = to_dds_duration(kHeartbeatPeriod);
  q.reliable_writer_qos().times.nackSupressionDuration = to_dds_duration(kNackSuppression);
  return q;
}

fdds::DataReaderQos reader_qos(const TopicQos& qos) {
  fdds::DataReaderQos q = fdds::DATAREADER_QOS_DEFAULT;
  apply_common(q, qos);
  return q;
}

void Participant::count_foreign_sample(const std::string& topic, std::uint64_t their_run) {
  const auto n = foreign_samples_.fetch_add(1) + 1;
  // The first one, then every power of two: a second network can send thousands a second.
  if ((n & (n - 1)) == 0)
    spdlog::warn("dropped a sample of another run on {} (run {:x}, ours {:x}; {} dropped so far): another netkf "
                 "network shares DDS domain {}; give each its own with --domain",
                 topic, their_run, run_, n, domain_);
}

}  // namespace netkf::dds
