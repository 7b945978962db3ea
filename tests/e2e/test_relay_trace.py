"""`netkf trace extract --topic` over a relay's record (docs/relay.md, "A topic's trace"): a Cyclone DDS
talker writes rt/chatter on domain 121; `netkf relay` passes it to 122 through a bursty,
delaying link (Gilbert-Elliott, loss 0.3, mean burst 4, delay 3 ms with 2 ms of jitter),
recording each sample's fate and delay. The topic's trace is extracted from the record, and a
second relay replays it as a `model: trace` link (`--trace`) for a second talker of the same
number of samples.

Independent expectations: the first run's record, read here with Python's csv module. Checked:
the extracted trace has a row per sample with the record's fate and delay (k the sample
index); the replaying relay decides every sample as the first did (fate and delay, sample for
sample); `netkf fit` of the trace counts the record's samples, drops and mean delay; a relay's record asked for a --link,
and an unknown topic, are refused with exit 2."""
import csv
import json
import math
import os

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, netkf, require_netns,
                         stop_process, wait_for, workdir)

require_netns()
FROM, TO = 121, 122
COUNT = 300
CHATTER = cyclone_programs("NETKF_CYCLONE_CHATTER")
out = workdir("relay_trace")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
processes = LoggedProcesses(out, env)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def relay_run(name, record, link_flags):
    """One relay of COUNT talker samples; the record's rows."""
    relay = processes.start(name, [NETKF, "relay", "--from-domain", str(FROM), "--to-domain", str(TO), "--topic",
                                   "rt/chatter", "--seed", "5", "--record", record] + link_flags)
    try:
        check(wait_for(lambda: "topic(s) from domain" in processes.text(name, ".log"), 20), name + " is up")
        talker = processes.start(name + "-talker", [CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT),
                                                    "--rate-hz", "300"])
        check(talker.wait(timeout=90) == 0, "the talker wrote %d samples through %s" % (COUNT, name))
        check(wait_for(lambda: os.path.exists(record) and len(rows(record)) == COUNT, 20),
              "%s's record has a line per sample" % name)
    finally:
        check(stop_process(relay) == 0, name + " exits 0")
    return rows(record) if os.path.exists(record) else []


first = relay_run("relay", os.path.join(out, "fates.csv"),
                  ["--model", "gilbert_elliott", "--loss", "0.3", "--mean-burst", "4", "--delay", "3", "--jitter", "2"])
dropped = sum(r["fate"] == "dropped" for r in first)
print("first run: %d samples, %d dropped" % (len(first), dropped), flush=True)
check([int(r["index"]) for r in first] == list(range(COUNT)), "the record numbers the samples 0..%d" % (COUNT - 1))
check(0 < dropped < COUNT, "the bursty link dropped some samples and delivered others (%d dropped)" % dropped)

trace = os.path.join(out, "trace.csv")
r = netkf("trace", "extract", os.path.join(out, "fates.csv"), "--topic", "rt/chatter", "-o", trace)
check(r.returncode == 0, "trace extract --topic rt/chatter (rc=%d)" % r.returncode)
lines = [l for l in open(trace) if not l.startswith("#")]
extracted = list(csv.DictReader(lines))
check(lines[0].strip() == "k,delivered,delay_ms", "the trace has a delay column (header %r)" % lines[0].strip())
same = all(int(t["k"]) == int(f["index"]) and int(t["delivered"]) == (f["fate"] == "delivered")
           and (math.isclose(float(t["delay_ms"]), float(f["delay_ms"]), rel_tol=1e-5, abs_tol=1e-6)
                if f["fate"] == "delivered" else t["delay_ms"] == "")
           for t, f in zip(extracted, first))
check(len(extracted) == COUNT and same, "the trace has the record's fate and delay for each of the %d samples" % COUNT)

second = relay_run("replay", os.path.join(out, "fates-replayed.csv"), ["--trace", trace])
check([r["fate"] for r in second] == [r["fate"] for r in first],
      "the relay replaying the trace drops exactly the samples the first dropped")
check(all(math.isclose(float(a["delay_ms"]), float(b["delay_ms"]), rel_tol=1e-5, abs_tol=1e-6)
          for a, b in zip(second, first) if a["fate"] == "delivered"),
      "and holds each delivered sample as long as the first did")

fit = netkf("fit", trace, "--json")
fitted = json.loads(fit.stdout) if fit.returncode == 0 else {}
delays = [float(r["delay_ms"]) for r in first if r["fate"] == "delivered"]
check((fitted.get("samples"), fitted.get("dropped")) == (COUNT, dropped)
      and (fitted.get("delay") or {}).get("samples") == len(delays)
      and math.isclose((fitted.get("delay") or {}).get("mean_ms", float("nan")), sum(delays) / len(delays), rel_tol=1e-6),
      "netkf fit of the trace counts the record's %d samples, %d dropped, and its mean delay %.4f ms (%s)"
      % (COUNT, dropped, sum(delays) / len(delays), {k: fitted.get(k) for k in ("samples", "dropped", "delay")}))
wrong = netkf("trace", "extract", os.path.join(out, "fates.csv"), "--link", "1", "-o", os.path.join(out, "x.csv"))
check(wrong.returncode == 2 and "--topic" in wrong.stderr,
      "a relay's record with --link is refused, naming --topic (rc=%d)" % wrong.returncode)
unknown = netkf("trace", "extract", os.path.join(out, "fates.csv"), "--topic", "rt/none", "-o", os.path.join(out, "y.csv"))
check(unknown.returncode == 2 and "rt/none" in unknown.stderr and "rt/chatter" in unknown.stderr,
      "an unknown topic is refused, naming the record's topics (rc=%d)" % unknown.returncode)
check(not os.path.exists(os.path.join(out, "x.csv")) and not os.path.exists(os.path.join(out, "y.csv")),
      "and nothing is written then")
finish()
