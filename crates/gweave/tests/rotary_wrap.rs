//! The wrap pass, checked by reading its output back with the core machine state: positions
//! on the cylinder, E scaling, surface speed per feed convention, lines kept byte for byte.

use std::f64::consts::PI;

use gweave::gcode::lexer::parse_into;
use gweave::gcode::state::AXIS_LETTERS;
use gweave::rotary::cylinder::{
    surface_length_mm, CylPoint, FeedConvention, MachineDelta, RotaryConfig, RotaryUnit, UnwrapConfig,
};
use gweave::rotary::emit::{number_text, rotary_number_format};
use gweave::rotary::wrap::{wrap_bytes, WrapConfig};
use gweave::rotary::RotaryError;
use gweave::{Block, Effect, State};
use proptest::prelude::*;

/// A mandrel whose circumference is exactly 60 mm.
fn machine() -> RotaryConfig {
    RotaryConfig::new(60.0 / PI)
}

/// The wrapped text after its header, which must name the machine.
fn wrap(config: &WrapConfig, input: &str) -> String {
    let out = String::from_utf8(wrap_bytes(config.clone(), input.as_bytes()).unwrap()).unwrap();
    // In the file's own line ending.
    let eol = if out.lines().next().is_some_and(|_| out.contains("\r\n")) { "\r\n" } else { "\n" };
    let header = config.machine.header_lines("wrap").map(|l| l + eol).concat();
    assert_eq!(RotaryConfig::from_header(&out).as_ref(), Some(&config.machine));
    out.strip_prefix(&header).expect("the header comes first").to_owned()
}

/// A move of the output in machine words.
#[derive(Debug)]
struct OutMove {
    from: [f64; 3],
    to: [f64; 3],
    e_mm: f64,
    feed: f64,
}

/// Reads G-code through the core state and returns the moves over (axial, rotary, radial).
fn read(text: &str, m: &RotaryConfig) -> (Vec<OutMove>, State) {
    let index = |c: char| AXIS_LETTERS.iter().position(|&l| l == c as u8).unwrap();
    let axes = [m.axial_axis, m.rotary_axis, m.radial_axis].map(index);
    let mut state = State::default();
    let mut block = Block::default();
    let mut moves = Vec::new();
    for line in text.lines() {
        parse_into(line.as_bytes(), &mut block);
        if let Effect::Move(mv) = state.apply(line.as_bytes(), &block) {
            moves.push(OutMove {
                from: axes.map(|i| mv.from[i]),
                to: axes.map(|i| mv.to[i]),
                e_mm: mv.e_mm(),
                feed: mv.feed_mm_min,
            });
        }
    }
    (moves, state)
}

/// The same machine read as a flat printer (Y for the rotary letter).
fn flat_reader(m: &RotaryConfig) -> RotaryConfig {
    RotaryConfig { rotary_axis: 'Y', ..m.clone() }
}

fn delta(mv: &OutMove) -> MachineDelta {
    MachineDelta {
        axial_mm: mv.to[0] - mv.from[0],
        rotary: mv.to[1] - mv.from[1],
        radial_mm: mv.to[2] - mv.from[2],
        e_mm: mv.e_mm,
    }
}

fn point(m: &RotaryConfig, w: [f64; 3]) -> CylPoint {
    m.point_from_words(w, 0.0)
}

#[test]
fn one_move_exactly() {
    let mut config = WrapConfig::new(machine());
    config.chord_tolerance_mm = 0.0;
    let input = "; start\r\nM104 S200\r\nG28 X Z\r\nG92 E0\r\nG1 Z0.2 F600\r\n\
                 G1 X10 Y15 E1.0 F1200 ; first\r\nM106 S255";
    let out = wrap(&config, input);
    let r0 = 30.0 / PI;
    let r = r0 + 0.2;
    // A quarter of the circumference is 90 degrees; at r the surface is longer by r/R0.
    let flat = 10f64.hypot(15.0);
    let surface = 10f64.hypot(15.0 * r / r0);
    let e = surface / flat;
    let feed = 10.0 * 60.0 / (surface / 20.0);
    let f = rotary_number_format();
    let expected = format!(
        "; start\r\nM104 S200\r\nG28 X Z\r\nG92 E0\r\nG92 A0.000\r\nG1 Z0.200 F600.000\r\n\
         G1 X10.000 A90.000 E{} F{} ; first\r\nM106 S255",
        number_text(&f, b'E', e),
        number_text(&f, b'F', feed)
    );
    assert_eq!(out, expected);
}

