//! A mixing hotend on the core's twin: the mixing commands, the inputs' step pulses, the
//! virtual tools in EEPROM. docs/firmware.md, "Mixing".

use std::cell::RefCell;
use std::rc::Rc;

use gweave_controller::twin::{FirstOrder, Memory, Twin};
use gweave_controller::{Settings, StepQueue, E, X};

/// X and E at the same steps per mm, cold extrusion allowed, `inputs` inputs.
fn settings(inputs: u8) -> Settings {
    Settings {
        steps_per_mm: [100.0, 100.0, 400.0, 100.0],
        extrude_min_c: 0.0,
        mixing_inputs: inputs,
        ..Settings::DEFAULT
    }
}

fn twin(inputs: u8, memory: Memory) -> Twin<'static, FirstOrder> {
    let queue: &'static StepQueue = Box::leak(Box::new(StepQueue::new()));
    Twin::with_memory(queue, settings(inputs), FirstOrder::default(), memory)
}

/// Sends `text`, expects every line answered, then lets the moves finish.
fn run(t: &mut Twin<'static, FirstOrder>, text: &str) -> String {
    let replies = t.run_lines(text.as_bytes(), 60_000).expect("every line answered");
    t.run_ms(5_000);
    String::from_utf8(replies).unwrap()
}

#[test]
fn a_mixed_move_pulses_each_input_its_exact_share() {
    let mut t = twin(3, Memory::default());
    let replies = run(
        &mut t,
        "M83\nM163 S0 P0.2\nM163 S1 P0.3\nM163 S2 P0.5\nM164 S4\nT4\nG1 X10 E10 F1200\nM165 A1 B1 C2\nG1 X20 E7.5\nG1 E5\n",
    );
    assert_eq!(replies, "ok\n".repeat(10));
    // E0 (the E motor's bit), E1, E2. The second move's 750 steps at 1:1:2 are 187.5, 187.5,
    // 375: E0's cumulative 387.5 rounds to 388, so E0 gets 188 and E1 187 (the prefix 875 is
    // exact); the totals add up to E's 2250 steps.
    let inputs = &t.pulses[E..E + 3];
    assert_eq!(inputs.iter().sum::<u64>(), 2250);
    assert_eq!(inputs, [200 + 188 + 125, 300 + 187 + 125, 500 + 375 + 250]);
    assert_eq!(t.pulses[X], 2000);
    assert_eq!(t.pulses[E + 3..], [0], "no input past those fitted");
}

#[test]
fn the_running_split_follows_the_ratio_within_one_step() {
    // X and E make the same steps, so X's pulses count E's progress: at every step event each
    // input's steps so far are within one step of its share of E so far, through a change of
    // mix between the moves.
    let mut t = twin(2, Memory::default());
    let events = Rc::new(RefCell::new(Vec::new()));
    let seen = Rc::clone(&events);
    t.on_step = Some(Box::new(move |motor, tick| seen.borrow_mut().push((tick, motor))));
    run(&mut t, "M163 S0 P0.3\nM163 S1 P0.7\nM164 S0\nG1 X10 E10 F1200\nM165 A0.9 B0.1\nG1 X20 E20\n");
    let events = events.borrow();
    let (mut x, mut done, mut ideal) = (0u32, [0u32; 2], [0f64; 2]);
    let mut i = 0;
    while i < events.len() {
        let tick = events[i].0;
        while i < events.len() && events[i].0 == tick {
            let motor = events[i].1;
            if motor == X {
                let share = if x < 1000 { [0.3, 0.7] } else { [0.9, 0.1] };
                x += 1;
                ideal[0] += share[0];
                ideal[1] += share[1];
            } else {
                done[motor - E] += 1;
            }
            i += 1;
        }
        for k in 0..2 {
            let off = (f64::from(done[k]) - ideal[k]).abs();
            assert!(off <= 1.0 + 1e-9, "input {k} at X step {x}: {} steps for {:.2}", done[k], ideal[k]);
        }
    }
    assert_eq!((x, done), (2000, [1200, 800]));
}

#[test]
fn virtual_tools_survive_m500_and_a_reset_and_m503_prints_them() {
    let mut t = twin(2, Memory::default());
    run(&mut t, "M163 S0 P0.25\nM163 S1 P0.75\nM164 S3\nM500\n");
    let memory = std::mem::take(&mut t.memory);
    let mut t = twin(2, Memory { sent: Vec::new(), ..memory });
    let replies = run(&mut t, "M503\nT3\nG1 X10 E8 F1200\n");
    assert!(
        replies.contains(
            "echo:; Mixing virtual tools:\necho:  M163 S0 P1.0000\necho:  M163 S1 P0.0000\necho:  M164 S0\n"
        ),
        "{replies}"
    );
    assert!(
        replies.contains("echo:  M163 S0 P0.2500\necho:  M163 S1 P0.7500\necho:  M164 S3\n"),
        "{replies}"
    );
    assert_eq!(t.pulses[E..E + 2], [200, 600]);
    // M502: the power-on tools again (tool 3 is input 0 alone on two inputs).
    let replies = run(&mut t, "M502\nM503\n");
    assert!(
        replies.contains("echo:  M163 S0 P1.0000\necho:  M163 S1 P0.0000\necho:  M164 S3\n"),
        "{replies}"
    );
}

#[test]
fn a_wrong_mixing_command_is_refused_and_changes_nothing() {
    let mut t = twin(2, Memory::default());
    let replies = run(
        &mut t,
        "M163 S2 P1\nM164 S16\nM163 S0 P0\nM163 S1 P0\nM164 S1\nT16\nM163 S0 P2000000\nT1\nG1 X10 E10 F1200\n",
    );
    assert_eq!(
        replies,
        "echo:M163 S = 2.00 is out of range: 0.00 to 1.00\nok\n\
         echo:M164 S = 16.00 is out of range: 0.00 to 15.00\nok\nok\nok\n\
         echo:M164: a mix of all zeros is not stored\nok\n\
         echo:T16 T = 16.00 is out of range: 0.00 to 15.00\nok\n\
         echo:M163 P = 2000000.00 is out of range: -1000000.00 to 1000000.00\nok\nok\nok\n"
    );
    assert_eq!(t.pulses[E..E + 2], [0, 1000], "tool 1 is still input 1 alone");
}

#[test]
fn without_a_mixing_hotend_the_mixing_commands_are_unknown() {
    let mut t = twin(0, Memory::default());
    let replies = run(&mut t, "M163 S0 P1\nG1 X10 E10 F1200\n");
    assert_eq!(replies, "echo:Unknown command: \"M163 S0 P1\"\nok\nok\n");
    assert_eq!(t.pulses[E..], [1000, 0, 0, 0]);
}
