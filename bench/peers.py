"""Times the Python G-code parsers gcodeparser and gcode-lib on one file: the peers gweave is
compared with. Prints one JSON object: {"gcodeparser_s": t, "gcode_lib_s": t, "bytes": n}."""

import json
import os
import sys
import time


def best_of(fn, runs=2):
    best = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main(path):
    import gcode_lib
    from gcodeparser import parse_gcode_lines

    def run_gcodeparser():
        with open(path) as f:
            for _ in parse_gcode_lines(f, include_comments=True):
                pass

    def run_gcode_lib():
        gcode_lib.load(path)

    print(json.dumps({
        "bytes": os.path.getsize(path),
        "gcodeparser_s": best_of(run_gcodeparser),
        "gcode_lib_s": best_of(run_gcode_lib),
    }))


if __name__ == "__main__":
    main(sys.argv[1])
