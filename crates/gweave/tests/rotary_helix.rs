//! The helical tube and custom helical paths, checked on their emitted G-code: every move is
//! read back as the firmware would read it and mapped to 3D.

use gweave::rotary::cylinder::{
    to_cartesian, CylPoint, FeedConvention, MachineDelta, RotaryConfig, RotaryUnit,
};
use gweave::rotary::helix::{
    write_paths, Handedness, HelicalPath, PrintSettings, Profile, Resolution, TubeParams,
};
use gweave::rotary::RotaryError;
use proptest::prelude::*;

/// One motion line as the firmware reads it.
#[derive(Clone, Debug)]
struct Move {
    /// Layer from the last `; layer k` comment.
    layer: Option<u32>,
    /// Axis words before and after: axial, rotary (its unit), radial.
    from: [f64; 3],
    to: [f64; 3],
    /// Filament moved, mm.
    e_mm: f64,
    /// Modal F at this line.
    feed: f64,
    /// G0.
    rapid: bool,
}

impl Move {
    fn delta(&self) -> MachineDelta {
        MachineDelta {
            axial_mm: self.to[0] - self.from[0],
            rotary: self.to[1] - self.from[1],
            radial_mm: self.to[2] - self.from[2],
            e_mm: self.e_mm,
        }
    }

    fn extruding(&self) -> bool {
        self.e_mm > 0.0
    }
}

/// A small reader of the generator's own output: G0/G1/G28/G90/G91/G92/M82/M83.
fn read_moves(text: &str, m: &RotaryConfig) -> Vec<Move> {
    let letters = [m.axial_axis, m.rotary_axis, m.radial_axis];
    let mut pos = [f64::NAN; 3];
    let (mut e, mut feed) = (0.0, 0.0);
    let (mut relative, mut relative_e) = (false, false);
    let mut layer = None;
    let mut moves = Vec::new();
    for line in text.lines() {
        let (code, comment) = line.split_once(';').unwrap_or((line, ""));
        if let Some(rest) = comment.trim().strip_prefix("layer ") {
            layer = rest.split(' ').next().and_then(|k| k.parse().ok());
        }
        let mut words = code.split_whitespace();
        let Some(command) = words.next() else {
            continue;
        };
        let words: Vec<(char, Option<f64>)> =
            words.map(|w| (w.chars().next().unwrap(), w[1..].parse().ok())).collect();
        let value = |letter: char| words.iter().find(|(l, _)| *l == letter).and_then(|w| w.1);
        match command {
            "G90" => relative = false,
            "G91" => relative = true,
            "M82" => relative_e = false,
            "M83" => relative_e = true,
            "G28" => {
                for (i, l) in letters.iter().enumerate() {
                    if words.iter().any(|(w, _)| w == l) {
                        pos[i] = 0.0;
                    }
                }
            }
            "G92" => {
                for (i, l) in letters.iter().enumerate() {
                    if let Some(v) = value(*l) {
                        pos[i] = v;
                    }
                }
                if let Some(v) = value('E') {
                    e = v;
                }
            }
            "G0" | "G1" => {
                let from = pos;
                for (i, l) in letters.iter().enumerate() {
                    if let Some(v) = value(*l) {
                        pos[i] = if relative { pos[i] + v } else { v };
                    }
                }
                let e_mm = match value('E') {
                    Some(v) if relative_e => v,
                    Some(v) => {
                        let moved = v - e;
                        e = v;
                        moved
                    }
                    None => 0.0,
                };
                if let Some(f) = value('F') {
                    feed = f;
                }
                moves.push(Move { layer, from, to: pos, e_mm, feed, rapid: command == "G0" });
            }
            _ => {}
        }
    }
    moves
}

/// The bead-centre point of a set of words: radius = R0 + radial - h/2.
fn point(m: &RotaryConfig, words: [f64; 3], h: f64) -> CylPoint {
    m.point_from_words(words, h / 2.0)
}

fn small_tube() -> TubeParams {
    let mut params = TubeParams::new(RotaryConfig::new(20.0));
    params.length_mm = 12.0;
    params.layers = 3;
    params
}

