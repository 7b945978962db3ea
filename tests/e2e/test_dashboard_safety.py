"""The dashboard's safety rules and limits from the outside (docs/dashboard.md, "Safety" and
"Limits"), with Python sockets as the clients:
- `--dashboard off` opens no port at all;
- a taken port is a clear error naming the flag, before any process starts (exit 2);
- `--dashboard-bind ADDR` listens there and requires the token printed at start; with
  `--dashboard-max-connections 4` and four WebSocket clients, a fifth connection is refused at
  once (503) and counted;
- the WebSocket is only on `/` and needs a valid Sec-WebSocket-Key (404, 400); refused traffic
  (foreign origins, bad keys, refused JSON, bad frames) is counted on /metrics and logged at a
  throttled rate;
- 5000 setParameters of one link in a burst: every request gets one answer (applied, or
  superseded by a newer one), and the applied ones are exactly the changes the launch logs and
  its journal (--record FILE.events.yaml) holds;
- 10 000 idle connections leave the launch's supervision (kill -9 of a sensor: restarted),
  /metrics and the page working: the launch holds at most its cap of descriptors for them, the
  excess is closed and counted, and the server closes every idle one;
- a request trickled byte by byte ("slowloris") and an idle keep-alive connection are closed
  by the server (within twice their documented timeouts, 10 s and 5 s).
Only addresses of the test's own network namespace are used (127.0.0.0/8 on its lo).
"""
import base64
import hashlib
import json
import os
import re
import resource
import select
import signal
import socket
import struct
import subprocess
import time
import urllib.error
import urllib.request

import yaml

from e2e_common import NETKF, Launch, check, finish, require_netns, wait_for, workdir


def listening():
    return subprocess.run(["ss", "-ltnH"], capture_output=True, text=True).stdout


