// `netkf security init DIR`: a CA, one identity per role, signed governance and
// permissions for DDS Security (layout in netkf/dds/security.hpp). Every key,
// certificate and signature is made by the openssl command (a child process):
// no cryptography is written here.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/dds/security.hpp"

namespace netkf::cli {

namespace {

namespace fs = std::filesystem;

struct SecurityInitOptions {
  std::string dir;
  bool force = false;
  int days = 365;
};

/// A failure with its exit code (2: bad usage/input, 1: the tool failed).
struct InitError {
  int code;
  std::string message;
};

/// The openssl executable on PATH, or empty.
std::string find_openssl() {
  const char *path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const auto end = dirs.find(':', start);
    const std::string d = dirs.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!d.empty()) {
      const fs::path candidate = fs::path(d) / "openssl";
      if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return {};
}

/// Run openssl with `args`; its output (stdout and stderr together). Throws
/// InitError when it does not exit 0, with what it printed.
std::string run_openssl(const std::string &openssl, const std::vector<std::string> &args) {
  int fds[2];
  if (pipe(fds) != 0) throw InitError{1, std::string("pipe: ") + std::strerror(errno)};
  const pid_t pid = fork();
  if (pid < 0) throw InitError{1, std::string("fork: ") + std::strerror(errno)};
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    close(fds[0]);
    close(fds[1]);
    std::vector<char *> argv{const_cast<char *>(openssl.c_str())};
    for (const auto &a : args) argv.push_back(const_cast<char *>(a.c_str()));
    argv.push_back(nullptr);
    execv(openssl.c_str(), argv.data());
    _exit(127);
  }
  close(fds[1]);
  std::string out;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(fds[0], buf, sizeof buf);
    if (n > 0)
      out.append(buf, static_cast<std::size_t>(n));
    else if (n == 0 || errno != EINTR)
      break;
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::string cmd = "openssl";
    for (const auto &a : args) cmd += " " + a;
    throw InitError{1, "'" + cmd + "' failed:\n" + out};
  }
  return out;
}

void write_file(const fs::path &p, const std::string &text) {
  std::ofstream out(p, std::ios::trunc);
  out << text;
  out.close();  // a full disk is seen here, not lost in the destructor
  if (!out) throw InitError{1, "cannot write " + p.string() + ": " + std::strerror(errno)};
}

