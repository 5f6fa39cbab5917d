"""Ctrl-C and the output arguments, as a Python caller meets them (issue 36, item 6).

A Ctrl-C during a long call stops it within a second, removes its scratch file, writes no output
and raises ``KeyboardInterrupt``; during ``gweave.main`` it raises ``SystemExit(130)`` so that
``finally`` blocks and ``atexit`` handlers run. An output together with ``in_place=True`` is
refused, as the command line refuses ``-o`` with ``--in-place``.
"""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, List

import pytest

import gweave

# About 100 MB of moves: each call below takes seconds on it (the debug build takes longer).
LINES = 5_000_000
# A binder-jet job of 3200 layers (the example's 8, 400 times): about 15 s of raster.
RASTER = Path(__file__).resolve().parents[3] / "examples" / "raster"


@pytest.fixture(scope="module")
def big(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("big") / "big.gcode"
    path.write_bytes(b"T0\n" + b"G1 X1.5 Y2.25 E0.125\n" * LINES + b"T1\n")
    return path


def scratch_files(folder: Path) -> List[Path]:
    return [p for p in folder.iterdir() if p.name.startswith(".gweave-")]


def bytes_read() -> int:
    """What this process has read so far, all threads (``rchar`` of ``/proc/self/io``)."""
    for line in Path("/proc/self/io").read_text().splitlines():
        if line.startswith("rchar:"):
            return int(line.split()[1])
    raise AssertionError("no rchar in /proc/self/io")


# A call that writes nothing is interrupted once it has read this much of its input: well into
# its work, and far from its end, with a debug build as with a release one (a fixed delay let a
# release build's `estimate` finish first: 0.3 s for the 100 MB).
READ_BEFORE_CTRL_C = 8 << 20


def interrupt_when(ready: Callable[[], bool], sent: List[float], ended: threading.Event) -> None:
    """A thread that sends this process SIGINT (a real Ctrl-C) once ``ready()``, noting when;
    nothing if the call ``ended`` first."""

    def run() -> None:
        while not ready():
            if ended.wait(0.002):
                return
        time.sleep(0.05)
        if not ended.is_set():
            sent.append(time.monotonic())
            os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=run, daemon=True).start()


@pytest.fixture
def python_ctrl_c():
    """Python's own Ctrl-C handling (``KeyboardInterrupt``), whatever the test runner set."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def calls(big: Path, out: Path):
    return {
        "cat": lambda: gweave.cat(big, out),
        "purge_shift": lambda: gweave.purge_shift(big, out, purge_mm=5),
        "mix": lambda: gweave.mix(big, out, map=["T0=Orange", "T1=Violet"]),
        "preview": lambda: gweave.preview(big, output=out.with_suffix(".png")),
        "sim": lambda: gweave.sim(big),
        "estimate": lambda: gweave.estimate(big),
        "raster": lambda: gweave.raster([RASTER / "layers"] * 400, out, head=RASTER / "c6602.toml"),
    }


@pytest.mark.parametrize("name", ["cat", "purge_shift", "mix", "preview", "sim", "estimate", "raster"])
def test_ctrl_c_stops_a_long_call_within_a_second_and_writes_nothing(big, tmp_path, name, python_ctrl_c):
    # Regression: the call ran to its end, wrote its output, and only then raised.
    out = tmp_path / "out.gcode"
    call = calls(big, out)[name]
    sent: List[float] = []
    # Transforms are interrupted once their scratch file exists; the others (the preview draws
    # only after reading) once they are reading.
    writes = name not in ("preview", "sim", "estimate")
    read_at_start = bytes_read()
    ready = (
        (lambda: bool(scratch_files(tmp_path)))
        if writes
        else (lambda: bytes_read() - read_at_start > READ_BEFORE_CTRL_C)
    )
    ended = threading.Event()
    interrupt_when(ready, sent, ended)
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
    finally:
        ended.set()
    stopped = time.monotonic()
    assert sent, "the call ended before the interrupt was sent"
    assert stopped - sent[0] < 1.0, f"{name} took {stopped - sent[0]:.2f} s to stop"
    assert list(tmp_path.iterdir()) == [], "an output or a scratch file was left"


def test_ctrl_c_in_main_raises_system_exit_and_runs_finally_and_atexit(big, tmp_path):
    # Regression: the interpreter ended at once with status 130, running neither.
    out = tmp_path / "out.gcode"
    script = (
        "import atexit, sys, gweave\n"
        "atexit.register(lambda: print('atexit ran', flush=True))\n"
        "try:\n"
        f"    gweave.main(['cat', {str(big)!r}, '-o', {str(out)!r}, '-q'])\n"
        "except SystemExit as e:\n"
        "    print('SystemExit', e.code, type(e.__cause__).__name__, flush=True)\n"
        "    raise\n"
        "finally:\n"
        "    print('finally ran', flush=True)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    start = time.monotonic()
    while not scratch_files(tmp_path):
        assert child.poll() is None, child.communicate()
        assert time.monotonic() - start < 30, "no scratch file appeared"
        time.sleep(0.002)
    time.sleep(0.05)
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=30)
    assert child.returncode == 130, (child.returncode, stdout, stderr)
    assert stdout.decode().splitlines() == ["SystemExit 130 KeyboardInterrupt", "finally ran", "atexit ran"], stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "call",
    [
        lambda src, out: gweave.cat(src, out, in_place=True),
        lambda src, out: gweave.purge_shift(src, out, in_place=True, purge_mm=5),
        lambda src, out: gweave.mix(src, out, in_place=True, map=["T0=Orange", "T1=Violet"]),
        lambda src, out: gweave.rotary_wrap(src, out, in_place=True, mandrel_diameter=40),
    ],
    ids=["cat", "purge_shift", "mix", "rotary_wrap"],
)
def test_an_output_with_in_place_is_refused(data, tmp_path, call):
    # Regression: the output was ignored and the input replaced.
    src = tmp_path / "a.gcode"
    src.write_bytes((data / "cura" / "cura_dual.gcode").read_bytes())
    before = src.read_bytes()
    with pytest.raises(ValueError, match=r"output=.*wanted\.gcode and in_place=True: give one of them"):
        call(src, tmp_path / "wanted.gcode")
    assert src.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gcode"]