def status_of(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


def fetch(url):
    with urllib.request.urlopen(url, timeout=20) as r:
        return r.status, r.read().decode()


def metric(text, name, **labels):
    """The value of one series of a Prometheus text page (None when absent)."""
    want = ",".join('%s="%s"' % kv for kv in sorted(labels.items()))
    for line in text.splitlines():
        m = re.match(r"^([a-z_]+)(?:\{([^}]*)\})? (\S+)$", line)
        if m and m.group(1) == name and ",".join(sorted((m.group(2) or "").split(","))) == want:
            return float(m.group(3))
    return None


WS_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


class MiniWebSocket:
    """A minimal RFC 6455 client on a plain socket: the handshake, masked text frames, and the
    server's frames (text, binary, ping, close); enough for foxglove.websocket.v1's JSON."""

    def __init__(self, port, target="/", key=None, origin=None, host="127.0.0.1"):
        self.sock = socket.create_connection((host, port), timeout=30)
        self.key = key if key is not None else base64.b64encode(os.urandom(16)).decode()
        req = ("GET %s HTTP/1.1\r\nHost: %s:%d\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
               "Sec-WebSocket-Key: %s\r\nSec-WebSocket-Version: 13\r\n"
               "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n" % (target, host, port, self.key))
        if origin:
            req += "Origin: %s\r\n" % origin
        self.sock.sendall((req + "\r\n").encode())
        self.buf = b""
        while b"\r\n\r\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                break
            self.buf += chunk
        head, _, self.buf = self.buf.partition(b"\r\n\r\n")
        lines = head.decode(errors="replace").split("\r\n")
        self.status = int(lines[0].split(" ")[1]) if lines[0].startswith("HTTP/") else 0
        self.headers = {k.strip().lower(): v.strip() for k, _, v in (l.partition(":") for l in lines[1:])}
        self.body = self.buf.decode(errors="replace") if self.status != 101 else ""
        expected = base64.b64encode(hashlib.sha1((self.key + WS_GUID).encode()).digest()).decode()
        self.accepted = self.status == 101 and self.headers.get("sec-websocket-accept") == expected

    def send_frame(self, opcode, payload, masked=True):
        head = bytes([0x80 | opcode])
        n = len(payload)
        mask_bit = 0x80 if masked else 0
        if n < 126:
            head += bytes([mask_bit | n])
        elif n < 65536:
            head += bytes([mask_bit | 126]) + struct.pack(">H", n)
        else:
            head += bytes([mask_bit | 127]) + struct.pack(">Q", n)
        if masked:
            mask = os.urandom(4)
            payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
            head += mask
        self.sock.sendall(head + payload)

    def send_text(self, text):
        self.send_frame(0x1, text.encode())

    def _read(self, n):
        while len(self.buf) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError("the server closed the connection")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def recv(self):
        """(opcode, payload) of the next message (its fragments joined) or close frame; pings
        are answered."""
        message, first = b"", None
        while True:
            b0, b1 = self._read(2)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._read(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._read(8))[0]
            payload = self._read(n)
            opcode = b0 & 0x0F
            if opcode == 0x9:
                self.send_frame(0xA, payload)
                continue
            if opcode >= 0x8:  # close (or an unsolicited pong)
                if opcode == 0x8:
                    return opcode, payload
                continue
            first = opcode if first is None else first
            message += payload
            if b0 & 0x80:  # FIN
                return first, message

    def recv_json(self):
        while True:
            opcode, payload = self.recv()
            if opcode == 0x1:
                return json.loads(payload.decode())
            if opcode == 0x8:
                raise EOFError("close frame")

    def close(self):
        self.sock.close()


def handshake_status(port, **kw):
    ws = MiniWebSocket(port, **kw)
    ws.close()
    return ws.status, ws.body


def closed_by_server(sock, seconds):
    """Whether the server closes `sock` (EOF or reset) within `seconds`; what it sent is read."""
    end = time.monotonic() + seconds
    poller = select.poll()  # not select(): descriptors past 1024 (the 10 000 connections)
    poller.register(sock, select.POLLIN)
    while time.monotonic() < end:
        if not poller.poll(max(0.0, end - time.monotonic()) * 1000):
            break
        try:
            if sock.recv(65536) == b"":
                return True
        except OSError:
            return True
    return False


def warnings_of(text):
    return [l for l in text.splitlines() if "WARNING: dashboard: " in l]


require_netns()

# --dashboard off: nothing listens on TCP in this namespace while the network runs.
out = workdir("dashboard-off")
with Launch(None, 60, out, record=False, extra=["--dashboard", "off"]) as run:
    # A status line of a fused period (not the launch line's "period 10 ms").
    check(wait_for(lambda: re.search(r"^period \d+ ", run.output(), re.M) is not None, 20),
          "the network runs without a dashboard")
    check(listening().strip() == "", "no TCP port is open: %r" % listening())
    check("dashboard:" not in run.output(), "no dashboard URL is printed")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)

# A taken port: exit 2 with the flag named, and no node was started.
blocker = socket.socket()
blocker.bind(("127.0.0.1", 8470))
blocker.listen(1)
r = subprocess.run([NETKF, "launch", "--duration", "5"], capture_output=True, text=True, timeout=60)
print(r.stderr, flush=True)
check(r.returncode == 2, "a taken dashboard port ends the launch with exit 2 (rc=%d)" % r.returncode)
check("--dashboard PORT" in r.stderr and "8470" in r.stderr, "the error names the port and the flag")
check("started" not in r.stderr, "no process was started")
blocker.close()

