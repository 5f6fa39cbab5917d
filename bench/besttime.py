"""Best wall-clock time of N runs of a command: `python3 besttime.py N cmd args...`.

With several commands, `python3 besttime.py N -- cmd1 args -- cmd2 args ...`, the commands run
in turn, N rounds, and the best time of each is printed on one line, in order. This machine's
speed drifts by tens of percent within minutes; taking turns gives every command the same
chances, where N runs of one then N of the next can put one in a slow minute and not the other.
"""

import subprocess
import sys
import time

runs = int(sys.argv[1])
if sys.argv[2] == "--":
    commands, current = [], []
    for arg in sys.argv[3:] + ["--"]:
        if arg == "--":
            commands.append(current)
            current = []
        else:
            current.append(arg)
else:
    commands = [sys.argv[2:]]
best = [float("inf")] * len(commands)
for _ in range(runs):
    for i, command in enumerate(commands):
        t0 = time.perf_counter()
        subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        best[i] = min(best[i], time.perf_counter() - t0)
print(" ".join(f"{b:.3f}" for b in best))
