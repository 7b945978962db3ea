#pragma once
// DDS Security (Fast DDS builtin plugins: PKI-DH authentication,
// Access-Permissions, AES-GCM-GMAC crypto). One directory made by `netkf
// security init DIR` holds a CA, one identity per role and the signed
// governance and permissions; each process uses its role's identity.
//
// Layout of DIR (security_files):
//   ca/cert.pem, ca/key.pem                 the CA (identity CA and permissions
//   CA) governance.xml, governance.p7s          the domain's rules, and the
//   same signed by the CA identities/<role>/cert.pem, key.pem     the role's
//   certificate (signed by the CA) and key permissions/<role>.xml, <role>.p7s
//   what the role may publish/subscribe, signed by the CA
//
// The role table (role_policies) is built from the topic constants of
// topics.hpp: it is the only place that says which role writes which topic.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace netkf::dds {

/// The identities `security init` creates. plant/sensor/channel/estimator: the
/// node processes; ctl: `netkf ctl set-link` and a launch serving the dashboard
/// (which retunes links); observer: `netkf record`, `netkf ctl status`, a
/// launch without dashboard (read only).
enum class Role { plant, sensor, channel, estimator, ctl, observer };

std::string_view role_name(Role r);
/// Throws DdsError for an unknown name.
Role role_from_name(std::string_view name);
const std::vector<Role> &all_roles();

/// What a role may publish and subscribe (topic names from topics.hpp).
struct RolePolicy {
  Role role;
  std::vector<std::string_view> publish;
  std::vector<std::string_view> subscribe;
};
/// The table for every role, in all_roles() order.
const std::vector<RolePolicy> &role_policies();
const RolePolicy &role_policy(Role r);
/// Every topic name of topics.hpp (the governance has one rule for each).
const std::vector<std::string_view> &all_topic_names();

/// Paths of a role's security files in DIR (absolute: Fast DDS takes file://
/// URIs).
struct SecurityFiles {
  std::filesystem::path ca_cert;
  std::filesystem::path identity_cert;
  std::filesystem::path identity_key;
  std::filesystem::path governance;   // signed (governance.p7s)
  std::filesystem::path permissions;  // signed (permissions/<role>.p7s)
};
SecurityFiles security_files(const std::filesystem::path &dir, Role role);
/// Throws DdsError naming the first file that is missing or unreadable, or the identity key
/// when its group or others may read it (with the fix: chmod 600).
void check_security_files(const SecurityFiles &files);

/// Governance document: every domain in [0, 232]; authentication and encryption
/// required, unauthenticated participants refused, join access control,
/// discovery/liveliness/RTPS protection ENCRYPT; one rule per topic (and one
/// for any other name) with read and write access control and ENCRYPT
/// data/metadata protection.
std::string governance_xml();
/// Permissions document of `role` for the certificate subject `subject` (as
/// openssl prints it with -nameopt RFC2253), valid from `not_before` to
/// `not_after` (YYYY-MM-DDThh:mm:ss, UTC). Allows exactly role_policy(role) on
/// every domain; anything else is denied.
std::string permissions_xml(Role role, const std::string &subject, const std::string &not_before,
                            const std::string &not_after);
/// The subject of a role's certificate (what `security init` asks openssl for).
std::string role_subject(Role role);

}  // namespace netkf::dds