fn generate(params: &TubeParams) -> (String, Vec<Move>) {
    let mut out = Vec::new();
    params.write_gcode(&mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let moves = read_moves(&text, &params.machine);
    (text, moves)
}

fn printed(moves: &[Move]) -> impl Iterator<Item = &Move> {
    moves.iter().filter(|mv| mv.extruding())
}

#[test]
fn start_block_is_the_seeds() {
    let (text, _) = generate(&small_tube());
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[2].starts_with("G28 X Z"));
    assert_eq!(&lines[3..7], ["M109 S190", "G90", "G21", "M82"]);
    assert_eq!(&lines[7..11], ["G92 A0.000", "G92 E0", "G0 Z0.200 F3000.000", "G0 X0.200 F3000.000"]);
    assert!(lines[11].starts_with("; layer 0 radius 10.100 mm"));
    assert!(text.ends_with("M104 S0\nG91\nG1 Z5 F600 ; lift off the part\nG90\nM84\n"));
}

#[test]
fn every_extruded_point_lies_on_its_layer_cylinder() {
    let params = small_tube();
    let (_, moves) = generate(&params);
    let h = params.print.layer_height_mm;
    let tol = params.print.chord_tolerance_mm;
    let mut worst_sagitta: f64 = 0.0;
    let mut count = 0;
    for mv in printed(&moves) {
        let k = mv.layer.unwrap();
        let r_k = params.layer_radius_mm(k);
        let ends = [mv.from, mv.to].map(|w| point(&params.machine, w, h).to_cartesian());
        for [_, y, z] in ends {
            assert!((y.hypot(z) - r_k).abs() < 0.01, "{mv:?} off layer {k}");
        }
        let mid = [1, 2].map(|i| 0.5 * (ends[0][i] + ends[1][i]));
        let sagitta = r_k - mid[0].hypot(mid[1]);
        // Rounding the angle to 0.001 deg moves a point by 0.0002 mm at this radius.
        assert!(sagitta <= tol + 0.0005, "chord {mv:?} sags {sagitta} mm");
        worst_sagitta = worst_sagitta.max(sagitta);
        count += 1;
    }
    assert!(count > 3 * 12 / 2 * 50, "only {count} printed moves");
    // The tolerance is used, not undercut by a needlessly fine subdivision.
    assert!(worst_sagitta > 0.7 * tol, "worst sagitta {worst_sagitta}");
}

#[test]
fn the_helix_reverses_every_layer_when_interwoven() {
    for interweave in [true, false] {
        let mut params = small_tube();
        params.interweave = interweave;
        params.layers = 4;
        let (_, moves) = generate(&params);
        for k in 0..4 {
            let layer: Vec<&Move> = printed(&moves).filter(|mv| mv.layer == Some(k)).collect();
            let hands: Vec<f64> = layer
                .iter()
                .map(|mv| mv.delta())
                .filter(|d| d.axial_mm != 0.0)
                .map(|d| (d.axial_mm * d.rotary).signum())
                .collect();
            assert!(hands.len() > 100);
            let expected = if interweave && k % 2 == 1 { -1.0 } else { 1.0 };
            assert!(hands.iter().all(|&s| s == expected), "layer {k}");
            // Interwoven, the spindle never reverses; otherwise it does every layer.
            let spin = if interweave || k % 2 == 0 { 1.0 } else { -1.0 };
            assert!(layer.iter().all(|mv| mv.delta().rotary.signum() == spin));
        }
    }
}

/// Surface speed of every printed move, recomputed from its emitted F, against the request.
fn assert_surface_speed(params: &TubeParams) {
    let (_, moves) = generate(params);
    let m = &params.machine;
    let h = params.print.layer_height_mm;
    let v = params.print.print_speed_mm_s;
    let mut n = 0;
    for mv in printed(&moves) {
        let speed = m.surface_speed_mm_s(mv.from, mv.to, mv.feed, h / 2.0).unwrap();
        assert!((speed / v - 1.0).abs() < 0.01, "{mv:?}: {speed} mm/s");
        n += 1;
    }
    assert!(n > 1000);
}

#[test]
fn surface_speed_holds_for_every_feed_convention() {
    for convention in [FeedConvention::Nist, FeedConvention::Combined, FeedConvention::InverseTime] {
        let mut params = small_tube();
        params.machine.feed_convention = convention;
        assert_surface_speed(&params);
        // A linear Y in mm of circumference, the usual combined setup.
        params.machine.rotary_axis = 'Y';
        params.machine.rotary_unit = RotaryUnit::Mm;
        assert_surface_speed(&params);
    }
}

