"""Helpers of the tests that play a host: the CLI to run and waiting with a deadline."""

import os
import sys
import time


def gweave_command() -> list:
    """The CLI under test: $GWEAVE if set (a built binary), else the installed Python package."""
    exe = os.environ.get("GWEAVE")
    return [exe] if exe else [sys.executable, "-m", "gweave"]


def wait_for(condition, timeout_s: float, what: str) -> None:
    """Poll `condition` every 10 ms; fail naming `what` after `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.01)
