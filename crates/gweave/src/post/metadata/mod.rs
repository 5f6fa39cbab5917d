//! Metadata that stays true after a transform, and the header that says who wrote the file.
//!
//! Slicers write what a file will cost into comments that hosts, printers and `gweave stats`
//! read back: the PrusaSlicer family (PrusaSlicer, SuperSlicer, OrcaSlicer) ends the file with
//! `; filament used [mm] = a, b`, `[cm3]`, `[g]`, `; total filament used [g]`, the cost and
//! `; estimated printing time (normal mode) = 1h 2m 3s` (and silent mode); Slic3r writes one
//! `; filament used = 607.8mm (1.5cm3)` per extruder; Cura heads the file with `;TIME:6666` and
//! `;Filament used: 1.2m`, its Griffin flavour with `;PRINT.TIME:` and
//! `;EXTRUDER_TRAIN.n.MATERIAL.VOLUME_USED:`, and marks each layer's end with `;TIME_ELAPSED:`.
//! Progress for the printer's display is `M73 P<percent> R<minutes left>` (normal mode) and
//! `M73 Q.. S..` (silent mode), as Prusa's firmware reads them.
//!
//! A transform that adds purges or changes feed rates makes every one of these false. The
//! [`MetadataPass`] rewrites them in a second streaming copy of the written file, from
//! [`Figures`] measured on that file (its filament by the `stats` count, its times by the
//! virtual printer's estimate: the caller, which can depend on the estimator, fills them in).
//! Lines it does not know are copied byte for byte; a file that carries no such line (a
//! generated one) gets a PrusaSlicer-style footer, so `stats` can compare. The copy looks only
//! at the lines that hold an `M` or an `m`, found by a vector search, and writes the bytes
//! between the lines it changes in large writes (`copy.rs`): it costs little more than copying
//! the file. What it writes for a line is `rewrite.rs`'s.
//!
//! It also writes the run's header, one comment line `; gweave 0.1.0 mix -c mix.toml
//! (generated)`, which [`earlier_runs`] finds again: running the same transform on its own
//! output would stack (shift the changes twice, purge twice), and the caller refuses it.

use std::io::{self, BufRead, Write};

use crate::stats::DEFAULT_FILAMENT_DIAMETER_MM;

mod copy;
mod rewrite;

/// The start of gweave's header line.
const HEADER_START: &str = "; gweave ";
/// The end of gweave's header line.
const HEADER_END: &str = " (generated)";
/// Lines searched for earlier runs' headers: a chain of runs, after Cura's Griffin header
/// (about 25 lines); and bytes, so that a huge first line is not read whole.
const HEADER_SEARCH_LINES: usize = 200;
const HEADER_SEARCH_BYTES: u64 = 256 * 1024;

/// The header line for a run of `command_line` (the command and the options that shape its
/// output, written from the job's options value).
pub fn header_line(command_line: &str) -> String {
    format!("{HEADER_START}{} {command_line}{HEADER_END}", env!("CARGO_PKG_VERSION"))
}

/// A run of gweave recorded in a file's header.
#[derive(Debug, Clone, PartialEq)]
pub struct EarlierRun {
    /// Its 1-based line.
    pub line: u64,
    /// What ran: `0.1.0 purge-shift a.gcode --purge 2.5 -o b.gcode`.
    pub text: String,
}

impl EarlierRun {
    /// Whether the run was of `command` (`mix`, `purge-shift`, `rotary wrap`).
    pub fn is(&self, command: &str) -> bool {
        // The version, then the command's words.
        self.text.split_once(' ').is_some_and(|(_, rest)| {
            rest.strip_prefix(command).is_some_and(|after| after.is_empty() || after.starts_with(' '))
        })
    }
}

/// The gweave runs recorded in the first lines of `input`.
pub fn earlier_runs(input: impl BufRead) -> io::Result<Vec<EarlierRun>> {
    let mut runs = Vec::new();
    for (i, line) in input.take(HEADER_SEARCH_BYTES).split(b'\n').take(HEADER_SEARCH_LINES).enumerate() {
        let line = line?;
        let text = String::from_utf8_lossy(&line);
        let text = text.trim_end_matches('\r');
        if let Some(run) = text.strip_prefix(HEADER_START).and_then(|t| t.strip_suffix(HEADER_END)) {
            runs.push(EarlierRun { line: i as u64 + 1, text: run.to_owned() });
        }
    }
    Ok(runs)
}