/// A two-layer flat program: a square ring, travel, a diagonal, retractions.
fn program() -> String {
    let mut text = String::from(";FLAVOR:Marlin\nM82\nG28\nG92 E0\nG1 Z0.2 F1800\n");
    let mut e = 0.0;
    for (layer, z) in [0.2, 0.4].into_iter().enumerate() {
        text += &format!(";LAYER:{layer}\nG1 Z{z} F1800\nG0 X5 Y5 F1800\n");
        for (x, y) in [(25.0, 5.0), (25.0, 55.0), (5.0, 55.0), (5.0, 5.0), (20.0, 40.0)] {
            e += 0.05 * 30.0;
            text += &format!("G1 X{x} Y{y} E{e:.5}\n");
        }
        e -= 0.8;
        text += &format!("G1 E{e:.5} F2100\nG1 F1800\n");
        e += 0.8;
        text += &format!("G1 E{e:.5} F2100\n;TYPE:comment kept\nG1 F1800\n");
    }
    text
}

#[test]
fn surface_speed_holds_for_every_feed_convention() {
    for (convention, letter, unit) in [
        (FeedConvention::Nist, 'A', RotaryUnit::Degrees),
        (FeedConvention::Combined, 'A', RotaryUnit::Degrees),
        (FeedConvention::Combined, 'Y', RotaryUnit::Mm),
        (FeedConvention::InverseTime, 'A', RotaryUnit::Degrees),
    ] {
        let mut m = machine();
        m.feed_convention = convention;
        m.rotary_axis = letter;
        m.rotary_unit = unit;
        let out = wrap(&WrapConfig::new(m.clone()), &program());
        let (moves, _) = read(&out, &m);
        let mut checked = 0;
        for mv in &moves {
            let d = delta(mv);
            if d == MachineDelta::default() {
                continue; // a no-op line kept as written (`G1 Z0.2` at Z0.2)
            }
            let t_s = m.time_from_feed(&d, mv.feed).unwrap_or_else(|| panic!("{convention:?} {mv:?}"));
            let moved = d.axial_mm != 0.0 || d.rotary != 0.0 || d.radial_mm != 0.0;
            // Flat moves ran at 1800 mm/min = 30 mm/s, retractions at 2100 = 35 mm/s.
            let (speed, expected) = if moved {
                let len = surface_length_mm(point(&m, mv.from), point(&m, mv.to));
                (len / t_s, 30.0)
            } else {
                (d.e_mm.abs() / t_s, 35.0)
            };
            assert!((speed / expected - 1.0).abs() < 0.01, "{convention:?} {mv:?}: {speed}");
            checked += 1;
        }
        assert!(checked > 100, "{checked}");
        if convention == FeedConvention::InverseTime {
            let first = out.find("\nG1").unwrap();
            assert!(out.find("\nG93").unwrap() < first && out.ends_with("G94\n"));
        }
    }
}

