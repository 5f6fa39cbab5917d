//! `M700` on the core's twin: fired after the queued moves at the position they reached, the
//! refill wait, the refusals. docs/firmware.md, "Inkjet".

use gweave_controller::twin::{Fire, FirstOrder, Twin};
use gweave_controller::{Settings, StepQueue};

fn twin(heads: u8) -> Twin<'static, FirstOrder> {
    let queue: &'static StepQueue = Box::leak(Box::new(StepQueue::new()));
    let settings = Settings { inkjet_heads: heads, ..Settings::DEFAULT };
    let mut t = Twin::new(queue, settings, FirstOrder::default());
    // Home (the twin starts 100, 100 and 50 mm from the switches) so positions count from 0.
    t.run_lines(b"G28\n", 120_000).expect("homed");
    t
}

fn run(t: &mut Twin<'static, FirstOrder>, text: &str) -> String {
    String::from_utf8(t.run_lines(text.as_bytes(), 60_000).expect("every line answered")).unwrap()
}

#[test]
fn m700_fires_after_the_queued_moves_where_they_ended() {
    let mut t = twin(1);
    // No M400 between the move and the fire: the core waits for the move itself (the patch
    // would fire at once, while the head is still at X0).
    let replies = run(&mut t, "G1 X10 Y5 F3000\nM700 P0 S2049\nG1 X10.2646\nM700 P0 S4095\n");
    assert_eq!(replies, "ok\n".repeat(4));
    t.run_ms(1_000);
    let steps = |x: i64, y: i64| [x, y, 0, 0];
    // 80 steps/mm: 10 mm is 800 steps, 10.2646 mm is round(821.17) = 821.
    assert_eq!(t.fires.len(), 2);
    assert_eq!((t.fires[0].head, t.fires[0].nozzles, t.fires[0].steps), (0, 2049, steps(800, 400)));
    assert_eq!((t.fires[1].head, t.fires[1].nozzles, t.fires[1].steps), (0, 4095, steps(821, 400)));
}

#[test]
fn fires_of_one_head_are_spaced_by_its_refill_time_the_other_head_is_not() {
    let mut t = twin(2);
    let replies = run(&mut t, "M700 P0 S1\nM700 P0 S2\nM700 P1 S4\nM700 P0 S8\n");
    assert_eq!(replies, "ok\n".repeat(4));
    let fires: Vec<(u8, u16, u64)> = t.fires.iter().map(|f: &Fire| (f.head, f.nozzles, f.ms)).collect();
    let t0 = fires[0].2;
    // Head 0 again two clock edges later (more than 800 us); head 1 as soon as its line comes
    // (the host sends it on the `ok`, taken at the next turn); head 0 two edges after its last.
    assert_eq!(fires, vec![(0, 1, t0), (0, 2, t0 + 2), (1, 4, t0 + 3), (0, 8, t0 + 4)]);
}

#[test]
fn a_bad_m700_is_an_error_and_fires_nothing() {
    let mut t = twin(1);
    let replies = run(&mut t, "M700 P0 S4096\nM700 P1 S1\nM700 P0 S1.5\nM700 S3\nM700 P2 S1\nM700 P0\n");
    assert_eq!(
        replies,
        "Error:M700 S = 4096.00 is out of range: 0.00 to 4095.00\nok\n\
         Error:M700 P = 1.00 is not a whole number from 0.00 to 0.00: nothing fired\nok\n\
         Error:M700 S = 1.50 is not a whole number from 0.00 to 4095.00: nothing fired\nok\n\
         Error:M700 needs P<head>: nothing fired\nok\n\
         Error:M700 P = 2.00 is out of range: 0.00 to 1.00\nok\n\
         ok\n"
    );
    // `M700 P0` (no S) fires no nozzle: a fire of an empty mask.
    assert_eq!(t.fires.iter().map(|f| f.nozzles).collect::<Vec<_>>(), vec![0]);
}

#[test]
fn without_heads_m700_is_unknown() {
    let mut t = twin(0);
    let replies = run(&mut t, "M700 P0 S1\n");
    assert_eq!(replies, "echo:Unknown command: \"M700 P0 S1\"\nok\n");
    assert!(t.fires.is_empty());
}