#[test]
fn large_angles_are_rebased_without_changing_the_path() {
    let mut params = small_tube();
    params.machine.rotary_rebase_deg = 720.0;
    let (text, moves) = generate(&params);
    let rebases = text.lines().filter(|l| l.starts_with("G92 A")).count();
    // 3 layers of 29.5 turns: about 10 620 degrees, re-declared every 2 turns or so.
    assert!(rebases > 10, "{rebases}");
    assert!(moves.iter().all(|mv| mv.to[1].abs() < 730.0));
    assert_surface_speed(&params);
    // The same tube unrebased has the same printed points, modulo whole turns.
    let mut plain = params.clone();
    plain.machine.rotary_rebase_deg = 0.0;
    let (_, plain_moves) = generate(&plain);
    let [a, b] = [&moves, &plain_moves].map(|m| printed(m).map(|mv| mv.to).collect::<Vec<_>>());
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(&b) {
        let turns = (q[1] - p[1]) / 360.0;
        assert_eq!((p[0], p[2]), (q[0], q[2]));
        assert!((turns - turns.round()).abs() < 1e-6, "{p:?} {q:?}");
    }
}

#[test]
fn inverse_time_brackets_the_print_with_g93_g94() {
    let mut params = small_tube();
    params.machine.feed_convention = FeedConvention::InverseTime;
    let (text, _) = generate(&params);
    let g93 = text.find("\nG93").unwrap();
    let g94 = text.find("\nG94\n").unwrap();
    assert!(g93 < text.find("\nG1 ").unwrap() && g94 > text.rfind("E").unwrap());
    // Every G1 inside carries its own F.
    let inside = &text[g93..g94];
    assert!(inside.lines().filter(|l| l.starts_with("G1")).all(|l| l.contains(" F")));
}

#[test]
fn angular_speed_follows_each_layer_and_the_cap() {
    let mut params = small_tube();
    params.layers = 5;
    params.print.layer_height_mm = 2.0; // exaggerate the radius growth: 11 .. 19 mm
    params.print.bead_width_mm = 2.0;
    let (_, moves) = generate(&params);
    let m = params.machine.clone();
    for k in 0..5 {
        let (deg, t_s) = printed(&moves).filter(|mv| mv.layer == Some(k) && mv.delta().axial_mm != 0.0).fold(
            (0.0, 0.0),
            |(deg, t), mv| {
                let d = mv.delta();
                (deg + d.rotary.abs(), t + m.time_from_feed(&d, mv.feed).unwrap())
            },
        );
        let rate = deg / t_s;
        let expected = params.angular_speed_deg_s(k);
        assert!((rate / expected - 1.0).abs() < 0.01, "layer {k}: {rate} vs {expected}");
    }
    // 20 mm/s at r = 11 mm is 104 deg/s; a 60 deg/s cap slows every move down to it.
    params.machine.max_rotary_deg_s = Some(60.0);
    let (_, moves) = generate(&params);
    let mut capped = 0;
    for mv in printed(&moves) {
        let d = mv.delta();
        let rate = d.rotary.abs() / m.time_from_feed(&d, mv.feed).unwrap();
        assert!(rate < 60.0 * 1.01, "{mv:?} turns at {rate} deg/s");
        capped += usize::from(rate > 59.0);
    }
    assert!(capped > 100);
}

#[test]
fn extruded_volume_is_the_wall_volume() {
    for relative_e in [false, true] {
        let mut params = small_tube();
        params.print.relative_e = relative_e;
        let mut out = Vec::new();
        let summary = params.write_gcode(&mut out).unwrap();
        let moves = read_moves(&String::from_utf8(out).unwrap(), &params.machine);
        let filament: f64 = moves.iter().map(|mv| mv.e_mm).sum();
        assert!((filament - summary.filament_mm).abs() < 1e-4);
        let area = std::f64::consts::PI * 1.75f64.powi(2) / 4.0;
        let ratio = filament * area / params.wall_volume_mm3();
        assert!((ratio - 1.0).abs() < 0.01, "volume ratio {ratio}");
    }
    // An open lattice holds w/p of the wall.
    let mut params = small_tube();
    params.pitch_mm = Some(1.6);
    params.end_turns = 0.0;
    let summary = params.write_gcode(std::io::sink()).unwrap();
    let area = std::f64::consts::PI * 1.75f64.powi(2) / 4.0;
    // Bead centres run over length - w, so the helix covers (L - w)/p turns.
    let ratio = summary.filament_mm * area / params.wall_volume_mm3();
    let expected = 0.4 / 1.6 * (12.0 - 0.4) / 12.0;
    assert!((ratio / expected - 1.0).abs() < 0.01, "{ratio} vs {expected}");
}

