//! `gweave mix --wizard`: the mixing post-processor seed's questions (`docs/seeds.md`), asked on a terminal (plain line prompts, so
//! answers can be piped in), answered into a profile TOML for next time.
//!
//! The seed asked: one material or two (is the fourth input a second material?); for a
//! single-extruder file, each colour and the layer where it starts; for a multi-extruder file,
//! how many combinations and the colour of each slicer tool; for an unknown colour, its
//! proportions of cyan, magenta, yellow and the fourth input; with two materials, the proportion
//! of material 2 of each colour. We add the purge length and the Z feed cap, which the seed
//! hard-coded (25 mm, F200). An invalid answer is asked again; the end of input is an error.
//! Before anything is written the wizard shows what the profile will do (each mix with its
//! ratios and predicted colour, where it is used, the purge and the Z cap) and asks for a yes.

use std::io::{BufRead, Write};

use crate::colour::named_mixes::Palette;
use crate::gcode::state::MAX_TOOLS;

use super::profile::MixProfile;
use super::schedule::Plan;
use super::MixPassError;

struct Asker<'a> {
    input: &'a mut dyn BufRead,
    out: &'a mut dyn Write,
}

impl Asker<'_> {
    fn io(e: std::io::Error) -> MixPassError {
        MixPassError::Config(format!("wizard: {e}"))
    }

    /// One answer, trimmed; `default` when empty.
    fn ask(&mut self, question: &str, default: Option<&str>) -> Result<String, MixPassError> {
        match default {
            Some(d) => write!(self.out, "{question} [{d}]: "),
            None => write!(self.out, "{question}: "),
        }
        .and_then(|_| self.out.flush())
        .map_err(Self::io)?;
        let mut line = String::new();
        if self.input.read_line(&mut line).map_err(Self::io)? == 0 {
            return Err(MixPassError::Config("wizard: the answers ended early".into()));
        }
        let answer = line.trim();
        Ok(match (answer.is_empty(), default) {
            (true, Some(d)) => d.to_owned(),
            _ => answer.to_owned(),
        })
    }

    fn say(&mut self, text: &str) -> Result<(), MixPassError> {
        writeln!(self.out, "{text}").map_err(Self::io)
    }

    /// Asks until `parse` accepts the answer.
    fn ask_parsed<T>(
        &mut self,
        question: &str,
        default: Option<&str>,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<T, MixPassError> {
        loop {
            let a = self.ask(question, default)?;
            match parse(&a) {
                Some(v) => return Ok(v),
                None => self.say(&format!("  {a:?} is not a valid answer."))?,
            }
        }
    }

    fn yes(&mut self, question: &str) -> Result<bool, MixPassError> {
        self.ask_parsed(question, Some("n"), |a| match a.to_lowercase().as_str() {
            "y" | "yes" => Some(true),
            "n" | "no" => Some(false),
            _ => None,
        })
    }

    fn fraction(&mut self, question: &str) -> Result<f64, MixPassError> {
        self.ask_parsed(question, Some("0"), |a| a.parse::<f64>().ok().filter(|p| (0.0..=1.0).contains(p)))
    }
}

fn quote(s: &str) -> String {
    toml::Value::String(s.to_owned()).to_string()
}

