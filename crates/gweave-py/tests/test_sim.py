"""The virtual printer from Python: whole-file reports and one command at a time."""

from pathlib import Path

import pytest

import gweave

MACHINES = Path(__file__).resolve().parents[3] / "examples" / "machines"


def test_sim_report_of_a_real_file(data: Path) -> None:
    r = gweave.sim(data / "cura" / "cura_torus.gcode")
    f = r["filament_mm"][0]
    assert abs(f - 773.6185) < 1e-6
    assert r["count"][3] == round(f * 500)
    assert len(r["layer_s"]) == 28
    t = r["time"]
    assert t["heating_s"] > 60 and not r["halted"]


def test_sim_with_a_machine_profile(data: Path) -> None:
    r = gweave.sim(data / "cura" / "cura_torus.gcode", machine=MACHINES / "klipper.toml")
    assert r["machine"] == "Klipper cartesian"
    assert r["time"]["overhead_s"] > 0.25


def test_machine_by_the_name_of_a_built_in_profile(data: Path, tmp_path: Path, monkeypatch) -> None:
    # The example profiles were not installed with the package: `machine="klipper"` found no file.
    monkeypatch.chdir(tmp_path)
    path = data / "cura" / "cura_torus.gcode"
    by_name = gweave.estimate(path, machine="prusa-mk3")
    assert by_name["machine"] == "Prusa i3 MK3S"
    assert by_name == gweave.estimate(path, machine=MACHINES / "prusa-mk3.toml")
    assert gweave.sim(path, machine="klipper")["machine"] == "Klipper cartesian"
    # A file of that name wins over the built-in profile.
    (tmp_path / "klipper").write_text('name = "mine"\n')
    assert gweave.estimate(path, machine="klipper")["machine"] == "mine"


def test_the_slicers_limits_are_estimates_only(data: Path, tmp_path: Path, monkeypatch) -> None:
    # A new user's trial: `sim(machine="slicer")` raised a bare FileNotFoundError('slicer').
    monkeypatch.chdir(tmp_path)
    path = data / "prusaslicer" / "pr_box_3tool_tower.gcode"
    said = r"^--machine slicer \(the limits the slicer wrote into the file\) is for `gweave estimate` only"
    with pytest.raises(ValueError, match=said):
        gweave.sim(path, machine="slicer")
    assert gweave.estimate(path, machine="slicer")["total_s"] > 0


def test_estimate_plans_like_the_virtual_printer(data: Path) -> None:
    path = data / "cura" / "cura_torus.gcode"
    klipper = MACHINES / "klipper.toml"
    e = gweave.estimate(path, machine=klipper, steps=True)
    s = gweave.sim(path, machine=klipper)
    assert (e["machine"], e["planner"], e["steps_counted"]) == ("Klipper cartesian", "klipper", True)
    # The same planner on the same moves: the same motion time, to the bit.
    assert e["motion_s"] == s["time"]["motion_s"]
    assert len(e["layer_s"]) == 28
    assert e["steps"]["axes"][3] == s["steps"]["axes"][3] > 0
    fast = gweave.estimate(path, machine=klipper)
    assert fast["total_s"] == e["total_s"] and fast["steps"]["axes"] == [0, 0, 0, 0, 0]


def test_machine_replies_like_marlin() -> None:
    m = gweave.Machine()
    assert m.boot_lines()[0] == "start"
    assert m.execute("G1 X10 F3000") == ["ok"]
    assert m.execute("M114") == ["X:10.00 Y:0.00 Z:0.00 E:0.00 Count X:800 Y:0 Z:0", "ok"]
    assert m.execute("G123") == ['echo:Unknown command: "G123"', "ok"]
    assert m.execute("M105") == ["ok T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0"]
    assert m.execute("G1 X20 E1") == ["echo: cold extrusion prevented", "ok"]
    assert m.execute("M112") == ["Error:Printer halted. kill() called!"]
    assert m.now_s > 0
    assert m.report()["halted"] is True


def test_check_against_a_machine_profiles_bed(tmp_path: Path) -> None:
    # The purge line of Prusa's start G-code runs at Y -3: on the MK3S's bed, off one from Y 0.
    g = tmp_path / "purge-line.gcode"
    g.write_text("M104 S215\nG1 Y-3.0 F1000\nG1 X60 E9\n")
    mk3 = gweave.check(g, machine="prusa-mk3")
    assert (mk3["warnings"], mk3["bed"]["y_mm"]) == (0, [-4.0, 212.5])
    assert gweave.check(g, machine=MACHINES / "marlin-ramps.toml")["warnings"] == 2


def test_sim_stops_at_the_seeds_m0(tmp_path: Path) -> None:
    # `gweave sim` stopped at the controller seed's M0 (`[firmware] m0 = "seed"`), `gweave.sim`
    # ran on past it: the loop was written in both front ends. X500 is past the bed (out of
    # bounds) and only Marlin's M0 reaches it.
    job = tmp_path / "job.gcode"
    job.write_text("G28\nG1 X50 F3000\nM0\nG1 X500\n")
    marlin = tmp_path / "marlin.toml"
    marlin.write_text('[firmware]\nm0 = "marlin"\n')
    for profile, runs_on in [(MACHINES / "seed-controller.toml", False), (marlin, True)]:
        r = gweave.sim(job, machine=profile)
        out_of_bounds = any(w["kind"] == "out_of_bounds" for w in r["warnings"])
        assert out_of_bounds == runs_on, profile
        if not runs_on:
            assert r["position"][0] == 0.0, r["position"]  # the seed's M0 homes the axes


def test_estimate_names_the_file_and_line_as_the_cli(tmp_path: Path) -> None:
    # The estimate was set up in both front ends and its refusals drifted: Python said
    # `bad.gcode: line 3: ...` where the CLI says `bad.gcode:3: ...`.
    # (Marlin's `M204 S-1` is now skipped and counted, as the virtual printer refuses it and
    # carries on; a Klipper limit out of range still stops the estimate.)
    bad = tmp_path / "bad.gcode"
    bad.write_text("G28\nG1 X1 F600\nSET_VELOCITY_LIMIT ACCEL=-1\nG1 X5\n")
    with pytest.raises(ValueError) as refused:
        gweave.estimate(bad, machine=MACHINES / "klipper.toml")
    assert str(refused.value) == (
        f"{bad}:3: [motion.corners] max_accel_mm_s2 = -1 is out of range: 0.001 to 1000000 mm/s²"
    )


def test_sim_runs_a_core_profile_on_the_core_as_the_cli(tmp_path: Path) -> None:
    # `gweave sim` ran a `[firmware] kind = "gweave"` profile on the controller core; `gweave.sim`
    # ran it on the Marlin model. G1 X10 after homing is 800 steps at the profile's 80 steps/mm.
    job = tmp_path / "job.gcode"
    job.write_text("G28\nG1 X10 F600\n")
    r = gweave.sim(job, machine=MACHINES / "gweave-ramps.toml")
    assert r["lines"] == 2 and not r["halted"], r
    assert r["end_steps"][0] == 800, r
    with pytest.raises(ValueError, match=r"^fault is for the Marlin model"):
        gweave.sim(job, machine=MACHINES / "gweave-ramps.toml", fault=["hotend-cartridge-off@1s"])
