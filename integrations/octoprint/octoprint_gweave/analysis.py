"""gweave as OctoPrint's G-code analysis (the ``octoprint.filemanager.analysis.factory`` hook).

OctoPrint's own analysis times a file from a simple model; this queue fills the same
``gcodeAnalysis`` fields from gweave instead:

- ``estimatedPrintTime``: ``gweave estimate``'s ``total_s`` with the plugin's machine profile
  (the lookahead planner; heating waits and homing are not timed, as in ``gweave estimate``);
- ``filament.toolN``: ``gweave stats``' ``extruded_mm`` as ``length`` (mm) and its
  ``extruded_mm3`` as ``volume`` in cm³, OctoPrint's unit;
- ``printingArea`` and ``dimensions``: the box of every extrusion (``extrusion_bounds``);
- ``layers``: the layer count;
- ``gweave``: what the check before printing needs (``gweave check`` and the virtual printer's
  warnings, see :mod:`.verdict`) and the details (machine, per-layer time is left out: it grows
  with the file).

OctoPrint's ``travelArea`` is not filled: gweave measures the box of extrusions only.
"""

from __future__ import annotations

import logging
import time
from typing import Any, Callable, Dict, Optional

from octoprint.filemanager.analysis import AbstractAnalysisQueue, AnalysisAborted

from . import runner
from .verdict import summarise

# Share of the whole analysis each step takes, for the progress report (measured on the
# fixtures: the virtual printer is the slowest, stats the fastest).
STEPS = (("stats", 0.15), ("estimate", 0.25), ("check", 0.1), ("sim", 0.5))


def analyse(
    path: str,
    *,
    machine: Optional[str],
    bed: Optional[tuple],
    timeout_s: float,
    job: Optional[runner.Job] = None,
    progress: Optional[Callable[[float], None]] = None,
) -> Dict[str, Any]:
    """The ``gcodeAnalysis`` document for one file."""
    job = job or runner.Job()
    machine_args = ["--machine", machine] if machine else []
    done = 0.0
    parts: Dict[str, Any] = {}
    refused: Dict[str, str] = {}
    for step, share in STEPS:
        def report(f: float, base=done, share=share) -> None:
            if progress:
                progress(base + share * f)

        try:
            if step == "check":
                parts[step] = runner.check(job, path, bed=bed, timeout_s=timeout_s, progress=report)
            else:
                args = [step, path, *(machine_args if step in ("estimate", "sim") else [])]
                parts[step] = job.json(args, timeout_s=timeout_s, watch=path, progress=report)
        except runner.GweaveError as e:
            if job.aborted:
                raise
            # A file gweave refuses (stats stops at a checksum error) is the check's first error.
            refused[step] = str(e)
        done += share
        if progress:
            progress(done)
    return document(parts, refused, machine)


def document(parts: Dict[str, Any], refused: Dict[str, str], machine: Optional[str]) -> Dict[str, Any]:
    """The analysis from the parts that ran; a part gweave refused is an error of the check."""
    result: Dict[str, Any] = {}
    stats, estimate = parts.get("stats"), parts.get("estimate")
    if estimate:
        result["estimatedPrintTime"] = estimate["total_s"]
    if stats:
        result["filament"] = {
            f"tool{t['tool']}": {"length": t["extruded_mm"], "volume": t["extruded_mm3"] / 1000.0}
            for t in stats["filament"]
        }
        result["layers"] = stats["layers"]
        bounds = stats.get("extrusion_bounds")
        if bounds:
            lo, hi = bounds["min"], bounds["max"]
            result["printingArea"] = {
                "minX": lo[0], "minY": lo[1], "minZ": lo[2], "maxX": hi[0], "maxY": hi[1], "maxZ": hi[2]
            }
            result["dimensions"] = {"width": hi[0] - lo[0], "depth": hi[1] - lo[1], "height": hi[2] - lo[2]}
    summary = summarise(parts.get("check") or runner.CheckSummary(), parts.get("sim") or {})
    summary["errors"] = [f"gweave {step}: {msg}" for step, msg in refused.items()] + summary["errors"]
    result["gweave"] = {
        "machine": (estimate or {}).get("machine"),
        "machine_path": machine or None,
        "planner": (estimate or {}).get("planner"),
        "estimate": {k: estimate[k] for k in ("total_s", "motion_s", "dwell_s", "overhead_s", "blocks")}
        if estimate else None,
        "sim_total_s": parts["sim"]["time"]["total_s"] if "sim" in parts else None,
        "slicer": (stats or {}).get("slicer"),
        **summary,
    }
    return result


class GweaveAnalysisQueue(AbstractAnalysisQueue):
    """OctoPrint's analysis queue for ``gcode`` files, answered by gweave.

    ``plugin`` gives the settings (read at each file, so a changed machine applies to the next
    upload) and reports progress to the web interface.
    """

    def __init__(self, finished_callback, plugin) -> None:
        self._plugin = plugin
        self._job: Optional[runner.Job] = None
        self._reenqueue = True
        AbstractAnalysisQueue.__init__(self, finished_callback)
        self._logger = logging.getLogger("octoprint.plugins.gweave.analysis")

    def _do_analysis(self, high_priority: bool = False) -> Dict[str, Any]:
        entry = self._current
        self._job = runner.Job()
        started = time.monotonic()
        try:
            result = analyse(
                entry.absolute_path,
                machine=self._plugin.machine(),
                bed=self._plugin.bed(entry.printer_profile),
                timeout_s=self._plugin.timeout_s(),
                job=self._job,
                progress=lambda f: self._plugin.analysis_progress(entry.path, f),
            )
        except Exception as e:
            if self._job.aborted:
                raise AnalysisAborted(reenqueue=self._reenqueue)
            # OctoPrint's queue survives a RuntimeError only (it logs it; the file has no analysis).
            self._plugin.analysis_failed(entry.path, str(e))
            raise RuntimeError(f"gweave: {e}") from e
        finally:
            self._job = None
            # Done, failed or aborted (OctoPrint aborts a background analysis for an upload's):
            # the page's progress label goes either way, or it would stay at its last figure.
            self._plugin.analysis_progress(entry.path, 1.0)
        self._logger.info(
            "gweave analysed %s in %.2f s: %s s print time, errors: %s", entry.path, time.monotonic() - started,
            result.get("estimatedPrintTime"), result["gweave"]["errors"] or "none",
        )
        return result

    def _do_abort(self, reenqueue: bool = True) -> None:
        self._reenqueue = reenqueue
        job = self._job
        if job is not None:
            job.abort()
