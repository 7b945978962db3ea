"""Several hosts: three network namespaces that this test creates (each its own host name, a
veth into a bridge in the test's namespace, addresses 10.231.0.1-3 that exist only here), one
`netkf launch --only ...` per host over a Discovery Server that host A's launch serves:
  A: plant + sensors (--serve-discovery), B: channel, C: estimator (+ dashboard) and `netkf record`.
1. Open loop (data/groups.yaml, over 1000 periods): the truth and the samples delivered on host C
   equal a single-host run of the same scenario and seed in every period (as in sensor_groups:
   every stream is seeded per sensor and link); every period without a late sample (on either
   side; the recordings name them) fused the same samples; the estimates are equal bit for bit
   while the fused histories are, and each run's estimates are the core filter's over what it
   fused. A's --duration ends the run and B, C and the recorder end with it, all with exit 0.
2. Closed loop (the built-in default scenario): `netkf ctl` on C retunes a link of the channel on
   B and `ctl status` on C lists the processes of all three hosts (presence); a launch with
   another scenario file is refused naming the host it differs from; Ctrl-C on A's launch ends
   B and C cleanly; the state stays bounded.
A capture on the bridge shows DDS traffic between the hosts and not one multicast packet."""
import json
import os
import signal
import subprocess
import time

from e2e_common import (DATA, NETKF, BackgroundProcess, Launch, all_finite, check, contiguous, finish, last_period,
                        netkf_processes, read_periods, read_samples, require_netns, wait_for, workdir)

require_netns()
DOMAIN = int(os.environ["NETKF_DOMAIN"])
TAG = "nk%d" % os.getpid()
HOSTS = {"a": "10.231.0.1", "b": "10.231.0.2", "c": "10.231.0.3"}
SERVER = HOSTS["a"] + ":11811"
OPEN_LOOP_SECONDS = 24  # 1200 periods of 20 ms, at least 1000 recorded on both sides
out = workdir("multihost")


def sh(*cmd, check_rc=True):
    r = subprocess.run(list(cmd), capture_output=True, text=True)
    if check_rc and r.returncode != 0:
        raise RuntimeError("%s: %s" % (" ".join(cmd), r.stderr.strip()))
    return r


def on(host):
    """Run in test host `host`: its namespace, its own UTS namespace and host name, exec'd so the
    pid is the command's own."""
    return ["ip", "netns", "exec", TAG + host, "unshare", "--uts", "sh", "-c",
            'hostname "$0" && exec "$@"', "host-" + host]


def make_hosts():
    sh("sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1")  # the test's own namespace: the bridge side
    sh("ip", "link", "add", TAG + "br", "type", "bridge")
    sh("ip", "link", "set", TAG + "br", "up")
    for h, addr in HOSTS.items():
        ns = TAG + h
        sh("ip", "netns", "add", ns)
        sh("ip", "link", "add", TAG + h, "type", "veth", "peer", "name", "eth0", "netns", ns)
        sh("ip", "link", "set", TAG + h, "master", TAG + "br", "up")
        sh("ip", "netns", "exec", ns, "ip", "addr", "add", addr + "/24", "dev", "eth0")
        sh("ip", "netns", "exec", ns, "ip", "link", "set", "eth0", "up")
        sh("ip", "netns", "exec", ns, "ip", "link", "set", "lo", "up")
        # No IPv6 on the test hosts: its link-local chatter (router and neighbour solicitations)
        # is multicast from the kernel, not from DDS, and would blur the capture.
        sh("ip", "netns", "exec", ns, "sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1")


def remove_hosts():
    for h in HOSTS:
        sh("ip", "netns", "del", TAG + h, check_rc=False)
    sh("ip", "link", "del", TAG + "br", check_rc=False)


