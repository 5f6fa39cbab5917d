"""gweave for OctoPrint: gweave's print time and filament for every upload, uploads processed by a
gweave transform, and a check on the virtual printer before printing.

Settings (``plugins.gweave`` in OctoPrint's ``config.yaml``, or the plugin's settings page):

- ``machine``: a gweave machine profile (TOML path) for the print time and the virtual printer;
  empty: gweave's built-in machine (RAMPS 1.4 Marlin);
- ``on_upload``: a gweave transform applied to each uploaded G-code file, for example
  ``purge-shift --purge-mm 2.5`` or ``mix -c /path/mix.toml``; empty: uploads are stored as they come;
- ``block_on_errors``: refuse to start a print when the check finds errors;
- ``timeout_s``: the longest one gweave run may take.

The pieces: :mod:`.analysis` (the analysis queue), :mod:`.upload` (the preprocessor),
:mod:`.verdict` (what counts as an error), :mod:`.runner` (running the gweave CLI).
"""

from __future__ import annotations

import re
import threading
import time
from collections import deque
from typing import Any, Dict, Optional

import flask
import octoprint.filemanager
import octoprint.plugin
from octoprint.events import Events

from . import analysis, upload, verdict

__plugin_name__ = "gweave"
__plugin_pythoncompat__ = ">=3.8,<4"

# Seconds between two progress messages for the same file.
PROGRESS_EVERY_S = 0.5
# Upload reports kept for GET /api/plugin/gweave.
KEEP_UPLOADS = 20
# A request that would start a print: POST /api/files/local/<path> (select + print) or /api/job.
_FILES_API = re.compile(r"^/api/files/(local)/(.+)$")


