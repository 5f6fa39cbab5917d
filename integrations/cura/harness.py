"""Runs integrations/cura/Gweave.py through Cura's own post-processing machinery, headless.

Run with a Python that has Cura's Uranium (Debian's ``cura`` package: ``/usr/bin/python3``)::

    python3 harness.py GCODE OUTPUT '{"mode": "purge-shift", "purge_mm": 2.5}'

What is Cura's own code here: the ``Script`` base class from Cura's PostProcessingPlugin
(``/usr/lib/cura/plugins/PostProcessingPlugin/Script.py``), and Uranium's settings machinery it
drives (``ContainerRegistry``, ``DefinitionContainer`` parsing the script's settings JSON,
``InstanceContainer``, ``ContainerStack``, ``VersionUpgradeManager``). The script is loaded as
``PostProcessingPlugin.loadScripts`` loads a script (module named after the plugin's, class
named after the file), then created and initialised as ``addScriptToList`` does, its settings
set in its instance container as Cura's settings panel does, and ``execute`` called as
``PostProcessingPlugin.execute`` does. Only the Qt application is replaced, by a stand-in with the
two methods the settings machinery calls (``callLater``, ``getGlobalContainerStack``).

The G-code list is cut as Cura hands it over: the header, the start G-code
(``;Generated with Cura_SteamEngine``), one string per ``;LAYER:`` and what follows the last.
Prints the number of pieces in and out as JSON; writes their concatenation (what Cura saves).
"""

import importlib.util
import json
import os
import sys
import types

PLUGIN = os.environ.get("CURA_POSTPROCESSING", "/usr/lib/cura/plugins/PostProcessingPlugin")
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "Gweave.py")


class HeadlessApplication:
    """What Uranium's settings classes ask of Cura's application."""

    def callLater(self, fn, *args, **kwargs):
        fn(*args, **kwargs)

    def getGlobalContainerStack(self):
        return None


def setup_uranium():
    import UM.Settings.ContainerStack
    import UM.Settings.InstanceContainer
    from UM.Application import Application
    from UM.Settings.ContainerRegistry import ContainerRegistry
    from UM.VersionUpgradeManager import VersionUpgradeManager

    # What Uranium's Application.initialize() does for the settings (UM/Application.py).
    app = HeadlessApplication()
    Application._Application__instance = app
    registry = ContainerRegistry(app)
    UM.Settings.InstanceContainer.setContainerRegistry(registry)
    UM.Settings.ContainerStack.setContainerRegistry(registry)
    VersionUpgradeManager(app)


def load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def load_script_class():
    # The plugin package without its __init__ (that one needs the Qt application).
    pkg = types.ModuleType("PostProcessingPlugin")
    pkg.__path__ = [PLUGIN]
    sys.modules["PostProcessingPlugin"] = pkg
    load("PostProcessingPlugin.Script", os.path.join(PLUGIN, "Script.py"))
    # As PostProcessingPlugin.loadScripts: spec name `PostProcessingPlugin.PostProcessingPlugin.<file>`.
    module = load("PostProcessingPlugin.PostProcessingPlugin.Gweave", SCRIPT)
    return module.Gweave


def cura_pieces(text):
    pieces, start = [], 0
    lines = text.splitlines(keepends=True)
    at = 0
    for line in lines:
        if line.startswith(";Generated with") or line.startswith(";LAYER:"):
            if at > start:
                pieces.append(text[start:at])
                start = at
        at += len(line)
    pieces.append(text[start:])
    return pieces


def main():
    gcode, output, settings = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    setup_uranium()
    cls = load_script_class()
    script = cls()
    script.initialize()
    assert script._instance is not None, "Uranium refused the script's settings definition"
    for key, value in settings.items():
        script._instance.setProperty(key, "value", value)
        assert script.getSettingValueByKey(key) == value, (key, script.getSettingValueByKey(key))
    with open(gcode, encoding="utf-8", newline="") as f:
        data = cura_pieces(f.read())
    result = script.execute(data)
    with open(output, "w", encoding="utf-8", newline="") as f:
        f.write("".join(result))
    first = [p.split("\n", 1)[0] for p in result]
    print(json.dumps({"pieces_in": len(data), "pieces_out": len(result), "firsts_equal": first == [p.split("\n", 1)[0] for p in data]}))


if __name__ == "__main__":
    main()
