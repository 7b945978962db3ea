// DDS Security: the role table, file layout and the governance/permissions
// documents (see security.hpp). Signing and key generation are openssl's job
// (`netkf security init`).
#include "netkf/dds/security.hpp"

#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "netkf/dds/participant.hpp"
#include "netkf/dds/topics.hpp"

namespace netkf::dds {

namespace {
// Every domain id netkf accepts (resolve_domain): one document serves any
// --domain.
constexpr int kMinDomain = 0;
constexpr int kMaxDomain = 232;

std::string domains_xml(const std::string &indent) {
  std::ostringstream o;
  o << indent << "<domains>\n"
    << indent << "  <id_range><min>" << kMinDomain << "</min><max>" << kMaxDomain << "</max></id_range>\n"
    << indent << "</domains>\n";
  return o.str();
}

/// Topic names and subjects are ours (no '<' or '&'), but escape anyway: a
/// subject could carry them.
std::string xml_escape(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}
}  // namespace

std::string_view role_name(Role r) {
  switch (r) {
    case Role::plant:
      return "plant";
    case Role::sensor:
      return "sensor";
    case Role::channel:
      return "channel";
    case Role::estimator:
      return "estimator";
    case Role::ctl:
      return "ctl";
    case Role::observer:
      return "observer";
  }
  return "?";
}

Role role_from_name(std::string_view name) {
  for (Role r : all_roles())
    if (role_name(r) == name) return r;
  throw DdsError("unknown security role '" + std::string(name) + "'");
}

const std::vector<Role> &all_roles() {
  static const std::vector<Role> roles{Role::plant,     Role::sensor, Role::channel,
                                       Role::estimator, Role::ctl,    Role::observer};
  return roles;
}

const std::vector<std::string_view> &all_topic_names() {
  static const std::vector<std::string_view> names{topics::truth.name,           topics::tick.name,
                                                   topics::raw_measurement.name, topics::delivered_measurement.name,
                                                   topics::estimate.name,        topics::control_input.name,
                                                   topics::link_control.name,    topics::link_control_reply.name,
                                                   topics::link_status.name,     topics::link_change.name,
                                                   topics::presence.name,        topics::raw_measurement_batch.name,
                                                   topics::delivered_measurement_batch.name};
  return names;
}

const std::vector<RolePolicy> &role_policies() {
  using namespace topics;
  // What the live commands read (LiveBus): everything a recorder, the status
  // view or the dashboard shows. Nothing of it is written by an observer.
  const std::vector<std::string_view> observed{truth.name,       estimate.name,    delivered_measurement.name,
                                               link_status.name, link_change.name, link_control_reply.name,
                                               presence.name,    delivered_measurement_batch.name};
  // Presence: every process announces itself and may read who else takes part.
  static const std::vector<RolePolicy> table{
      {Role::plant, {truth.name, tick.name, presence.name}, {control_input.name, presence.name}},
      {Role::sensor, {raw_measurement.name, raw_measurement_batch.name, presence.name}, {truth.name, presence.name}},
      {Role::channel,
       {delivered_measurement.name, delivered_measurement_batch.name, link_status.name, link_control_reply.name,
        link_change.name, presence.name},
       {raw_measurement.name, raw_measurement_batch.name, link_control.name, presence.name}},
      {Role::estimator,
       {estimate.name, control_input.name, presence.name},
       {tick.name, delivered_measurement.name, delivered_measurement_batch.name, presence.name}},
      // The only writer of link control; reads what an observer reads (a launch
      // serving the dashboard runs as ctl).
      {Role::ctl, {link_control.name, presence.name}, observed},
      {Role::observer, {presence.name}, observed},
  };
  return table;
}

const RolePolicy &role_policy(Role r) {
  for (const auto &p : role_policies())
    if (p.role == r) return p;
  throw DdsError("no policy for role " + std::string(role_name(r)));
}

std::string role_subject(Role role) { return "CN=netkf-" + std::string(role_name(role)) + ",O=netkf"; }

SecurityFiles security_files(const std::filesystem::path &dir, Role role) {
  const auto base = std::filesystem::absolute(dir).lexically_normal();
  const std::string name(role_name(role));
  SecurityFiles f;
  f.ca_cert = base / "ca" / "cert.pem";
  f.identity_cert = base / "identities" / name / "cert.pem";
  f.identity_key = base / "identities" / name / "key.pem";
  f.governance = base / "governance.p7s";
  f.permissions = base / "permissions" / (name + ".p7s");
  return f;
}

void check_security_files(const SecurityFiles &files) {
  for (const auto *p :
       {&files.ca_cert, &files.identity_cert, &files.identity_key, &files.governance, &files.permissions}) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(*p, ec))
      throw DdsError("security file " + p->string() + " is missing (make the directory with: netkf security init DIR)");
    std::ifstream in(*p);
    if (!in || in.peek() == std::ifstream::traits_type::eof())
      throw DdsError("security file " + p->string() + " is unreadable or empty");
  }
  // A private key that others may read is no secret any more: refused, as ssh refuses one.
  struct stat st {};
  if (::stat(files.identity_key.c_str(), &st) == 0 && (st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw DdsError("security file " + files.identity_key.string() + " is a private key readable by others (mode " +
                   mode + "): make it the owner's only: chmod 600 " + files.identity_key.string());
  }
}