#[test]
fn points_lie_on_the_mapped_flat_path_and_e_scales() {
    let m = machine();
    let config = WrapConfig::new(m.clone());
    let input = program();
    let out = wrap(&config, &input);
    let (moves, state) = read(&out, &m);
    let r0 = m.mandrel_radius_mm();
    // Every printed point maps back to the flat ring's edges or the diagonal.
    for mv in moves.iter().filter(|mv| mv.e_mm > 0.0) {
        let p = point(&m, mv.to);
        let flat = [p.axial_mm, p.theta_deg / 360.0 * 60.0, p.radius_mm - r0];
        let on_edge =
            [flat[0] - 5.0, flat[0] - 25.0, flat[1] - 5.0, flat[1] - 55.0].iter().any(|d| d.abs() < 0.002)
                || ((flat[1] - 5.0) - (flat[0] - 5.0) * 35.0 / 15.0).abs() < 0.01;
        assert!(on_edge, "{flat:?}");
        // Chord midpoints stay within the tolerance of the cylinder.
        let (a, b) = (point(&m, mv.from).to_cartesian(), p.to_cartesian());
        let mid = (0.5 * (a[1] + b[1])).hypot(0.5 * (a[2] + b[2]));
        assert!(p.radius_mm - mid <= 0.01 + 0.001);
    }
    // Total E: each flat segment's E times its surface stretch, minus nothing (retractions
    // and their recoveries cancel).
    let (flat_moves, _) = read(&input, &flat_reader(&m));
    let expected: f64 = flat_moves
        .iter()
        .filter(|mv| mv.e_mm > 0.0 && mv.from != mv.to)
        .map(|mv| {
            let (from, to) = ([mv.from[0], mv.from[1], mv.from[2]], mv.to);
            mv.e_mm * config.unwrap.e_scale(&m, from, to)
        })
        .sum();
    assert!((state.filament_mm[0] - expected).abs() < 1e-4, "{} vs {expected}", state.filament_mm[0]);
    assert!(expected > 15.0 * 1.01, "the scale must show");
}

#[test]
fn other_lines_are_kept_byte_for_byte() {
    let input = program();
    let out = wrap(&WrapConfig::new(machine()), &input);
    let is_motion = |l: &str| {
        let c = l.split(' ').next().unwrap_or("");
        (matches!(c, "G0" | "G1" | "G2" | "G3") && l.contains(['X', 'Y', 'Z', 'E']))
            || l.starts_with("G92 A")
            || l.starts_with("G9") && !l.starts_with("G92")
    };
    let keep_in: Vec<&str> = input.lines().filter(|l| !is_motion(l)).collect();
    let keep_out: Vec<&str> = out.lines().filter(|l| !is_motion(l)).collect();
    assert_eq!(keep_in, keep_out);
    assert!(keep_in.contains(&";TYPE:comment kept") && keep_in.contains(&"G1 F1800"));
}

#[test]
fn arcs_are_linearised_before_wrapping() {
    let m = machine();
    let out =
        wrap(&WrapConfig::new(m.clone()), "G1 X10 Y10 Z0.2 F1200\nG2 X20 Y10 I5 J0 E2\nG3 X10 Y10 R5 E4");
    assert!(!out.contains("G2") && !out.contains("G3"));
    let (moves, state) = read(&out, &m);
    let printing: Vec<&OutMove> = moves.iter().filter(|mv| mv.e_mm > 0.0).collect();
    assert!(printing.len() > 20);
    for mv in printing {
        let p = point(&m, mv.to);
        let (x, y) = (p.axial_mm, p.theta_deg / 360.0 * 60.0);
        assert!(((x - 15.0).hypot(y - 10.0) - 5.0).abs() < 0.011, "({x}, {y})");
    }
    // A full circle of flat radius 5 at z = 0.2: each flat piece stretched by its Y share.
    assert!(state.filament_mm[0] > 4.0 && state.filament_mm[0] < 4.0 * (1.0 + 0.2 / 9.55));
}

#[test]
fn set_position_and_homing_in_machine_words() {
    let mut config = WrapConfig::new(machine());
    config.chord_tolerance_mm = 0.0;
    // Half a turn and 1 mm axial at r = R0 + 1 at 10 mm/s; NIST F is the axial speed.
    let surface = 1f64.hypot(PI * (30.0 / PI + 1.0));
    let feed = number_text(&rotary_number_format(), b'F', 60.0 / (surface / 10.0));
    let out = wrap(&config, "G1 Z1 F600\nG92 X1 Y15 E3\nG1 X2 F600\nG28 Y\nG1 X3 Y30 F600\n");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines,
        [
            "G92 A0.000",
            "G1 Z1.000 F600.000",
            "G92 X1.000 A90.000 E3",
            "G1 X2.000 F600.000",
            "G28 Y",
            // Homing Y may have turned the mandrel: the angle is declared again.
            "G92 A0.000",
            &format!("G1 X3.000 A180.000 F{feed}"),
        ]
    );
}

