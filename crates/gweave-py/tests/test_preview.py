"""gweave.preview and gweave.toolpath on cura/cura_dual.gcode (cylinder on T0, sphere on T1)."""

import pytest

import gweave
from _png import read_png

# Layer 60 (Z 12.3): T0 extrudes over X 117.6..145.4, Y 108.6..136.4 (the cylinder) and T1 over
# X 110.7..126.3, Y 119.7..135.3 (the sphere), read from the file.
T0_BOX = ((117.6, 145.4), (108.6, 136.4))
T1_BOX = ((110.69, 126.31), (119.69, 135.31))
ORANGE, BLUE, BACKGROUND = (0xE6, 0x9F, 0x00), (0x00, 0x72, 0xB2), (0xF7, 0xF7, 0xF5)


def test_preview_png_shows_both_tools(data):
    png = gweave.preview(data / "cura" / "cura_dual.gcode", layer=60, size=(400, 300))
    w, h, px = read_png(png)
    assert (w, h) == (400, 300)
    assert px.count(ORANGE) > 2000 and px.count(BLUE) > 2000, (px.count(ORANGE), px.count(BLUE))


def test_preview_report_names_the_colours(data, tmp_path):
    png, report = gweave.preview(data / "cura" / "cura_dual.gcode", layer=60, size=(400, 300), report=True)
    assert png.startswith(b"\x89PNG") and report["bytes"] == len(png)
    assert report["layers_drawn"] == [60, 60] and report["strokes"] > 100
    assert report["legend"] == [{"label": "T0", "colour": "#e69f00"}, {"label": "T1", "colour": "#0072b2"}]
    # The same picture as without the report.
    assert png == gweave.preview(data / "cura" / "cura_dual.gcode", layer=60, size=(400, 300))


def test_preview_beyond_the_last_layer_names_the_last_layer(data):
    # It was a blank picture: a user asking for layer 500 of a 204-layer file learnt nothing.
    with pytest.raises(ValueError, match=r"layer 500 is past the file's last layer, 203 \(layers count from 0\)"):
        gweave.preview(data / "cura" / "cura_dual.gcode", layers=(500, 600), size=(200, 100))


def test_preview_writes_svg_and_html(data, tmp_path):
    svg = gweave.preview(data / "cura" / "cura_dual.gcode", output=tmp_path / "l.svg", layer=60)
    assert (tmp_path / "l.svg").read_bytes() == svg
    assert svg.count(b"<path ") > 10
    html = gweave.preview(data / "cura" / "cura_dual.gcode", output=tmp_path / "v.html")
    assert html.startswith(b"<!DOCTYPE html>") and b"https://" not in html
    with pytest.raises(ValueError, match=r"^output: unknown output format \"jpg\" \(png, svg or html\)$"):
        gweave.preview(data / "cura" / "cura_dual.gcode", output=tmp_path / "x.jpg")
    with pytest.raises(ValueError, match="unknown view"):
        gweave.preview(data / "cura" / "cura_dual.gcode", view="side")


def test_toolpath_arrays(data):
    np = pytest.importorskip("numpy")
    tp = gweave.toolpath(data / "cura" / "cura_dual.gcode")
    n = len(tp["tool"])
    assert tp["start"].shape == (n, 3) and tp["end"].shape == (n, 3) and n > 50_000
    assert tp["start"].dtype == np.float32 and tp["extruding"].dtype == np.bool_
    assert len(tp["layer_z"]) == 204
    # Chained: each segment starts where the one before ended.
    assert np.array_equal(tp["start"][1:], tp["end"][:-1])
    for tool, ((x0, x1), (y0, y1)) in ((0, T0_BOX), (1, T1_BOX)):
        sel = tp["extruding"] & (tp["layer"] == 60) & (tp["tool"] == tool)
        assert sel.sum() > 50
        xy = np.concatenate([tp["start"][sel], tp["end"][sel]])
        assert xy[:, 0].min() >= x0 - 0.01 and xy[:, 0].max() <= x1 + 0.01
        assert xy[:, 1].min() >= y0 - 0.01 and xy[:, 1].max() <= y1 + 0.01
        assert np.allclose(xy[:, 2], 12.3, atol=1e-4)
    names = tp["feature_names"]
    used = {names[i] for i in np.unique(tp["feature"][tp["extruding"]])}
    assert {"outer_wall", "inner_wall", "infill"} <= used
    fewer = gweave.toolpath(data / "cura" / "cura_dual.gcode", travel=False, min_len=1.0)
    assert fewer["extruding"].all() and len(fewer["tool"]) < (tp["extruding"]).sum()
    assert tp["on_cylinder"] is False


