// DDS Security: the generated governance and permissions (parsed as XML, checked against the
// intended role table), `netkf security init` (files openssl verifies, key modes, refusals),
// and secured participants over real Fast DDS (runs in a private network namespace).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tinyxml2.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/dds/dds.hpp"

namespace fs = std::filesystem;
namespace nd = netkf::dds;
using netkf::dds::Role;

namespace {

std::set<std::string> topic_list(tinyxml2::XMLElement* rule, const char* kind) {
  std::set<std::string> out;
  for (auto* k = rule->FirstChildElement(kind); k; k = k->NextSiblingElement(kind))
    for (auto* t = k->FirstChildElement("topics")->FirstChildElement("topic"); t; t = t->NextSiblingElement("topic"))
      out.insert(t->GetText());
  return out;
}

/// Run `netkf security ARGS...` in-process; the command's exit code.
int security_cli(std::vector<std::string> args) {
  CLI::App app;
  netkf::cli::add_security_command(app);
  std::vector<const char*> argv{"netkf", "security"};
  for (const auto& a : args) argv.push_back(a.c_str());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    return 2;
  }
  return 0;
}

fs::path fresh_dir(const std::string& name) {
  auto d = fs::temp_directory_path() / ("netkf-test-security-" + std::to_string(getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d.parent_path());
  return d;
}

int sh(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()); }

}  // namespace

// The intended table, written out here on purpose: the generated permissions must match it.
TEST(SecurityPolicy, PermissionsAllowExactlyTheIntendedTopics) {
  // Presence: every role announces itself and reads who else takes part.
  const std::string presence = "netkf/presence";
  // A sensor process of several sensors sends batches (docs/interop.md, "Batches").
  const std::string raw = "netkf/measurement/raw", raw_batch = "netkf/measurement/raw_batch";
  const std::string delivered = "netkf/measurement/delivered", delivered_batch = "netkf/measurement/delivered_batch";
  const std::set<std::string> observed{"netkf/truth",      "netkf/estimate",    delivered,          delivered_batch,
                                       "netkf/link/status", "netkf/link/change", "netkf/link/reply", presence};
  const std::map<Role, std::pair<std::set<std::string>, std::set<std::string>>> intended{
      {Role::plant, {{"netkf/truth", "netkf/tick", presence}, {"netkf/control", presence}}},
      {Role::sensor, {{raw, raw_batch, presence}, {"netkf/truth", presence}}},
      {Role::channel,
       {{delivered, delivered_batch, "netkf/link/status", "netkf/link/reply", "netkf/link/change", presence},
        {raw, raw_batch, "netkf/link/control", presence}}},
      {Role::estimator,
       {{"netkf/estimate", "netkf/control", presence}, {"netkf/tick", delivered, delivered_batch, presence}}},
      {Role::ctl, {{"netkf/link/control", presence}, observed}},
      {Role::observer, {{presence}, observed}},
  };
  ASSERT_EQ(nd::all_roles().size(), intended.size());
  // Each also under its ROS 2 name (--naming ros2: "rt/" before it, as rmw names a topic).
  const auto with_ros2_names = [](const std::set<std::string>& names) {
    std::set<std::string> both = names;
    for (const auto& n : names) both.insert("rt/" + n);
    return both;
  };
  for (auto [role, netkf_topics] : intended) {
    const std::pair<std::set<std::string>, std::set<std::string>> topics{with_ros2_names(netkf_topics.first),
                                                                         with_ros2_names(netkf_topics.second)};
    SCOPED_TRACE(std::string(nd::role_name(role)));
    const std::string xml =
        nd::permissions_xml(role, nd::role_subject(role), "2020-01-01T00:00:00", "2030-01-01T00:00:00");
    tinyxml2::XMLDocument doc;
    ASSERT_EQ(doc.Parse(xml.c_str()), tinyxml2::XML_SUCCESS) << xml;
    auto* grant = doc.FirstChildElement("dds")->FirstChildElement("permissions")->FirstChildElement("grant");
    ASSERT_NE(grant, nullptr);
    EXPECT_EQ(std::string(grant->FirstChildElement("subject_name")->GetText()), nd::role_subject(role));
    EXPECT_EQ(std::string(grant->FirstChildElement("default")->GetText()), "DENY");
    auto* allow = grant->FirstChildElement("allow_rule");
    ASSERT_NE(allow, nullptr);
    EXPECT_EQ(grant->FirstChildElement("deny_rule"), nullptr);
    EXPECT_EQ(topic_list(allow, "publish"), topics.first);
    EXPECT_EQ(topic_list(allow, "subscribe"), topics.second);
  }
  // Only ctl may write link control.
  for (Role r : nd::all_roles()) {
    const auto& p = nd::role_policy(r).publish;
    const bool writes = std::find(p.begin(), p.end(), nd::topics::link_control.name) != p.end();
    EXPECT_EQ(writes, r == Role::ctl) << nd::role_name(r);
  }
}

