#!/usr/bin/env bash
# The blind window of a killed estimator in a closed loop (BENCHMARKS.md, "Blind window of a
# restart"): `netkf launch` of tests/e2e/data/closed_loop.yaml (A = 1.2, plant.state_bound 1e6)
# for 8 s, kill -9 of the estimator 4 s in, the periods the plant then runs without a control
# input (the longest run of u = 0 in the recording) and the largest |x|. MODE: spare (the
# default launch), fresh (--no-warm-spares), standby (--standby: the primary is killed). Two busy
# loops load both cores, as in the issue's reproduction. Run inside scripts/in-netns.sh.
# Usage: bench/bench_blind_window.sh NETKF MODE RUNS DOMAIN0 WORKDIR
set -euo pipefail
netkf=$1 mode=$2 runs=$3 domain0=$4 dir=$5
scenario=$(cd "$(dirname "$0")/.." && pwd)/tests/e2e/data/closed_loop.yaml
extra=()
case $mode in
  spare) ;;
  fresh) extra=(--no-warm-spares) ;;
  standby) extra=(--standby) ;;
  *) echo "unknown mode $mode" >&2; exit 2 ;;
esac
busy=()
trap 'kill "${busy[@]}" 2>/dev/null || true' EXIT
yes >/dev/null & busy+=($!)
yes >/dev/null & busy+=($!)
for i in $(seq 1 "$runs"); do
  mkdir -p "$dir"
  run=$(mktemp -d "$dir/$mode-$i.XXXX")
  "$netkf" launch "$scenario" --duration 8 --dashboard off --status-interval 0 --log-level info \
    --record "$run/r.csv" --pid-file "$run/pids.txt" --domain $((domain0 + i)) "${extra[@]}" >"$run/log.txt" 2>&1 &
  launch=$!
  sleep 4
  if [ "$mode" = standby ]; then
    # The primary: the estimator of the highest --ownership-strength.
    victim=$(for p in $(awk '/^estimator_node/ {print $NF}' "$run/pids.txt"); do
      strength=$(tr '\0' '\n' </proc/"$p"/cmdline | grep -A1 -x -- --ownership-strength | tail -1)
      echo "$strength $p"
    done | sort -n | tail -1 | cut -d' ' -f2)
  else
    victim=$(awk 'NF == 2 && $1 == "estimator_node" {print $2}' "$run/pids.txt")
  fi
  kill -9 "$victim"
  rc=0
  wait "$launch" || rc=$?
  python3 - "$run" "$mode" "$rc" <<'PY'
import csv, re, sys
run, mode, rc = sys.argv[1], sys.argv[2], sys.argv[3]
rows = list(csv.DictReader(open(run + "/r.csv")))
# An input is missing when u = 0 although the estimate before gives a nonzero one (with the
# dead-beat gain, x̂ = 0 after a period that fused nothing gives a true u = 0).
xhat = {int(r["k"]): r["xhat0"] for r in rows}
zero = [int(r["k"]) for r in rows if int(r["k"]) > 0 and r["u0"] and float(r["u0"]) == 0.0 and
        (xhat.get(int(r["k"]) - 1) in (None, "") or float(xhat[int(r["k"]) - 1]) != 0.0)]
best = cur = 0
last = None
for k in zero:
    cur = cur + 1 if last is not None and k == last + 1 else 1
    best, last = max(best, cur), k
log = open(run + "/log.txt").read()
m = re.search(r"readers of the estimate and the control input matched (\d+) ms", log)
print("| %s | %s | %d | %.3g | %s |" % (mode, "diverged (exit %s)" % rc if "closed loop diverged" in log else "exit " + rc,
                                     best, max(abs(float(r["x0"])) for r in rows), m.group(1) if m else "-"))
PY
done
