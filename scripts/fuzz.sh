#!/usr/bin/env bash
# Runs every libFuzzer target of tests/fuzz for a bounded time (docs/development.md, "Fuzzing").
# Builds the clang fuzzing build in ./build-fuzz first if needed. Each target starts from its seed
# corpus (tests/fuzz/corpus/<target>, read only) and writes what it finds into a scratch folder;
# an input that crashes, hangs (over 10 s) or runs out of memory (2 GiB) is saved in
# tests/fuzz/crashes/<target>/ for a person to fix and add to the corpus.
# Prints each target's executions; the last line is "fuzz: N targets, E executions, C crashes".
# Exits non-zero when any target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=60
build=build-fuzz
usage="usage: scripts/fuzz.sh [--seconds N] [--build-dir DIR] [TARGET...]"
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds="${2:?$usage}"; shift 2 ;;
    --build-dir) build="${2:?$usage}"; shift 2 ;;
    -h|--help) echo "$usage"; echo "targets: rgbd_frame depth_link pose_wire pose_hdrext rig dataset posed_sequence whep whep_http_head whep_offer"; exit 0 ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[ ${#targets[@]} -gt 0 ] || targets=(rgbd_frame depth_link pose_wire pose_hdrext rig dataset posed_sequence whep whep_http_head whep_offer)
case "$seconds" in ''|*[!0-9]*) echo "fuzz: --seconds needs a whole number" >&2; exit 2 ;; esac

if [ ! -f "$build/build.ninja" ]; then
  command -v clang++ >/dev/null || { echo "fuzz: clang++ is missing (apt-get install clang)" >&2; exit 2; }
  CC=clang CXX=clang++ meson setup "$build" -Dfuzzing=enabled -Dtests=disabled -Dbuildtype=debugoptimized
fi
ninja -C "$build" $(printf 'tests/fuzz/fuzz_%s ' "${targets[@]}")

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
total=0
crashes=0
for t in "${targets[@]}"; do
  mkdir -p "$scratch/$t" "tests/fuzz/crashes/$t"
  log="$scratch/$t.log"
  rc=0
  "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="tests/fuzz/crashes/$t/" "$scratch/$t" "tests/fuzz/corpus/$t" >"$log" 2>&1 || rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  execs=${execs:-0}
  total=$((total + execs))
  if [ "$rc" -ne 0 ]; then
    crashes=$((crashes + 1))
    echo "fuzz: $t: $execs executions, CRASHED (exit $rc); its input is in tests/fuzz/crashes/$t/:"
    grep -E "^==[0-9]+==ERROR|runtime error|Test unit written|ALARM|out-of-memory|deadly signal" "$log" | head -5 | sed 's/^/  /'
  else
    echo "fuzz: $t: $execs executions in ${seconds} s, no crash"
  fi
done
echo "fuzz: ${#targets[@]} targets, $total executions, $crashes crashes"
[ "$crashes" -eq 0 ]