/// What the file as written prints and costs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Figures {
    /// Filament out of the nozzle per tool, mm (`stats`'s count).
    pub filament_mm: Vec<f64>,
    /// Filament diameter, mm (0: `stats`' default, 1.75 mm).
    pub diameter_mm: f64,
    /// The file's `filament_density` per tool, g/cm³ (the first for tools past the list).
    pub density_g_cm3: Vec<f64>,
    /// The file's `filament_cost` per tool, money per kg (the first for tools past the list).
    pub cost_per_kg: Vec<f64>,
    /// Estimated print time in normal and silent mode, s.
    pub time_s: [f64; 2],
    /// Estimated time of the first layer, normal and silent mode, s.
    pub first_layer_s: [f64; 2],
    /// The estimated elapsed time at each progress line (`M73`, `;TIME_ELAPSED:`), in file
    /// order, normal and silent mode, s.
    pub progress_s: Vec<[f64; 2]>,
}

impl Figures {
    fn area_mm2(&self) -> f64 {
        let d = if self.diameter_mm > 0.0 { self.diameter_mm } else { DEFAULT_FILAMENT_DIAMETER_MM };
        std::f64::consts::PI * d * d / 4.0
    }

    fn cm3(&self) -> Vec<f64> {
        self.filament_mm.iter().map(|mm| mm * self.area_mm2() / 1000.0).collect()
    }

    fn grams(&self) -> Vec<f64> {
        let per_tool = |list: &[f64], i: usize| list.get(i).or(list.first()).copied().unwrap_or(0.0);
        self.cm3().iter().enumerate().map(|(i, cm3)| cm3 * per_tool(&self.density_g_cm3, i)).collect()
    }

    fn cost(&self) -> f64 {
        let per_tool = |list: &[f64], i: usize| list.get(i).or(list.first()).copied().unwrap_or(0.0);
        self.grams().iter().enumerate().map(|(i, g)| g / 1000.0 * per_tool(&self.cost_per_kg, i)).sum()
    }
}

/// Reads the settings [`Figures`] needs from a comment (`; filament_density = 1.24, 1.27`).
pub fn read_setting(comment: &[u8], figures: &mut Figures) {
    let c = comment.trim_ascii();
    if let Some(v) = c.strip_prefix(b"filament_density =") {
        figures.density_g_cm3 = numbers(v);
    } else if let Some(v) = c.strip_prefix(b"filament_cost =") {
        figures.cost_per_kg = numbers(v);
    }
}

/// Whether the line (without its end) is a progress line whose time [`Figures::progress_s`]
/// holds: `M73` or Cura's `;TIME_ELAPSED:`.
pub fn is_progress_line(line: &[u8]) -> bool {
    let t = line.trim_ascii_start();
    t.get(..3).is_some_and(|c| c.eq_ignore_ascii_case(b"M73") && !t.get(3).is_some_and(u8::is_ascii_digit))
        || t.starts_with(b";TIME_ELAPSED:")
}

/// The second pass: the header first, then the file with its metadata rewritten from
/// [`Figures`], and a footer if it had none ([`MetadataPass::copy`]).
pub struct MetadataPass {
    figures: Figures,
    header: String,
    /// The header is written before the first line, or after Cura's Griffin header block or
    /// its `;FLAVOR:` line.
    header_written: bool,
    first_line: bool,
    /// The next entry of `figures.progress_s`.
    progress: usize,
    /// A filament line seen (else the footer is added).
    wrote_filament: bool,
    /// The next Slic3r `; filament used =` line's tool.
    slic3r_tool: usize,
    eol: Vec<u8>,
    /// The last line written has no line ending (the file's last line, unterminated): what is
    /// added after it starts a line of its own.
    open_line: bool,
    /// The copy is inside a line longer than [`MAX_LINE`](crate::gcode::reader::MAX_LINE),
    /// whose start it has copied as it is, as it copies the rest.
    long_line: bool,
}

impl MetadataPass {
    /// The pass writing `header` (a [`header_line`]) first and the metadata from `figures`.
    pub fn new(figures: Figures, header: String) -> Self {
        MetadataPass {
            figures,
            header,
            header_written: false,
            first_line: true,
            progress: 0,
            wrote_filament: false,
            slic3r_tool: 0,
            eol: b"\n".to_vec(),
            open_line: false,
            long_line: false,
        }
    }

    fn write_header(&mut self, out: &mut dyn Write) -> io::Result<()> {
        self.header_written = true;
        self.end_open_line(out)?;
        out.write_all(self.header.as_bytes())?;
        out.write_all(&self.eol)
    }

    /// Ends the last line written if it has no line ending, so that what follows is a line.
    fn end_open_line(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if std::mem::take(&mut self.open_line) {
            out.write_all(&self.eol)?;
        }
        Ok(())
    }
}

/// Whether [`MetadataPass`] would rewrite the whole line `line` (without its end) from the
/// figures: a progress line or one of the slicer's figures. A generator whose own lines never
/// are, and whose user snippets hold none, knows its figures without measuring its output
/// ([`write_footer`]).
pub fn needs_figures(line: &[u8]) -> bool {
    let mut pass =
        MetadataPass::new(Figures { progress_s: vec![[0.0; 2]], ..Figures::default() }, String::new());
    pass.rewrite(line).is_some()
}