#[test]
fn keep_arc_length_keeps_e() {
    let mut config = WrapConfig::new(machine());
    config.unwrap.keep_arc_length = true;
    config.unwrap.arc_length_z1_mm = 0.2;
    let out = wrap(&config, "G1 Z0.4 F600\nG1 Y10 E1 F600\n");
    let (moves, state) = read(&out, &config.machine);
    assert!((state.filament_mm[0] - 1.0).abs() < 1e-9);
    // A = Y*180/(pi*(R0 + z - z1)) with R0 = 30/pi.
    let a = 10.0 * 180.0 / (PI * (30.0 / PI + 0.2));
    assert!((moves.last().unwrap().to[1] - a).abs() < 0.0006);
}

#[test]
fn errors_name_the_line() {
    let config = WrapConfig::new(machine());
    let err = wrap_bytes(config.clone(), b"G1 X1 F600\nG20\nG1 X2\n").unwrap_err();
    assert!(matches!(err, RotaryError::Engine(gweave::Error::Pass { line: Some(3), .. })), "{err}");
    let err = wrap_bytes(config.clone(), b"G1 X1 E1\n").unwrap_err();
    assert_eq!(err.to_string(), "<input>:1: invalid rotary setting `F`: a move before any feed rate was set");
    let err = wrap_bytes(config, b"G1 X1 F600\nG1 Z-50\n").unwrap_err();
    assert!(matches!(*as_inner(&err), RotaryError::BelowAxis { .. }), "{err}");
    let bad = WrapConfig::from_toml_str("chord_tolerance_mm = -1\n[machine]\nmandrel_diameter_mm = 20");
    assert_eq!(bad.unwrap_err().to_string(), "chord_tolerance_mm = -1 is out of range: 0 or 0.001 to 10 mm");
}

fn as_inner(err: &RotaryError) -> &RotaryError {
    match err {
        RotaryError::Engine(gweave::Error::Pass { source, .. }) => {
            source.downcast_ref().expect("a RotaryError")
        }
        other => other,
    }
}

#[test]
fn real_slicer_file_wraps() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/cura/cura_torus.gcode");
    let input = std::fs::read(path).unwrap();
    // The Ender 3 bed is 220 mm deep: a mandrel of that circumference.
    let m = RotaryConfig::new(220.0 / PI);
    let mut config = WrapConfig::new(m.clone());
    config.unwrap.seam_rotation_per_layer_deg = 3.0;
    let out = wrap_bytes(config.clone(), &input).unwrap();
    let text = String::from_utf8(out).unwrap();
    let (moves, state) = read(&text, &m);
    let (flat_moves, flat_state) = read(std::str::from_utf8(&input).unwrap(), &flat_reader(&m));
    // Filament grows by the stretch of each printed segment, at most that of the top layer.
    let top_mm = flat_moves.iter().map(|mv| mv.to[2]).fold(0.0, f64::max);
    let grown = state.filament_mm[0] / flat_state.filament_mm[0];
    assert!(grown > 1.0 && grown < 1.0 + top_mm / m.mandrel_radius_mm(), "{grown}");
    assert!(moves.len() >= flat_moves.len());
    let motion = text.lines().filter(|l| l.starts_with("G0 ") || l.starts_with("G1 "));
    assert!(motion.clone().all(|l| !l.contains('Y')), "a flat Y word survived");
    // Every move of the output has its F: none relies on the modal feed.
    assert!(motion.filter(|l| l.contains(['X', 'A', 'Z', 'E'])).all(|l| l.contains(" F")));
}

