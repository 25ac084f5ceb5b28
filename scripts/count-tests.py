#!/usr/bin/env python3
"""Counts GoogleTest cases in build/test-results/*.xml for the test programs
meson knows, but those of the suites named after the build directory (left
out of the run: scripts/test.sh --no-suite); a program without a report
(crash, hang) counts as one failure. Prints "N passed, N failed, N skipped"."""
import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

build = Path(sys.argv[1] if len(sys.argv) > 1 else "build")
left_out = set(sys.argv[2:])
tests = json.loads(subprocess.check_output(["meson", "introspect", str(build), "--tests"]))
# meson names a suite "project:suite" too.
tests = [t for t in tests if not left_out & {s.split(":")[-1] for s in t.get("suite", [])}]
passed = failed = skipped = 0
for t in tests:
    report = build / "test-results" / (t["name"] + ".xml")
    try:
        root = ET.parse(report).getroot()
    except (OSError, ET.ParseError):
        print(f"test program {t['name']} left no report (crashed or never ran)", file=sys.stderr)
        failed += 1
        continue
    for case in root.iter("testcase"):
        if case.find("failure") is not None:
            failed += 1
        elif case.get("result") == "skipped" or case.find("skipped") is not None:
            skipped += 1
        else:
            passed += 1
print(f"{passed} passed, {failed} failed, {skipped} skipped")
sys.exit(1 if failed else 0)