/// Asks the questions on `input`/`out` and returns the profile as TOML text (already checked),
/// or `None` when the summary was not confirmed.
pub fn run_wizard(input: &mut dyn BufRead, out: &mut dyn Write) -> Result<Option<String>, MixPassError> {
    let mut a = Asker { input, out };
    let palette = Palette::seed();
    a.say("gweave mix wizard: inputs E0 cyan, E1 magenta, E2 yellow, E3 white/black or material 2.")?;
    let names: Vec<&str> = palette.entries().iter().map(|e| e.name.as_str()).collect();
    a.say(&format!("Palette: {}; or any #RRGGBB.", names.join(", ")))?;
    let by_layer = a.ask_parsed(
        "Is the file for 1 = one extruder (colours by layer) or 2 = several extruders (a colour per tool)?",
        Some("1"),
        |x| match x {
            "1" => Some(true),
            "2" => Some(false),
            _ => None,
        },
    )?;
    // Material 2's name, when E3 holds one: an answer for a colour too (all of E3, as `support`).
    let material2 = match a.yes("Does E3 hold a second material (e.g. PVA)? (y/n)")? {
        true => Some(a.ask("Name of material 2", Some("PVA"))?),
        false => None,
    };
    let mut mixes = String::new();
    let mut job = String::new();
    let mut inputs = String::new();
    if let Some(m) = &material2 {
        for (colour, material) in
            [("#00a0e0", "PLA"), ("#e0007a", "PLA"), ("#ffe000", "PLA"), ("#f0ecd8", m.as_str())]
        {
            inputs.push_str(&format!(
                "[[hardware.inputs]]\ncolour = \"{colour}\"\nmaterial = {}\n",
                quote(material)
            ));
        }
    }
    // One colour with its proportion of material 2 and, if unknown, its ratios.
    let colour =
        |a: &mut Asker, question: &str, mixes: &mut String| -> Result<Option<String>, MixPassError> {
            loop {
                let name = a.ask(question, None)?;
                if name.is_empty() {
                    return Ok(None);
                }
                let lower = name.to_lowercase();
                let all_material2 = ["support", "material2"].contains(&lower.as_str())
                    || material2.as_ref().is_some_and(|m| m.to_lowercase() == lower);
                let known = name.starts_with('#') || palette.get(&name).is_some() || all_material2;
                if name.starts_with('#') && crate::colour::Srgb8::parse_hex(&name).is_err() {
                    a.say("  A colour is #RRGGBB.")?;
                    continue;
                }
                if !known {
                    a.say(&format!("  {name:?} is not in the palette."))?;
                    if !a.yes("  Define it? (y/n)")? {
                        continue;
                    }
                    let ratios =
                        a.ask_parsed("  Proportions of cyan, magenta, yellow, E3 (4 numbers)", None, |x| {
                            let v: Vec<f64> = x
                                .split([' ', ','])
                                .filter(|s| !s.is_empty())
                                .filter_map(|s| s.parse().ok())
                                .collect();
                            (v.len() == 4 && v.iter().all(|r| *r >= 0.0) && v.iter().sum::<f64>() > 0.0)
                                .then_some(v)
                        })?;
                    let r: Vec<String> = ratios.iter().map(f64::to_string).collect();
                    mixes.push_str(&format!("[mix.{}]\nratios = [{}]\n", quote(&name), r.join(", ")));
                }
                let p = if material2.is_some() && !all_material2 {
                    a.fraction(&format!("  Proportion of material 2 in {name} (0-1)"))?
                } else {
                    0.0
                };
                return Ok(Some(if p > 0.0 { format!("{name}@{p}") } else { name }));
            }
        };
    if by_layer {
        let mut first = true;
        while let Some(c) = colour(&mut a, "Colour (empty when done)", &mut mixes)? {
            let layer: u32 = if first {
                a.ask_parsed(&format!("  Layer at which {c} starts"), Some("0"), |x| x.parse().ok())?
            } else {
                a.ask_parsed(&format!("  Layer at which {c} starts"), None, |x| x.parse().ok())?
            };
            first = false;
            job.push_str(&format!("[[schedule]]\nlayer = {layer}\nmix = {}\n", quote(&c)));
        }
    } else {
        let n: u32 =
            a.ask_parsed("How many slicer tools (T0, T1, ...) does the file use?", Some("2"), |x| {
                x.parse().ok().filter(|n| (1..=MAX_TOOLS).contains(n))
            })?;
        job.push_str("[map]\n");
        for t in 0..n {
            let c = loop {
                if let Some(c) =
                    colour(&mut a, &format!("Colour for T{t} ('support' = 100 % material 2)"), &mut mixes)?
                {
                    break c;
                }
            };
            job.push_str(&format!("T{t} = {}\n", quote(&c)));
        }
    }
    let purge: f64 =
        a.ask_parsed("Purge length at each change, mm of filament (0 = none)", Some("25"), |x| {
            x.parse().ok().filter(|v: &f64| *v >= 0.0)
        })?;
    let cap: f64 = a.ask_parsed("Largest Z feed rate, mm/min (0 = no cap)", Some("200"), |x| {
        x.parse().ok().filter(|v: &f64| *v >= 0.0)
    })?;
    let purge_table = if purge > 0.0 {
        format!("[purge]\nmode = \"length\"\nlength_mm = {purge:?}\n")
    } else {
        "[purge]\nmode = \"off\"\n".to_owned()
    };
    let text = format!(
        "# Written by gweave mix --wizard.\n[hardware]\n\
         # dialect: marlin | marlin-direct | reprapfirmware; unset, the G-code file's flavour decides.\n\
         {inputs}\n{purge_table}\n\
         [z_cap]\nmax_z_feed_mm_min = {cap:?}\n\n{mixes}\n{job}"
    );
    let profile = MixProfile::from_toml_str(&text)?;
    let plan = Plan::new(&profile)?;
    a.say(&summary(&profile, &plan))?;
    let confirmed =
        a.ask_parsed("Write this profile? (y/n)", Some("y"), |x| match x.to_lowercase().as_str() {
            "y" | "yes" => Some(true),
            "n" | "no" => Some(false),
            _ => None,
        })?;
    Ok(confirmed.then_some(text))
}