proptest! {
    /// The seam closes: y = 0 and y = C are the same point of the cylinder, whatever the
    /// seam offset, layer and height.
    #[test]
    fn wrapping_is_closed_at_the_seam(
        x in -50.0f64..50.0,
        z in 0.0f64..10.0,
        diameter in 5.0f64..200.0,
        offset in -360.0f64..360.0,
        per_layer in -10.0f64..10.0,
        layer in 0u32..500,
    ) {
        let m = RotaryConfig::new(diameter);
        let unwrap = UnwrapConfig {
            seam_offset_deg: offset,
            seam_rotation_per_layer_deg: per_layer,
            ..Default::default()
        };
        let a = unwrap.map(&m, [x, 0.0, z], layer).unwrap().to_cartesian();
        let b = unwrap.map(&m, [x, m.circumference_mm(), z], layer).unwrap().to_cartesian();
        for i in 0..3 {
            prop_assert!((a[i] - b[i]).abs() < 1e-9, "{:?} {:?}", a, b);
        }
    }

    /// E scale: the surface length of the mapped points over the flat length, between 1 and
    /// r/R0, and 1 for axial moves.
    #[test]
    fn e_scale_is_the_surface_stretch(
        from in proptest::array::uniform3(0.0f64..40.0),
        to_xy in proptest::array::uniform2(0.0f64..40.0),
    ) {
        let m = RotaryConfig::new(30.0);
        let unwrap = UnwrapConfig::default();
        let to = [to_xy[0], to_xy[1], from[2]];
        let flat = (to[0] - from[0]).hypot(to[1] - from[1]);
        prop_assume!(flat > 1e-6);
        let scale = unwrap.e_scale(&m, from, to);
        let mapped = surface_length_mm(unwrap.map(&m, from, 0).unwrap(), unwrap.map(&m, to, 0).unwrap());
        prop_assert!((scale * flat - mapped).abs() < 1e-9);
        prop_assert!(scale >= 1.0 - 1e-12 && scale <= (15.0 + from[2]) / 15.0 + 1e-12);
        let axial = unwrap.e_scale(&m, from, [to[0], from[1], from[2]]);
        prop_assert!((axial - 1.0).abs() < 1e-12);
    }
}