class GweavePlugin(
    octoprint.plugin.SettingsPlugin,
    octoprint.plugin.TemplatePlugin,
    octoprint.plugin.AssetPlugin,
    octoprint.plugin.EventHandlerPlugin,
    octoprint.plugin.SimpleApiPlugin,
):
    def __init__(self) -> None:
        self._pending: Dict[str, Dict[str, Any]] = {}
        self._uploads: deque = deque(maxlen=KEEP_UPLOADS)
        self._progress_sent: Dict[str, float] = {}
        self._lock = threading.Lock()

    # ---- settings ------------------------------------------------------------------------------

    def get_settings_defaults(self) -> Dict[str, Any]:
        return {"machine": "", "on_upload": "", "block_on_errors": False, "timeout_s": 600}

    def machine(self) -> Optional[str]:
        return (self._settings.get(["machine"]) or "").strip() or None

    def timeout_s(self) -> float:
        return float(self._settings.get(["timeout_s"]) or 600)

    @staticmethod
    def bed(profile: Optional[Dict[str, Any]]) -> Optional[tuple]:
        """The printer profile's volume for ``gweave check --bed`` (rectangular beds from 0,0 only)."""
        volume = (profile or {}).get("volume") or {}
        if volume.get("formFactor") != "rectangular" or volume.get("origin") != "lowerleft":
            return None
        return (float(volume["width"]), float(volume["depth"]), float(volume["height"]))

    # ---- web interface -------------------------------------------------------------------------

    def get_template_configs(self):
        return [{"type": "settings", "custom_bindings": False}]

    def get_assets(self):
        return {"js": ["js/gweave.js"], "css": ["css/gweave.css"]}

    def get_api_commands(self):
        return {}

    def on_api_get(self, request):
        """The last upload reports, and with ``?path=`` the check of that file."""
        path = request.args.get("path")
        body: Dict[str, Any] = {"uploads": list(self._uploads)}
        if path:
            body["verdict"] = self.verdict("local", path)
        return flask.jsonify(body)

    # ---- analysis ------------------------------------------------------------------------------

    def analysis_queue_factories(self, *args, **kwargs):
        return {"gcode": lambda finished: analysis.GweaveAnalysisQueue(finished, self)}

    def analysis_progress(self, path: str, fraction: float) -> None:
        now = time.monotonic()
        with self._lock:
            last = self._progress_sent.get(path, 0.0)
            if fraction < 1.0 and now - last < PROGRESS_EVERY_S:
                return
            self._progress_sent[path] = now
            if fraction >= 1.0:
                self._progress_sent.pop(path, None)
        self._plugin_manager.send_plugin_message(
            self._identifier, {"type": "progress", "path": path, "progress": round(fraction, 3)}
        )

    def analysis_failed(self, path: str, message: str) -> None:
        self._logger.error("gweave could not analyse %s: %s", path, message)
        self._plugin_manager.send_plugin_message(
            self._identifier, {"type": "analysis_error", "path": path, "message": message}
        )

    # ---- upload processing ---------------------------------------------------------------------

    def preprocess(self, path, file_object, links=None, printer_profile=None, allow_overwrite=True, *args, **kwargs):
        if not octoprint.filemanager.valid_file_type(path, type="gcode"):
            return file_object
        on_upload = self._settings.get(["on_upload"]) or ""
        try:
            argv = upload.parse(on_upload)
        except upload.UploadArgsError as e:
            return self._upload_done(path, file_object, on_upload, str(e))
        if argv is None:
            return file_object
        stored, error = upload.process(file_object, argv, timeout_s=self.timeout_s())
        return self._upload_done(path, stored, on_upload, error)

    def _upload_done(self, path: str, stored, on_upload: str, error: Optional[str]):
        report = {"path": path, "on_upload": on_upload, "ok": error is None, "error": error, "date": int(time.time())}
        if error is None:
            self._logger.info("gweave %s: %s processed", on_upload, path)
        else:
            self._logger.error("gweave %s: %s stored as uploaded: %s", on_upload, path, error)
        with self._lock:
            self._pending[path] = report
            self._uploads.append(report)
        self._plugin_manager.send_plugin_message(self._identifier, {"type": "upload", **report})
        return stored

    # ---- events: upload reports into metadata, the check when a file is selected --------------

    def on_event(self, event, payload):
        if event == Events.FILE_ADDED and payload.get("storage") == "local":
            with self._lock:
                report = self._pending.pop(payload["path"], None)
            if report is not None:
                self._file_manager.set_additional_metadata(
                    "local", payload["path"], "gweave", {"upload": report}, overwrite=True
                )
        elif event == Events.FILE_SELECTED and payload.get("origin") == "local":
            threading.Thread(target=self._announce_check, args=(payload["path"],), daemon=True).start()

    def _announce_check(self, path: str) -> None:
        v = self.verdict("local", path)
        self._plugin_manager.send_plugin_message(
            self._identifier,
            {"type": "check", "path": path, "block": bool(self._settings.get_boolean(["block_on_errors"])), **v},
        )

    def verdict(self, origin: str, path: str) -> Dict[str, Any]:
        """The check of a stored file: from its analysis, or run now if it has none yet."""
        meta = self._file_manager.get_metadata(origin, path) or {}
        found = (meta.get("analysis") or {}).get("gweave")
        if found is None:
            profile = self._printer_profile_manager.get_current_or_default()
            try:
                found = analysis.analyse(
                    self._file_manager.path_on_disk(origin, path),
                    machine=self.machine(),
                    bed=self.bed(profile),
                    timeout_s=self.timeout_s(),
                )["gweave"]
            except Exception as e:  # the check itself failed: that is an error to show
                found = {"errors": [f"gweave could not check the file: {e}"], "warnings": []}
        return {"errors": found.get("errors", []), "warnings": found.get("warnings", []), "details": found}

    # ---- blocking a print on errors ------------------------------------------------------------

    def before_api_request(self, *args, **kwargs):
        return [self._refuse_print_on_errors]

    def _refuse_print_on_errors(self):
        request = flask.request
        if request.method != "POST" or not self._settings.get_boolean(["block_on_errors"]):
            return None
        body = request.get_json(silent=True) or {}
        command = body.get("command")
        path = None
        if request.path == "/api/job" and command in ("start", "restart"):
            job = (self._printer.get_current_job() or {}).get("file") or {}
            if job.get("origin") == "local":
                path = job.get("path")
        else:
            m = _FILES_API.match(request.path)
            if m and command == "select" and body.get("print") in (True, "true", 1):
                path = m[2]
        if not path:
            return None
        v = self.verdict("local", path)
        if not verdict.blocking(v):
            return None
        message = f"gweave: {path} not printed: " + "; ".join(v["errors"])
        self._logger.warning(message)
        self._plugin_manager.send_plugin_message(self._identifier, {"type": "blocked", "path": path, **v})
        return flask.make_response(flask.jsonify(error=message), 409)


__plugin_implementation__ = GweavePlugin()
__plugin_hooks__ = {
    "octoprint.filemanager.analysis.factory": __plugin_implementation__.analysis_queue_factories,
    "octoprint.filemanager.preprocessor": __plugin_implementation__.preprocess,
    "octoprint.server.api.before_request": __plugin_implementation__.before_api_request,
}
