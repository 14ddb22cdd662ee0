#!/usr/bin/python3
"""Lists the skipped tests of a catkin test run, one line each.

usage: skipped_tests.py TEST_RESULTS_DIR [SKIPPED_LIST]

gtest cases that called GTEST_SKIP are read from the JUnit XML files under
TEST_RESULTS_DIR ("gtest SUITE.NAME: reason"); SKIPPED_LIST (written by
CMake) holds the rostests that were not registered, one line each.
"""

import glob
import os
import sys
import xml.etree.ElementTree as ElementTree


def skipped_gtests(results_dir):
    lines = []
    for path in sorted(glob.glob(os.path.join(results_dir, "**", "gtest-*.xml"), recursive=True)):
        for case in ElementTree.parse(path).getroot().iter("testcase"):
            skip = case.find("skipped")
            if skip is None and case.get("result") != "skipped":
                continue
            reason = (skip.get("message") if skip is not None else "") or ""
            reason = reason.strip().splitlines()[-1] if reason.strip() else "skipped"
            lines.append(f"gtest {case.get('classname')}.{case.get('name')}: {reason}")
    return lines


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    lines = skipped_gtests(argv[1])
    if len(argv) > 2 and os.path.exists(argv[2]):
        with open(argv[2]) as listing:
            lines += [line.rstrip("\n") for line in listing if line.strip()]
    for line in lines:
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