TEST(SecurityPolicy, GovernanceRequiresAuthenticationAndEncryptsEveryTopic) {
  tinyxml2::XMLDocument doc;
  const std::string xml = nd::governance_xml();
  ASSERT_EQ(doc.Parse(xml.c_str()), tinyxml2::XML_SUCCESS) << xml;
  auto* rule = doc.FirstChildElement("dds")->FirstChildElement("domain_access_rules")->FirstChildElement("domain_rule");
  ASSERT_NE(rule, nullptr);
  auto text = [](tinyxml2::XMLElement* e, const char* name) {
    return std::string(e->FirstChildElement(name)->GetText());
  };
  EXPECT_EQ(text(rule, "allow_unauthenticated_participants"), "false");
  EXPECT_EQ(text(rule, "enable_join_access_control"), "true");
  EXPECT_EQ(text(rule, "discovery_protection_kind"), "ENCRYPT");
  EXPECT_EQ(text(rule, "liveliness_protection_kind"), "ENCRYPT");
  EXPECT_EQ(text(rule, "rtps_protection_kind"), "ENCRYPT");
  std::vector<std::string> expressions;
  for (auto* t = rule->FirstChildElement("topic_access_rules")->FirstChildElement("topic_rule"); t;
       t = t->NextSiblingElement("topic_rule")) {
    expressions.push_back(text(t, "topic_expression"));
    EXPECT_EQ(text(t, "enable_read_access_control"), "true");
    EXPECT_EQ(text(t, "enable_write_access_control"), "true");
    EXPECT_EQ(text(t, "data_protection_kind"), "ENCRYPT");
    EXPECT_EQ(text(t, "metadata_protection_kind"), "ENCRYPT");
  }
  std::vector<std::string> expected(nd::all_topic_names().begin(), nd::all_topic_names().end());
  expected.push_back("*");  // last: any other topic is access-controlled too
  EXPECT_EQ(expressions, expected);
}

TEST(SecurityInit, MakesFilesOpensslVerifies) {
  const auto dir = fresh_dir("init");
  ASSERT_EQ(security_cli({"init", dir.string(), "--days", "30"}), 0);
  const std::string ca = (dir / "ca" / "cert.pem").string();
  EXPECT_EQ(sh("openssl smime -verify -in " + (dir / "governance.p7s").string() + " -CAfile " + ca + " -out /dev/null"),
            0);
  for (Role r : nd::all_roles()) {
    SCOPED_TRACE(std::string(nd::role_name(r)));
    const auto files = nd::security_files(dir, r);
    EXPECT_NO_THROW(nd::check_security_files(files));
    EXPECT_EQ(sh("openssl verify -CAfile " + ca + " " + files.identity_cert.string()), 0);
    EXPECT_EQ(sh("openssl smime -verify -in " + files.permissions.string() + " -CAfile " + ca + " -out /dev/null"), 0);
    // The signed permissions are the generated document for the certificate's subject.
    EXPECT_EQ(sh("openssl smime -verify -in " + files.permissions.string() + " -CAfile " + ca +
                 " | grep -q '<subject_name>" + nd::role_subject(r) + "</subject_name>'"),
              0);
    EXPECT_EQ(sh("openssl x509 -in " + files.identity_cert.string() +
                 " -noout -subject -nameopt RFC2253 | grep -qx 'subject=" + nd::role_subject(r) + "'"),
              0);
    struct stat st {};
    ASSERT_EQ(stat(files.identity_key.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0600u);
  }
  // A certificate of another CA does not verify against this one.
  const auto other = fresh_dir("other");
  ASSERT_EQ(security_cli({"init", other.string()}), 0);
  EXPECT_NE(sh("openssl verify -CAfile " + ca + " " + nd::security_files(other, Role::ctl).identity_cert.string()), 0);

  // An existing directory is kept unless --force; --force replaces it (a new CA).
  std::ifstream old_ca_in(ca);
  const std::string old_ca((std::istreambuf_iterator<char>(old_ca_in)), {});
  EXPECT_EQ(security_cli({"init", dir.string()}), 2);
  EXPECT_EQ(security_cli({"init", dir.string(), "--force"}), 0);
  std::ifstream new_ca_in(ca);
  EXPECT_NE(std::string((std::istreambuf_iterator<char>(new_ca_in)), {}), old_ca);
  // --force does not delete a directory that `security init` did not make.
  const auto foreign = fresh_dir("foreign");
  fs::create_directories(foreign);
  std::ofstream(foreign / "precious.txt") << "x";
  EXPECT_EQ(security_cli({"init", foreign.string(), "--force"}), 2);
  EXPECT_TRUE(fs::exists(foreign / "precious.txt"));
  fs::remove_all(dir.parent_path());
}

// Paths that cannot be made are exit 2 with a sentence (they were exit 1 with a raw
// "filesystem error"); a symbolic link is neither followed nor replaced.
TEST(SecurityInit, UnusablePathsAreRefusedClearly) {
  const auto base = fresh_dir("paths");
  fs::create_directories(base);
  fs::create_symlink(base / "nowhere", base / "dangling");
  fs::create_directories(base / "real");
  fs::create_symlink(base / "real", base / "link");
  std::ofstream(base / "file") << "x";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "empty path"},
      {"/proc/netkf-security-test", "cannot make /proc/netkf-security-test"},
      {(base / "dangling").string(), "is a symbolic link to a missing path"},
      {(base / "link").string(), "is a symbolic link"},
      {(base / "file").string(), "exists and is not a directory"},
      {(base / "file" / "sub").string(), "is not a directory"},
  };
  for (const auto& [dir, says] : cases) {
    SCOPED_TRACE(dir);
    testing::internal::CaptureStderr();
    const int rc = security_cli({"init", dir});
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_EQ(rc, 2);
    EXPECT_NE(err.find(says), std::string::npos) << err;
    EXPECT_EQ(err.find("filesystem error"), std::string::npos) << err;
  }
  EXPECT_TRUE(fs::is_symlink(base / "dangling"));
  EXPECT_FALSE(fs::exists(base / "nowhere"));
  EXPECT_TRUE(fs::is_empty(base / "real"));
  // "DIR/" is the directory DIR.
  ASSERT_EQ(security_cli({"init", (base / "made").string() + "/", "--days", "2"}), 0);
  EXPECT_TRUE(fs::is_regular_file(base / "made" / "governance.p7s"));
  // A private key others may read is refused, naming the key and the fix.
  const auto files = nd::security_files(base / "made", Role::plant);
  for (const auto mode : {fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read,
                          fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read}) {
    fs::permissions(files.identity_key, mode, fs::perm_options::replace);
    try {
      nd::check_security_files(files);
      ADD_FAILURE() << "a key readable by others was taken";
    } catch (const nd::DdsError& e) {
      EXPECT_NE(std::string(e.what()).find("chmod 600 " + files.identity_key.string()), std::string::npos) << e.what();
    }
  }
  fs::permissions(files.identity_key, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  EXPECT_NO_THROW(nd::check_security_files(files));
  fs::remove_all(base.parent_path());
}