#[test]
fn layers_join_without_travel() {
    let params = small_tube();
    let (_, moves) = generate(&params);
    let first = moves.iter().position(Move::extruding).unwrap();
    let last = moves.iter().rposition(Move::extruding).unwrap();
    let idle: Vec<&Move> = moves[first..last].iter().filter(|mv| !mv.extruding()).collect();
    // Only the radial steps between layers, one layer height each, and no G0.
    assert_eq!(idle.len(), params.layers as usize - 1);
    for mv in idle {
        let d = mv.delta();
        assert_eq!((d.axial_mm, d.rotary), (0.0, 0.0));
        assert!((d.radial_mm - 0.2).abs() < 1e-9);
    }
    assert!(moves[first..last].iter().all(|mv| !mv.rapid));
    // Each layer starts where the previous one ended.
    let layers = params.layer_points().unwrap();
    for pair in layers.windows(2) {
        let (end, start) = (pair[0].last().unwrap(), pair[1][0]);
        assert_eq!((end.axial_mm, end.theta_deg), (start.axial_mm, start.theta_deg));
        assert!((start.radius_mm - end.radius_mm - 0.2).abs() < 1e-12);
    }
}

#[test]
fn tube_toml() {
    let params = TubeParams::from_toml_str(
        "length_mm = 30\nlayers = 2\n[machine]\nmandrel_diameter_mm = 25\n\
         feed_convention = \"combined\"\n[print]\nrelative_e = true\n[print.numbers]\n\
         position_decimals = 4",
    )
    .unwrap();
    assert_eq!(params.layers, 2);
    assert_eq!(params.machine.feed_convention, FeedConvention::Combined);
    assert_eq!(params.print.numbers.position_decimals, 4);
    assert!(params.interweave);
    let typo = TubeParams::from_toml_str("layer = 2\n[machine]\nmandrel_diameter_mm = 25");
    assert!(matches!(typo, Err(RotaryError::Toml(_))));
    let dense = TubeParams::from_toml_str("pitch_mm = 0.3\n[machine]\nmandrel_diameter_mm = 25");
    assert!(matches!(dense, Err(RotaryError::Config { key: "pitch_mm", .. })));
}

#[test]
fn cone_follows_its_radius_profile() {
    let cone = Profile::Table(vec![(0.0, 10.0), (20.0, 15.0)]);
    let path = HelicalPath::new(0.0, 20.0, cone.clone(), Profile::Constant(0.5));
    let res = Resolution { chord_tolerance_mm: 0.01, segments_per_turn: None };
    let points = path.points(res).unwrap();
    let last = points.last().unwrap();
    assert_eq!(last.axial_mm, 20.0);
    // 20 mm at 0.5 mm per turn is 40 turns.
    assert!((last.theta_deg - 40.0 * 360.0).abs() < 1e-6);
    for pair in points.windows(2) {
        let [a, b] = [pair[0], pair[1]];
        assert!(b.axial_mm > a.axial_mm);
        assert!((b.radius_mm - (10.0 + 0.25 * b.axial_mm)).abs() < 1e-9);
        // The chord midpoint against the cone's radius there.
        let (ca, cb) = (a.to_cartesian(), b.to_cartesian());
        let mid_r = (0.5 * (ca[1] + cb[1])).hypot(0.5 * (ca[2] + cb[2]));
        let cone_r = 10.0 + 0.25 * 0.5 * (a.axial_mm + b.axial_mm);
        assert!(cone_r - mid_r <= 0.01 + 1e-9, "{a:?} {b:?}");
    }
}

#[test]
fn variable_pitch_integrates_turns() {
    // p(x) = 0.4 + 0.02 x: turns = integral of dx/p = ln(p(20)/p(0))/0.02 = 34.66.
    let pitch = Profile::Custom(std::sync::Arc::new(|x: f64| 0.4 + 0.02 * x));
    let mut path = HelicalPath::new(20.0, 0.0, Profile::Constant(12.0), pitch);
    path.handedness = Handedness::Left;
    let res = Resolution { chord_tolerance_mm: 0.005, segments_per_turn: Some(90) };
    let points = path.points(res).unwrap();
    let turns = points.last().unwrap().theta_deg / 360.0;
    let expected = (0.8f64 / 0.4).ln() / 0.02;
    // Backwards and left-handed: the angle grows.
    assert!((turns - expected).abs() < 0.01, "{turns} vs {expected}");
    // 90 segments per turn is finer than the tolerance needs at r = 12 here.
    assert!(points.windows(2).all(|p| p[1].theta_deg - p[0].theta_deg <= 4.0 + 1e-9));
}

