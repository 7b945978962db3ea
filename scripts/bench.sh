#!/usr/bin/env bash
# The benchmarks of BENCHMARKS.md: build the default preset, run the named benchmarks (all when
# none is named) and print each result as rows of its table in BENCHMARKS.md. Benchmarks, not
# tests: they take minutes, load both cores, and their numbers depend on the machine's load.
# Everything that starts DDS participants runs inside scripts/in-netns.sh (the ctest-based ones
# through ctest, whose DDS tests run there by themselves). Raw outputs stay in
# build/default/bench-results/.
# Usage: scripts/bench.sh [--list] [NAME...]
set -euo pipefail
cd "$(dirname "$0")/.."

names=(fused-update late-fusion monte-carlo python-filter analyze analyze-many latency hop-clock hop-delivery capacity sensors-100hz sensor-limit dashboard
       dashboard-many security recovery blind-window multi-host shutdown-aborts relay setup)
declare -A about=(
  [fused-update]="one fused measurement update: production, naive stacked inverse, sequential Joseph (bench_fused_update)"
  [late-fusion]="worst-case re-run of late_policy fuse_within: D = 64 periods, 16 sensors (bench_late_fusion)"
  [monte-carlo]="Monte Carlo filter steps per second against NumPy (bench_monte_carlo, bench/numpy_monte_carlo.py)"
  [python-filter]="a filter step from Python (netkf.Filter) against statsmodels' Kalman filter (bench/python_filter.py)"
  [analyze]="wall time of netkf analyze --json per scenario (bench/bench_analyze.sh)"
  [analyze-many]="wall and CPU time of netkf analyze --json for 512-sensor scenarios (bench/bench_many_sensors.sh)"
  [latency]="pipeline latency against one bare DDS hop, 8 sensors at 100 Hz, auto grouping and one process per sensor (bench_latency)"
  [hop-clock]="the same with the bare hop on the truth's clock and on its own (bench_latency --hop-clock)"
  [hop-delivery]="the bare hop by the transports (shared memory) and by Fast DDS data-sharing, alternating, the pipeline as the control (bench_latency --hop-delivery)"
  [capacity]="sensors at 100 Hz without unintended loss, 64 and 128 sensors (bench_latency --capacity)"
  [sensors-100hz]="256 sensors at 100 Hz for 10 minutes: late share, pipeline latency, RSS and fds (bench/bench_sensor_rate.sh)"
  [sensor-limit]="the largest live network: 512 to 4096 sensors at 10 Hz and 1024 at 100 Hz, 40 s each (bench/bench_sensor_rate.sh)"
  [dashboard]="the dashboard's cost: pipeline latency and the launch's CPU with a browser or a protocol client (bench/bench_dashboard.sh)"
  [dashboard-many]="the page and a late ctl status at 4096 sensors × 10 Hz and 1024 × 100 Hz: link table, selection, launch CPU (bench/bench_dashboard_many.sh)"
  [security]="pipeline latency without and with DDS Security (bench_latency --secure-compare)"
  [recovery]="periods lost to a killed or stopped process (e2e fault_estimator, fault_channel; integration DdsRestart)"
  [blind-window]="a killed estimator in a closed loop under load: periods without an input, fresh process, warm spare, standby (bench/bench_blind_window.sh)"
  [multi-host]="three hosts over a Discovery Server (e2e multi_host)"
  [shutdown-aborts]="Fast DDS aborts while a run stops, counted over repeated launches"
  [relay]="netkf relay's throughput and CPU per sample against a bare hop, 100 B to 1 MB payloads, Cyclone DDS at both ends (bench/bench_relay.sh)"
  [setup]="the README's two commands on a fresh clone, cold (empty caches) and warm, per step (bench/bench_setup.sh)"
)

usage() {
  echo "usage: scripts/bench.sh [--list] [NAME...]   (no NAME: every benchmark, in this order)"
  list
}
list() {
  local n
  for n in "${names[@]}"; do printf '  %-16s %s\n' "$n" "${about[$n]}"; done
}

selected=()
for a in "$@"; do
  case $a in
    --list) list; exit 0 ;;
    -h | --help) usage; exit 0 ;;
    -*) echo "bench.sh: unknown option $a" >&2; usage >&2; exit 2 ;;
    *)
      if [ -z "${about[$a]+set}" ]; then
        echo "bench.sh: unknown benchmark '$a' (scripts/bench.sh --list)" >&2
        exit 2
      fi
      selected+=("$a") ;;
  esac