/// The PrusaSlicer-style footer [`MetadataPass`] adds to a file without the slicer's figures,
/// each line ended by `eol`.
pub fn write_footer(f: &Figures, eol: &[u8], out: &mut dyn Write) -> io::Result<()> {
    // A file that extrudes nothing (an inkjet raster) used none.
    let list = |v: &[f64]| match v {
        [] => "0.00".to_owned(),
        v => v.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", "),
    };
    let eol = String::from_utf8_lossy(eol);
    write!(out, "; filament used [mm] = {}{eol}", list(&f.filament_mm))?;
    write!(out, "; filament used [cm3] = {}{eol}", list(&f.cm3()))?;
    write!(out, "; estimated printing time (normal mode) = {}{eol}", prusa_duration(f.time_s[0]))
}

/// A duration as PrusaSlicer writes it: `5h 31m 58s`, `7m 46s`, `1d 0h 0m 1s`.
pub(crate) fn prusa_duration(t_s: f64) -> String {
    let t = t_s.max(0.0).round() as u64;
    let (d, h, m, s) = (t / 86400, t / 3600 % 24, t / 60 % 60, t % 60);
    if d > 0 {
        format!("{d}d {h}h {m}m {s}s")
    } else if h > 0 {
        format!("{h}h {m}m {s}s")
    } else if m > 0 {
        format!("{m}m {s}s")
    } else {
        format!("{s}s")
    }
}

