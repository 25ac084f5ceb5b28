#!/usr/bin/env bash
# Set-up + every test. Ends with "N passed, N failed, N skipped", counting each
# GoogleTest case (a test program that crashes counts as one more failure).
#   scripts/test.sh                      set up and build ./build, run its suite
#   scripts/test.sh --build-dir DIR      run the suite of an already configured DIR (built first), e.g.
#                                        the sanitizer build (docs/development.md); no set-up
#   --processes N                        test programs at once (default 2, one per core)
#   --timeout-multiplier N               for slower builds (sanitizers: 3)
#   --no-suite NAME                      leave out the programs of a meson suite (tests/meson.build: docs)
set -uo pipefail
cd "$(dirname "$0")/.."

build=build
processes=2
timeout_multiplier=1
no_suite=()
usage="usage: scripts/test.sh [--build-dir DIR] [--processes N] [--timeout-multiplier N] [--no-suite NAME]"
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build="${2:?$usage}"; shift 2 ;;
    --processes) processes="${2:?$usage}"; shift 2 ;;
    --timeout-multiplier) timeout_multiplier="${2:?$usage}"; shift 2 ;;
    --no-suite) no_suite+=("${2:?$usage}"); shift 2 ;;
    -h|--help) echo "$usage"; exit 0 ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done

if [ "$build" = build ]; then
  ./scripts/setup.sh || { echo "0 passed, 1 failed, 0 skipped"; exit 1; }
else
  ninja -C "$build" || { echo "0 passed, 1 failed, 0 skipped"; exit 1; }
fi

rm -rf "$build/test-results"
mkdir -p "$build/test-results"
meson test -C "$build" --print-errorlogs --num-processes "$processes" --timeout-multiplier "$timeout_multiplier" \
  ${no_suite[@]/#/--no-suite=}
meson_rc=$?

summary=$(python3 scripts/count-tests.py "$build" "${no_suite[@]}")
count_rc=$?
# A failure meson saw that no report shows (a timeout, a crash or a leak found at exit) still counts.
if [ $meson_rc -ne 0 ] && [ $count_rc -eq 0 ]; then
  summary=$(echo "$summary" | awk '{ $3 = $3 + 1; print }')
  count_rc=1
fi
echo "$summary"
exit $count_rc
