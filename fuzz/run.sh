#!/usr/bin/env bash
# Runs the libFuzzer targets built in $FUZZ_BUILD (make fuzz). FUZZING.md explains.
#
#   fuzz/run.sh smoke SECONDS "volume nifti calls"
#       each target SECONDS on a fresh copy of fuzz/corpus/<target>; prints its
#       executions, executions per second (wall clock, and per CPU second of
#       the fuzzer with the load average at the start) and coverage; fails on
#       any finding.
#   fuzz/run.sh soak SECONDS "volume nifti calls"
#       the same on a persistent corpus (build-fuzz/soak/<target>, seeded from
#       fuzz/corpus), one target after the other, and appends one row per
#       target to the soak log at the end of FUZZING.md; then prints each
#       target's executions since its last finding, added up from the log.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=$1
seconds=$2
targets=$3
build=${FUZZ_BUILD:-build-fuzz}
log_md=FUZZING.md
mkdir -p "$build/findings"

max_len() {
  case $1 in volume) echo 4096 ;; calls) echo 512 ;; *) echo 8192 ;; esac
}

# Executions since the target's last finding, from the soak log rows
# "| date | commit | fuzz_<t> | seconds | executions | exec/s | cov | result |".
cumulative() {
  awk -F'|' -v t="fuzz_$1" '
    $4 ~ "^ *" t " *$" {
      gsub(/[ ,]/, "", $6); r = $9; gsub(/ /, "", r);
      if (r == "nofinding") total += $6; else total = 0;
    }
    END { printf "%d", total }' "$log_md"
}

status=0
for t in $targets; do
  len=$(max_len "$t")
  dict=""
  [ -f "fuzz/$t.dict" ] && dict="-dict=fuzz/$t.dict"
  if [ "$mode" = soak ]; then
    work=$build/soak/$t
    if [ ! -d "$work" ]; then mkdir -p "$work" && cp fuzz/corpus/"$t"/* "$work"/; fi
  else
    work=$build/smoke/$t
    rm -rf "$work" && mkdir -p "$work" && cp fuzz/corpus/"$t"/* "$work"/
  fi
  log=$build/$mode-$t.log
  echo "== fuzz_$t: $seconds s, max_len $len ($mode)"
  result="no finding"
  load=$(cut -d' ' -f1 /proc/loadavg 2>/dev/null || echo "?")
  # The fuzzer's CPU seconds (bash's time keyword, user + system): on a shared
  # machine the wall-clock rate says more about the other jobs than the target.
  TIMEFORMAT='%U %S'
  if ! { time "./$build/fuzz_$t" "$work" $dict -max_len="$len" -max_total_time="$seconds" -timeout=30 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/findings/$t-" > "$log" 2>&1; } 2> "$log.cpu"; then
    tail -n 60 "$log"
    echo "fuzz $mode: fuzz_$t found a problem: see $build/findings/ and $log"
    result="FINDING"
    status=1
  fi
  execs=$(awk '/^stat::number_of_executed_units/ {print $2}' "$log")
  rate=$(awk '/^stat::average_exec_per_sec/ {print $2}' "$log")
  cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -n 1 || true)
  cpu_rate=$(awk -v e="${execs:-0}" '{ c = $1 + $2 } END { if (c > 0) printf "%.0f", e / c; else print "?" }' "$log.cpu")
  echo "fuzz_$t: ${execs:-?} executions in $seconds s, ${rate:-?} exec/s (${cpu_rate} per CPU second, load ${load}), ${cov:-no coverage line}"
  if [ "$mode" = soak ]; then
    commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
    printf '| %s | %s | fuzz_%s | %s | %s | %s | %s | %s |\n' "$(date -u +%Y-%m-%dT%H:%MZ)" "$commit" "$t" \
      "$seconds" "${execs:-0}" "${rate:-0} (${cpu_rate}/CPU s, load ${load})" "${cov:-?}" "$result" >> "$log_md"
    echo "fuzz_$t: $(cumulative "$t") executions since its last finding (soak log of $log_md)"
  fi
  [ "$status" -eq 0 ] || exit 1
done
echo "fuzz $mode: no findings"
