//! `gweave mix`'s colour tools: `--predict`, `--calibration-card`, `--fit` (see `docs/mix.md`).

use std::path::Path;
use std::process::ExitCode;

use anyhow::{anyhow, bail, Result};
use gweave::colour::fit::{fit, parse_csv, FitError};
use gweave::colour::predict::{parse_ratios, predict, Prediction};
use gweave::post::mix::card::{card_mixes, fitted_profile_toml};
use gweave::post::mix::profile::MixProfile;
use gweave::render::card::card_png;
use gweave::render::MixColours;
use gweave::{MixOptions, Target};
use gweave_sim::transform::calibration_card;

use crate::common::{print_summary, read_text, write_bytes, ReportArgs};
use crate::options::failed;

/// `--predict C:M:Y:W ...`: each mix's predicted colour, with the profile's filaments.
pub fn predict_all(profile: &MixProfile, mixes: &[String], report: &ReportArgs) -> Result<ExitCode> {
    let model = profile.hardware.mixing_model()?;
    let predictions =
        mixes.iter().map(|s| Ok(predict(&model, &parse_ratios(s)?)?)).collect::<Result<Vec<Prediction>>>()?;
    if report.emit_result(&predictions)? {
        print_summary(|out| {
            for p in &predictions {
                let ratios: Vec<String> = p.ratios.iter().map(|r| format!("{r:.4}")).collect();
                let [l, a, b] = p.lab;
                writeln!(out, "{}  {}  L {l:.1} a {a:.1} b {b:.1}", ratios.join(":"), p.srgb)?;
            }
            Ok(())
        })?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Size of `--card-png`'s picture, px (a preview's default).
const CARD_PICTURE_PX: [u32; 2] = [1200, 900];

/// `--calibration-card -o card.gcode [--report card.json] [--card-png card.png]`: the card is
/// written by the library's job (`gweave_sim::transform::calibration_card`, its header from
/// `options`). With `picture`, the card's picture is drawn from the file written (numbered
/// swatches).
pub fn card(
    profile: &MixProfile,
    options: &MixOptions,
    output: &Path,
    target: &Target,
    picture: Option<&Path>,
    report: &ReportArgs,
) -> Result<ExitCode> {
    if picture.is_some() && target.is_stdout() {
        bail!("--card-png draws the card from its file: give -o FILE, not -");
    }
    let card = calibration_card(profile, options, target).map_err(failed)?;
    if let Some(png) = picture {
        let mix = MixColours::from_profile(profile)?;
        let bytes = card_png(output, &card.swatches, mix, &profile.card, CARD_PICTURE_PX)?;
        write_bytes(png, &bytes)?;
    }
    for w in &card.mix.warnings {
        eprintln!("gweave: warning: {w}");
    }
    #[derive(serde::Serialize)]
    struct Swatches<'a> {
        swatches: &'a [gweave::post::mix::card::Swatch],
        purge: &'a gweave::post::mix::report::PurgeTotals,
    }
    let summary = Swatches { swatches: &card.swatches, purge: &card.mix.purge };
    if report.emit(&summary)? && !target.is_stdout() {
        print_summary(|out| {
            writeln!(
                out,
                "{} swatches, swatch 1 at the front left, rows of {} (rows and columns count from 1, as in the JSON):",
                card.swatches.len(),
                profile.card.columns
            )?;
            for s in &card.swatches {
                let ratios: Vec<String> = s.ratios.iter().map(|r| format!("{r:.4}")).collect();
                writeln!(
                    out,
                    "  {:>3}  row {} col {}  {}  predicted {}",
                    s.id,
                    s.row,
                    s.column,
                    ratios.join(":"),
                    s.predicted
                )?;
            }
            writeln!(out, "purges {} x, {:.1} mm", card.mix.purge.count, card.mix.purge.filament_mm)?;
            writeln!(out, "Next: print {}, measure each swatch (id,srgb CSV), then gweave mix --fit measured.csv -o fitted.toml", output.display())
        })?;
    }
    Ok(ExitCode::SUCCESS)
}

/// `--fit measured.csv -o fitted.toml`.
pub fn fit_profile(
    profile: &MixProfile,
    profile_text: &str,
    csv: &Path,
    output: &Path,
    report: &ReportArgs,
) -> Result<ExitCode> {
    let measured = parse_csv(&read_text(csv)?).map_err(|e| match e {
        FitError::Csv { line, message } => anyhow!("{}:{line}: {message}", csv.display()),
        other => other.into(),
    })?;
    let start = profile.hardware.mixing_model()?;
    let fitted = fit(&start, &card_mixes(profile.hardware.inputs.len()), &measured)?;
    let text = fitted_profile_toml(profile_text, profile, &fitted.model)?;
    write_bytes(output, text.as_bytes())?;
    #[derive(serde::Serialize)]
    struct Row {
        id: u32,
        delta_e_before: f64,
        delta_e: f64,
    }
    #[derive(serde::Serialize)]
    struct FitReport {
        swatches: Vec<Row>,
        mean_delta_e: f64,
        max_delta_e: f64,
        colours: Vec<String>,
        strengths: Vec<f64>,
        tint_exponents: Vec<f64>,
    }
    let rows: Vec<Row> = fitted
        .delta_e
        .iter()
        .map(|&(id, before, after)| Row { id, delta_e_before: before, delta_e: after })
        .collect();
    let n = rows.len().max(1) as f64;
    let r = FitReport {
        mean_delta_e: rows.iter().map(|r| r.delta_e).sum::<f64>() / n,
        max_delta_e: rows.iter().map(|r| r.delta_e).fold(0.0, f64::max),
        colours: fitted.model.inputs().iter().map(|c| c.to_hex()).collect(),
        strengths: fitted.model.strengths().to_vec(),
        tint_exponents: fitted.model.tint_exponents().to_vec(),
        swatches: rows,
    };
    if report.emit(&r)? {
        print_summary(|out| {
            writeln!(out, "swatch  CIEDE2000 before -> fitted")?;
            for row in &r.swatches {
                writeln!(out, "  {:>3}   {:>6.2} -> {:.2}", row.id, row.delta_e_before, row.delta_e)?;
            }
            writeln!(out, "mean {:.2}, max {:.2}", r.mean_delta_e, r.max_delta_e)?;
            for (i, ((c, s), p)) in r.colours.iter().zip(&r.strengths).zip(&r.tint_exponents).enumerate() {
                writeln!(out, "E{i} {c} strength {s:.4} tint exponent {p:.3}")?;
            }
            writeln!(
                out,
                "Wrote {}: use it with -c (mix, --predict, preview --mix-profile).",
                output.display()
            )
        })?;
    }
    Ok(ExitCode::SUCCESS)
}
