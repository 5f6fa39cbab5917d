"""The check before printing: what ``gweave check`` and the virtual printer say about a file.

Errors (printing is blocked on them when ``block_on_errors`` is set):
- ``gweave check`` errors: malformed numbers, checksum or line-number errors;
- the virtual printer halted (a thermal fault or ``M112``) or refused a command (a move out of
  the machine's reach, a bad mixing or limit value).

Warnings (shown, never blocking): ``gweave check`` warnings (moves off the printer profile's bed,
extrusion before any hotend temperature, absurd feed rates, ...) and the virtual printer's other
warnings (out of bounds, cold extrusion, unknown commands, heating waits that never end).
"""

from __future__ import annotations

from typing import Any, Dict, List

# Virtual printer warnings that mean the real machine would stop or refuse.
SIM_ERRORS = ("refused", "thermal")
# Detailed virtual printer warnings kept for display.
KEEP_SIM = 10


def summarise(check, sim: Dict[str, Any]) -> Dict[str, Any]:
    """The ``gweave`` part of the analysis that the badge and the print check read."""
    errors: List[str] = []
    warnings: List[str] = []
    if check.errors:
        errors.append(f"gweave check: {count(check.errors, 'error')}")
    if check.warnings:
        warnings.append(f"gweave check: {count(check.warnings, 'warning')}")
    if sim.get("halted"):
        faults = "; ".join(f.get("message", str(f)) if isinstance(f, dict) else str(f) for f in sim["thermal_faults"])
        errors.append(f"virtual printer halted{': ' + faults if faults else ''}")
    for kind, n in sorted(sim.get("warning_counts", {}).items()):
        (errors if kind in SIM_ERRORS else warnings).append(f"virtual printer: {n} {kind.replace('_', ' ')}")
    return {
        "errors": errors,
        "warnings": warnings,
        "check": {"errors": check.errors, "warnings": check.warnings, "first": check.first},
        "sim": {
            "halted": bool(sim.get("halted")),
            "warning_counts": sim.get("warning_counts", {}),
            "first": [describe(w) for w in sim.get("warnings", [])[:KEEP_SIM]],
        },
    }


def count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def describe(w: Dict[str, Any]) -> str:
    """One virtual printer warning as a line: ``line 12: cold extrusion (hotend 0 at 25 C, min 170 C)``."""
    kind = w.get("kind", "?")
    extra = {k: v for k, v in w.items() if k not in ("line", "t_s", "kind")}
    detail = ", ".join(f"{k} {v}" for k, v in extra.items())
    return f"line {w.get('line')}: {kind.replace('_', ' ')}" + (f" ({detail})" if detail else "")


def blocking(verdict: Dict[str, Any]) -> bool:
    return bool(verdict.get("errors"))