def run_multi_host(name, scenario, a_extra, body):
    """Record on C, then the launches on A (first: the plant waits for the rest), B and C; `body`
    runs while they do and ends the run; returns (launches, recorder)."""
    d = os.path.join(out, name)
    os.makedirs(d)
    common = ["--domain", str(DOMAIN), "--dashboard", "off"]
    scen = [scenario] if scenario else []
    record = BackgroundProcess(on("c") + [NETKF, "record"] + scen +
                               ["--out", os.path.join(d, "c-periods.csv"),
                                "--samples", os.path.join(d, "c-samples.csv"),
                                "--domain", str(DOMAIN), "--discovery-server", SERVER],
                               log=os.path.join(d, "record.log"), new_session=True)
    launches = {}
    launches["a"] = Launch(scenario, 0, d, record=False, name="a", prefix=on("a"),
                           extra=["--only", "plant,sensors", "--serve-discovery", SERVER] + common + a_extra)
    time.sleep(1.0)
    launches["b"] = Launch(scenario, 0, d, record=False, name="b", prefix=on("b"),
                           extra=["--only", "channel", "--discovery-server", SERVER] + common)
    launches["c"] = Launch(scenario, 0, d, record=False, name="c", prefix=on("c"),
                           extra=["--only", "estimator", "--discovery-server", SERVER, "--domain", str(DOMAIN),
                                  "--dashboard", "8470"])
    try:
        body(launches, record, d)
        rcs = {h: launches[h].wait(40) for h in launches}
        rcs["record"] = record.wait(20)
    finally:
        for launch in launches.values():
            launch.__exit__(None, None, None)
        record.kill()  # when it did not end in time
        record.close()
        print("---- record output ----\n" + record.output(), flush=True)
    return launches, record, rcs, d


def late_periods(rows, samples, last):
    """The periods (<= last) that lost a sample to its deadline, as the estimator says (each row's
    late_samples names the period of every late sample it counts), checked against the samples
    recording: a delivered sample that was not fused is late, and nothing else is."""
    said = {k for r in rows for (k, _) in r["late_samples"] if k <= last}
    seen = {s["k"] for s in samples if not s["fused"] and s["k"] <= last}
    return said, seen


def same_late_periods(said, seen, last):
    """A late sample of one of the last periods may be counted by an estimate after the recording's
    end: the two views must agree up to a few periods before it."""
    return {k for k in said if k < last - 5} == {k for k in seen if k < last - 5}


def replay(scenario, periods, samples):
    """netkf_replay: the core filter offline over the samples this recording fused."""
    r = subprocess.run([os.environ["NETKF_REPLAY"], scenario, samples, periods], capture_output=True, text=True)
    print(r.stdout, r.stderr, flush=True)
    return json.loads(r.stdout) if r.returncode == 0 else None


def compare_open_loop(scenario, reference, multi):
    """Three hosts against one, period by period. Open loop: nothing the network does reaches
    the plant, so the truth must be equal in every period and the channel's decisions (seeded
    per link and period) too. What the estimator fuses depends on time only through lateness: a
    sample that misses its deadline on one side is recorded as late there (late_samples), and
    every period without late samples must fuse the same samples. A late sample changes its
    period's estimate and, through the filter's memory, every later one: the estimates are equal
    while the fused histories are, and each run's estimates are the core filter's over what that
    run fused (netkf_replay) in every period."""
    ref_rows, rows = read_periods(reference[0], 2), read_periods(multi[0], 2)
    ref_samples, samples = read_samples(reference[1]), read_samples(multi[1])
    check(bool(rows) and rows[0]["k"] == 0, "the recording on host C starts at period 0 (the plant waited for it)")
    check(contiguous(rows) and all_finite(rows), "host C recorded every period, all finite (%d)" % len(rows))
    last = min(ref_rows[-1]["k"], rows[-1]["k"]) if ref_rows and rows else -1
    check(last + 1 >= 1000, "both runs recorded periods 0..%d (at least 1000 periods)" % last)

    def delivered(ss):
        return sorted((s["k"], s["sensor_id"], tuple(s["y"])) for s in ss if s["k"] <= last)

    check(delivered(samples) == delivered(ref_samples),
          "three hosts delivered exactly the samples of the single-host run (%d samples)" % len(delivered(samples)))
    late = set()
    for name, rr, ss in (("one host", ref_rows, ref_samples), ("three hosts", rows, samples)):
        said, seen = late_periods(rr, ss, last)
        check(same_late_periods(said, seen, last), "%s: the periods the estimator counted late samples for are those whose delivered "
              "samples were not fused (%d; %s vs %s)" % (name, len(said), sorted(said)[:10], sorted(seen)[:10]))
        late |= said | seen
    by_k, ref_by_k = {r["k"]: r for r in rows}, {r["k"]: r for r in ref_rows}
    truth_differs = [k for k in range(last + 1) if by_k[k]["x"] != ref_by_k[k]["x"]]
    check(not truth_differs, "the truth is the same in all %d periods (differs in %s)" % (last + 1, truth_differs[:10]))
    on_time = [k for k in range(last + 1) if k not in late]
    fused_differs = [k for k in on_time if by_k[k]["fused"] != ref_by_k[k]["fused"]]
    print("periods 0..%d: %d with a late sample on either side %s" % (last, len(late), sorted(late)[:20]), flush=True)
    check(not fused_differs, "in each of the %d periods without late samples, three hosts fused the samples one host "
          "fused (differs in %s)" % (len(on_time), fused_differs[:10]))
    same_history = next((k for k in range(last + 1) if by_k[k]["fused"] != ref_by_k[k]["fused"]), last + 1)
    estimate_differs = [k for k in range(same_history)
                        if (by_k[k]["xhat"], by_k[k]["trace_P"]) != (ref_by_k[k]["xhat"], ref_by_k[k]["trace_P"])]
    check(not estimate_differs, "while the fused histories are equal (%d periods), the estimates are equal bit for "
          "bit (differ in %s)" % (same_history, estimate_differs[:10]))
    for name, rec in (("one host", reference), ("three hosts", multi)):
        res = replay(scenario, *rec)
        check(res is not None and res["fused_mismatch"] == 0 and res["max_xhat_diff"] <= 1e-9 and
              res["max_trace_P_diff"] <= 1e-9, "%s: every estimate is the core filter's over the samples it fused "
              "(netkf_replay: %s)" % (name, res))


