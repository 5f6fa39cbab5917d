//! Every G-code command against every kind of hostile input: whatever the bytes, each run ends
//! by itself (a result or a refusal with exit code 1), without a panic, within its time limit and
//! a fixed memory budget, leaving the input as it was and no temporary file behind. The same
//! holds for the bombs of issue 36: containers whose metadata or blocks inflate, layer images
//! whose header says more than any bed, and a count bomb in every count of every profile type.

use std::fs;
use std::path::Path;
use std::time::Duration;

use crate::harness::*;

/// Peak memory any command may use on these inputs, whatever their bytes (the budget in
/// docs/reliability.md).
const BUDGET_MIB: f64 = 64.0;

/// Megabytes of each garbage input: enough that memory growing with the line shows (the old
/// reader held about 40 bytes per byte of such a line), small enough for a debug build in CI.
const GARBAGE: usize = 8 << 20;

/// The hostile inputs, by name.
fn inputs() -> Vec<(&'static str, Vec<u8>)> {
    let fixture = fs::read(fixture_path("cura/cura_torus.gcode")).expect("fixture");
    let head = &fixture[..200_000];
    let mut utf16 = vec![0xFF, 0xFE];
    utf16.extend(head.iter().flat_map(|&b| [b, 0]));
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(head);
    let words = b"G1 X1 Y1 E1 ".repeat(GARBAGE / 12);
    let mut numbers = b"M104 S200\nM109 S200\nG28\nG92 E0\n".to_vec();
    for n in ["1e308", "-1e308", &"9".repeat(400), "nan", "inf", "-0", "0x10", "1e-320"] {
        numbers.extend(format!("G1 X{n} Y{n} E{n} F{n}\nG4 P{n}\nM104 S{n}\nG92 E{n}\n").bytes());
    }
    let arcs = b"M104 S200\nM109 S200\nG28\nG92 E0\nG1 X10 Y10 F3000\n\
                 G2 X10 Y0 I10000000 J0 E1 F1000\nG3 X0 Y0 R1e9 E2\nG2 X1 Y1 I1e-12 J0 E3\n"
        .to_vec();
    vec![
        ("zeros", vec![0; GARBAGE]),
        ("ff", vec![0xFF; GARBAGE]),
        ("hashes", vec![b'#'; GARBAGE]),
        ("one_line_of_words", words),
        ("cr_only", fixture.iter().map(|&b| if b == b'\n' { b'\r' } else { b }).collect()),
        ("utf16", utf16),
        ("bom", bom),
        ("huge_numbers", numbers),
        ("huge_arcs", arcs),
        ("empty", Vec::new()),
        ("newlines", vec![b'\n'; 100_000]),
    ]
}

/// Each command as a user would type it on `in.gcode`.
const COMMANDS: &[&[&str]] = &[
    &["stats", "in.gcode"],
    &["check", "in.gcode"],
    &["cat", "in.gcode", "-o", "out.gcode"],
    &["cat", "in.gcode", "-o", "out.gcode", "--lenient"],
    &["sim", "in.gcode"],
    &["estimate", "in.gcode"],
    &["mix", "in.gcode", "--at-layer", "0=Orange", "-o", "out.gcode"],
    &["purge-shift", "in.gcode", "--purge-mm", "2", "-o", "out.gcode"],
    &["rotary", "wrap", "in.gcode", "--mandrel-diameter", "30", "-o", "out.gcode"],
    &["preview", "in.gcode", "-o", "out.png"],
    &["preview", "in.gcode", "-o", "out.html", "--view", "iso"],
];

/// Runs every command on `bytes`; returns what went wrong, one line per failed run. (`check`
/// reports on standard output, the others on standard error.)
fn sweep(name: &str, bytes: &[u8]) -> Vec<String> {
    let mut failures = Vec::new();
    for args in COMMANDS {
        let dir = tempfile::tempdir().expect("temp dir");
        let input = dir.path().join("in.gcode");
        fs::write(&input, bytes).expect("input written");
        let outcome = gweave(dir.path(), args).limit(Duration::from_secs(30)).run();
        let what = format!("{name}: gweave {}", args.join(" "));
        failures.extend(judge(&what, &outcome, dir.path()));
        if fs::read(&input).ok().as_deref() != Some(bytes) {
            failures.push(format!("{what}: input changed"));
        }
    }
    failures
}

#[test]
fn every_command_survives_every_hostile_input() {
    let failures: Vec<String> = inputs().iter().flat_map(|(name, bytes)| sweep(name, bytes)).collect();
    assert!(failures.is_empty(), "{} failed runs:\n{}", failures.len(), failures.join("\n"));
}

