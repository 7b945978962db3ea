"""No packet of a default launch goes to a multicast address or leaves 127/8: capture
everything on `lo` inside the namespace during a default launch (tcpdump)."""
import ipaddress
import os
import signal
import subprocess
import time

from e2e_common import BackgroundProcess, Launch, check, finish, require_netns, workdir

require_netns()
out = workdir("loopback")
pcap = os.path.join(out, "lo.pcap")
# /sys may still show the host's interfaces (sysfs is not remounted): ask the kernel.
links = subprocess.run(["ip", "-o", "link", "show"], capture_output=True, text=True).stdout
ifaces = sorted(l.split(":")[1].strip().split("@")[0] for l in links.splitlines() if l.strip())
check(ifaces == ["lo"], "the namespace has only lo (%s)" % ifaces)
dump = BackgroundProcess(["tcpdump", "-i", "any", "-n", "-U", "-w", pcap], log=os.path.join(out, "tcpdump.log"))
time.sleep(1.0)
try:
    with Launch(None, 6, out) as run:  # the built-in default scenario
        rc = run.wait(60)
    check(rc == 0, "default launch exits 0 (rc=%s)" % rc)
finally:
    time.sleep(0.5)
    dump.stop(signal.SIGTERM, 10)
    dump.close()
r = subprocess.run(["tcpdump", "-n", "-r", pcap], capture_output=True, text=True)
lines = [l for l in r.stdout.splitlines() if " IP " in l or " IP6 " in l]
check(len(lines) > 0, "packets were captured (%d): the capture works" % len(lines))
bad = []
for l in lines:
    parts = l.split()
    try:
        i = parts.index("IP") if "IP" in parts else parts.index("IP6")
        src, dst = parts[i + 1], parts[i + 3].rstrip(":")
    except (ValueError, IndexError):
        bad.append(l)
        continue
    for addr in (src, dst):
        host = addr.rsplit(".", 1)[0] if addr.count(".") == 4 else addr
        try:
            ip = ipaddress.ip_address(host)
        except ValueError:
            bad.append(l)
            break
        if ip.is_multicast or not (ip.version == 4 and ip in ipaddress.ip_network("127.0.0.0/8")):
            bad.append(l)
            break
check(not bad, "every packet is unicast within 127/8 (%d offending)%s" % (len(bad), "".join("\n    " + b for b in bad[:5])))
finish()
