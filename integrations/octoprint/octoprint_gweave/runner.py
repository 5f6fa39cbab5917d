"""Running the gweave command line for the plugin.

Every job runs the CLI of the installed gweave Python package (``python -m gweave``, the same
Rust binary as the ``gweave`` command) in a child process, for three reasons: the numbers are the
CLI's by construction (the file's time *is* ``gweave estimate``'s), a file that makes the engine
fail cannot take OctoPrint down with it, and the job can be stopped (the analysis queue aborts a
job when a print starts).

Memory stays bounded: ``stats``, ``estimate`` and ``sim`` answer with reports whose size does not
grow with the file (one entry per layer at most; the virtual printer keeps at most 1000 warnings),
and ``check``, whose JSON lists every finding, is read as text line by line, keeping the first
:data:`KEEP_FINDINGS`.

Progress on a large file comes from the child's own read position (``/proc/<pid>/fdinfo``): the
engine reads the input front to back, so the offset of its descriptor over the file size is the
fraction done. Where ``/proc`` does not exist, no progress is reported.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence

# Findings of `gweave check` kept for display; the counts are always complete.
KEEP_FINDINGS = 20
# How often the read position is sampled, seconds.
POLL_S = 0.25
# The bytes gweave reads from a file's end before its main read (`TAIL_BYTES`, gcode/ends.rs).
ENDS_TAIL = 256 * 1024

Progress = Callable[[float], None]


class GweaveError(Exception):
    """gweave refused the job: the message is the CLI's own (``file:line:column: what``)."""


@dataclass
class CheckSummary:
    errors: int = 0
    warnings: int = 0
    first: List[Dict[str, object]] = field(default_factory=list)


class Job:
    """One CLI run. :meth:`abort` may be called from another thread."""

    def __init__(self) -> None:
        self._proc: Optional[subprocess.Popen] = None
        self._lock = threading.Lock()
        self.aborted = False

    def abort(self) -> None:
        with self._lock:
            self.aborted = True
            if self._proc is not None and self._proc.poll() is None:
                self._proc.kill()

    def run(
        self,
        args: Sequence[str],
        *,
        timeout_s: float,
        watch: Optional[str] = None,
        progress: Optional[Progress] = None,
        on_line: Optional[Callable[[str], None]] = None,
    ) -> str:
        """Runs ``gweave ARGS``; returns its standard output (or "" when ``on_line`` took it).

        A non-zero exit raises :class:`GweaveError` with the last lines of standard error, except
        that ``check`` (1: findings) and ``sim`` (1: the machine halted) report through output.
        """
        cmd = [sys.executable, "-m", "gweave", *args]
        with self._lock:
            if self.aborted:
                raise GweaveError("aborted")
            self._proc = subprocess.Popen(
                cmd,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                stdin=subprocess.DEVNULL,
                text=True,
                errors="replace",
            )
        proc = self._proc
        stderr_tail: List[str] = []
        # stderr drained on its own thread so a chatty child never blocks on a full pipe.
        err_thread = threading.Thread(target=_tail, args=(proc.stderr, stderr_tail), daemon=True)
        err_thread.start()
        stop = threading.Event()
        watcher = None
        if watch and progress:
            watcher = threading.Thread(target=_watch, args=(proc.pid, watch, progress, stop), daemon=True)
            watcher.start()
        timer = threading.Timer(timeout_s, proc.kill)
        timer.start()
        try:
            if on_line is not None:
                for line in proc.stdout:  # type: ignore[union-attr]
                    on_line(line.rstrip("\n"))
                out = ""
            else:
                out = proc.stdout.read()  # type: ignore[union-attr]
            code = proc.wait()
        finally:
            timer.cancel()
            stop.set()
            # Joined, so no late sample follows what the caller reports next.
            if watcher is not None:
                watcher.join()
            err_thread.join(timeout=5)
        if self.aborted:
            raise GweaveError("aborted")
        if code < 0:
            raise GweaveError(f"gweave {args[0]} stopped after {timeout_s:.0f} s (or was killed)")
        if code != 0 and not (args[0] in ("check", "sim") and code == 1):
            msg = "\n".join(stderr_tail).strip() or f"gweave {args[0]} exited with {code}"
            raise GweaveError(msg)
        return out

    def json(self, args: Sequence[str], **kw) -> Dict[str, object]:
        return json.loads(self.run([*args, "--json", "-q"], **kw))