/// `1.24, 1.27` -> [1.24, 1.27] (an unreadable entry as 0).
fn numbers(v: &[u8]) -> Vec<f64> {
    String::from_utf8_lossy(v).split([',', ';']).map(|s| s.trim().parse().unwrap_or(0.0)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rewrite(text: &str, figures: Figures) -> String {
        let pass = MetadataPass::new(figures, header_line("mix a.gcode -o b.gcode"));
        let mut out = Vec::new();
        let path = std::path::Path::new("t.gcode");
        pass.copy(text.as_bytes(), path, path, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn figures() -> Figures {
        Figures {
            filament_mm: vec![1000.0, 250.5],
            diameter_mm: 1.75,
            density_g_cm3: vec![1.24],
            cost_per_kg: vec![20.0, 40.0],
            time_s: [3723.0, 4000.0],
            first_layer_s: [61.0, 70.0],
            progress_s: vec![[0.0, 0.0], [0.0, 0.0], [1861.5, 2000.0], [3723.0, 4000.0]],
        }
    }

    #[test]
    fn prusaslicer_figures_are_rewritten_and_the_rest_kept() {
        let text = "; generated by PrusaSlicer 2.7.0\r\nM73 P0 R0\r\nM73 Q0 S0\r\nG1 X1 E1 ; keep\r\nM73 P7 R9 ; half\r\nM73 P100 R0\r\n\
; filament used [mm] = 1.00, 2.00\r\n; filament used [cm3] = 0.00, 0.00\r\n; filament used [g] = 0.00, 0.00\r\n\
; total filament used [g] = 0.00\r\n; total filament cost = 0.00\r\n; estimated printing time (normal mode) = 1m 0s\r\n\
; estimated printing time (silent mode) = 1m 0s\r\n; estimated first layer printing time (normal mode) = 1s\r\n; filament_density = 1.24\r\n";
        let out = rewrite(text, figures());
        let area = std::f64::consts::PI * 1.75 * 1.75 / 4.0;
        let g0 = 1000.0 * area / 1000.0 * 1.24;
        let g1 = 250.5 * area / 1000.0 * 1.24;
        let expected = format!(
            "; gweave {} mix a.gcode -o b.gcode (generated)\r\n; generated by PrusaSlicer 2.7.0\r\nM73 P0 R62\r\nM73 Q0 S67\r\n\
G1 X1 E1 ; keep\r\nM73 P50 R31 ; half\r\nM73 P100 R0\r\n; filament used [mm] = 1000.00, 250.50\r\n\
; filament used [cm3] = {:.2}, {:.2}\r\n; filament used [g] = {g0:.2}, {g1:.2}\r\n; total filament used [g] = {:.2}\r\n\
; total filament cost = {:.2}\r\n; estimated printing time (normal mode) = 1h 2m 3s\r\n\
; estimated printing time (silent mode) = 1h 6m 40s\r\n; estimated first layer printing time (normal mode) = 1m 1s\r\n\
; filament_density = 1.24\r\n",
            env!("CARGO_PKG_VERSION"),
            area,
            250.5 * area / 1000.0,
            g0 + g1,
            g0 / 1000.0 * 20.0 + g1 / 1000.0 * 40.0,
        );
        assert_eq!(out, expected);
    }

    #[test]
    fn cura_and_slic3r_figures_are_rewritten() {
        let f = Figures { progress_s: vec![[12.25, 12.25]], ..figures() };
        let out = rewrite(";FLAVOR:Marlin\n;TIME:6666\n;Filament used: 0m\n;TIME_ELAPSED:1.0\n", f.clone());
        assert!(
            out.starts_with(";FLAVOR:Marlin\n; gweave ")
                && out.ends_with(";TIME:3723\n;Filament used: 1.00000m, 0.25050m\n;TIME_ELAPSED:12.250000\n"),
            "{out}"
        );
        let out = rewrite(
            "G1 X1\n; filament used = 607.8mm (1.5cm3)\n; filament used = 1.0mm (0.0cm3)\n",
            f.clone(),
        );
        assert!(
            out.ends_with("; filament used = 1000.0mm (2.4cm3)\n; filament used = 250.5mm (0.6cm3)\n"),
            "{out}"
        );
        // Griffin: the header stays on top, the gweave line follows it.
        let out = rewrite(";START_OF_HEADER\n;PRINT.TIME:1\n;EXTRUDER_TRAIN.1.MATERIAL.VOLUME_USED:0\n;END_OF_HEADER\nG1 X1\n", f);
        let header = header_line("mix a.gcode -o b.gcode");
        let volume = 250.5 * std::f64::consts::PI * 1.75 * 1.75 / 4.0;
        assert!(
            out.starts_with(&format!(";START_OF_HEADER\n;PRINT.TIME:3723\n;EXTRUDER_TRAIN.1.MATERIAL.VOLUME_USED:{volume:.0}\n;END_OF_HEADER\n{header}\nG1 X1\n")),
            "{out}"
        );
    }

    #[test]
    fn a_file_without_figures_gets_a_footer() {
        let out = rewrite("G1 X1 E1\n", Figures { filament_mm: vec![12.345], ..Default::default() });
        assert!(out.ends_with("G1 X1 E1\n; filament used [mm] = 12.35\n; filament used [cm3] = 0.03\n; estimated printing time (normal mode) = 0s\n"), "{out}");
        let out = rewrite("G1 X1\n", Figures::default());
        assert!(out.ends_with("G1 X1\n; filament used [mm] = 0.00\n; filament used [cm3] = 0.00\n; estimated printing time (normal mode) = 0s\n"), "{out}");
    }

    /// Regression: after a last line without a line ending the footer ran on in it
    /// (`;End of Gcode; filament used [mm] = ...`, a comment no host reads), and so did the
    /// header after a Griffin header block ending the file.
    #[test]
    fn what_follows_an_unterminated_last_line_starts_a_line() {
        let out =
            rewrite("G1 X1 E1\n;End of Gcode", Figures { filament_mm: vec![12.345], ..Default::default() });
        assert!(out.ends_with("\n;End of Gcode\n; filament used [mm] = 12.35\n; filament used [cm3] = 0.03\n; estimated printing time (normal mode) = 0s\n"), "{out}");
        let header = header_line("mix a.gcode -o b.gcode");
        let out = rewrite(";START_OF_HEADER\r\n;END_OF_HEADER", Figures::default());
        assert!(
            out.starts_with(&format!(";START_OF_HEADER\r\n;END_OF_HEADER\r\n{header}\r\n; filament used")),
            "{out}"
        );
    }

    #[test]
    fn earlier_runs_are_found_by_command() {
        let text = "; gweave 0.1.0 purge-shift a.gcode --purge 2 (generated)\n; gweave 0.1.0 mix a.gcode -o b.gcode (generated)\n; gweave mix: 2 mixes\n; gweave 0.1.0 rotary wrap p.gcode (generated)\n";
        let runs = earlier_runs(text.as_bytes()).unwrap();
        assert_eq!(runs.iter().map(|r| r.line).collect::<Vec<_>>(), [1, 2, 4]);
        assert!(
            runs[0].is("purge-shift") && !runs[0].is("mix") && runs[1].is("mix") && runs[2].is("rotary wrap")
        );
        assert!(!runs[2].is("rotary tube") && !runs[2].is("rotary wrapper"));
    }

    #[test]
    fn durations_as_prusaslicer_writes_them() {
        assert_eq!(prusa_duration(19918.0), "5h 31m 58s");
        assert_eq!(prusa_duration(466.0), "7m 46s");
        assert_eq!(prusa_duration(86401.0), "1d 0h 0m 1s");
        assert_eq!(prusa_duration(59.6), "1m 0s");
        assert!(
            is_progress_line(b"M73 P1 R2")
                && is_progress_line(b";TIME_ELAPSED:3")
                && !is_progress_line(b"M730")
        );
    }
}
