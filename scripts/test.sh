#!/usr/bin/env bash
# Set-up + every test. Ends with "N passed, N failed, N skipped", counting each
# GoogleTest case (a test program that crashes counts as one more failure).
set -uo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh || { echo "0 passed, 1 failed"; exit 1; }

rm -rf build/test-results
mkdir -p build/test-results
meson test -C build --print-errorlogs --num-processes 2
meson_rc=$?

summary=$(python3 scripts/count-tests.py build)
count_rc=$?
# A failure meson saw that no report shows (a timeout, a crash at exit) still counts.
if [ $meson_rc -ne 0 ] && [ $count_rc -eq 0 ]; then
  summary=$(echo "$summary" | awk '{ $3 = $3 + 1; print }')
  count_rc=1
fi
echo "$summary"
exit $count_rc
