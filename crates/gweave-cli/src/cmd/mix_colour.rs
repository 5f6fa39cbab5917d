//! `gweave mix`'s colour tools: `--predict`, `--calibration-card`, `--fit` (see `docs/mix.md`).

use std::process::ExitCode;

use anyhow::Result;
use gweave::colour::predict::{parse_ratios, predict, Prediction};
use gweave::post::mix::profile::MixProfile;

use crate::common::{print_summary, ReportArgs};

/// `--predict C:M:Y:W ...`: each mix's predicted colour, with the profile's filaments.
pub fn predict_all(profile: &MixProfile, mixes: &[String], report: &ReportArgs) -> Result<ExitCode> {
    let model = profile.hardware.mixing_model()?;
    let predictions =
        mixes.iter().map(|s| Ok(predict(&model, &parse_ratios(s)?)?)).collect::<Result<Vec<Prediction>>>()?;
    if report.emit(&predictions)? {
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
