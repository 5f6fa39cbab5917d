"""Best wall-clock time of N runs of a command: `python3 besttime.py N cmd args...`.

With several commands, `python3 besttime.py N -- cmd1 args -- cmd2 args ...`, the commands run
in turn, N rounds, and the best time of each is printed on one line, in order. This machine's
speed drifts by tens of percent within minutes; taking turns gives every command the same
chances, where N runs of one then N of the next can put one in a slow minute and not the other.

`python3 besttime.py --cpu N ...` prints the best CPU time of each instead (user + system, all
its threads): what a command costs when other work shares the cores, where its wall time is
its share of them.
"""

import resource
import subprocess
import sys
import time

cpu = sys.argv[1] == "--cpu"
if cpu:
    del sys.argv[1]


def clock() -> float:
    if not cpu:
        return time.perf_counter()
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


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
        t0 = clock()
        subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        best[i] = min(best[i], clock() - t0)
print(" ".join(f"{b:.3f}" for b in best))
