//! `gweave mix --predict`, `--calibration-card` and `--fit` through the real binary: a card
//! printed with filaments unlike the defaults, "measured" from a known model, fitted, and the
//! fitted profile predicting blends that were not on the card.

use std::path::Path;
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `--predict` for each of `ratios` with `profile`, as (srgb, lab).
fn predict(profile: Option<&Path>, ratios: &[String]) -> Vec<(String, [f64; 3])> {
    let mut args = vec!["mix", "--json"];
    let p;
    if let Some(path) = profile {
        p = path.to_str().unwrap().to_owned();
        args.extend(["-c", p.as_str()]);
    }
    for r in ratios {
        args.extend(["--predict", r.as_str()]);
    }
    let v = json(&gweave(&args));
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let lab: Vec<f64> = p["lab"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            (p["srgb"].as_str().unwrap().to_owned(), [lab[0], lab[1], lab[2]])
        })
        .collect()
}

fn delta_e(a: [f64; 3], b: [f64; 3]) -> f64 {
    use gweave::colour::{Ciede2000, Lab};
    Lab::new(a[0], a[1], a[2]).difference(Lab::new(b[0], b[1], b[2]))
}

#[test]
fn predict_prints_text_and_json() {
    let out = gweave(&["mix", "--predict", "1:0:1:0"]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "0.5000:0.0000:0.5000:0.0000  #69c348  L 71.1 a -48.9 b 51.8\n"
    );
    let p = predict(None, &["0:0:0:1".into()]);
    assert_eq!(p[0].0, "#f5f5f0");
    let bad = gweave(&["mix", "--predict", "1:x:0:0"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("ratios \"1:x:0:0\""));
}

#[test]
fn a_measured_card_fits_a_profile_that_predicts_other_blends() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name);
    // The real filaments (unknown to gweave): other colours and strengths than the defaults.
    let truth = d("truth.toml");
    let inputs = [("#1496d2", 0.9), ("#c8146e", 0.15), ("#fad21e", 1.5), ("#f0eee6", 0.6)];
    let mut text = String::new();
    for (c, s) in inputs {
        text.push_str(&format!("[[hardware.inputs]]\ncolour = \"{c}\"\nstrength = {s}\n"));
    }
    std::fs::write(&truth, text).unwrap();
    // The card with the default profile, and its swatches.
    let card = d("card.gcode");
    let report = d("card.json");
    let out = gweave(&[
        "mix",
        "--calibration-card",
        "-o",
        card.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let swatches: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let swatches = swatches["swatches"].as_array().unwrap();
    assert_eq!(swatches.len(), 30);
    let ratios: Vec<String> = swatches
        .iter()
        .map(|s| s["ratios"].as_array().unwrap().iter().map(|r| r.to_string()).collect::<Vec<_>>().join(":"))
        .collect();
    // "Measure" the printed card: the true model's colours, as #rrggbb from a photo.
    let measured = predict(Some(&truth), &ratios);
    let mut csv = "id,srgb\n".to_owned();
    for (s, (hex, _)) in swatches.iter().zip(&measured) {
        csv.push_str(&format!("{},{hex}\n", s["id"]));
    }
    std::fs::write(d("measured.csv"), csv).unwrap();
    let fitted = d("fitted.toml");
    let fit = json(&gweave(&[
        "mix",
        "--fit",
        d("measured.csv").to_str().unwrap(),
        "-o",
        fitted.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(fit["swatches"].as_array().unwrap().len(), 30);
    assert_eq!(fit["tint_exponents"].as_array().unwrap().len(), 4, "{fit}");
    assert!(fit["mean_delta_e"].as_f64().unwrap() < 1.0, "{fit}");
    // Blends not on the card: the fitted profile follows the real filaments, the default does not.
    let off_card: Vec<String> =
        ["0.6:0.2:0.2:0", "0.1:0.1:0.1:0.7", "0.2:0.5:0:0.3", "0:0.3:0.6:0.1", "0.4:0:0.4:0.2", "1:1:1:1"]
            .map(String::from)
            .to_vec();
    let real = predict(Some(&truth), &off_card);
    let mean = |p: &[(String, [f64; 3])]| {
        p.iter().zip(&real).map(|(a, b)| delta_e(a.1, b.1)).sum::<f64>() / real.len() as f64
    };
    let after = mean(&predict(Some(&fitted), &off_card));
    let before = mean(&predict(None, &off_card));
    assert!(after <= 3.0 && before > 5.0, "mean CIEDE2000 {before:.2} -> {after:.2}");
    // An output naming an input is refused, and nothing is written from a bad row.
    let same = gweave(&[
        "mix",
        "--fit",
        d("measured.csv").to_str().unwrap(),
        "-o",
        d("measured.csv").to_str().unwrap(),
    ]);
    assert!(!same.status.success());
    std::fs::write(d("bad.csv"), "id,srgb\n1,#00a0e0\n2,#nothex\n").unwrap();
    let bad =
        gweave(&["mix", "--fit", d("bad.csv").to_str().unwrap(), "-o", d("bad.toml").to_str().unwrap()]);
    assert!(!bad.status.success());
    let said = String::from_utf8_lossy(&bad.stderr);
    assert!(said.contains(&format!("{}:3: ", d("bad.csv").display())), "{said}");
    assert!(!d("bad.toml").exists());
}

/// Runs `gweave args` with `answers` on standard input.
fn gweave_answering(args: &[&str], answers: &str) -> Output {
    use std::io::Write;
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_gweave"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(answers.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

#[test]
fn the_wizard_confirms_then_writes_and_runs_the_job() {
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("mix.toml");
    let out = dir.path().join("out.gcode");
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_torus.gcode");
    let args = [
        "mix",
        "--wizard",
        input.to_str().unwrap(),
        "-c",
        profile.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ];
    // Orange from layer 0, default purge and cap; declined: nothing is written.
    let no = gweave_answering(&args, "1\nn\nOrange\n0\n\n\n\nn\n");
    assert!(!no.status.success());
    assert!(String::from_utf8_lossy(&no.stdout).contains("Summary:"));
    assert!(!profile.exists() && !out.exists());
    // Confirmed: the profile, then the file rewritten with it.
    let yes = gweave_answering(&args, "1\nn\nOrange\n0\n\n\n\ny\n");
    assert!(yes.status.success(), "{}", String::from_utf8_lossy(&yes.stderr));
    assert!(std::fs::read_to_string(&profile).unwrap().contains("mix = \"Orange\""));
    let gcode = std::fs::read_to_string(&out).unwrap();
    assert!(gcode.contains("M163 S1 P0.1717\n"), "the job ran");
    // Without -o it says plainly that the file was not processed.
    std::fs::remove_file(&profile).unwrap();
    let only = gweave_answering(&args[..5], "1\nn\nOrange\n0\n\n\n\ny\n");
    assert!(only.status.success());
    assert!(String::from_utf8_lossy(&only.stderr).contains("the wizard only wrote the profile"));
}

#[test]
fn quiet_hides_the_card_summary_but_not_a_prediction() {
    // -q means no human summary in every command; the card's summary printed through it
    // before. A prediction is the command's result, not a summary: -q leaves it.
    let dir = tempfile::tempdir().unwrap();
    let card = dir.path().join("card.gcode");
    let loud = gweave(&["mix", "--calibration-card", "-o", card.to_str().unwrap()]);
    assert!(loud.status.success(), "{}", String::from_utf8_lossy(&loud.stderr));
    assert!(!loud.stdout.is_empty());
    let quiet = gweave(&["mix", "--calibration-card", "-o", card.to_str().unwrap(), "-q"]);
    assert!(quiet.status.success(), "{}", String::from_utf8_lossy(&quiet.stderr));
    assert_eq!(String::from_utf8_lossy(&quiet.stdout), "");
    let predicted = gweave(&["mix", "--predict", "1:0:1:0", "-q"]);
    assert_eq!(
        String::from_utf8_lossy(&predicted.stdout),
        "0.5000:0.0000:0.5000:0.0000  #69c348  L 71.1 a -48.9 b 51.8\n"
    );
}

#[test]
fn the_card_counts_rows_from_1_in_the_terminal_and_the_json_and_draws_numbered_swatches() {
    // Issue 39: the terminal said "row 2 col 1" for swatch 7 while card.json said row 1,
    // column 0. Both count from 1 now, as the swatch ids do.
    let dir = tempfile::tempdir().unwrap();
    let (card, report, png) =
        (dir.path().join("card.gcode"), dir.path().join("card.json"), dir.path().join("card.png"));
    let out = gweave(&[
        "mix",
        "--calibration-card",
        "-o",
        card.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--card-png",
        png.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let line = text.lines().find(|l| l.trim_start().starts_with("7 ")).unwrap();
    assert!(line.contains("row 2 col 1"), "{line}");
    assert!(text.contains("rows and columns count from 1, as in the JSON"), "{text}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let s7 = &json["swatches"][6];
    assert_eq!((s7["id"].as_u64(), s7["row"].as_u64(), s7["column"].as_u64()), (Some(7), Some(2), Some(1)));
    // The picture: a PNG of the preview's size (its pixels are tested in render::card).
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!((&bytes[16..20], &bytes[20..24]), (&1200u32.to_be_bytes()[..], &900u32.to_be_bytes()[..]));
    // The picture is drawn from the card's file: with -o - there is none.
    let refused = gweave(&["mix", "--calibration-card", "-o", "-", "--card-png", png.to_str().unwrap()]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--card-png draws the card from its file"));
}

/// Regression (issue 40): the card's header was the command line as typed (argv through a
/// global mutex), so the same card typed in another order or with an alias named another run.
/// It is written from the options now, as every job's: the library's header to the byte.
#[test]
fn the_card_header_is_written_from_the_options_whatever_was_typed() {
    use gweave::post::mix::MixOptions;
    use gweave::Strictness;
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("mix profile.toml");
    std::fs::write(&profile, "").unwrap();
    let card = dir.path().join("card.gcode");
    let header = |args: &[&str]| {
        let mut all = vec!["mix"];
        all.extend(args);
        all.extend(["-o", card.to_str().unwrap(), "-q"]);
        let out = gweave(&all);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        std::fs::read_to_string(&card).unwrap().lines().next().unwrap().to_owned()
    };
    let c = profile.to_str().unwrap();
    let typed = header(&["--purge-mm", "20", "--calibration-card", "-c", c]);
    assert_eq!(typed, header(&["--calibration-card", "--config", c, "--purge-mm", "20"]));
    let options = MixOptions { config: Some(profile.clone()), purge_mm: Some(20.0), ..MixOptions::default() };
    let from_options = gweave_sim::transform::command_line(&options, Strictness::Strict);
    let version = env!("CARGO_PKG_VERSION");
    let words = from_options.strip_prefix("mix ").unwrap();
    assert_eq!(typed, format!("; gweave {version} mix --calibration-card {words} (generated)"));
    assert_eq!(words, format!("-c {c:?} --purge-mm 20"));
}
