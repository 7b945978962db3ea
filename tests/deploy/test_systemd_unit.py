"""deploy/: the install layout and the systemd unit template (ctest label deploy; no DDS).

1. `cmake --install` of the build tree into a temporary prefix lays out what the unit runs:
   bin/netkf resolves to libexec/netkf/cli/netkf, and the node executables sit where the CLI
   looks for them (cli/launch/launch_supervisor.cpp: the directory above the CLI's, then <node>);
   scenarios, DDS profiles, example environment files, the unit and its sysusers entry.
2. The installed netkf@.service runs that prefix's netkf.
3. `systemd-analyze verify` (and `security --offline`, exposure below 4) on the template instantiated as netkf@test.service (a copy whose
   environment file is a test one): exit 0 and not one message about our unit. The same check
   on a copy with a mistake (a missing ExecStart binary, an unknown key) does report it, so
   the check can fail.
Environment: NETKF_BUILD_DIR (the build tree), NETKF_CMAKE (cmake), NETKF_SYSTEMD_ANALYZE."""
import os
import shutil
import subprocess
import sys
import tempfile

failures = []


def check(ok, message):
    print(("  ok: " if ok else "  FAILED: ") + message, flush=True)
    if not ok:
        failures.append(message)


build = os.environ["NETKF_BUILD_DIR"]
cmake = os.environ.get("NETKF_CMAKE", "cmake")
analyze = os.environ.get("NETKF_SYSTEMD_ANALYZE") or shutil.which("systemd-analyze")
if not analyze:
    print("systemd-analyze not found: install systemd (scripts/deps.sh)")
    sys.exit(1)
tmp = tempfile.mkdtemp(prefix="netkf-deploy-")
prefix = os.path.join(tmp, "prefix")

# ---- 1. the install layout
r = subprocess.run([cmake, "--install", build, "--prefix", prefix], capture_output=True, text=True)
print(r.stdout[-3000:], r.stderr[-3000:], flush=True)
check(r.returncode == 0, "cmake --install into a temporary prefix (rc=%d)" % r.returncode)
cli_link = os.path.join(prefix, "bin", "netkf")
cli_real = os.path.join(prefix, "libexec", "netkf", "cli", "netkf")
check(os.path.islink(cli_link) and os.path.realpath(cli_link) == os.path.realpath(cli_real)
      and os.access(cli_real, os.X_OK), "bin/netkf is a link to libexec/netkf/cli/netkf")
# Where the CLI looks for its nodes, from its resolved path: two directories up, then <node>.
node_root = os.path.dirname(os.path.dirname(os.path.realpath(cli_link)))
for node in ("plant_node", "sensor_node", "channel_emulator", "estimator_node"):
    path = os.path.join(node_root, node)
    check(os.path.isfile(path) and os.access(path, os.X_OK), "%s installed where netkf finds it" % node)
share = os.path.join(prefix, "share", "netkf")
for rel in ("scenarios/default.yaml", "scenarios/sinopoli-scalar.yaml", "dds/localhost.xml", "dds/discovery-server.xml",
            "dds/cyclonedds-localhost.xml", "systemd/host-a.env", "systemd/host-b.env", "systemd/host-c.env"):
    check(os.path.isfile(os.path.join(share, rel)), "share/netkf/%s installed" % rel)
check(os.path.isfile(os.path.join(prefix, "lib", "sysusers.d", "netkf.conf")), "lib/sysusers.d/netkf.conf installed")
r = subprocess.run([cli_link, "--help"], capture_output=True, text=True)
check(r.returncode == 0 and "launch" in r.stdout, "the installed netkf runs (netkf --help lists launch)")

# ---- 2. the installed unit runs the installed CLI
unit_path = os.path.join(prefix, "lib", "systemd", "system", "netkf@.service")
unit = open(unit_path).read() if os.path.isfile(unit_path) else ""
exec_lines = [l for l in unit.splitlines() if l.startswith("ExecStart=")]
check(len(exec_lines) == 1 and exec_lines[0].startswith("ExecStart=%s launch " % cli_link),
      "the installed unit's ExecStart runs %s (%s)" % (cli_link, exec_lines))
check("EnvironmentFile=/etc/netkf/%i.env" in unit.splitlines(), "the instance names /etc/netkf/INSTANCE.env")

# ---- 3. systemd-analyze verify, on a copy whose environment file is a test one
units = os.path.join(tmp, "units")
os.makedirs(units)
env_file = os.path.join(tmp, "test.env")
with open(env_file, "w") as f:
    f.write("NETKF_SCENARIO=%s\nNETKF_ROLES=plant,sensors\nNETKF_DOMAIN=7\n"
            "NETKF_DISCOVERY=--serve-discovery 127.0.0.1:11811\nNETKF_EXTRA=--dashboard off\n"
            % os.path.join(share, "scenarios", "default.yaml"))


def verify(text):
    with open(os.path.join(units, "netkf@.service"), "w") as f:
        f.write(text)
    r = subprocess.run([analyze, "verify", os.path.join(units, "netkf@test.service")], capture_output=True, text=True,
                       env=dict(os.environ, SYSTEMD_LOG_COLOR="0"))
    out = (r.stdout + r.stderr).splitlines()
    # Messages about other units (e.g. the host's own) are not ours to judge.
    ours = [l for l in out if "netkf@" in l]
    return r.returncode, ours, out


test_unit = unit.replace("EnvironmentFile=/etc/netkf/%i.env", "EnvironmentFile=%s" % env_file)
check(test_unit != unit, "the test copy reads the test environment file")
rc, ours, out = verify(test_unit)
print("systemd-analyze verify netkf@test.service:\n    " + "\n    ".join(out or ["(no output)"]), flush=True)
check(rc == 0 and not ours, "systemd-analyze verify: exit 0 and no message about netkf@ (rc=%d, %d messages)"
      % (rc, len(ours)))

# The hardening, as systemd rates it (0 = fully locked down .. 10 = unprotected; 3.4 when
# written): keep it below 4 ("OK") so a lost directive shows.
r = subprocess.run([analyze, "security", "--offline=true", os.path.join(units, "netkf@test.service")],
                   capture_output=True, text=True, env=dict(os.environ, SYSTEMD_LOG_COLOR="0", SYSTEMD_COLORS="0"))
level = [l for l in r.stdout.splitlines() if "Overall exposure level" in l]
print("\n".join(level) or r.stdout[-2000:] + r.stderr[-2000:], flush=True)
try:
    exposure = float(level[0].split(":")[1].split()[0])
except (IndexError, ValueError):
    exposure = None
check(exposure is not None and exposure < 4.0, "systemd-analyze security rates the unit's exposure below 4 (%s)" % exposure)

broken = test_unit.replace(cli_link, os.path.join(prefix, "bin", "no-such-netkf")).replace(
    "KillMode=mixed", "KillMode=mixed\nNoSuchKey=1")
rc, ours, out = verify(broken)
check(rc != 0 and any("no-such-netkf" in l for l in ours) and any("NoSuchKey" in l for l in ours),
      "the same check reports a unit with a missing binary and an unknown key (rc=%d: %s)" % (rc, ours))

if failures:
    print("%d expectation(s) failed; files kept in %s" % (len(failures), tmp))
    sys.exit(1)
shutil.rmtree(tmp, ignore_errors=True)
print("all expectations met")