std::string governance_xml() {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!-- netkf governance: written by `netkf security init`; signed copy: "
       "governance.p7s -->\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
       "     "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/"
       "20170901/omg_shared_ca_governance.xsd\">\n"
       "  <domain_access_rules>\n"
       "    <domain_rule>\n"
    << domains_xml("      ")
    << "      "
       "<allow_unauthenticated_participants>false</"
       "allow_unauthenticated_participants>\n"
       "      <enable_join_access_control>true</enable_join_access_control>\n"
       "      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
       "      "
       "<liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
       "      <rtps_protection_kind>ENCRYPT</rtps_protection_kind>\n"
       "      <topic_access_rules>\n";
  auto rule = [&o](std::string_view expression) {
    o << "        <topic_rule>\n"
         "          <topic_expression>"
      << xml_escape(expression)
      << "</topic_expression>\n"
         "          "
         "<enable_discovery_protection>true</enable_discovery_protection>\n"
         "          "
         "<enable_liveliness_protection>true</enable_liveliness_protection>\n"
         "          "
         "<enable_read_access_control>true</enable_read_access_control>\n"
         "          "
         "<enable_write_access_control>true</enable_write_access_control>\n"
         "          "
         "<metadata_protection_kind>ENCRYPT</metadata_protection_kind>\n"
         "          <data_protection_kind>ENCRYPT</data_protection_kind>\n"
         "        </topic_rule>\n";
  };
  for (auto name : all_topic_names()) rule(name);
  // Any other topic (first match wins): protected alike, so the permissions'
  // default DENY applies to it too.
  rule("*");
  o << "      </topic_access_rules>\n"
       "    </domain_rule>\n"
       "  </domain_access_rules>\n"
       "</dds>\n";
  return o.str();
}

std::string permissions_xml(Role role, const std::string &subject, const std::string &not_before,
                            const std::string &not_after) {
  const auto &policy = role_policy(role);
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!-- netkf permissions of role "
    << role_name(role) << ": written by `netkf security init`; signed copy: " << role_name(role)
    << ".p7s -->\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
       "     "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/"
       "20170901/omg_shared_ca_permissions.xsd\">\n"
       "  <permissions>\n"
       "    <grant name=\"netkf_"
    << role_name(role)
    << "\">\n"
       "      <subject_name>"
    << xml_escape(subject)
    << "</subject_name>\n"
       "      <validity>\n"
       "        <not_before>"
    << not_before << "</not_before>\n        <not_after>" << not_after
    << "</not_after>\n"
       "      </validity>\n"
       "      <allow_rule>\n"
    << domains_xml("        ");
  auto list = [&o](const char *tag, const std::vector<std::string_view> &names) {
    if (names.empty()) return;
    o << "        <" << tag << ">\n          <topics>\n";
    // Each topic under both namings (--naming ros2: docs/ros2.md), so one security directory
    // serves a network of either.
    for (auto n : names)
      for (TopicNaming naming : {TopicNaming::netkf, TopicNaming::ros2})
        o << "            <topic>" << xml_escape(dds_topic_name(n, naming)) << "</topic>\n";
    o << "          </topics>\n        </" << tag << ">\n";
  };
  list("publish", policy.publish);
  list("subscribe", policy.subscribe);
  o << "      </allow_rule>\n"
       "      <default>DENY</default>\n"
       "    </grant>\n"
       "  </permissions>\n"
       "</dds>\n";
  return o.str();
}

}  // namespace netkf::dds
