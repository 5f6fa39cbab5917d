//! The inkjet canvas holds one layer: each finished layer is handed to the machine's sink (or,
//! as under `gweave serve`, to none) and its canvases are cleared for the next, so memory stays
//! flat whatever the number of layers, and a profile whose one layer would not fit the budget is
//! refused when the machine is built (issue B6: `sim` and `serve` kept every layer's canvases
//! and aborted on an allocation after a few thousand layers, or four layers of sixteen heads).

use std::path::Path;
use std::sync::{Arc, Mutex};

use gweave::gen::printhead::HeadOffset;
use gweave_sim::{
    InkjetError, InkjetLayer, LayerSink, Machine, MachineProfile, Outcome, CANVAS_BUDGET_BYTES,
};

/// `examples/machines/binder-jet.toml` (a 600 x 600 pitch powder bed, one head) with `heads`
/// heads side by side and its canvas `side_px` square.
fn binder_jet(heads: usize, side_px: usize) -> MachineProfile {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/binder-jet.toml");
    let mut profile = MachineProfile::from_toml_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let ink = profile.inkjet.as_mut().unwrap();
    ink.printhead.heads =
        (0..heads).map(|h| HeadOffset { offset_x_mm: 5.0 * h as f64, offset_y_mm: 0.0 }).collect();
    (ink.width_px, ink.height_px) = (Some(side_px), Some(side_px));
    profile
}

/// What a sink was handed of one layer: its index, Z and drops per head (the layers themselves
/// are not kept: a test holding a thousand would grow as the canvas did).
#[derive(Debug)]
struct Handed {
    index: usize,
    z_mm: f64,
    drops: Vec<u64>,
}

/// A sink that tallies what it is handed.
#[derive(Debug, Default, Clone)]
struct Tally(Arc<Mutex<Vec<Handed>>>);

impl LayerSink for Tally {
    fn layer(&mut self, index: usize, layer: &InkjetLayer) -> Result<(), InkjetError> {
        let drops = layer.heads.iter().map(|b| b.count_ones()).collect();
        self.0.lock().unwrap().push(Handed { index, z_mm: layer.z_mm, drops });
        Ok(())
    }
}

/// `layers` layers of one full fire (all 12 nozzles) per head at the bed's corner, a layer
/// 0.01 mm above the last, as the reproduction fires them; `check` looks at the machine
/// after each layer.
fn fire_layers(machine: &mut Machine, layers: usize, heads: usize, mut check: impl FnMut(&Machine)) {
    assert_eq!(machine.execute(b"G28", &mut |_, _| {}), Outcome::Ok);
    for k in 1..=layers {
        let mut lines =
            vec![format!("G1 Z{:.2} F300", 0.01 * k as f64), "G1 X30 Y30 F3000".into(), "M400".into()];
        lines.extend((0..heads).map(|h| format!("M700 P{h} S4095")));
        for line in &lines {
            assert_eq!(machine.execute(line.as_bytes(), &mut |_, _| {}), Outcome::Ok, "{line}");
        }
        check(machine);
    }
}

#[test]
fn a_thousand_inkjet_layers_keep_memory_flat() {
    let (layers, heads) = (1000, 4);
    // Each head: 10 words of 8 bytes a row x 600 rows, and 5 bytes a row to know which rows
    // took a drop.
    let one_layer = heads as u64 * (10 * 8 * 600 + 600 * 5);
    // With a sink (`sim --raster-out`) and without (`serve`): the same one layer held.
    for sink in [Some(Tally::default()), None] {
        let mut machine = Machine::new(binder_jet(heads, 600)).unwrap();
        if let Some(sink) = &sink {
            machine.send_inkjet_layers_to(Box::new(sink.clone()));
        }
        fire_layers(&mut machine, layers, heads, |m| assert_eq!(m.inkjet().unwrap().held_bytes(), one_layer));
        machine.finish(&mut |_, _| {});
        let canvas = machine.inkjet().unwrap();
        assert_eq!((canvas.layer_count(), canvas.held_bytes()), (layers, 0));
        let report = machine.report().inkjet.unwrap();
        assert_eq!(report.layers, layers);
        assert_eq!(report.drops_per_head, [12 * layers as u64; 4]);
        if let Some(Tally(handed)) = sink {
            // Every layer handed over once, in order, with its own drops only: a cleared canvas.
            let handed = handed.lock().unwrap();
            assert_eq!(handed.len(), layers);
            for (k, Handed { index, z_mm, drops }) in handed.iter().enumerate() {
                assert_eq!((*index, drops.as_slice()), (k, &[12; 4][..]));
                assert!((z_mm - 0.01 * (k + 1) as f64).abs() < 1e-9, "layer {k} at Z {z_mm}");
            }
        }
    }
}

/// The first case: 3 000 layers on one head of the largest canvas (20 000 x 20 000
/// pitches, in range) took 50 MB more a layer and aborted on an allocation (after some 80
/// layers under a 4 GB limit); one layer is held.
#[test]
fn three_thousand_layers_of_the_largest_canvas_hold_one() {
    let mut machine = Machine::new(binder_jet(1, 20_000)).unwrap();
    let one_layer = 20_000u64.div_ceil(64) * 8 * 20_000 + 20_000 * 5;
    assert!(one_layer <= CANVAS_BUDGET_BYTES, "{one_layer}");
    fire_layers(&mut machine, 3000, 1, |m| assert_eq!(m.inkjet().unwrap().held_bytes(), one_layer));
    machine.finish(&mut |_, _| {});
    assert_eq!(machine.report().inkjet.unwrap().layers, 3000);
}

/// The second case: four layers of sixteen heads on that canvas reached 2.94 GB; one
/// layer of them is 766 MiB, past the budget, so the machine is not built and says which keys
/// to change.
#[test]
fn sixteen_heads_of_the_largest_canvas_are_refused_before_the_first_fire() {
    let err = Machine::new(binder_jet(16, 20_000)).unwrap_err().to_string();
    assert!(err.starts_with("the inkjet canvases of one layer, 20000 x 20000 nozzle pitches for each of 16 heads, would take 765.7 MiB, more than the limit of 64 MiB: give a smaller [inkjet] width_px and height_px"), "{err}");
    // The same sixteen heads over the default 600 x 600 bed are a few MiB.
    assert!(Machine::new(binder_jet(16, 600)).is_ok());
}
