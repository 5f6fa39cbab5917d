"""Best wall-clock time of N runs of a command: `python3 besttime.py N cmd args...`."""

import subprocess
import sys
import time

runs = int(sys.argv[1])
best = float("inf")
for _ in range(runs):
    t0 = time.perf_counter()
    subprocess.run(sys.argv[2:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    best = min(best, time.perf_counter() - t0)
print(f"{best:.3f}")