/// One random line of a slicer-like program.
fn any_line() -> impl Strategy<Value = String> {
    let n = || -20.0f64..80.0;
    prop_oneof![
        (n(), n(), 0.0f64..3.0).prop_map(|(x, y, e)| format!("G1 X{x:.3} Y{y:.3} E{e:.4}")),
        (n(), n(), 100.0f64..9000.0).prop_map(|(x, y, f)| format!("G0 X{x:.2} Y{y:.2} F{f:.0}")),
        (0.0f64..5.0).prop_map(|z| format!("G1 Z{z:.2}")),
        (n(), n(), -10.0f64..10.0, -10.0f64..10.0)
            .prop_map(|(x, y, i, j)| format!("G2 X{x:.2} Y{y:.2} I{i:.2} J{j:.2} E1")),
        (n(), n(), -30.0f64..30.0).prop_map(|(x, y, r)| format!("G3 X{x:.2} Y{y:.2} R{r:.2}")),
        (-2.0f64..2.0).prop_map(|e| format!("G1 E{e:.3} F2400")),
        Just("G92 E0".to_owned()),
        Just("G91".to_owned()),
        Just("G90".to_owned()),
        Just("M83".to_owned()),
        Just("G28 X".to_owned()),
        Just(";LAYER:1".to_owned()),
        (n(), n()).prop_map(|(x, y)| format!("G92 X{x:.1} Y{y:.1}")),
        Just("M106 S128 ; fan".to_owned()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any such program wraps without error in every convention, and the lines that carry no
    /// motion come out unchanged and in order.
    #[test]
    fn wrapping_never_panics(lines in proptest::collection::vec(any_line(), 0..40), conv in 0usize..3) {
        let mut m = machine();
        m.feed_convention =
            [FeedConvention::Nist, FeedConvention::Combined, FeedConvention::InverseTime][conv];
        let input = format!("G1 F1200\n{}\n", lines.join("\n"));
        // Every program here is valid (radii stay above the axis): wrapping must succeed.
        // Random parts are wider than the circumference: wrapping them over themselves is allowed.
        let out = wrap_bytes(WrapConfig { allow_overlap: true, ..WrapConfig::new(m) }, input.as_bytes());
        prop_assert!(out.is_ok(), "{:?}", out.err());
        if let Ok(out) = out {
            let out = String::from_utf8(out).unwrap();
            let plain = |l: &&str| l.starts_with('M') || l.starts_with(';') || *l == "G92 E0";
            let kept: Vec<&str> = input.lines().filter(plain).collect();
            let came: Vec<&str> = out.lines().skip(2).filter(plain).collect();
            prop_assert_eq!(kept, came);
        }
    }
}

/// Regression (issue 25): a flat move of many turns round a thin mandrel became gigabytes of
/// chords; past `MAX_CHORDS_PER_MOVE` it is refused, naming the line.
#[test]
fn a_move_of_endless_turns_is_refused() {
    let mut config = WrapConfig::new(RotaryConfig::new(1.0));
    config.chord_tolerance_mm = 0.001;
    // A bead (a travel takes the short way round, in one move), on a part allowed to overlap.
    config.allow_overlap = true;
    let err = wrap_bytes(config, b"G1 X1 F600\nG1 Y1000000000 E1\n").unwrap_err();
    assert!(matches!(err, RotaryError::Engine(gweave::Error::Pass { line: Some(2), .. })), "{err}");
    assert!(matches!(*as_inner(&err), RotaryError::TooManyChords { limit: 1_000_000 }), "{err}");
}

/// Regression (issue 25): a `G2` of radius 10 km, nearly a full turn, wrapped onto a 30 mm
/// mandrel would be ~60 million chords (2.4 GB): the chords of one move's pieces add up, and
/// the move is refused once they pass the limit instead of writing until the disk is full.
#[test]
fn a_huge_arc_is_refused_not_wrapped_into_gigabytes() {
    let config = WrapConfig::new(RotaryConfig::new(30.0));
    let err = wrap_bytes(config, b"G92 E0\nG1 X10 Y10 F3000\nG2 X10 Y0 I10000000 J0 E1 F1000\n").unwrap_err();
    assert!(matches!(err, RotaryError::Engine(gweave::Error::Pass { line: Some(3), .. })), "{err}");
    assert!(matches!(*as_inner(&err), RotaryError::TooManyChords { limit: 1_000_000 }), "{err}");
}

/// Regression: `leave_feed_mode` wrote the closing `G94` of the inverse-time convention with a
/// bare `\n` in a CRLF file, and straight after a last line that had no ending.
#[test]
fn leave_feed_mode_ends_g94_with_the_files_line_ending() {
    let mut machine = machine();
    machine.feed_convention = FeedConvention::InverseTime;
    let config = WrapConfig::new(machine);
    let body = "G92 E0\r\nG1 Z0.2 F600\r\nG1 X10 Y15 E1.0 F1200 ; first\r\nM106 S255";
    let out = wrap(&config, &format!("{body}\r\n"));
    assert!(out.ends_with("\r\nM106 S255\r\nG94\r\n"), "{out:?}");
    assert!(!out.replace("\r\n", "").contains('\n'), "a bare LF in {out:?}");
    // A file without a final ending: G94 is the last line, on a line of its own, without one.
    let out = wrap(&config, body);
    assert!(out.ends_with("\r\nM106 S255\r\nG94"), "{out:?}");
    assert!(!out.replace("\r\n", "").contains('\n'), "a bare LF in {out:?}");
}

/// A new user's trial: a part wider than the mandrel was refused as "invalid rotary setting
/// `allow_overlap`", a setting the user never gave. The refusal says the part does not fit,
/// by how much, and the two ways out; `allow_overlap` wraps it over itself.
#[test]
fn a_part_wider_than_the_mandrel_does_not_fit() {
    let input = "G1 F1200\nG1 X0 Y0 Z0.2\nG1 X10 Y70 E5\n";
    let err = wrap_bytes(WrapConfig::new(machine()), input.as_bytes()).unwrap_err();
    assert!(matches!(err, RotaryError::WiderThanMandrel(_)), "{err}");
    let said = err.to_string();
    assert!(
        said.starts_with("the part does not fit round the mandrel: the part's extrusions span 70.000 mm"),
        "{said}"
    );
    assert!(
        said.ends_with("use a mandrel of at least 22.282 mm, or allow it with --allow-overlap"),
        "{said}"
    );
    let allowed = WrapConfig { allow_overlap: true, ..WrapConfig::new(machine()) };
    assert!(wrap_bytes(allowed, input.as_bytes()).is_ok());
}
