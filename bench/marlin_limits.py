"""Marlin's planner against gweave's Marlin mode (bench/marlin.sh): the fixture prepared as
tests/data/README.md says, and the same limits for both tools.

`python3 marlin_limits.py prepare SRC DST`: the prepared copy of a fixture.
`python3 marlin_limits.py mcodes SET MODE`: the settings lines for marlin-calc.
`python3 marlin_limits.py toml SET MODE`: the same limits as a gweave machine profile.
`python3 marlin_limits.py total FILE`: marlin-calc's estimatedPrintTime from its output on stdin.
SET is prusa, ender3 or ramps; MODE jd (junction deviation) or jerk (classic jerk).
"""

import re
import sys

SETS = {
    "prusa": dict(steps=(80, 80, 400, 500), acc=(9000, 9000, 500, 10000), feed=(500, 500, 12, 120),
                  accel=1500, jerk=(10, 10, 0.2, 2.5), jd=0.013),
    "ender3": dict(steps=(80, 80, 400, 93), acc=(500, 500, 100, 5000), feed=(500, 500, 5, 25),
                   accel=500, jerk=(10, 10, 0.3, 5), jd=0.08),
    "ramps": dict(steps=(80, 80, 4000, 500), acc=(3000, 3000, 100, 10000), feed=(300, 300, 5, 25),
                  accel=3000, jerk=(10, 10, 0.3, 5), jd=0.013),
}


def prepare(src, dst):
    out = ["M207 S3"]
    for line in open(src, errors="replace"):
        words = line.split(";")[0].split()
        cmd = words[0] if words else ""
        if cmd in ("G28", "M109", "M190") or (cmd == "G10" and any(w[0] in "PS" for w in words[1:])):
            continue
        out.append(line.rstrip("\n").replace("{machine_depth}", "220"))
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


def mcodes(s, mode):
    axes = lambda t: " ".join(f"{a}{v:g}" for a, v in zip("XYZE", t))
    a = s["accel"]
    corner = f"M205 {axes(s['jerk'])} S0 T0" if mode == "jerk" else f"M205 S0 T0 J{s['jd']:g}"
    return "\n".join([f"M92 {axes(s['steps'])}", f"M201 {axes(s['acc'])}", f"M203 {axes(s['feed'])}",
                      f"M204 P{a:g} R{a:g} T{a:g}", corner])


def toml(s, mode):
    axes = lambda t, a: "\n".join(f"{k} = {float(v)!r}" for k, v in zip("xyze", t)) + f"\na = {a}"
    corner = ("jerk_mm_s = { " + ", ".join(f"{k} = {float(v)!r}" for k, v in zip("xyze", s["jerk"])) + " }"
              if mode == "jerk" else f"junction_deviation_mm = {float(s['jd'])!r}")
    steps = "\n".join(f"{k} = {float(v)!r}" for k, v in zip("xyze", s["steps"]))
    a = float(s["accel"])
    return (f"name = \"{mode} limits\"\n[motion.steps]\n{steps}\n[motion.max_feed_mm_s]\n{axes(s['feed'], 360.0)}\n"
            f"[motion.max_accel_mm_s2]\n{axes(s['acc'], 3600.0)}\n"
            f"[motion.accel]\nprint_mm_s2 = {a}\nretract_mm_s2 = {a}\ntravel_mm_s2 = {a}\n"
            f"[motion.corners]\nmode = \"marlin\"\n{corner}\n")


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "prepare":
        prepare(sys.argv[2], sys.argv[3])
    elif what == "mcodes":
        print(mcodes(SETS[sys.argv[2]], sys.argv[3]))
    elif what == "toml":
        print(toml(SETS[sys.argv[2]], sys.argv[3]))
    elif what == "total":
        print(re.search(r'"estimatedPrintTime": ([0-9.e+-]+)', sys.stdin.read()).group(1))