# --dashboard-bind: the token is required on every request.
out = workdir("dashboard-bind")
with Launch(None, 60, out, record=False, extra=["--dashboard-bind", "127.0.0.2", "--dashboard", "8471",
                                                 "--dashboard-max-connections", "4"]) as run:
    check(wait_for(lambda: "dashboard: http://127.0.0.2:8471/?token=" in run.output(), 20),
          "the URL with its token is printed")
    m = re.search(r"dashboard: (http://127\.0\.0\.2:8471/\?token=([0-9a-f]+))", run.output())
    if m:
        url, token = m.group(1), m.group(2)
        check(len(token) == 32, "the token has 128 bits")
        check(status_of("http://127.0.0.2:8471/") == 401, "the page without the token: 401")
        check(status_of("http://127.0.0.2:8471/metrics") == 401, "/metrics without the token: 401")
        check(status_of("http://127.0.0.2:8471/?token=" + "0" * 32) == 401, "a wrong token: 401")
        check(status_of(url) == 200, "the page with the token: 200")
        check(status_of("http://127.0.0.2:8471/metrics?token=" + token) == 200, "/metrics with the token: 200")
        # --dashboard-max-connections 4: four WebSocket clients hold every slot (none is idle
        # HTTP to give way), so a fifth connection is refused at once with 503.
        clients = [MiniWebSocket(8471, target="/?token=" + token, host="127.0.0.2") for _ in range(4)]
        check(all(c.accepted for c in clients), "four WebSocket clients with the token are accepted")
        fifth = socket.create_connection(("127.0.0.2", 8471), timeout=20)
        fifth.settimeout(20)
        try:
            said = fifth.recv(4096).decode(errors="replace")
        except OSError as e:
            said = "error: %s" % e
        check(said.startswith("HTTP/1.1 503"), "a fifth connection is refused at once with 503: %r" % said[:60])
        fifth.close()
        clients.pop().close()  # a slot for /metrics (free once the server has seen the close)
        busy = []  # 503s while the slot was not free yet: refused and counted too
        m = wait_for(lambda: busy.append(status_of("http://127.0.0.2:8471/metrics?token=" + token)) or busy[-1] == 200, 20)
        _, text = fetch("http://127.0.0.2:8471/metrics?token=" + token) if m else (0, "")
        check(metric(text, "netkf_dashboard_connections_closed_total", reason="refused") == 1 + busy.count(503) and
              metric(text, "netkf_dashboard_connections", state="max") == 4,
              "/metrics counts the refused connection and shows the limit 4: %s" %
              [l for l in text.splitlines() if l.startswith("netkf_dashboard")])
        for c in clients:
            c.close()
    check("127.0.0.2:8471" in listening() and "127.0.0.1:8471" not in listening(), "listens on the given address only")
    # A run stopped before its first estimate is a failed run (the network never got ready).
    check(wait_for(lambda: re.search(r"^period \d+ ", run.output(), re.M) is not None, 20), "the network runs")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)