remove_hosts()
make_hosts()
capture_path = os.path.join(out, "bridge.pcap")
capture = BackgroundProcess(["tcpdump", "-i", TAG + "br", "-n", "-U", "-w", capture_path],
                            log=os.path.join(out, "tcpdump.log"), echo=False)
try:
    time.sleep(1.0)  # tcpdump listening
    # ---------------------------------------------------------------- 1. open loop
    # At least 1000 periods (20 ms each) in the range both runs recorded.
    scenario = os.path.join(DATA, "groups.yaml")
    ref_dir = os.path.join(out, "reference")
    os.makedirs(ref_dir)
    with Launch(scenario, OPEN_LOOP_SECONDS, ref_dir, samples=True, extra=["--dashboard", "off"]) as ref:
        rc = ref.wait(OPEN_LOOP_SECONDS + 60)
    check(rc == 0, "the single-host reference run exits 0 (rc=%s)" % rc)

    def open_loop(launches, record, d):
        # A's --duration ends the run; the rest must follow by themselves.
        pass

    launches, record, rcs, d = run_multi_host("open", scenario, ["--duration", str(OPEN_LOOP_SECONDS + 2)],
                                              open_loop)
    check(rcs == {"a": 0, "b": 0, "c": 0, "record": 0}, "every launch and the recorder exit 0 (%s)" % rcs)
    a_log, b_log, c_log = (launches[h].output() for h in "abc")
    check("serving discovery on " + SERVER in a_log, "host A's launch serves discovery on " + SERVER)
    check("this host runs channel" in b_log, "host B's launch says it runs only the channel")
    check("the plant (pid" in b_log and "on host-a) ended the run" in b_log,
          "host B's launch ended because the plant on host-a ended the run")
    check("on host-a) ended the run" in c_log, "host C's launch ended with the run too")
    check("on host-a) ended the run" in record.output(), "the recorder on C ended with the run")
    compare_open_loop(scenario, (ref.record, ref.samples),
                      (os.path.join(d, "c-periods.csv"), os.path.join(d, "c-samples.csv")))

    # ---------------------------------------------------------------- 2. closed loop, steered from C
    def closed_loop(launches, record, d):
        ok = wait_for(lambda: last_period(os.path.join(d, "c-periods.csv")) >= 100, 60)
        check(ok, "the closed-loop run is under way on host C")
        r = subprocess.run(on("c") + [NETKF, "ctl", "set-link", "2", "--bernoulli", "0.3", "--domain", str(DOMAIN),
                                      "--discovery-server", SERVER, "--timeout", "15"],
                           capture_output=True, text=True, timeout=40)
        print(r.stdout, r.stderr, flush=True)
        check(r.returncode == 0 and "link 2: applied" in r.stdout,
              "`netkf ctl set-link` on host C retunes link 2 of the channel on host B (rc=%d)" % r.returncode)
        r = subprocess.run(on("c") + [NETKF, "ctl", "status", "--json", "--domain", str(DOMAIN),
                                      "--discovery-server", SERVER, "--timeout", "15"],
                           capture_output=True, text=True, timeout=40)
        try:
            status = json.loads(r.stdout)
        except ValueError:
            status = {}
        links = {link["sensor_id"]: link for link in status.get("links", [])}
        check(links.get(2, {}).get("loss") == 0.3, "ctl status on C shows link 2 at loss 0.3")
        hosts_roles = sorted({(p["host"], p["role"]) for p in status.get("processes", [])})
        print("processes:", hosts_roles, flush=True)
        for want in [("host-a", "plant"), ("host-a", "sensors"), ("host-b", "channel"), ("host-c", "estimator"),
                     ("host-c", "record"), ("host-a", "launch"), ("host-b", "launch"), ("host-c", "launch")]:
            check(want in hosts_roles, "ctl status lists %s on %s (presence)" % (want[1], want[0]))
        # The dashboard on host C shows the network of all three hosts.
        r = subprocess.run(on("c") + ["python3", "-c", "import urllib.request,sys;"
                                      "sys.stdout.write(urllib.request.urlopen('http://127.0.0.1:8470/metrics',"
                                      "timeout=10).read().decode())"], capture_output=True, text=True, timeout=30)
        check(r.returncode == 0 and "netkf_estimator_period" in r.stdout, "host C's dashboard serves /metrics with estimates")
        # Another scenario on the network's domain is refused, naming the host it differs from.
        r = subprocess.run(on("b") + [NETKF, "launch", os.path.join(DATA, "groups.yaml"), "--only", "channel",
                                      "--discovery-server", SERVER, "--domain", str(DOMAIN), "--dashboard", "off",
                                      "--status-interval", "0"], capture_output=True, text=True, timeout=60)
        print(r.stderr[-2000:], flush=True)
        check(r.returncode == 2 and "loaded another scenario" in r.stderr and "on host-" in r.stderr,
              "a launch with another scenario file exits 2 naming the host that runs the other (rc=%d)" %
              r.returncode)
        time.sleep(1.0)
        # Ctrl-C on host A ends the run everywhere.
        launches["a"].proc.send_signal(signal.SIGINT)

    launches, record, rcs, d = run_multi_host("closed", None, [], closed_loop)
    check(rcs == {"a": 0, "b": 0, "c": 0, "record": 0},
          "after Ctrl-C on host A, every launch and the recorder exit 0 (%s)" % rcs)
    check("ended the run" in launches["b"].output() and "ended the run" in launches["c"].output(),
          "hosts B and C ended because the plant on A ended the run")
    rows = read_periods(os.path.join(d, "c-periods.csv"), 2)
    check(len(rows) >= 50 and all_finite(rows), "the closed loop ran %d periods, all finite" % len(rows))
    a_log = launches["a"].output()
    check("exceeds plant.state_bound" not in a_log and "ended the run: stopped" in launches["b"].output(),
          "the closed loop stayed within the state bound until Ctrl-C stopped it")
    check(wait_for(lambda: not netkf_processes(DOMAIN), 10), "no netkf process is left on domain %d" % DOMAIN)
finally:
    capture.stop(signal.SIGINT, 10)
    capture.close()
    remove_hosts()


def count(expression):
    r = subprocess.run(["tcpdump", "-n", "-r", capture_path, expression], capture_output=True, text=True)
    return len([line for line in r.stdout.splitlines() if line.strip()])


between_hosts = count("udp and src net 10.231.0.0/24 and dst net 10.231.0.0/24")
check(between_hosts > 1000, "DDS traffic crossed the bridge between the hosts (%d UDP packets)" % between_hosts)
# DDS would multicast over UDP (SPDP to 239.255.0.1), after its socket joined the group (IGMP
# from the host's address). The kernel's own IGMP/IPv6 chatter when an interface comes up (from
# 0.0.0.0 or ::) is not DDS and is not counted.
multicast = count("udp and (dst net 224.0.0.0/4 or dst host 255.255.255.255 or dst host 10.231.0.255)")
check(multicast == 0, "not one UDP multicast or broadcast packet on the bridge (%d)" % multicast)
joins = count("igmp and not src host 0.0.0.0")
check(joins == 0, "no host joined a multicast group (%d IGMP reports from a host address)" % joins)
finish()
