/*
 * gweave in OctoPrint's page: a badge under each G-code file in the file list (gweave's print
 * time, the check's verdict, the upload processing, the analysis progress), and notifications
 * for the plugin's messages (an upload gweave refused, the check of a selected file, a print
 * refused on errors). The settings page binds to OctoPrint's settings view model directly.
 */
$(function () {
    // The badge goes into the file list's own template, before Knockout first renders it, under
    // the file's name (the action buttons take the bottom right of an entry).
    var template = document.getElementById("files_template_machinecode");
    if (template && template.innerHTML.indexOf("gweave-badge") < 0) {
        template.innerHTML = template.innerHTML.replace(
            /(<div class="internal"[\s\S]*?<\/div>)/,
            '$1<div class="gweave-badge" data-bind="html: window.gweaveBadge ? window.gweaveBadge($data) : \'\'"></div>'
        );
    }

    function GweaveViewModel(parameters) {
        var self = this;
        self.settings = parameters[0];
        // Analysis progress per file path, 0..1, while gweave reads it.
        self.progress = ko.observable({});

        function label(kind, text, title) {
            return '<span class="label ' + kind + '" title="' + _.escape(title || "") + '">' + _.escape(text) + "</span> ";
        }

        function count(n, what) {
            return n + " " + what + (n === 1 ? "" : "s");
        }

        window.gweaveBadge = function (file) {
            var out = "";
            var p = self.progress()[file.path];
            if (p !== undefined && p < 1) {
                out += label("label-info", "gweave " + Math.round(p * 100) + " %", "gweave is analysing this file");
            }
            var a = file.gcodeAnalysis && file.gcodeAnalysis.gweave;
            if (a) {
                var secs = file.gcodeAnalysis.estimatedPrintTime;
                var lines = (a.errors || []).concat(a.warnings || []);
                var kind = a.errors && a.errors.length ? "label-important" : lines.length ? "label-warning" : "label-success";
                var text = "gweave" + (secs !== undefined ? " " + formatDuration(secs) : "");
                if (a.errors && a.errors.length) text += ", " + count(a.errors.length, "error");
                else if (lines.length) text += ", " + count(lines.length, "warning");
                out += label(kind, text, (a.machine ? a.machine + ": " : "") + (lines.join("\n") || "no warnings"));
            }
            var u = file.gweave && file.gweave.upload;
            if (u) {
                out += u.ok
                    ? label("label-success", "gweave " + u.on_upload.split(" ")[0], "processed on upload: gweave " + u.on_upload)
                    : label("label-important", "stored as uploaded", "gweave " + u.on_upload + ": " + u.error);
            }
            return out;
        };

        function notify(title, text, type) {
            new PNotify({ title: title, text: _.escape(text), type: type, hide: type !== "error" });
        }

        self.onDataUpdaterPluginMessage = function (plugin, data) {
            if (plugin !== "gweave") return;
            if (data.type === "progress") {
                var p = _.clone(self.progress());
                p[data.path] = data.progress;
                self.progress(p);
            } else if (data.type === "upload" && !data.ok) {
                notify("gweave: " + data.path + " stored as uploaded", "gweave " + data.on_upload + ": " + data.error, "error");
            } else if (data.type === "analysis_error") {
                notify("gweave could not analyse " + data.path, data.message, "error");
            } else if (data.type === "check" && (data.errors.length || data.warnings.length)) {
                var lines = data.errors.concat(data.warnings);
                if (data.details && data.details.sim) lines = lines.concat(data.details.sim.first || []);
                var blocked = data.block && data.errors.length ? "\nPrinting is blocked until the errors are fixed." : "";
                notify("gweave: " + data.path, lines.join("\n") + blocked, data.errors.length ? "error" : "notice");
            } else if (data.type === "blocked") {
                notify("gweave: print refused", data.path + ": " + data.errors.join("; "), "error");
            }
        };
    }

    OCTOPRINT_VIEWMODELS.push({
        construct: GweaveViewModel,
        dependencies: ["settingsViewModel"],
        elements: []
    });
});