def test_toolpath_of_a_rotary_program_lies_on_its_cylinders(tmp_path):
    np = pytest.importorskip("numpy")
    tube = tmp_path / "tube.gcode"
    gweave.rotary_tube(tube, mandrel_diameter=20, length=30, layer_count=2)
    # The header names the machine: the beads come out in 3D, layer k at the nozzle radius
    # 10 + 0.2 (k + 1) mm from the mandrel's axis (X), from X 0 to 30.
    tp = gweave.toolpath(tube, travel=False)
    assert tp["on_cylinder"] is True
    assert np.allclose(tp["layer_z"], [10.2, 10.4], atol=1e-6)
    for k, radius in enumerate((10.2, 10.4)):
        # A bead's layer is the radius it starts at (the tube climbs to the next layer while
        # extruding, so the last bead of a layer ends on the next one).
        pts = tp["start"][tp["layer"] == k]
        assert len(pts) > 100
        assert np.allclose(np.hypot(pts[:, 1], pts[:, 2]), radius, atol=1e-4)
        assert pts[:, 0].min() >= -1e-4 and pts[:, 0].max() <= 30 + 1e-4
    # Read flat, the rotary word would be a coordinate: nothing on a cylinder.
    assert gweave.toolpath(tube, travel=False, mandrel_diameter=None)["on_cylinder"] is True
    flat = tmp_path / "flat.gcode"
    flat.write_bytes(b"".join(l for l in tube.read_bytes().splitlines(keepends=True) if not l.startswith(b"; ")))
    assert gweave.toolpath(flat, travel=False)["on_cylinder"] is False
    again = gweave.toolpath(flat, travel=False, mandrel_diameter=20)
    assert again["on_cylinder"] is True and np.array_equal(again["start"], tp["start"])




def test_preview_colours_a_mixed_file_by_its_predicted_mixes(data, tmp_path):
    # examples/mix/bands.toml: Blue from layer 0, Yellow from 10, Magenta from 19.
    profile = data.parent.parent / "examples" / "mix" / "bands.toml"
    out = tmp_path / "bands.gcode"
    gweave.mix(data / "cura" / "cura_torus.gcode", out, config=profile)

    def dominant(layer):
        png = gweave.preview(out, layer=layer, colour_by="mix", mix_profile=profile, size=(300, 300))
        _, _, px = read_png(png)
        colours = [c for c in px if c != BACKGROUND]
        return max(set(colours), key=colours.count)

    blue, yellow = dominant(5), dominant(15)
    assert blue[2] > max(blue[0], blue[1]), blue
    assert yellow[0] > 200 and yellow[1] > 180 and yellow[2] < 80, yellow


def test_preview_draws_rotary_output_on_its_cylinder(tmp_path):
    # A tube on a 20 mm mandrel, 30 mm long: seen from the top, 2 x 10.4 mm across (the outer
    # layer's nozzle radius), not the 65 mm of the circumference.
    out = tmp_path / "tube.gcode"
    gweave.rotary_tube(out, mandrel_diameter=20, length=30, layer_count=2)
    w, h, px = read_png(gweave.preview(out, size=(400, 400)))
    column = [px[y * w + w // 2] for y in range(h)]
    lit = [y for y, c in enumerate(column) if c != BACKGROUND]
    row = [px[(h // 2) * w + x] for x in range(w)]
    cols = [x for x, c in enumerate(row) if c != BACKGROUND]
    ratio = (lit[-1] - lit[0] + 1) / (cols[-1] - cols[0] + 1)
    assert abs(ratio - 20.8 / 30.0) < 0.05, ratio
