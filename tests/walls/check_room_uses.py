#!/usr/bin/python3
"""No DDS, CLI11 or sockets below the rooms that own them, by what the compiler read.

cmake/NetkfRoomRules.cmake refuses the links when the build is configured; this checks the
headers: for every object file of a protected target, the headers it included (ninja's
dependency log, written by the compiler) must hold none of the refused family. A library can
only use Fast DDS, CLI11 or a socket by including its headers, so this sees a use that a
header-only path (Boost's Asio and Beast come with Boost::headers) would hide from the links.

Usage: check_room_uses.py BUILD_DIR NINJA RULE=TARGET,TARGET... [RULE=...]
with RULE one of NO_DDS, NO_CLI11, NO_SOCKETS.
"""
import re
import subprocess
import sys

FAMILIES = {
    "NO_DDS": re.compile(r"/(fastdds|fastrtps|fastcdr)/"),
    "NO_CLI11": re.compile(r"/CLI/[^/]+\.hpp$"),
    # Asio's event loop (timers, signals: the nodes' Asio thread) includes the system's socket
    # headers itself; a socket is Asio's ip/ or socket API, or Beast (HTTP, WebSocket).
    "NO_SOCKETS": re.compile(r"/boost/beast/|/boost/asio/ip/|/boost/asio/(basic_)?(stream_|datagram_|raw_)?socket"),
}
OBJECT = re.compile(r"^(\S+\.o): #deps")
TARGET = re.compile(r"CMakeFiles/([A-Za-z0-9_]+)\.dir/")


def object_headers(build_dir, ninja):
    """{object: [headers]} from ninja's dependency log."""
    out = subprocess.run([ninja, "-C", build_dir, "-t", "deps"], capture_output=True, text=True, check=True).stdout
    deps, current = {}, None
    for line in out.splitlines():
        m = OBJECT.match(line)
        if m:
            current = m.group(1)
            deps[current] = []
        elif line.startswith("    ") and current:
            deps[current].append(line.strip())
        else:
            current = None
    return deps


def main():
    build_dir, ninja, rules = sys.argv[1], sys.argv[2], sys.argv[3:]
    deps = object_headers(build_dir, ninja)
    failures, checked = [], {}
    for rule in rules:
        name, _, targets = rule.partition("=")
        family = FAMILIES[name]
        protected = set(t for t in targets.split(",") if t)
        for obj, headers in deps.items():
            m = TARGET.search(obj)
            if not m or m.group(1) not in protected:
                continue
            checked.setdefault(name, set()).add(m.group(1))
            bad = [h for h in headers if family.search(h)]
            if bad:
                failures.append(f"{name}: {obj} includes {bad[0]}" + (f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""))
    for name in FAMILIES:
        # A rule that checked nothing is a broken test, not a pass (e.g. an empty dependency log).
        if name in [r.partition("=")[0] for r in rules] and not checked.get(name):
            failures.append(f"{name}: no object file of its targets was found in the dependency log")
    for name, targets in sorted(checked.items()):
        print(f"{name}: {len(targets)} targets checked: {' '.join(sorted(targets))}")
    for f in failures:
        print("FAIL:", f)
    print("room uses: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