# ---- the limits of a running launch's dashboard (default port 8470, cap 256)
out = workdir("dashboard-limits")
PORT = 8470
BASE = "http://127.0.0.1:%d" % PORT
with Launch(None, 300, out, record=True) as run:
    check(wait_for(lambda: re.search(r"^period \d+ ", run.output(), re.M) is not None, 30), "the network runs")
    launch_pid = run.proc.pid

    # The WebSocket is on / only, with a valid key; the refusals are counted and logged (throttled).
    ok = MiniWebSocket(PORT)
    check(ok.accepted and ok.recv_json()["op"] == "serverInfo", "a valid handshake on / is accepted (101)")
    ok.close()
    status, body = handshake_status(PORT, target="/metrics")
    check(status == 404, "a WebSocket upgrade on /metrics is refused: %d %s" % (status, body.strip()))
    for bad_key in ("abc", "MDEyMzQ1Njc4OWFiY2Rl", "!!!!!!!!!!!!!!!!!!!!!!=="):
        status, body = handshake_status(PORT, key=bad_key)
        check(status == 400 and "Sec-WebSocket-Key" in body, "an invalid Sec-WebSocket-Key %r is refused: %d %s" %
              (bad_key, status, body.strip()))
    foreign = 40
    statuses = [handshake_status(PORT, origin="http://evil.example")[0] for _ in range(foreign)]
    check(statuses == [403] * foreign, "%d handshakes from a foreign origin: 403 each" % foreign)
    refused_requests = 1 + 3 + foreign
    ws = MiniWebSocket(PORT)
    ws.recv_json(), ws.recv_json()  # serverInfo, advertise
    ws.send_text("not json")
    ws.send_text('{"op":"nope"}')
    ws.send_frame(0x2, b"\x02\x00")
    levels = []
    while len(levels) < 3:
        m = ws.recv_json()
        if m.get("op") == "status" and m.get("level") == 2:
            levels.append(m["message"])
    check(len(levels) == 3, "refused JSON, an unknown op and a binary message get an error status each: %s" % levels)
    ws.send_frame(0x1, b'{"op":"getParameters"}', masked=False)  # a client frame must be masked
    closing = None
    try:
        while closing is None:
            opcode, payload = ws.recv()
            if opcode == 0x8:
                closing = struct.unpack(">H", payload[:2])[0] if len(payload) >= 2 else 0
    except (EOFError, OSError):
        pass
    if closing is not None:
        ws.send_frame(0x8, struct.pack(">H", 1000))  # the close handshake's answer
    check(closing == 1002 and closed_by_server(ws.sock, 20),
          "an unmasked client frame closes the connection (close code %s: protocol error)" % closing)
    ws.close()
    wait_for(lambda: metric(fetch(BASE + "/metrics")[1], "netkf_dashboard_refused_total", what="message") == 4, 10)
    _, text = fetch(BASE + "/metrics")
    check(metric(text, "netkf_dashboard_refused_total", what="request") == refused_requests,
          "/metrics counts the %d refused handshakes: %s" % (refused_requests,
                                                              metric(text, "netkf_dashboard_refused_total", what="request")))
    check(metric(text, "netkf_dashboard_refused_total", what="message") == 4,
          "/metrics counts 3 refused messages and 1 bad frame: %s" % metric(text, "netkf_dashboard_refused_total",
                                                                             what="message"))
    logged = warnings_of(run.output())
    check(1 <= len(logged) < refused_requests, "refused traffic is logged, throttled (%d lines for %d refusals): %s" %
          (len(logged), refused_requests + 4, logged[:6]))
    check(any("evil.example" in l and "403" in l for l in logged) and any("Sec-WebSocket-Key" in l for l in logged),
          "the log names the refusals (origin, key)")

    # 5000 setParameters of link 2 in a burst: one answer each; applied ones = the log = the journal.
    n_set = 5000
    ws = MiniWebSocket(PORT)
    ws.recv_json(), ws.recv_json()
    value = {"r%d" % i: round(0.001 * (i + 1), 6) for i in range(n_set)}
    for i in range(n_set):
        ws.send_text('{"op":"setParameters","id":"r%d","parameters":[{"name":"link.2.delay_ms","value":%r}]}' %
                     (i, value["r%d" % i]))
    answers, statuses_seen, repeated = {}, [], 0
    end = time.monotonic() + 120
    ws.sock.settimeout(30)
    while len(answers) < n_set and time.monotonic() < end:
        try:
            m = ws.recv_json()
        except (EOFError, OSError) as e:
            print("reading the answers:", e, flush=True)
            break
        if m.get("op") == "parameterValues" and m.get("id") in value:
            repeated += m["id"] in answers
            answers[m["id"]] = {p["name"]: p["value"] for p in m["parameters"]}
        elif m.get("op") == "status":
            statuses_seen.append((m["level"], m["message"]))
    ws.close()
    check(len(answers) == n_set and repeated == 0, "every one of the %d requests got one parameterValues answer "
          "(%d answered, %d twice)" % (n_set, len(answers), repeated))
    applied = [i for i, v in value.items() if abs(answers.get(i, {}).get("link.2.delay_ms", -1) - v) < 1e-9]
    superseded = [m for lvl, m in statuses_seen if lvl == 1 and "superseded" in m]
    unanswered = [m for lvl, m in statuses_seen if "did not answer" in m or "could not be sent" in m]
    print("applied %d, superseded %d" % (len(applied), len(superseded)), flush=True)
    check(applied and len(applied) + len(superseded) == n_set,
          "each request was applied (%d) or answered superseded (%d)" % (len(applied), len(superseded)))
    check(not unanswered, "no change went unanswered by the channel: %s" % unanswered[:3])
    check(value["r%d" % (n_set - 1)] == answers.get("r%d" % (n_set - 1), {}).get("link.2.delay_ms"),
          "the last request was applied")
    from_dashboard = lambda: re.findall(r"link 2: .*\(from dashboard\)", run.output())
    wait_for(lambda: len(from_dashboard()) >= len(applied), 30)
    check(len(from_dashboard()) == len(applied),
          "the launch logs each applied change once (%d lines, %d applied)" % (len(from_dashboard()), len(applied)))

    # 10 000 idle connections: the cap holds, the excess is closed and counted, all keeps working.
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    n_idle = min(10000, hard - 500)
    fds_before = len(os.listdir("/proc/%d/fd" % launch_pid))
    idle = []
    for _ in range(n_idle):
        idle.append(socket.create_connection(("127.0.0.1", PORT), timeout=30))
    print("opened %d idle connections" % len(idle), flush=True)
    status, text = fetch(BASE + "/metrics")
    check(status == 200, "/metrics answers with %d idle connections open" % n_idle)
    fds_after = len(os.listdir("/proc/%d/fd" % launch_pid))
    check(fds_after <= fds_before + 256 + 8, "the launch holds at most its cap of descriptors for them (%d, %d before)" %
          (fds_after, fds_before))
    closed = sum(metric(text, "netkf_dashboard_connections_closed_total", reason=r) or 0 for r in ("evicted", "refused"))
    open_now = metric(text, "netkf_dashboard_connections", state="open")
    check(open_now is not None and open_now <= 256 and closed >= n_idle - 256,
          "/metrics: %s open (cap 256), %d closed at the cap (evicted or refused)" % (open_now, closed))
    status, page = fetch(BASE + "/")
    check(status == 200 and "<html" in page, "the page is served")
    sensor = run.child_pids().get("sensor_node[1]")
    restarts_before = run.output().count("started sensor_node[1]")
    os.kill(sensor, signal.SIGKILL)
    check(wait_for(lambda: run.output().count("started sensor_node[1]") > restarts_before, 30),
          "kill -9 of sensor_node[1]: the launch restarts it")
    check("could not start" not in run.output(), "no process failed to start")
    # The server closes every one of them (the evicted at once, the rest idle for 5 s).
    still = {sock.fileno(): sock for sock in idle}
    poller = select.poll()
    for fd in still:
        poller.register(fd, select.POLLIN)
    end = time.monotonic() + 30
    while still and time.monotonic() < end:
        for fd, _ in poller.poll(1000):
            try:
                gone = still[fd].recv(4096) == b""
            except OSError:
                gone = True
            if gone:
                poller.unregister(fd)
                still.pop(fd).close()
    check(not still, "the server closed all %d idle connections (%d left)" % (n_idle, len(still)))
    for sock in still.values():
        sock.close()

    # Slowloris: a header trickled a byte every 0.5 s; an idle keep-alive connection.
    slow = socket.create_connection(("127.0.0.1", PORT), timeout=30)
    slow.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n")
    sent, cut = 0, False
    start = time.monotonic()
    while time.monotonic() - start < 20:
        try:
            slow.sendall(b"X")
            sent += 1
        except OSError:
            cut = True
            break
        if closed_by_server(slow, 0.5):
            cut = True
            break
    slow.close()
    check(cut, "a trickled request is closed by the server within 20 s (twice the 10 s request timeout); "
          "%d bytes trickled" % sent)
    keep = socket.create_connection(("127.0.0.1", PORT), timeout=30)
    keep.sendall(b"GET /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    first = keep.recv(65536)
    check(first.startswith(b"HTTP/1.1 200"), "a keep-alive request is answered")
    check(closed_by_server(keep, 10), "the idle keep-alive connection is closed within 10 s (twice the 5 s idle timeout)")
    keep.close()
    _, text = fetch(BASE + "/metrics")
    check((metric(text, "netkf_dashboard_connections_closed_total", reason="request_timeout") or 0) >= 1 and
          (metric(text, "netkf_dashboard_connections_closed_total", reason="idle_timeout") or 0) >= 1,
          "/metrics counts the request and idle timeouts")
    check("more like it left out" in run.output(), "the throttled log says how many refusals it left out")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)
with open(run.record + ".events.yaml") as f:
    journal = (yaml.safe_load(f) or {}).get("events", [])
check(len(journal) == len(applied), "the journal holds each applied change once (%d entries, %d applied)" %
      (len(journal), len(applied)))
finish()