/// Binary G-code and gzip whose container is the bomb (metadata that inflates, more metadata
/// blocks than the specification has, a G-code block of 64 MiB, half a million metadata items,
/// many empty blocks, bytes after a gzip stream), through every command: read by its content,
/// whatever its name.
fn container_bombs() -> Vec<(&'static str, Vec<u8>)> {
    use crate::bombs::*;
    let flavour = b"gcode_flavor=marlin2\n".as_slice();
    let mut gcode_block = bgcode_with(b"printer_model=MK4\n", flavour, 1, 1);
    gcode_block.extend(block(GCODE, &b"G1 X1\n".repeat((64 << 20) / 6), true));
    let mut gzip = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut gzip, b"M104 S200\nG1 X1 E1 F600\n").unwrap();
    let mut gzip_trailing = gzip.finish().unwrap();
    gzip_trailing.extend_from_slice(b"\0\0\0\0trailing");
    vec![
        ("printer_metadata_64_mib", bgcode_with(&empty_items(64 << 20), flavour, 1, 1)),
        ("thirty_slicer_blocks", bgcode_with(b"printer_model=MK4\n", &empty_items(1 << 20), 30, 1)),
        ("metadata_items", bgcode_with(&empty_items(1 << 20), flavour, 1, 1)),
        ("gcode_block_64_mib", gcode_block),
        ("empty_gcode_blocks", bgcode_with(b"printer_model=MK4\n", flavour, 1, 20_000)),
        ("gzip_trailing_bytes", gzip_trailing),
    ]
}

#[test]
fn every_command_survives_every_container_bomb() {
    let failures: Vec<String> =
        container_bombs().iter().flat_map(|(name, bytes)| sweep(name, bytes)).collect();
    assert!(failures.is_empty(), "{} failed runs:\n{}", failures.len(), failures.join("\n"));
}

/// Layer images whose header is the bomb, through `raster`: refused (or rastered) within the
/// budget and the time limit, leaving no output.
#[test]
fn raster_survives_every_image_bomb() {
    use crate::bombs::{bmp_header, png};
    let mut truncated = png(60_000, 60_000, 1);
    truncated.truncate(200);
    let images: Vec<(&str, &str, Vec<u8>)> = vec![
        ("png_60000_1bit", "a.png", png(60_000, 60_000, 1)),
        ("png_21000_1bit", "a.png", png(21_000, 21_000, 1)),
        ("png_21000_8bit", "a.png", png(21_000, 64, 8)),
        ("png_truncated", "a.png", truncated),
        ("png_zero_size", "a.png", png(0, 0, 1)),
        ("bmp_header_only", "a.bmp", bmp_header(60_000, 60_000)),
        ("bmp_negative", "a.bmp", bmp_header(-5, i32::MIN)),
    ];
    let mut failures = Vec::new();
    for (name, file, bytes) in &images {
        for extra in [&[][..], &["--pixel-mm", "0.00254"], &["--pixel-mm", "2.54"]] {
            let dir = tempfile::tempdir().expect("temp dir");
            fs::write(dir.path().join(file), bytes).expect("input written");
            let mut args = vec!["raster", file, "-o", "out.gcode"];
            args.extend_from_slice(extra);
            let outcome = gweave(dir.path(), &args).limit(Duration::from_secs(30)).run();
            failures.extend(judge(&format!("{name}: gweave {}", args.join(" ")), &outcome, dir.path()));
        }
    }
    assert!(failures.is_empty(), "{} failed runs:\n{}", failures.len(), failures.join("\n"));
}