TEST(SecurityInit, MissingOpensslIsAClearError) {
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  ::setenv("PATH", "/nonexistent", 1);
  testing::internal::CaptureStderr();
  const int rc = security_cli({"init", fresh_dir("no-openssl").string()});
  const std::string err = testing::internal::GetCapturedStderr();
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(err.find("openssl not found"), std::string::npos) << err;
}

TEST(SecurityParticipant, MissingIdentityFileIsNamed) {
  nd::ParticipantOptions o;
  o.domain = 93;
  o.security = nd::ParticipantOptions::Security{fresh_dir("absent"), Role::sensor};
  try {
    nd::Participant p(o);
    FAIL() << "a participant was created without its security files";
  } catch (const nd::DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("ca/cert.pem"), std::string::npos) << e.what();
  }
}

// Real Fast DDS: a secured sensor reaches a secured channel; an unsecured reader gets nothing;
// a sensor identity cannot create a link-control writer.
TEST(SecurityParticipant, OnlyAuthenticatedPeersExchangeSamples) {
  const auto dir = fresh_dir("peers");
  ASSERT_EQ(security_cli({"init", dir.string()}), 0);
  auto options = [&](const char* name, std::optional<Role> role) {
    nd::ParticipantOptions o;
    o.domain = 93;
    o.name = name;
    if (role) o.security = nd::ParticipantOptions::Security{dir, *role};
    return o;
  };
  nd::Participant sensor(options("sensor", Role::sensor));
  nd::Participant channel(options("channel", Role::channel));
  nd::Participant outsider(options("outsider", std::nullopt));
  std::atomic<int> secured_rx{0}, outsider_rx{0};
  nd::Reader<netkf::wire::Measurement> rx(channel, nd::topics::raw_measurement, [&](netkf::wire::Measurement&&) { ++secured_rx; });
  nd::Reader<netkf::wire::Measurement> spy(outsider, nd::topics::raw_measurement,
                                     [&](netkf::wire::Measurement&&) { ++outsider_rx; });
  nd::Writer<netkf::wire::Measurement> tx(sensor, nd::topics::raw_measurement);
  ASSERT_TRUE(tx.wait_for_matched(1, std::chrono::seconds(20)));
  for (int k = 0; k < 20; ++k) tx.write(nd::make_measurement(1, k, nd::steady_now_ns(), netkf::Vector::Ones(1)));
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (secured_rx < 20 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(secured_rx.load(), 20);
  EXPECT_EQ(tx.matched(), 1);  // the channel only
  EXPECT_EQ(outsider_rx.load(), 0);
  EXPECT_THROW(nd::Writer<netkf::wire::LinkControl>(sensor, nd::topics::link_control), nd::DdsError);
  fs::remove_all(dir.parent_path());
}