def _tail(stream, keep: List[str], n: int = 20) -> None:
    for line in stream:
        keep.append(line.rstrip("\n"))
        del keep[:-n]


def _watch(pid: int, path: str, progress: Progress, stop: threading.Event) -> None:
    """Samples the child's read offset in ``path`` until ``stop``, reporting it as a fraction
    that never goes back.

    gweave opens the file more than once: before its main read it reads the file's two ends
    (the slicer's settings, a cut file's missing footer), seeking to the last 256 KB. A sample
    that lands there must not count as progress, or the bar would jump near 1 and fall back. So a
    position in the last ``ENDS_TAIL`` bytes counts only when the same descriptor has moved
    forward to it since the last sample: the ends are read in one go and then stand still (or
    close), the main read goes on forward. Any figure below one already shown is dropped.
    """
    try:
        size = os.path.getsize(path)
        real = os.path.realpath(path)
    except OSError:
        return
    if size <= 0 or not os.path.isdir(f"/proc/{pid}/fd"):
        return
    fd, seen, shown = None, None, 0.0
    while not stop.wait(POLL_S):
        try:
            if fd is None:
                fd = next(
                    (n for n in os.listdir(f"/proc/{pid}/fd") if os.readlink(f"/proc/{pid}/fd/{n}") == real),
                    None,
                )
                if fd is None:
                    continue
            with open(f"/proc/{pid}/fdinfo/{fd}") as f:
                pos = int(next(line for line in f if line.startswith("pos:")).split()[1])
        except (OSError, StopIteration, ValueError):
            # The child closed the file or exited: nothing left to measure.
            fd, seen = None, None
            continue
        moved = seen is not None and pos > seen
        seen = pos
        if (moved or pos < size - ENDS_TAIL) and pos / size > shown:
            shown = min(pos / size, 1.0)
            progress(shown)


# `path:line:column: severity: message`, as `gweave check` prints each finding.
_FINDING = re.compile(r"^.*?:(\d+):(\d+): (error|warning): (.*)$")
# `path: N lines, E errors, W warnings`, its last line.
_SUMMARY = re.compile(r"^.*: (\d+) lines, (\d+) errors, (\d+) warnings$")


def check(job: Job, path: str, *, bed: Optional[Sequence[float]], timeout_s: float, progress=None) -> CheckSummary:
    """``gweave check`` read as text: complete counts, the first findings only."""
    summary = CheckSummary()

    def line(text: str) -> None:
        m = _FINDING.match(text)
        if m and len(summary.first) < KEEP_FINDINGS:
            summary.first.append(
                {"line": int(m[1]), "column": int(m[2]), "severity": m[3], "message": m[4]}
            )
        s = _SUMMARY.match(text)
        if s:
            summary.errors, summary.warnings = int(s[2]), int(s[3])

    args = ["check", path]
    if bed:
        args += ["--bed", ",".join(f"{v:g}" for v in bed)]
    job.run(args, timeout_s=timeout_s, watch=path, progress=progress, on_line=line)
    return summary


def transform(job: Job, argv: Sequence[str], src: str, dst: str, *, timeout_s: float) -> str:
    """``gweave <argv[0]> SRC -o DST <argv[1:]>``: what the CLI writes for the same arguments."""
    job.run([argv[0], src, "-o", dst, *argv[1:]], timeout_s=timeout_s)
    return dst