/// Every count of every profile type set to a bomb (the largest integers, 2^32, a million,
/// -1), each through the command that reads that profile: refused (or run) within the budget.
#[test]
fn every_profile_count_survives_every_count_bomb() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let example = |path: &str| fs::read_to_string(repo.join(path)).expect("example");
    let moves = "G28\nM104 S200\nM109 S200\nG1 X10 Y10 Z0.2 F3000\nG1 X20 Y10 E1 F1200\n";
    let sim = &["sim", "in.gcode", "--machine", "p.toml"][..];
    let mix = &["mix", "in.gcode", "--config", "p.toml", "-o", "out.gcode"][..];
    let raster = &["raster", "layer.bmp", "--head", "p.toml", "-o", "out.gcode"][..];
    let tube = &["rotary", "tube", "-c", "p.toml", "-o", "out.gcode"][..];
    let purge = &["purge-shift", "in.gcode", "-c", "p.toml", "-o", "out.gcode"][..];
    let inkjet = example("examples/machines/inkjet-c6602.toml");
    let tube_toml = example("examples/rotary/tube.toml");
    let lattice = example("examples/rotary/lattice.toml");
    let seed = example("examples/machines/seed-controller.toml");
    // (profile type, its text with the count as `{N}`, the key, the command that reads it)
    let counts: Vec<(&str, String, &str, &[&str])> = vec![
        ("machine", "mixing_inputs = {N}\n".into(), "mixing_inputs", sim),
        ("machine", "[motion.corners]\nmode = \"marlin\"\nlookahead_blocks = {N}\n".into(), "lookahead_blocks", sim),
        ("machine", "[thermal]\nrecord_max_samples = {N}\n".into(), "record_max_samples", sim),
        ("machine", seed.replace("adc_max = 1023", "adc_max = {N}"), "adc_max", sim),
        ("machine", seed.replace("oversample = 1 ", "oversample = {N} "), "oversample", sim),
        ("machine", inkjet.replace("[inkjet]\n", "[inkjet]\nwidth_px = {N}\n"), "width_px", sim),
        ("mix", "[hardware]\nvirtual_tools = {N}\n".into(), "virtual_tools", mix),
        ("mix", "[hardware]\nratio_decimals = {N}\n".into(), "ratio_decimals", mix),
        ("mix", "[hardware]\nrrf_heater = {N}\n".into(), "rrf_heater", mix),
        ("mix", "[hardware]\nmaterial2_input = {N}\n".into(), "material2_input", mix),
        ("mix", "[card]\ncolumns = {N}\n".into(), "columns", mix),
        ("mix", "[card]\nlayers = {N}\n".into(), "layers", mix),
        ("mix", "[numbers]\nposition_decimals = {N}\n".into(), "position_decimals", mix),
        (
            "mix",
            "[[gradient]]\nfrom_layer = 0\nto_layer = 9\nstart = \"Red\"\nend = \"Blue\"\nevery_layers = {N}\n".into(),
            "every_layers",
            mix,
        ),
        ("mix", "[[schedule]]\nmix = \"Red\"\nlayer = {N}\n".into(), "layer", mix),
        ("printhead", "nozzle_count = {N}\n".into(), "nozzle_count", raster),
        ("rotary", tube_toml.replace("layers = 4", "layers = {N}"), "layers", tube),
        ("rotary", lattice.replace("segments_per_turn = 120", "segments_per_turn = {N}"), "segments_per_turn", tube),
        ("purge-shift", "purge_mm = 5\nmax_window_lines = {N}\n".into(), "max_window_lines", purge),
    ];
    let bombs = ["18446744073709551615", "9223372036854775807", "4294967296", "1000000", "-1"];
    let mut failures = Vec::new();
    for (kind, text, key, args) in &counts {
        assert!(text.contains("{N}"), "{kind} {key}: no place for the count");
        for bomb in bombs {
            let dir = tempfile::tempdir().expect("temp dir");
            fs::write(dir.path().join("in.gcode"), moves).expect("input");
            fs::write(dir.path().join("layer.bmp"), crate::bombs::bmp_header(4, 4)).expect("image");
            fs::write(dir.path().join("p.toml"), text.replace("{N}", bomb)).expect("profile");
            let outcome = gweave(dir.path(), args).limit(Duration::from_secs(30)).run();
            let what = format!("{kind} {key} = {bomb}: gweave {}", args.join(" "));
            failures.extend(judge(&what, &outcome, dir.path()));
            // A refusal is the count's, not some other key's (a negative count is refused by
            // its type, in a message that names the table when the table is an enum's).
            if outcome.code == Some(1) && bomb != "-1" && !outcome.stderr.contains(key) {
                failures.push(format!("{what}: refused without naming {key}: {}", outcome.stderr));
            }
        }
    }
    assert!(failures.is_empty(), "{} failed runs:\n{}", failures.len(), failures.join("\n"));
}

/// What went wrong with one run in `dir` (none if it was sound): a hang, a crash, an exit code
/// other than 0 or 1, a refusal without a word, the budget passed, a scratch file or a partial
/// output left.
fn judge(what: &str, outcome: &Outcome, dir: &Path) -> Vec<String> {
    let mut failures = Vec::new();
    let first_error = outcome.stderr.lines().next().unwrap_or("").to_string();
    if outcome.hung {
        failures.push(format!("{what}: hung (killed after {:?})", outcome.elapsed));
    } else if outcome.signal.is_some() || outcome.stderr.contains("panicked") {
        failures.push(format!("{what}: crashed (signal {:?}): {first_error}", outcome.signal));
    } else if !matches!(outcome.code, Some(0 | 1)) {
        failures.push(format!("{what}: exit {:?}: {first_error}", outcome.code));
    } else if outcome.code == Some(1) && outcome.stderr.trim().is_empty() && outcome.stdout.is_empty() {
        failures.push(format!("{what}: refused without a word"));
    }
    if outcome.peak_mib >= BUDGET_MIB {
        failures.push(format!("{what}: peak memory {:.0} MiB", outcome.peak_mib));
    }
    if outcome.stderr.len() > 4096 {
        failures.push(format!("{what}: a message of {} bytes", outcome.stderr.len()));
    }
    if snapshot(dir)
        .keys()
        .any(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".gweave-")))
    {
        failures.push(format!("{what}: temporary file left"));
    }
    if outcome.code == Some(1) && dir.join("out.gcode").exists() {
        failures.push(format!("{what}: partial output left"));
    }
    failures
}