/// What the profile will do, in a few lines.
fn summary(profile: &MixProfile, plan: &Plan) -> String {
    let mut s = String::from("\nSummary:\n  inputs:");
    for (i, input) in profile.hardware.inputs.iter().enumerate() {
        s.push_str(&format!(" E{i} {} {}", input.material, input.colour));
    }
    s.push('\n');
    for m in &plan.mixes {
        let ratios: Vec<String> = m.mix.ratios().iter().map(|r| format!("{r:.2}")).collect();
        s.push_str(&format!("  {:<16} {}  predicted {}\n", m.label, ratios.join(":"), m.predicted));
    }
    for e in &profile.schedule {
        if let Some(layer) = e.layer {
            s.push_str(&format!("  from layer {layer}: {}\n", e.mix.label()));
        }
    }
    for (tool, mix) in &profile.map {
        s.push_str(&format!("  {tool}: {}\n", mix.label()));
    }
    let purge = match profile.purge.mode {
        super::profile::PurgeMode::Off => "no purge".to_owned(),
        _ => format!("purge {} mm at each change", profile.purge.length_mm),
    };
    let cap = match profile.z_cap.max_z_feed_mm_min {
        c if c > 0.0 => format!("Z at most F{c}"),
        _ => "no Z cap".to_owned(),
    };
    s.push_str(&format!("  {purge}; {cap}"));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wizard(answers: &str) -> Result<(String, String), MixPassError> {
        let mut out = Vec::new();
        let toml = run_wizard(&mut answers.as_bytes(), &mut out)?.expect("confirmed");
        Ok((toml, String::from_utf8(out).unwrap()))
    }

    #[test]
    fn a_summary_comes_before_the_confirmation() {
        let mut out = Vec::new();
        let declined = run_wizard(&mut "1\nn\nOrange\n0\n\n30\n\nn\n".as_bytes(), &mut out).unwrap();
        assert_eq!(declined, None);
        let said = String::from_utf8(out).unwrap();
        let summary = said.find("Summary:").unwrap();
        assert!(summary < said.find("Write this profile? (y/n) [y]:").unwrap(), "{said}");
        assert!(said.contains("  Orange           0.00:0.17:0.83:0.00  predicted #"), "{said}");
        assert!(
            said.contains("  from layer 0: Orange\n  purge 30 mm at each change; Z at most F200"),
            "{said}"
        );
    }

    #[test]
    fn the_seeds_single_extruder_session() {
        // Orange from 0, a new Pink from 10, Orange from 25, Blue from 75; default purge and cap.
        let answers = "1\nn\nOrange\n0\nPink\ny\n0 0.6 0.1 0.3\n10\nOrange\n25\nBlue\n75\n\n\n\ny\n";
        let (toml, said) = wizard(answers).unwrap();
        assert!(said.contains("\"Pink\" is not in the palette."));
        let p = MixProfile::from_toml_str(&toml).unwrap();
        let layers: Vec<(Option<u32>, String)> =
            p.schedule.iter().map(|s| (s.layer, s.mix.label())).collect();
        assert_eq!(
            layers,
            [
                (Some(0), "Orange".to_owned()),
                (Some(10), "Pink".to_owned()),
                (Some(25), "Orange".to_owned()),
                (Some(75), "Blue".to_owned())
            ]
        );
        assert_eq!((p.purge.length_mm, p.z_cap.max_z_feed_mm_min), (25.0, 200.0));
        let plan = Plan::new(&p).unwrap();
        assert_eq!(plan.mixes[1].units, [0, 6000, 1000, 3000]);
    }

    #[test]
    fn the_seeds_multi_material_session() {
        // Two tools, E3 holds PVA: the part Red with 10 % PVA, the support all PVA; no purge.
        let answers = "2\ny\nPVA\n2\nRed\n0.1\nsupport\n0\n150\n\n";
        let (toml, _) = wizard(answers).unwrap();
        let p = MixProfile::from_toml_str(&toml).unwrap();
        assert_eq!(p.map["T0"].label(), "Red@0.1");
        assert_eq!(p.map["T1"].label(), "support");
        assert_eq!(p.hardware.inputs[3].material, "PVA");
        assert_eq!(p.purge.mode, super::super::profile::PurgeMode::Off);
        assert_eq!(p.z_cap.max_z_feed_mm_min, 150.0);
        let plan = Plan::new(&p).unwrap();
        assert_eq!(plan.mixes[plan.for_tool(0).unwrap()].units, [0, 4500, 4500, 1000]);
    }

    #[test]
    fn the_wizard_takes_material_2s_name_as_a_colour_and_refuses_0_tools() {
        // It asked for material 2's name (PVA), then rejected "PVA" as a tool's colour, and it
        // accepted a file with 0 tools (a profile mapping nothing).
        let answers = "2\ny\nPVA\n0\n2\nRed\n0.1\nPVA\n0\n150\n\n";
        let (toml, said) = wizard(answers).unwrap();
        assert!(said.contains("\"0\" is not a valid answer."), "{said}");
        assert!(!said.contains("\"PVA\" is not in the palette."), "{said}");
        let p = MixProfile::from_toml_str(&toml).unwrap();
        assert_eq!(p.map["T1"].label(), "PVA");
        let plan = Plan::new(&p).unwrap();
        assert_eq!(plan.mixes[plan.for_tool(1).unwrap()].units, [0, 0, 0, 10000]);
    }

    #[test]
    fn bad_answers_are_asked_again_and_eof_is_an_error() {
        let (toml, said) = wizard("3\n1\nn\n#12345\n#ff0000\nx\n0\n\n\n\n\n").unwrap();
        assert!(said.contains("\"3\" is not a valid answer."));
        assert!(said.contains("A colour is #RRGGBB."));
        assert!(toml.contains("mix = \"#ff0000\""));
        assert!(wizard("1\nn\nOrange\n").is_err());
    }
}