done
if [ ${#selected[@]} -eq 0 ]; then selected=("${names[@]}"); fi

out=build/default/bench-results
bin=build/default/bench
netkf=build/default/cli/netkf
netns=scripts/in-netns.sh

# report MODE ARGS...: the rows of a BENCHMARKS.md table from a benchmark's raw output.
report() {
  python3 - "$@" <<'PY'
import ast, json, re, statistics, sys

mode, args = sys.argv[1], sys.argv[2:]
STATS = re.compile(r"p50=\s*([\d.]+) us\s+p99=\s*([\d.]+) us\s+max=\s*([\d.]+) us")


def stats(line):
    m = STATS.search(line)
    return tuple(float(v) for v in m.groups()) if m else None


def latency_runs(path):
    """Each run of bench_latency: pipeline and bare-hop stats, ratio, counts."""
    runs = []
    for line in open(path):
        if line.startswith("latency run") or line.startswith("capacity:"):
            runs.append({"head": line.strip()})
        elif not runs:
            continue
        elif "pipeline: sample publish -> estimate publish" in line:
            runs[-1]["pipeline"] = stats(line)
        elif "bare Fast DDS hop" in line:
            runs[-1]["hop"] = stats(line)
        elif "pipeline p50 / bare hop p50 =" in line:
            runs[-1]["ratio"] = float(line.split("=")[1].split()[0])
        elif "periods=" in line:
            runs[-1].update({k: int(v) for k, v in re.findall(r"([a-z-]+)=(-?\d+)", line)})
    return runs


def span(values, fmt="%.0f"):
    return (fmt + "-" + fmt) % (min(values), max(values))


def medians(path, field):
    """Google Benchmark medians in µs by (name, first arg, second arg): run names NAME/x:A/y:B."""
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}
    t = {}
    for b in json.load(open(path))["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        name, first, second = b["run_name"].split("/")
        t[(name, int(first.split(":")[1]), int(second.split(":")[1]))] = b[field] * scale[b["time_unit"]]
    return t


if mode == "fused-update":
    # BM_FusedUpdate_Production/n:2/d:1 -> ("Production", 2, 1)
    t = {(name.split("_")[-1], n, d): v for (name, n, d), v in medians(args[0], "cpu_time").items()}
    print("| n | d (received, m_i=2) | production [µs] | naive stacked inverse [µs] | sequential Joseph [µs] "
          "| naive / production | production per sensor [µs] | production marginal cost per added sensor [µs] |")
    print("|---|---|---|---|---|---|---|---|")
    for n in (2, 6, 12):
        prev = None
        for d in (1, 4, 16, 64):
            p, naive, seq = (t[(k, n, d)] for k in ("Production", "NaiveStackedInverse", "SequentialJoseph"))
            marginal = "–" if prev is None else "%.3f" % ((p - prev[1]) / (d - prev[0]))
            print("| %d | %d | %.2f | %.2f | %.2f | %.1f× | %.3f | %s |" % (n, d, p, naive, seq, naive / p, p / d, marginal))
            prev = (d, p)

elif mode == "late-fusion":
    t = medians(args[0], "real_time")  # BM_ReRun_Worst/n:2/D:64
    print("| n | D | sensors (m_i=2) | worst re-run (D periods) [µs] | per re-run period [µs] | one in-time period [µs] |")
    print("|---|---|---|---|---|---|")
    for n in (2, 6, 12):
        rerun, in_time = t[("BM_ReRun_Worst", n, 64)], t[("BM_InTimePeriod", n, 64)]
        print("| %d | 64 | 16 | %.1f | %.2f | %.2f |" % (n, rerun, rerun / 64, in_time))

elif mode == "monte-carlo":
    data = json.load(open(args[0]))
    rate = {b["name"].replace("/real_time", ""): b["filter_steps_per_s"] / 1e6 for b in data["benchmarks"]}
    numpy = {}
    for line in open(args[1]):
        m = re.match(r"(scalar|6-state).*= ([\d.]+) M filter-steps/s", line)
        if m:
            numpy[m.group(1)] = float(m.group(2))
    fmt = lambda v: ("%.1f" if v >= 10 else "%.2f") % v + " M/s"
    print("| scenario | netkf fast kernel, 1 thread | netkf fast kernel, 2 threads | netkf reference kernel (core filter), 2 threads "
          "| NumPy (vectorised over runs, 1 core) | netkf / NumPy, per core | netkf / NumPy, 2 threads |")
    print("|---|---|---|---|---|---|---|")
    for label, key, bench, runs, ref_runs in (("scalar (A=-1.25, λ=0.6)", "scalar", "BM_Scalar", 20000, 2000),
                                              ("6-state, 4-sensor (λ=0.8)", "6-state", "BM_SixState4Sensors", 2000, 500)):
        one, two = rate["%s_Fast/%d/1" % (bench, runs)], rate["%s_Fast/%d/2" % (bench, runs)]
        ref, np_rate = rate["%s_Reference/%d/2" % (bench, ref_runs)], numpy[key]
        print("| %s | %s | %s | %s | %s | %.1f× | %.1f× |" % (label, fmt(one), fmt(two), fmt(ref), fmt(np_rate),
                                                          one / np_rate, two / np_rate))

elif mode == "analyze":
    shipped, rows = [], {}
    for line in open(args[0]):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 2 and cells[1].replace(".", "").isdigit():
            rows[cells[0]] = float(cells[1])
            if cells[0].startswith("deploy/scenarios/"):
                shipped.append(float(cells[1]))
    print("| scenarios | wall time, best of 3 |")
    print("|---|---|")
    print("| every shipped scenario (`deploy/scenarios/*.yaml`) | %s s |" % span(shipped, "%.2f"))
    six = "tests/data/theory/six-state-four-sensors.yaml"
    print("| the 6-state, 4-sensor test scenario (`%s`) | %.2f s |" % (six, rows[six]))

elif mode in ("latency", "hop-clock"):
    label, path = args
    runs = [r for r in latency_runs(path) if r.get("pipeline")]
    ratios = sorted(r["ratio"] for r in runs if "ratio" in r)
    ratio = "%.2f (%.2f-%.2f)" % (ratios[len(ratios) // 2], ratios[0], ratios[-1]) if ratios else "–"
    row = [label, span([r["pipeline"][0] for r in runs]) + " µs",
           span([r["hop"][0] for r in runs if r.get("hop")]) + " µs" if any(r.get("hop") for r in runs) else "–", ratio]
    if mode == "latency":
        row.append(str(sum(r.get("periods-with-unintended-loss", 0) for r in runs)))
    print("| " + " | ".join(row) + " |")

elif mode == "hop-delivery":
    label, path = args
    runs = [r for r in latency_runs(path) if r.get("pipeline") and r.get("hop")]
    ratios = sorted(r["pipeline"][0] / r["hop"][0] for r in runs)
    got = [int(n) for n in re.findall(r"bare Fast DDS hop .*? n=(\d+)", open(path).read())]
    print("| %s | %s µs | %s µs | %.2f (%.2f-%.2f) | %s µs | %d-%d |" % (
        label, span([r["pipeline"][0] for r in runs]), span([r["hop"][0] for r in runs]),
        ratios[len(ratios) // 2], ratios[0], ratios[-1], span([r["hop"][1] for r in runs]), min(got), max(got)))

elif mode == "capacity":
    label, path = args
    for r in latency_runs(path):
        if not r.get("pipeline"):
            continue
        d = re.match(r"capacity: (\d+) sensors", r["head"]).group(1)
        periods, short = r.get("periods", 0), r.get("periods-with-unintended-loss", 0) + r.get("gaps", 0)
        loss = "**0**" if short == 0 else "%d (%.2f %%), max latency %.1f ms" % (short, 100.0 * short / max(periods, 1),
                                                                              r["pipeline"][2] / 1000)
        print("| %s | %s | %d | %s | %.0f / %.0f µs |" % (d, label, periods, loss, r["pipeline"][0], r["pipeline"][1]))

elif mode == "dashboard":
    p50, cpu = {}, {}
    for line in open(args[0]):
        m = re.match(r"run (\d+) (\S+)\s+(.*)", line)
        if not m:
            continue
        run, what, rest = int(m.group(1)), m.group(2), m.group(3)
        if "launch CPU" in rest:
            cpu[(run, what)] = re.search(r"launch CPU ([\d.]+)", rest).group(1)
        elif stats(rest):
            p50[(run, what)] = "%.1f" % stats(rest)[0]
    runs = sorted({k[0] for k in p50} | {k[0] for k in cpu})
    print("Pipeline p50 (sample publish → estimate publish), µs:\n")
    print("| run | no client | one browser | one protocol client |\n|---|---|---|---|")
    for i in runs:
        print("| %d | %s |" % (i, " | ".join(p50.get((i, w), "—") for w in ("without", "browser", "client"))))
    print("\nThe launch process's own CPU, % of one core:\n")
    print("| run | no client | one browser |\n|---|---|---|")
    for i in runs:
        print("| %d | %s |" % (i, " | ".join(cpu.get((i, w), "—") for w in ("without", "with"))))

elif mode == "security":
    rows, final = {}, ""
    for r in latency_runs(args[0]):
        m = re.match(r"latency run (\d+)/\d+ (without|WITH) DDS Security", r["head"])
        if m and r.get("pipeline"):
            rows.setdefault(int(m.group(1)), {})[m.group(2)] = r["pipeline"]
    for line in open(args[0]):
        if line.startswith("pipeline p50 over"):
            final = line.strip()
    print("| run | without: p50 | without: p99 | with security: p50 | with security: p99 |\n|---|---|---|---|---|")
    for i in sorted(rows):
        w, s = rows[i].get("without"), rows[i].get("WITH")
        cell = lambda x, j, f: f % x[j] if x else "—"
        print("| %d | %s | %s | %s | %s |" % (i, cell(w, 0, "%.1f"), cell(w, 1, "%.0f"), cell(s, 0, "%.1f"), cell(s, 1, "%.0f")))
    m = re.search(r"without security median ([\d.]+) us, with security median ([\d.]+) us", final)
    if m:
        print("| median | **%s** | | **%s** | |" % m.groups())

elif mode == "recovery":
    text = open(args[0]).read()
    print("| fault | measured |\n|---|---|")
    for m in re.finditer(r"resumed after period \d+; fused again from period \S+; (\d+) periods open-loop", text):
        print("| estimator `kill -9` (`fault_estimator`) | %s periods open-loop |" % m.group(1))
    for fault, pattern in (("channel `SIGSTOP` 2 s, then `SIGCONT`", r"SIGSTOP: an outage[^(]*\((\[.*\])\)"),
                           ("channel `kill -9`", r"kill -9: an outage[^(]*\((\[.*\])\)")):
        for m in re.finditer(pattern, text):
            outages = ast.literal_eval(m.group(1))
            print("| %s (`fault_channel`) | periods without samples: %s |"
                  % (fault, ", ".join(str(n) for _, n in outages) or "none"))
    for m in re.finditer(r"first sample (\d+) ms after it started, .*missing (\d+)", text):
        print("| restarted reader, one writer at 500 samples/s (`DdsRestart`) | first sample %s ms after it started; "
              "%s samples written after the match never arrived |" % m.groups())

elif mode == "multi-host":
    text = open(args[0]).read()
    print("| what | measured |\n|---|---|")
    for label, pattern in (("periods recorded on C (open loop)", r"host C recorded every period, all finite \((\d+)\)"),
                           ("periods equal to a single-host run", r"equal the single-host run for the first (\d+) periods"),
                           ("closed-loop periods", r"the closed loop ran (\d+) periods"),
                           ("UDP packets between the hosts on the bridge", r"between the hosts \((\d+) UDP packets\)"),
                           ("multicast or broadcast packets on the bridge", r"broadcast packet on the bridge \((\d+)\)"),
                           ("IGMP joins", r"joined a multicast group \((\d+) IGMP"),
                           ("whole test", r"Total Test time \(real\) =\s*([\d.]+ sec)")):
        m = re.search(pattern, text)
        print("| %s | %s |" % (label, m.group(1) if m else "not found (see the log)"))
PY
}

bench_fused_update() {
  "$bin/bench_fused_update" --benchmark_min_time=0.2 --benchmark_repetitions=3 \
    --benchmark_report_aggregates_only=true --benchmark_format=json --benchmark_out="$out/fused-update.json" >/dev/null
  report fused-update "$out/fused-update.json"
}

bench_late_fusion() {
  "$bin/bench_late_fusion" --benchmark_min_time=0.2 --benchmark_repetitions=3 \
    --benchmark_report_aggregates_only=true --benchmark_format=json --benchmark_out="$out/late-fusion.json" >/dev/null
  report late-fusion "$out/late-fusion.json"
}

bench_monte_carlo() {
  "$bin/bench_monte_carlo" --benchmark_min_time=1 --benchmark_out="$out/monte-carlo.json" --benchmark_out_format=json
  /usr/bin/python3 bench/numpy_monte_carlo.py 100000 300 2000 | tee "$out/monte-carlo-numpy.txt"
  report monte-carlo "$out/monte-carlo.json" "$out/monte-carlo-numpy.txt"
}

bench_python_filter() {
  /usr/bin/python3 bench/python_filter.py | tee "$out/python-filter.md"
}

bench_analyze() {
  bench/bench_analyze.sh "$netkf" | tee "$out/analyze.md"
  echo
  report analyze "$out/analyze.md"
}

bench_analyze_many() {
  bench/bench_many_sensors.sh "$netkf" | tee "$out/analyze-many.md"
}

bench_latency() {
  "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 | tee "$out/latency-auto.txt"
  "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 --sensors-per-process 1 | tee "$out/latency-one.txt"
  echo
  echo "| sensors run as | pipeline p50 (5 runs) | bare hop p50 | ratio median (min-max) | late periods |"
  echo "|---|---|---|---|---|"
  report latency "auto (the default)" "$out/latency-auto.txt"
  report latency "one process per sensor" "$out/latency-one.txt"
}

bench_hop_clock() {
  "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 --hop-clock truth | tee "$out/hop-clock-truth.txt"
  "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 | tee "$out/hop-clock-free.txt"
  echo
  echo "| hop clock | pipeline p50 | bare hop p50 | ratio median (min-max) |"
  echo "|---|---|---|---|"
  report hop-clock "truth (hop in the sensors' burst)" "$out/hop-clock-truth.txt"
  report hop-clock "free (the bench's own clock)" "$out/hop-clock-free.txt"
}

bench_hop_delivery() {
  local series
  for series in 1 2; do
    "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 | tee "$out/hop-delivery-transport-$series.txt"
    "$netns" "$bin/bench_latency" --repeat 5 --seconds 12 --hop-delivery data-sharing \
      | tee "$out/hop-delivery-data-sharing-$series.txt"
  done
  echo
  echo "| bare hop delivered by | pipeline p50 (the control) | bare hop p50 | ratio p50 median (min-max) | bare hop p99 | hop samples received of 9600 after warm-up |"
  echo "|---|---|---|---|---|---|"
  for series in 1 2; do
    report hop-delivery "transports (shared memory), series $series" "$out/hop-delivery-transport-$series.txt"
    report hop-delivery "data-sharing (bounded twin), series $series" "$out/hop-delivery-data-sharing-$series.txt"
  done
}

bench_relay() {
  "$netns" bench/bench_relay.sh build/default "$out/relay" | tee "$out/relay.md"
}

bench_capacity() {
  "$netns" "$bin/bench_latency" --capacity --sensors 64 --max-sensors 128 --seconds 30 --warmup 10 \
    | tee "$out/capacity-30s.txt"
  "$netns" "$bin/bench_latency" --capacity --sensors 64 --max-sensors 64 --seconds 60 --warmup 10 \
    | tee "$out/capacity-60s.txt"
  echo
  echo "| sensors × 100 Hz | run as | periods measured | periods with unintended loss | pipeline p50 / p99 |"
  echo "|---|---|---|---|---|"
  report capacity "auto, 30 s" "$out/capacity-30s.txt"
  report capacity "auto, 60 s" "$out/capacity-60s.txt"
}

rate_header() {
  echo "| sensors, rate, run | periods | fused per period (mean; min–max) | expected (0.9 n) | late share | pipeline p50 / p99 | RSS MB at 30 s → end (peak) | fds at 30 s → end | exit |"
  echo "|---|---|---|---|---|---|---|---|---|"
}

bench_sensors_100hz() {
  rate_header
  bench/bench_sensor_rate.sh 256 10 600 62 "$netkf"
}

bench_sensor_limit() {
  local n
  rate_header
  for n in 512 1024 1536 2048 4096; do bench/bench_sensor_rate.sh "$n" 100 40 62 "$netkf"; done
  bench/bench_sensor_rate.sh 1024 10 40 62 "$netkf"
}

bench_dashboard_many() {
  bench/bench_dashboard_many.sh 4096 100 60 152 | tee "$out/dashboard-4096.txt"
  bench/bench_dashboard_many.sh 1024 10 60 152 | tee "$out/dashboard-1024-100hz.txt"
}

bench_dashboard() {
  bench/bench_dashboard.sh 3 20 | tee "$out/dashboard.txt"
  echo
  report dashboard "$out/dashboard.txt"
}

bench_security() {
  local dir=$out/security
  rm -rf "$dir"
  "$netkf" security init "$dir" >/dev/null
  "$netns" "$bin/bench_latency" --repeat 3 --seconds 10 --sensors 8 --domain 94 --secure-compare "$dir" \
    | tee "$out/security.txt"
  echo
  report security "$out/security.txt"
}

bench_recovery() {
  ctest --preset default -R 'e2e_fault_estimator|e2e_fault_channel|DdsRestart' -V >"$out/recovery.log" 2>&1 \
    || echo "some of these tests failed: $out/recovery.log"
  report recovery "$out/recovery.log"
}

bench_multi_host() {
  ctest --preset default -R e2e_multi_host -V >"$out/multi-host.log" 2>&1 \
    || echo "e2e_multi_host failed: $out/multi-host.log"
  report multi-host "$out/multi-host.log"
}

# launch_stops RUNS SCENARIO LAUNCH-ARGS...: launches that end by --duration on domain 97, inside
# the namespace; an abort shows as "killed by signal 6" in the launch's log.
launch_stops() {
  local runs=$1 scenario=$2 aborts=0 run load log=$out/shutdown-aborts.log
  shift 2
  load=$(cut -d' ' -f1 /proc/loadavg)
  for ((run = 1; run <= runs; run++)); do
    "$netns" "$netkf" launch "$@" --dashboard off --domain 97 >"$log" 2>&1 || true
    if grep -q 'killed by signal 6' "$log"; then
      aborts=$((aborts + 1))
      cp "$log" "$out/shutdown-abort-$aborts.log"
    fi
  done
  printf '| %d | %s | load average %s at the start%s | %d |\n' "$runs" "$scenario" "$load" "${busy_note:-}" "$aborts"
}

bench_blind_window() {
  local mode
  echo "| restart | run | longest run of periods without an input | max \\|x\\| | restarted estimator's readers matched [ms] |"
  echo "|---|---|---|---|---|"
  for mode in fresh spare standby; do
    $netns bench/bench_blind_window.sh "$netkf" "$mode" 6 150 "$out/blind-window"
  done
}

# The README's two commands on a fresh clone of HEAD with caches of its own (about an hour on
# 2 cores): nothing else should run meanwhile. The raw files stay in the work directory.
bench_setup() {
  local work
  work=$out/setup-$(date -u +%Y%m%d-%H%M%S)
  bench/bench_setup.sh HEAD "$work" 10 >&2
}

bench_shutdown_aborts() {
  local many=$out/many-sensors.yaml i
  {  # the scenario of the e2e test many_sensors (tests/e2e/test_many_sensors.py): 512 sensors
    printf 'name: many-sensors\nperiod_ms: 100\nseed: 5\nplant:\n  A: [[0.95, 0.1], [0.0, 0.9]]\n'
    printf '  Q: [[0.1, 0.0], [0.0, 0.1]]\n  x0: [0.0, 0.0]\nsensors:\n'
    for i in $(seq 1 512); do
      printf '  - { id: %d, C: [[1.0, 0.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } }\n' "$i"
    done
    printf 'estimator:\n  deadline_ms: 80\n'
  } >"$many"
  echo "| runs | scenario | machine | aborts |"
  echo "|---|---|---|---|"
  # shellcheck disable=SC2016  # backquotes are markdown here
  launch_stops 15 'built-in default, `--duration 3 --dashboard off`' --duration 3
  # shellcheck disable=SC2016
  launch_stops 8 '512 sensors (the `many_sensors` scenario), `--duration 8 --dashboard off`' "$many" --duration 8
  busy=()
  trap 'kill "${busy[@]}" 2>/dev/null || true' EXIT
  for i in 1 2 3; do
    yes >/dev/null &
    busy+=($!)
  done
  # shellcheck disable=SC2016
  busy_note=', 3 busy loops (`yes > /dev/null`) beside it'
  launch_stops 6 'the same 512 sensors' "$many" --duration 8
  kill "${busy[@]}"
  wait "${busy[@]}" 2>/dev/null || true
  busy=() busy_note=
  trap - EXIT
}

scripts/build.sh default
mkdir -p "$out"
for name in "${selected[@]}"; do
  echo "=== $name: ${about[$name]}"
  "bench_${name//-/_}"
  echo
done