/// UTC time as the permissions' validity wants it: YYYY-MM-DDThh:mm:ss.
std::string utc_text(std::chrono::system_clock::time_point t) {
  const std::time_t tt = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

/// A random positive certificate serial (hex): each certificate gets its own.
std::string random_serial() {
  std::random_device rd;
  char buf[40];
  std::snprintf(buf, sizeof buf, "0x%07x%08x%08x%08x", rd() & 0x7ffffff, rd(), rd(), rd());
  return buf;
}

/// "subject=CN=netkf-sensor,O=netkf\n" -> "CN=netkf-sensor,O=netkf".
std::string certificate_subject(const std::string &openssl, const fs::path &cert) {
  std::string s = run_openssl(openssl, {"x509", "-in", cert.string(), "-noout", "-subject", "-nameopt", "RFC2253"});
  if (s.rfind("subject=", 0) == 0) s = s.substr(8);
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

/// "CN=netkf-sensor,O=netkf" -> "/O=netkf/CN=netkf-sensor" (openssl -subj, most
/// significant first).
std::string subj_argument(const std::string &rfc2253) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (;;) {
    const auto comma = rfc2253.find(',', start);
    parts.push_back(rfc2253.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  std::string out;
  for (auto it = parts.rbegin(); it != parts.rend(); ++it) out += "/" + *it;
  return out;
}

/// Does `dir` hold what an earlier `security init` made (the only kind --force
/// replaces)?
bool looks_like_security_dir(const fs::path &dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "ca" / "cert.pem", ec) && fs::is_directory(dir / "identities", ec) &&
         fs::is_regular_file(dir / "governance.p7s", ec);
}

void sign(const std::string &openssl, const fs::path &ca, const fs::path &in, const fs::path &out) {
  // S/MIME, clear-signed text (-text): what the builtin Access-Permissions
  // plugin reads.
  run_openssl(openssl, {"smime", "-sign", "-text", "-in", in.string(), "-out", out.string(), "-signer",
                        (ca / "cert.pem").string(), "-inkey", (ca / "key.pem").string()});
}

void new_key(const std::string &openssl, const fs::path &key) {
  // ECDSA P-256: what the PKI-DH plugin's ECDSA-SHA256 signatures use.
  run_openssl(openssl, {"genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", key.string()});
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
}

/// The CA (identity and permissions CA in one), the signed governance, and one identity and
/// signed permissions document per role, in `tmp`. Returns the end of validity (UTC text).
std::string make_pki(const std::string &openssl, const fs::path &tmp, int days_valid) {
  const std::string days = std::to_string(days_valid);
  // The CA: identity CA and permissions CA in one.
  const fs::path ca = tmp / "ca";
  new_key(openssl, ca / "key.pem");
  run_openssl(openssl, {"req", "-new", "-x509", "-sha256", "-days", days, "-key", (ca / "key.pem").string(), "-subj",
                        "/O=netkf/CN=netkf CA", "-set_serial", random_serial(), "-addext",
                        "basicConstraints=critical,CA:TRUE", "-addext",
                        "keyUsage=critical,digitalSignature,keyCertSign,cRLSign", "-out", (ca / "cert.pem").string()});
  // digitalSignature: the CA also signs the governance and permissions (S/MIME); a CA with
  // only keyCertSign fails their verification ("unsuitable certificate purpose").

  // Governance, signed.
  write_file(tmp / "governance.xml", dds::governance_xml());
  sign(openssl, ca, tmp / "governance.xml", tmp / "governance.p7s");

  // One identity and permissions document per role.
  const auto now = std::chrono::system_clock::now();
  const std::string not_before = utc_text(now - std::chrono::minutes(5));  // small clock differences
  const std::string not_after = utc_text(now + std::chrono::hours(24) * days_valid);
  for (const auto role : dds::all_roles()) {
    const std::string name(dds::role_name(role));
    const fs::path id = tmp / "identities" / name;
    fs::create_directories(id);
    new_key(openssl, id / "key.pem");
    run_openssl(openssl, {"req", "-new", "-sha256", "-key", (id / "key.pem").string(), "-subj",
                          subj_argument(dds::role_subject(role)), "-out", (id / "request.csr").string()});
    run_openssl(openssl, {"x509", "-req", "-sha256", "-days", days, "-in", (id / "request.csr").string(), "-CA",
                          (ca / "cert.pem").string(), "-CAkey", (ca / "key.pem").string(), "-set_serial",
                          random_serial(), "-out", (id / "cert.pem").string()});
    fs::remove(id / "request.csr");
    // The subject exactly as openssl wrote it into the certificate: the
    // permissions must name it.
    const std::string subject = certificate_subject(openssl, id / "cert.pem");
    const fs::path xml = tmp / "permissions" / (name + ".xml");
    write_file(xml, dds::permissions_xml(role, subject, not_before, not_after));
    sign(openssl, ca, xml, tmp / "permissions" / (name + ".p7s"));
  }
  return not_after;
}

/// What init made, and how to use it.
void print_made(const fs::path &dir, int days, const std::string &not_after) {
  std::cout << "netkf security: made " << dir.string() << " (valid " << days << " days, until " << not_after
            << " UTC)\n"
            << "  CA:          ca/cert.pem (its key ca/key.pem signs "
               "everything; keep it private)\n"
            << "  governance:  governance.p7s (authentication and encryption "
               "required)\n";
  for (const auto role : dds::all_roles()) {
    const std::string name(dds::role_name(role));
    std::cout << "  " << name << std::string(12 - name.size(), ' ') << " identities/" << name
              << "/{cert,key}.pem, permissions/" << name << ".p7s\n";
  }
  std::cout << "Use: netkf launch --secure " << dir.string() << " (and --secure on ctl, record)\n";
}

void init(const SecurityInitOptions &o) {
  const std::string openssl = find_openssl();
  if (openssl.empty())
    throw InitError{1,
                    "openssl not found on PATH: `netkf security init` runs "
                    "it to make keys and certificates "
                    "(install it, e.g. apt-get install openssl)"};
  if (o.dir.empty()) throw InitError{2, "give the directory to make (got an empty path)"};
  fs::path dir = fs::absolute(o.dir).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();  // "sec/": the directory sec
  std::error_code ec;
  // A symbolic link is not followed, kept or replaced: the directory is made where it is named.
  if (fs::is_symlink(fs::symlink_status(dir, ec)))
    throw InitError{2, dir.string() + " is a symbolic link" +
                           (fs::exists(dir, ec) ? std::string() : std::string(" to a missing path")) +
                           ": give the directory itself"};
  const fs::path parent = dir.parent_path();
  if (!fs::is_directory(parent, ec))
    throw InitError{2, "cannot make " + dir.string() + ": " + parent.string() + " is not a directory"};
  if (access(parent.c_str(), W_OK) != 0)
    throw InitError{2, "cannot make " + dir.string() + " in " + parent.string() + ": " + std::strerror(errno)};
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw InitError{2, dir.string() + " exists and is not a directory: not replaced"};
  if (fs::exists(dir, ec)) {
    const bool empty = fs::is_directory(dir, ec) && fs::is_empty(dir, ec);
    if (!empty && !o.force) throw InitError{2, dir.string() + " exists: give --force to replace it"};
    if (!empty && !looks_like_security_dir(dir))
      throw InitError{2, dir.string() +
                             " exists and is not a directory made by "
                             "`netkf security init`: not replaced"};
  }
  // Everything is made in a sibling first and moved in place at the end: an
  // interrupted or failed init leaves no half-made directory (and --force keeps
  // the old one until then).
  const fs::path tmp = dir.parent_path() / ("." + dir.filename().string() + ".tmp-" + std::to_string(getpid()));
  fs::remove_all(tmp, ec);
  struct RemoveOnExit {
    fs::path p;
    ~RemoveOnExit() {
      std::error_code e;
      fs::remove_all(p, e);
    }
  } cleanup{tmp};
  const mode_t old_umask = umask(077);  // keys and the directory: owner only
  struct RestoreUmask {
    mode_t m;
    ~RestoreUmask() { umask(m); }
  } restore{old_umask};
  if (!fs::create_directories(tmp / "ca", ec) || ec)
    throw InitError{2, "cannot make " + dir.string() + ": " + ec.message()};
  fs::create_directories(tmp / "identities");
  fs::create_directories(tmp / "permissions");
  const std::string not_after = make_pki(openssl, tmp, o.days);
  // Public files readable by the group/others as usual; keys and the directory
  // stay owner-only.
  for (const auto &entry : fs::recursive_directory_iterator(tmp)) {
    if (entry.is_regular_file() && entry.path().filename() != "key.pem")
      fs::permissions(entry.path(),
                      fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read,
                      fs::perm_options::replace);
  }

  if (fs::exists(dir, ec)) fs::remove_all(dir);  // checked above: empty, or an earlier init's
  fs::rename(tmp, dir);
  cleanup.p.clear();

  print_made(dir, o.days, not_after);
}

}  // namespace

void add_security_command(CLI::App &app) {
  auto o = std::make_shared<SecurityInitOptions>();
  auto *cmd = app.add_subcommand("security", "DDS Security: certificates, governance and permissions");
  cmd->require_subcommand(1);
  auto *init_cmd = cmd->add_subcommand("init",
                                       "Make DIR: a CA, one identity per role (plant, sensor, channel, "
                                       "estimator, ctl, observer), signed "
                                       "governance and permissions (runs openssl)");
  init_cmd->add_option("dir", o->dir, "Directory to create")->required();
  init_cmd->add_flag("--force", o->force, "Replace DIR when an earlier `security init` made it");
  init_cmd->add_option("--days", o->days, "Validity of the certificates and permissions, in days")
      ->check(CLI::Range(1, 36500))
      ->capture_default_str();
  init_cmd->callback([o] {
    try {
      init(*o);
    } catch (const InitError &e) {
      std::cerr << "netkf: error: " << e.message << "\n";
      throw CLI::RuntimeError(e.code);
    } catch (const fs::filesystem_error &e) {
      // The directory cannot be made where it is named (a read-only or special file system).
      std::cerr << "netkf: error: cannot make " << o->dir << ": " << e.code().message() << "\n";
      throw CLI::RuntimeError(2);
    } catch (const std::exception &e) {
      std::cerr << "netkf: error: " << e.what() << "\n";
      throw CLI::RuntimeError(1);
    }
  });
}

}  // namespace netkf::cli
