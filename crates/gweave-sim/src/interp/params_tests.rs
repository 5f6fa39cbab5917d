//! Every number word the registry declares is checked by the dispatcher: one value past each
//! end of its range and a word that is not a number are refused with the uniform `echo:` reply,
//! and the line changes nothing.

use gweave::range::{self};
use gweave::Range;

use super::{Machine, COMMANDS};
use crate::profile::MachineProfile;

/// The default machine with every optional command built in.
fn full_machine() -> Machine {
    let text = "[firmware]\npsu_control = true\nautoreport_pos = true\nprobe = true\npin_control = true\n\
                fw_retract = true\nlinear_advance = true\n";
    Machine::new(MachineProfile::from_toml_str(text).unwrap()).unwrap()
}

/// What a refused line must leave as it was: the modal state, the planner's limits, the
/// heaters, the settings and the machine's own values.
fn snapshot(m: &Machine) -> String {
    format!(
        "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}",
        m.core.state(),
        m.core.profile(),
        m.thermal,
        m.settings,
        m.host,
        (m.feed_pct, m.flow_pct, m.autoreport_s, m.tool, m.homed, m.shift_mm, m.now_s()),
    )
}

/// A value just outside `range` on each side: below its minimum (between 0 and the minimum
/// when 0 is allowed too) and above its maximum.
fn outside(range: Range) -> [f64; 2] {
    let below = if range.zero && range.min > 0.0 { range.min / 2.0 } else { range.min - 1.0 };
    // Past 2^53 one more is the same number (`M700 S`'s 64 nozzle bits): twice is past it.
    let above = if range.max + 1.0 > range.max { range.max + 1.0 } else { range.max * 2.0 };
    [below, above]
}

#[test]
fn every_ranged_word_refuses_values_outside_and_keeps_the_state() {
    let mut checked = 0;
    for spec in COMMANDS {
        for code in spec.codes.split_whitespace() {
            for param in spec.params {
                for letter in param.letters.chars() {
                    let values = outside(param.range).map(|v| (format!("{v}"), range::short(v)));
                    for (written, shown) in values.into_iter().chain([("nan".into(), "nan".into())]) {
                        let mut m = full_machine();
                        let before = snapshot(&m);
                        let line = format!("{code} {letter}{written}");
                        let mut replies = Vec::new();
                        m.execute(line.as_bytes(), &mut |_, l| replies.push(l.to_owned()));
                        let want = format!("echo:{code} {letter} = {shown} is out of range: {}", param.range);
                        assert_eq!(replies, [want], "{line}");
                        assert_eq!(snapshot(&m), before, "{line} changed the machine");
                        assert_eq!(m.report().warning_counts.get("refused"), Some(&1), "{line}");
                        checked += 1;
                    }
                }
            }
        }
    }
    // And the table is not empty: the temperatures, feeds, limits, fan... are all in it.
    assert!(checked > 150, "{checked}");
}

/// The ends themselves are in range: the same lines with the limits are carried out.
#[test]
fn the_ends_of_each_range_are_accepted() {
    for spec in COMMANDS {
        for code in spec.codes.split_whitespace() {
            for param in spec.params {
                for letter in param.letters.chars() {
                    for v in [param.range.min, param.range.max] {
                        let mut m = full_machine();
                        let line = format!("{code} {letter}{v}");
                        let mut replies = Vec::new();
                        m.execute(line.as_bytes(), &mut |_, l| replies.push(l.to_owned()));
                        assert!(replies.iter().all(|l| !l.contains("out of range")), "{line}: {replies:?}");
                    }
                }
            }
        }
    }
}

/// Marlin clamps `M104 S` to the hotend's maximum less its overshoot; a value the range allows
/// but the machine cannot reach is still clamped (hosts send 300 to a 275 °C hotend), one
/// beyond any hotend is refused and the target in force stays.
#[test]
fn hotend_targets_clamp_within_the_range_and_are_refused_beyond_it() {
    use crate::thermal::heater::HeaterId;
    let mut m = full_machine();
    let mut replies = Vec::new();
    for line in ["M104 S200", "M104 S501", "M104 S-1"] {
        m.execute(line.as_bytes(), &mut |_, l| replies.push(l.to_owned()));
    }
    assert_eq!(
        replies,
        ["echo:M104 S = 501 is out of range: 0 to 500 °C", "echo:M104 S = -1 is out of range: 0 to 500 °C"]
    );
    assert_eq!(m.thermal.target(HeaterId::Hotend(0)).unwrap(), 200.0);
    m.execute(b"M104 S499", &mut |_, _| {});
    let clamped = m.thermal.target(HeaterId::Hotend(0)).unwrap();
    assert!(clamped < 499.0 && clamped > 200.0, "{clamped}");
}