#[test]
fn bad_profiles_are_errors() {
    let res = Resolution { chord_tolerance_mm: 0.01, segments_per_turn: None };
    let nan = Profile::Custom(std::sync::Arc::new(|_| f64::NAN));
    let path = HelicalPath::new(0.0, 5.0, Profile::Constant(10.0), nan);
    assert!(matches!(path.points(res), Err(RotaryError::Profile { what: "pitch", .. })));
    let unsorted = Profile::Table(vec![(5.0, 10.0), (1.0, 11.0)]);
    let path = HelicalPath::new(0.0, 5.0, unsorted, Profile::Constant(1.0));
    assert!(matches!(path.points(res), Err(RotaryError::Config { key: "radius_mm", .. })));
    let tiny = HelicalPath::new(0.0, 1e6, Profile::Constant(10.0), Profile::Constant(1e-3));
    assert!(matches!(tiny.points(res), Err(RotaryError::TooManyPoints { .. })));
}

#[test]
fn custom_paths_program() {
    let machine = RotaryConfig::new(20.0);
    let print = PrintSettings::default();
    let a = HelicalPath::new(0.0, 5.0, Profile::Constant(10.1), Profile::Constant(1.0));
    let mut b = HelicalPath::new(10.0, 15.0, Profile::Constant(10.1), Profile::Constant(1.0));
    b.start_theta_deg = 1800.0;
    let mut out = Vec::new();
    let summary = write_paths(&machine, &print, &[a, b], &mut out).unwrap();
    let moves = read_moves(&String::from_utf8(out).unwrap(), &machine);
    // Two helices of 5 turns of hypot(2 pi 10.1, 1) mm, joined by one travel move.
    let len = 10.0 * (std::f64::consts::TAU * 10.1).hypot(1.0);
    assert!((summary.filament_mm - print.filament_for_mm(len)).abs() < 1e-6);
    let first = moves.iter().position(Move::extruding).unwrap();
    let travel: Vec<&Move> = moves[first..].iter().filter(|mv| !mv.extruding()).collect();
    assert_eq!(travel.len(), 2); // the jump to path b, and the final lift
    assert_eq!(travel[0].to[0], 10.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Any tube: points on the cylinder, volume of the wall, chords within tolerance.
    #[test]
    fn any_tube_is_on_its_cylinders(
        diameter in 5.0f64..80.0,
        length in 2.0f64..10.0,
        layers in 1u32..4,
        h in 0.1f64..0.4,
        tol in 0.002f64..0.05,
    ) {
        let mut params = TubeParams::new(RotaryConfig::new(diameter));
        params.length_mm = length;
        params.layers = layers;
        params.print.layer_height_mm = h;
        params.print.chord_tolerance_mm = tol;
        for (k, layer) in params.layer_points().unwrap().iter().enumerate() {
            let r_k = params.layer_radius_mm(k as u32);
            for pair in layer.windows(2) {
                let [a, b] = [pair[0].to_cartesian(), pair[1].to_cartesian()];
                prop_assert!((a[1].hypot(a[2]) - r_k).abs() < 1e-9);
                let mid = (0.5 * (a[1] + b[1])).hypot(0.5 * (a[2] + b[2]));
                prop_assert!(r_k - mid <= tol + 1e-9);
            }
        }
        let summary = params.write_gcode(std::io::sink()).unwrap();
        let area = std::f64::consts::PI * 1.75f64.powi(2) / 4.0;
        let ratio = summary.filament_mm * area / params.wall_volume_mm3();
        prop_assert!((ratio - 1.0).abs() < 0.01, "ratio {}", ratio);
    }
}

#[test]
fn cartesian_helper_matches_points() {
    let p = CylPoint::new(1.0, 30.0, 2.0);
    assert_eq!(p.to_cartesian(), to_cartesian(1.0, 30.0, 2.0));
}

/// Regression (issue 25): `rotary tube --layers 1000000000` wrote until the disk was full; the
/// whole tube's chords are now estimated and refused before a byte is written.
#[test]
fn a_tube_of_too_many_chords_is_refused_before_writing() {
    let mut t = TubeParams::new(RotaryConfig::new(20.0));
    t.layers = 1_000;
    t.length_mm = 10_000.0;
    let mut out = Vec::new();
    let err = t.write_gcode(&mut out).unwrap_err();
    assert!(matches!(err, RotaryError::TooManyPoints { limit: 5_000_000 }), "{err}");
    assert!(out.is_empty(), "{} bytes written", out.len());
    t.layers = 1_000_000;
    assert_eq!(t.validate().unwrap_err().to_string(), "layers = 1000000 is out of range: 1 to 1000");
}
