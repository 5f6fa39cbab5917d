//! `gweave check`: a lint for G-code before it reaches a printer. It reports what would go wrong
//! on a machine: bad checksums and line numbers, malformed or unknown commands, extrusion before
//! any hotend temperature, moves off the bed, absurd feed rates, and extrusion values that drift
//! in single-precision firmware, and (given the machine's table, [`WordRanges`]) number words
//! outside their command's physical range, which the printer refuses.

use std::io::Write;

use serde::Serialize;

use crate::bed::Bed;
use crate::error::{Error, Result};
use crate::firmware::Firmware;
use crate::gcode::arc::ArcRefusal;
use crate::gcode::diag::RefusedArc;
use crate::gcode::diag::{Diagnostic, Finding, Severity, WordOutOfRange};
use crate::gcode::effect::Motion;
use crate::gcode::ends::{missing_footer, read_ends, Footer};
use crate::gcode::flavour::flavour_of_comment;
use crate::gcode::layers::Feature;
use crate::gcode::line::{Block, Command, Value};
use crate::gcode::reader::{Part, RawLine};
use crate::gcode::state::{Effect, AXIS_LETTERS, E, MAX_TOOLS, X, Y, Z};
use crate::klipper_extruder::KlipperExtruder;
use crate::pass::{Ctx, Flow, Pass, PassError, Progress, Step, Strictness};
use crate::range::OutOfRange;
use crate::run::Run;

/// The physical range of each command's number words, as the machine that reads the file
/// declares them. The engine reads G-code for every firmware and keeps no such table: the
/// virtual printer's command registry has one (`gweave_sim::REGISTRY_RANGES`, the ranges its
/// `sim` refuses a line by and its `estimate` skips one by), and a caller that links both
/// (`gweave check`, Python's `gweave.check`) lends it to [`check_file_with`].
pub trait WordRanges: std::fmt::Debug + Sync {
    /// The first number word of the line in `block` (read from `line`; a line without a
    /// command is a move in the modal `motion`) outside its command's range.
    fn check(&self, block: &Block, line: &[u8], motion: Motion) -> Result<(), RefusedWord>;
}

/// A number word outside the range its command declares ([`WordRanges::check`]): which word,
/// so that the finding points at its column, and the refusal the printer replies with
/// (`G4 S = -1 is out of range: 0 to 86400 s`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{refusal}")]
pub struct RefusedWord {
    /// The word's letter (`b'S'`).
    pub letter: u8,
    /// The refusal, naming the command and the word (`G4 S`).
    pub refusal: OutOfRange,
}

/// Lint settings.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CheckOptions {
    /// The printable volume; `None` skips the bounds check.
    pub bed: Option<Bed>,
    /// Feed rates above this are absurd, mm/min (default 60 000 = 1 m/s).
    pub max_feed_mm_min: f64,
    /// Relative extrusion longer than this without `G92 E` drifts in float firmware, mm.
    pub max_relative_e_mm: f64,
    /// Absolute E beyond this loses resolution in single precision, mm.
    pub max_absolute_e_mm: f64,
    /// Marlin's `EXTRUDE_MAXLENGTH`, mm: it skips the E of a move feeding more (200 in its
    /// shipped configuration; 0: no limit).
    pub marlin_extrude_max_mm: f64,
    /// Klipper's `[extruder]` limits, for a file read for Klipper: its `max_extrude_only_distance`
    /// and `max_extrude_cross_section`, whose moves past them stop the print
    /// ([`KlipperExtruder`]). [`check_file`] takes the nozzle and filament the file's slicer
    /// settings state.
    pub klipper: KlipperExtruder,
    /// At most this many findings are kept (all are counted).
    pub max_findings: usize,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            bed: None,
            max_feed_mm_min: 60_000.0,
            max_relative_e_mm: 100_000.0,
            max_absolute_e_mm: 100_000.0,
            marlin_extrude_max_mm: 200.0,
            klipper: KlipperExtruder::default(),
            max_findings: 1000,
        }
    }
}

/// One finding at a line.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct LineFinding {
    /// The line number, from 1.
    pub line: u64,
    /// What was found and at which column.
    #[serde(flatten)]
    pub diagnostic: Diagnostic,
    /// How serious it is.
    pub severity: Severity,
}

/// Findings of one kind, shown as one line: a wipe tower off the bed is thousands of moves, a
/// file sent with the wrong checksums thousands of lines, and a user needs to read each once.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FindingGroup {
    /// The first finding of the kind.
    pub first: LineFinding,
    /// How many there are, the first included.
    pub count: u64,
    /// The line of the last one.
    pub last_line: u64,
    /// Moves off the bed: the lowest and highest position reached on the axis, mm.
    pub range_mm: Option<[f64; 2]>,
    /// Moves off the bed: the feature the slicer said they print (`wipe_tower`), if any.
    pub feature: Option<Feature>,
}

/// What makes two findings one kind: the finding, the axis or command it names, its severity
/// (an exponent a firmware misreads is an error, one it reads a warning), and for moves off the
/// bed the feature they print (a wipe tower apart from a skirt).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct GroupKey {
    kind: std::mem::Discriminant<Finding>,
    detail: String,
    severity: Severity,
    feature: Feature,
}

impl GroupKey {
    fn of(finding: &Finding, feature: Feature) -> Self {
        let (detail, feature) = match finding {
            Finding::OutsideBed { axis, .. } => (axis.to_string(), feature),
            Finding::UnknownCommand { command } => (command.clone(), Feature::Unknown),
            Finding::OutOfRange(w) => (w.word.clone(), Feature::Unknown),
            Finding::ArcRefused(arc) => {
                (format!("{:?}", std::mem::discriminant(&arc.refusal)), Feature::Unknown)
            }
            Finding::MalformedNumber { letter }
            | Finding::NotFinite { letter }
            | Finding::MissingValue { letter } => (letter.to_string(), Feature::Unknown),
            // Grouped by letter too: every `F` written `1e300` apart from `X`s written `1e-05`.
            Finding::ExponentNotation { word } => {
                (word.get(..1).unwrap_or_default().to_owned(), Feature::Unknown)
            }
            _ => (String::new(), Feature::Unknown),
        };
        GroupKey { kind: std::mem::discriminant(finding), detail, severity: finding.severity(), feature }
    }
}

/// The lint's result.
#[derive(Debug, Clone, Default, Serialize)]
pub struct CheckReport {
    /// Lines read.
    pub lines: u64,
    /// Error-level findings.
    pub errors: u64,
    /// Warning-level findings.
    pub warnings: u64,
    /// Every finding, in file order (the first [`CheckOptions::max_findings`]).
    pub findings: Vec<LineFinding>,
    /// The findings by kind, in the order each kind first appears (at most
    /// [`CheckOptions::max_findings`] kinds; all findings are counted).
    pub groups: Vec<FindingGroup>,
    /// The bed moves were held to, if any.
    pub bed: Option<Bed>,
    /// Where that bed came from: `given`, or the file's settings used (`bed_shape = ...`).
    pub bed_from: Option<String>,
}

impl CheckReport {
    /// The file has no error-level finding.
    pub fn passed(&self) -> bool {
        self.errors == 0
    }

    /// Whether the file fails the check: an error, or with `strict` a warning too.
    pub fn failed(&self, strict: bool) -> bool {
        self.errors > 0 || (strict && self.warnings > 0)
    }
}

/// The lint pass.
#[derive(Debug, Default)]
pub struct CheckPass {
    options: CheckOptions,
    /// What the lint found so far.
    pub report: CheckReport,
    last_line_number: Option<i64>,
    relative_e_since_reset_mm: f64,
    drift_reported: bool,
    cold_reported: bool,
    /// The file says it is for Ultimaker's Griffin firmware (Cura's `;FLAVOR:Griffin`).
    griffin: bool,
    /// Each kind's place in `report.groups`.
    group_of: std::collections::HashMap<GroupKey, usize>,
    /// The feature of the line being checked.
    feature: Feature,
    /// The machine's word ranges, if lent ([`CheckPass::with_ranges`]).
    ranges: Option<&'static dyn WordRanges>,
    /// The footer the file's ends lack, if it looks cut short ([`missing_footer`]): flagged at
    /// its last line.
    missing_footer: Option<Footer>,
}

impl CheckPass {
    /// The lint with `options`.
    pub fn new(options: CheckOptions) -> Self {
        let bed_from = options.bed.map(|_| "given".to_owned());
        let report = CheckReport { bed: options.bed, bed_from, ..Default::default() };
        CheckPass { options, report, ..Default::default() }
    }

    /// Also flags number words outside the ranges `ranges` declares.
    pub fn with_ranges(self, ranges: &'static dyn WordRanges) -> Self {
        CheckPass { ranges: Some(ranges), ..self }
    }

    /// A word of the line outside its command's range, on a line that is not already malformed
    /// (a malformed number is outside every range, and already an error). Whether it found one.
    fn check_ranges(&mut self, ctx: &Ctx<'_>) -> bool {
        let Some(ranges) = self.ranges else { return false };
        let block = ctx.block;
        if block.diagnostics.iter().any(|d| d.finding.severity() == Severity::Error) {
            return false;
        }
        let Err(RefusedWord { letter, refusal }) = ranges.check(block, ctx.line.bytes, ctx.state.motion)
        else {
            return false;
        };
        let column = column_of(block, letter);
        let OutOfRange { name: word, value, range } = refusal;
        let finding = Finding::OutOfRange(Box::new(WordOutOfRange { word, value, range }));
        self.add(ctx.line.number, Diagnostic::at(column, finding));
        true
    }

    fn add(&mut self, line: u64, diagnostic: Diagnostic) {
        let severity = diagnostic.finding.severity();
        match severity {
            Severity::Error => self.report.errors += 1,
            Severity::Warning => self.report.warnings += 1,
        }
        let key = GroupKey::of(&diagnostic.finding, self.feature);
        let value_mm = match diagnostic.finding {
            Finding::OutsideBed { value_mm, .. } => Some(value_mm),
            _ => None,
        };
        let finding = LineFinding { line, diagnostic, severity };
        match self.group_of.get(&key) {
            Some(&i) => {
                let g = &mut self.report.groups[i];
                g.count += 1;
                g.last_line = line;
                if let (Some([lo, hi]), Some(v)) = (&mut g.range_mm, value_mm) {
                    (*lo, *hi) = (lo.min(v), hi.max(v));
                }
            }
            None if self.report.groups.len() < self.options.max_findings => {
                self.group_of.insert(key.clone(), self.report.groups.len());
                self.report.groups.push(FindingGroup {
                    first: finding.clone(),
                    count: 1,
                    last_line: line,
                    range_mm: value_mm.map(|v| [v, v]),
                    feature: value_mm.and(Some(key.feature)).filter(|f| *f != Feature::Unknown),
                });
            }
            None => {}
        }
        if self.report.findings.len() < self.options.max_findings {
            self.report.findings.push(finding);
        }
    }
}

impl Pass for CheckPass {
    fn long_line(&mut self, piece: &RawLine<'_>, _out: &mut dyn Write) -> Result<(), PassError> {
        if let Part::Last { len } = piece.part {
            self.report.lines = piece.number;
            self.add(piece.number, Diagnostic::at(0, Finding::LineTooLong { len }));
        }
        Ok(())
    }

    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let n = ctx.line.number;
        self.report.lines = n;
        self.feature = ctx.state.structure.feature;
        let block = ctx.block;
        for d in &block.diagnostics {
            self.add(n, d.clone());
        }
        if let Some((num, span)) = block.line_number {
            if let Some(last) = self.last_line_number {
                let is_reset = block.command.is_m(110);
                if !is_reset && num != last + 1 {
                    self.add(
                        n,
                        Diagnostic::at(
                            span.start as usize,
                            Finding::LineNumberSequence { expected: last + 1, found: num },
                        ),
                    );
                }
            }
            self.last_line_number =
                Some(if block.command.is_m(110) { block.get(b'N').map_or(num, |v| v as i64) } else { num });
        }
        if let Some(flavour) = block.comment_text(ctx.line.bytes).and_then(flavour_of_comment) {
            self.griffin = flavour.eq_ignore_ascii_case(b"Griffin");
        }
        // A name such as `PRINT_START` is a Klipper macro or a RepRapFirmware meta command; a
        // Marlin board (the firmware a file that names no other is read for) knows none, and
        // `sim` calls it an unknown command: so does the lint.
        if block.command == Command::Extended && ctx.state.options().firmware == Firmware::Marlin {
            let command = String::from_utf8_lossy(block.command_span.of(ctx.line.bytes)).into_owned();
            self.add(
                n,
                Diagnostic::at(block.command_span.start as usize, Finding::UnknownCommand { command }),
            );
        }
        if let Command::Code { letter, number, .. } = block.command {
            if !(is_known(letter, number) || self.griffin && is_griffin(letter, number)) {
                let command =
                    String::from_utf8_lossy(block.command_span.of(ctx.line.bytes)).to_ascii_uppercase();
                self.add(
                    n,
                    Diagnostic::at(block.command_span.start as usize, Finding::UnknownCommand { command }),
                );
            }
            if letter == b'T' && number >= MAX_TOOLS {
                let at = block.command_span.start as usize;
                let command = String::from_utf8_lossy(block.command_span.of(ctx.line.bytes))
                    .to_ascii_uppercase()
                    .into();
                self.add(n, Diagnostic::at(at, Finding::ToolOutOfRange { command }));
            }
        }
        if let Some(w) = block.word(b'F') {
            if let Value::Number(f) = w.value {
                if f <= 0.0 || f > self.options.max_feed_mm_min {
                    self.add(
                        n,
                        Diagnostic::at(
                            w.span.start as usize,
                            Finding::AbsurdFeedRate { feed_mm_min: round3(f) },
                        ),
                    );
                }
            }
        }
        if let (true, Some(footer)) = (ctx.line.eol.is_empty(), self.missing_footer) {
            // Where the text stops: just past the last line's last byte.
            self.add(n, Diagnostic::at(ctx.line.bytes.len(), Finding::NoFooter { footer }));
        }
        if self.check_ranges(ctx) {
            // The printer refuses the whole line: it does not move, so what the move would
            // have done (off the bed, too much filament) is not found as well.
            return Ok(Flow::Continue);
        }
        // The effect by reference: a copy of the move (its two positions and its path, read
        // back just after the state wrote them) made `check` a fifth slower on bench/data's
        // file, for the same instruction count (0.81 s against 0.665).
        match ctx.effect {
            Effect::Move(m) => {
                let e = m.e_mm();
                if e > 0.0 && !ctx.state.thermal.hotend_set && !self.cold_reported {
                    self.cold_reported = true;
                    let col = column_of(block, b'E');
                    self.add(n, Diagnostic::at(col, Finding::ExtrusionBeforeHeating));
                }
                if let Some(bed) = self.options.bed {
                    let reach = m.reach();
                    for axis in [X, Y, Z] {
                        let [lo, hi] = reach[axis];
                        let v = if bed.contains(axis, lo) { hi } else { lo };
                        if !bed.contains(axis, v) {
                            let letter = AXIS_LETTERS[axis];
                            let col = column_of(block, letter);
                            self.add(
                                n,
                                Diagnostic::at(
                                    col,
                                    Finding::OutsideBed { axis: letter as char, value_mm: round3(v) },
                                ),
                            );
                        }
                    }
                }
                if let Some(limit) = self.extrusion_limit(ctx.state.options().firmware, e, m) {
                    self.add(n, Diagnostic::at(column_of(block, b'E'), limit));
                }
                if ctx.state.relative_e() {
                    self.relative_e_since_reset_mm += e.abs();
                    if self.relative_e_since_reset_mm > self.options.max_relative_e_mm && !self.drift_reported
                    {
                        self.drift_reported = true;
                        self.add(
                            n,
                            Diagnostic::at(
                                0,
                                Finding::RelativeEDrift {
                                    since_reset_mm: round3(self.relative_e_since_reset_mm),
                                },
                            ),
                        );
                    }
                } else if m.to[E].abs() > self.options.max_absolute_e_mm && !self.drift_reported {
                    self.drift_reported = true;
                    self.add(n, Diagnostic::at(0, Finding::AbsoluteEPrecision { e_mm: round3(m.to[E]) }));
                }
            }
            Effect::ArcRefused(refusal) => {
                let firmware = ctx.state.options().firmware;
                // At the R word when the radius is the cause, else at the command.
                let col = match refusal {
                    ArcRefusal::NoCentre | ArcRefusal::Relative => block.command_span.start as usize,
                    _ => column_of(block, b'R'),
                };
                let arc = RefusedArc { firmware, refusal: *refusal };
                self.add(n, Diagnostic::at(col, Finding::ArcRefused(Box::new(arc))));
            }
            Effect::SetPosition if block.has(b'E') => {
                self.relative_e_since_reset_mm = 0.0;
                self.drift_reported = false;
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }
}

impl CheckPass {
    /// The firmware's limit on the filament one move feeds, if `m` passes it: Marlin's
    /// `PREVENT_LENGTHY_EXTRUDE` (`Marlin/src/module/planner.cpp`: the E part is dropped with
    /// `echo: too long extrusion prevented`), Klipper's extruder checks, which stop the print
    /// ([`KlipperExtruder::refusal`]). One comparison for every other Marlin move, whose
    /// filament `e` (mm) the caller has read.
    #[inline]
    fn extrusion_limit(&self, firmware: Firmware, e: f64, m: &crate::gcode::effect::Move) -> Option<Finding> {
        match firmware {
            Firmware::Marlin => {
                let max_mm = self.options.marlin_extrude_max_mm;
                (max_mm > 0.0 && e.abs() > max_mm).then(|| Finding::LongExtrusion {
                    firmware,
                    e_mm: round3(e),
                    max_mm: max_mm as f32,
                })
            }
            Firmware::Klipper => self.options.klipper.refusal(e, m),
            Firmware::RepRapFirmware | Firmware::LinuxCnc => None,
        }
    }
}

/// Where the word `letter` starts in the line, for a finding about it (0, the line, without one).
fn column_of(block: &Block, letter: u8) -> usize {
    block.word(letter).map_or(0, |w| w.span.start as usize)
}

/// A figure as the finding shows it, to the micrometre (JSON keeps it a number).
pub(crate) fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Checks the file at `path`, reading past malformed lines (each is a finding). Without a bed
/// in `options`, the bed the slicer's settings in the file describe is used, if they give one
/// ([`Bed::from_file`]).
pub fn check_file(
    path: &std::path::Path,
    options: CheckOptions,
    progress: &mut dyn Progress,
) -> Result<CheckReport> {
    check_file_with(path, options, None, progress)
}

/// [`check_file`], with number words also held to the machine's `ranges` if given.
pub fn check_file_with(
    path: &std::path::Path,
    mut options: CheckOptions,
    ranges: Option<&'static dyn WordRanges>,
    progress: &mut dyn Progress,
) -> Result<CheckReport> {
    let mut from_file = None;
    let ends = read_ends(path).map_err(|e| Error::io(path, e))?;
    // Read as text once for every setting looked up (a lossy read of the file's ends is some
    // 2 million instructions: 75 a line of the guard's 30 000).
    let ends_text = String::from_utf8_lossy(&ends);
    options.klipper = options.klipper.from_settings(&ends_text);
    if options.bed.is_none() {
        if let Some(found) = Bed::from_settings(&ends_text) {
            options.bed = Some(found.bed);
            from_file = Some(found.from.join(", "));
        }
    }
    let mut pass = CheckPass { missing_footer: missing_footer(&ends), ..CheckPass::new(options) };
    if let Some(ranges) = ranges {
        pass = pass.with_ranges(ranges);
    }
    Run::file(path).progress(progress).strictness(Strictness::Lenient).scan(&mut pass)?;
    if from_file.is_some() {
        pass.report.bed_from = from_file;
    }
    Ok(pass.report)
}

/// Whether a G/M/T code is one that some mainstream firmware (Marlin, RepRapFirmware, Klipper,
/// Prusa) understands.
pub(crate) fn is_known(letter: u8, number: u32) -> bool {
    match letter {
        b'T' | b'D' => true,
        b'G' => {
            matches!(number, 0..=6 | 10..=12 | 17..=21 | 26..=35 | 38 | 53..=61 | 68 | 69 | 75 | 76 | 80 | 90..=94)
        }
        b'M' => matches!(
            number,
            0..=5 | 7..=10 | 16..=49 | 73 | 75..=92 | 98..=129 | 140..=155 | 163..=166 | 190..=193
                | 200..=221 | 226 | 232 | 240 | 250..=252 | 260..=261 | 280..=292 | 300..=309
                | 350..=351 | 355 | 360..=361 | 380..=381 | 400..=431 | 450..=456 | 470..=472 | 486
                | 500..=505 | 510..=512 | 524 | 540 | 550..=599 | 600..=609 | 650..=674 | 700..=703
                | 710 | 851 | 862 | 868 | 869 | 871 | 876 | 900..=918 | 928 | 929 | 950..=958 | 997..=999
        ),
        _ => false,
    }
}

/// Codes only Ultimaker's Griffin firmware has: `G280` primes the nozzle (Cura writes it at
/// the start and after each tool's first use on Ultimaker 3 and S-series printers).
fn is_griffin(letter: u8, number: u32) -> bool {
    letter == b'G' && number == 280
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pass::{drive_reader, Reading, Strictness};
    use std::io;
    use std::path::Path;

    fn findings(text: &str) -> Vec<(u64, String)> {
        findings_with(text, CheckOptions::default())
    }

    fn findings_with(text: &str, options: CheckOptions) -> Vec<(u64, String)> {
        checked(text, options).findings.iter().map(|f| (f.line, f.diagnostic.finding.to_string())).collect()
    }

    /// The report of `text` checked with `options`, read leniently.
    fn checked(text: &str, options: CheckOptions) -> CheckReport {
        let mut pass = CheckPass::new(options);
        let reading = Reading { strictness: Strictness::Lenient, ..Reading::new(Path::new("t.gcode")) };
        drive_reader(text.as_bytes(), reading, &mut pass, &mut io::sink()).unwrap();
        pass.report
    }

    /// A machine's table that refuses every `S` word, under a name that does not end with it.
    #[derive(Debug)]
    struct RefusesS;

    impl WordRanges for RefusesS {
        fn check(&self, block: &Block, _: &[u8], _: Motion) -> std::result::Result<(), RefusedWord> {
            match block.get(b'S') {
                Some(v) => Err(RefusedWord {
                    letter: b'S',
                    refusal: OutOfRange {
                        name: "the period".into(),
                        value: v.to_string(),
                        range: "0 to 1 s".into(),
                    },
                }),
                None => Ok(()),
            }
        }
    }

    /// Regression (check_ranges_letter_from_message): the finding's column is the refused word's,
    /// carried as its letter, not read back from the end of the refusal's text.
    #[test]
    fn a_refused_word_is_found_at_its_column_whatever_the_refusal_says() {
        let mut pass = CheckPass::new(CheckOptions::default()).with_ranges(&RefusesS);
        let reading = Reading { strictness: Strictness::Lenient, ..Reading::new(Path::new("t.gcode")) };
        drive_reader(&b"G4 P1 S5\nG4 P1\n"[..], reading, &mut pass, &mut io::sink()).unwrap();
        let found: Vec<(u64, u32, String)> = pass
            .report
            .findings
            .iter()
            .map(|f| (f.line, f.diagnostic.column, f.diagnostic.finding.to_string()))
            .collect();
        assert_eq!(
            found,
            [(1, 7, "the period = 5 is out of range: 0 to 1 s (the printer refuses the line)".to_owned())]
        );
    }

    /// Regression (a new user's trial: `G1 X1e11` was both out of range and "outside the bed"):
    /// a line the printer refuses does not move, so its move is not also found off the bed;
    /// the next line's move is.
    #[test]
    fn a_refused_line_is_not_also_found_off_the_bed() {
        let bed = Bed::new([0.0, 0.0], [200.0, 200.0], Some(200.0)).unwrap();
        let mut pass =
            CheckPass::new(CheckOptions { bed: Some(bed), ..CheckOptions::default() }).with_ranges(&RefusesS);
        let reading = Reading { strictness: Strictness::Lenient, ..Reading::new(Path::new("t.gcode")) };
        drive_reader(&b"G1 X300 S5\nG1 X310\n"[..], reading, &mut pass, &mut io::sink()).unwrap();
        let found: Vec<(u64, String)> =
            pass.report.findings.iter().map(|f| (f.line, f.diagnostic.finding.to_string())).collect();
        assert_eq!(
            found,
            [
                (1, "the period = 5 is out of range: 0 to 1 s (the printer refuses the line)".to_owned()),
                (2, "move outside the bed: X=310.000 mm".to_owned())
            ]
        );
    }

    /// The findings of `text` read for `firmware`: line, column, severity, text.
    fn findings_for(text: &str, firmware: Firmware) -> Vec<(u64, u32, Severity, String)> {
        findings_for_with(text, firmware, CheckOptions::default())
    }

    fn findings_for_with(
        text: &str,
        firmware: Firmware,
        options: CheckOptions,
    ) -> Vec<(u64, u32, Severity, String)> {
        let mut pass = CheckPass::new(options);
        let options = crate::StateOptions { firmware, ..Default::default() };
        let reading = Reading { options, ..Reading::new(Path::new("t.gcode")) };
        drive_reader(text.as_bytes(), reading, &mut pass, &mut io::sink()).unwrap();
        let found = pass.report.findings.iter();
        found.map(|f| (f.line, f.diagnostic.column, f.severity, f.diagnostic.finding.to_string())).collect()
    }

    /// Regression (a G2/G3 its firmware refuses passed `check`, and moved in a straight line):
    /// an error at the R word when the radius is the cause, else at the command, in the words
    /// of the firmware the file is read for.
    #[test]
    fn an_arc_the_firmware_refuses_is_an_error_where_its_cause_is() {
        // Numbered, as a host sends it: the command is not the line's start.
        let text = "G1 X0 Y0\nN2 G2 X10 Y0\nG2 X10 Y0 R4\nG3 X0 Y0 R-5\n";
        let read_as = |firmware: Firmware| {
            let found = findings_for(text, firmware);
            assert!(found.iter().all(|f| f.2 == Severity::Error), "{found:?}");
            found.into_iter().map(|(line, column, _, text)| (line, column, text)).collect::<Vec<_>>()
        };
        let no_centre =
            "refuses this arc, and the machine does not move: an arc needs R or a non-zero I or J";
        assert_eq!(read_as(Firmware::Marlin), [(2, 4, format!("marlin {no_centre}"))]);
        assert_eq!(
            read_as(Firmware::RepRapFirmware),
            [
                (2, 4, format!("reprapfirmware {no_centre}")),
                (
                    3,
                    11,
                    "reprapfirmware refuses this arc, and the machine does not move: R4.0000 cannot reach \
                     an end point 10.0000 mm away (half of it is 5.0000 mm)"
                        .to_owned()
                ),
                // Line 3 did not move, so line 4 ends where it starts.
                (
                    4,
                    10,
                    "reprapfirmware refuses this arc, and the machine does not move: an R arc must end \
                     elsewhere than it starts"
                        .to_owned()
                )
            ]
        );
        let klipper = read_as(Firmware::Klipper);
        assert_eq!(klipper.len(), 3);
        assert_eq!(
            klipper[2],
            (4, 10, "klipper refuses this arc, and the machine does not move: arcs are read by I and J only, not R".into())
        );
    }

    /// Regression (one move feeding 1 000 000 mm of filament passed `check`, while `sim` runs
    /// it without its E as Marlin does): each firmware's limit on one move's filament, at the
    /// E word. Marlin drops the E past 200 mm (a warning); Klipper stops the print on an
    /// extrude-only move or a retraction past 50 mm (an error), and on a printing move by its
    /// bead's cross-section (`a_bead_wider_than_klipper_takes_is_found_at_its_e`).
    #[test]
    fn a_move_feeding_more_than_the_firmware_takes_is_found_at_its_e() {
        let text = "M104 S200\nM83\nG1 X10 Y10 E60\nG1 E150\nG1 X20 E250\nG1 E-60\n";
        let read_as = |firmware: Firmware| findings_for(text, firmware);
        assert_eq!(
            read_as(Firmware::Marlin),
            [(
                5,
                8,
                Severity::Warning,
                "a move feeding 250.000 mm of filament: marlin skips the E of a move past 200 mm ('too long \
                 extrusion prevented', its EXTRUDE_MAXLENGTH)"
                    .to_owned()
            )]
        );
        let klipper = read_as(Firmware::Klipper);
        let lines: Vec<(u64, Severity)> = klipper.iter().map(|f| (f.0, f.2)).collect();
        // Lines 3 and 5 print blobs: 60 mm of filament over 14 mm, 250 over 10.
        assert_eq!(lines, [3, 4, 5, 6].map(|n| (n, Severity::Error)));
        assert!(klipper[0].3.starts_with("a move extruding a 10.205 mm² bead"), "{}", klipper[0].3);
        assert_eq!(
            klipper[1].3,
            "an extrude-only move of 150.000 mm: klipper stops the print past 50 mm ('Extrude only move too \
             long', its max_extrude_only_distance)"
        );
        assert!(read_as(Firmware::RepRapFirmware).is_empty());
    }

    /// Regression (`check` passed the printing moves Klipper stops a print at, "Move exceeds
    /// maximum extrusion": a purge pushed over a few millimetres, a wipe tower's ramming): a
    /// bead wider than `max_extrude_cross_section` (4 x 0.4² = 0.64 mm² by default) is an
    /// error at its E word; a normal line, a tiny dab and a cross-section the printer raised
    /// pass.
    #[test]
    fn a_bead_wider_than_klipper_takes_is_found_at_its_e() {
        let text = "M104 S200\nM83\nG1 X10 E0.4\nG1 X12 E3\nG1 X12.1 E0.1\n";
        let found = findings_for(text, Firmware::Klipper);
        assert_eq!(
            found,
            [(
                4,
                8,
                Severity::Error,
                "a move extruding a 3.608 mm² bead: klipper stops the print past 0.640 mm² ('Move exceeds \
                 maximum extrusion', its max_extrude_cross_section: 4 x nozzle_diameter² unless set)"
                    .to_owned()
            )]
        );
        assert!(findings_for(text, Firmware::Marlin).is_empty());
        let raised = KlipperExtruder { max_extrude_cross_section_mm2: 5.0, ..KlipperExtruder::default() };
        let options = CheckOptions { klipper: raised, ..CheckOptions::default() };
        assert!(findings_for_with(text, Firmware::Klipper, options).is_empty());
    }

    #[test]
    fn g280_is_known_only_to_griffin_files() {
        let found = findings(";FLAVOR:Marlin\nG280\nG281\n");
        assert_eq!(found, [(2, "unknown command G280".into()), (3, "unknown command G281".into())]);
        let found = findings(";FLAVOR:Griffin\nG280\nG281\n");
        assert_eq!(found, [(3, "unknown command G281".to_string())]);
    }

    /// A wipe tower off a 200 mm bed printed 40 364 warnings, one per move, 1 000 of them line
    /// by line: they are one group, with the range the tower reaches and where it is.
    #[test]
    fn a_wipe_tower_off_the_bed_is_one_finding_group_not_a_flood() {
        let mut text = String::from("M104 S200\n;TYPE:Perimeter\nG1 X10 Y10 E1\n;TYPE:Wipe tower\n");
        for i in 0..2000 {
            text.push_str(&format!("G1 X{} Y20 E{}\n", 180 + i % 70, 2 + i));
        }
        text.push_str(";TYPE:Skirt/Brim\nG1 X230 Y5 E2002\nG1 X231 Y5 E2003\nG13\nG13\n");
        let options = CheckOptions { bed: Some("200,200,200".parse().unwrap()), ..Default::default() };
        let report = checked(&text, options);
        let groups: Vec<_> = report
            .groups
            .iter()
            .map(|g| (g.first.line, g.count, g.last_line, g.range_mm, g.feature))
            .collect();
        assert_eq!(
            groups,
            [
                // X 200 is on the bed's edge: X 201 .. 249 are off it, 49 of every 70 moves.
                (26, 1391, 2004, Some([201.0, 249.0]), Some(Feature::WipeTower)),
                (2006, 2, 2007, Some([230.0, 231.0]), Some(Feature::Skirt)),
                (2008, 2, 2009, None, None),
            ]
        );
        assert_eq!(report.warnings, 1395);
        assert_eq!(report.findings.len(), 1000);
    }

    /// Exponents group by letter and severity: `F1e300` (a template's `printf`, read as `F1
    /// E300`: an error) apart from `F2E3` (a warning), and both apart from `X`s. The severity
    /// is part of the group's key, not spelled into its text.
    #[test]
    fn exponents_group_by_letter_and_severity() {
        let text = "M104 S200\nG1 F1e300\nG1 F2E3\nG1 F1e200\nG1 X1e2\nG1 F3E1\n";
        let groups: Vec<_> = checked(text, CheckOptions::default())
            .groups
            .iter()
            .map(|g| (g.first.line, g.count, g.first.diagnostic.finding.severity()))
            .collect();
        // And a group of its own: `F1e300`'s `E300`, then `F2E3`'s `E3` (297 mm back), feed more
        // than Marlin takes in one move.
        assert_eq!(
            groups,
            [
                (2, 2, Severity::Error),
                (2, 2, Severity::Warning),
                (3, 2, Severity::Warning),
                (5, 1, Severity::Error)
            ]
        );
    }

    /// An arc whose ends are on the bed but whose bulge is not.
    #[test]
    fn arcs_leave_the_bed_between_their_ends() {
        let options = CheckOptions { bed: Some("100,100,100".parse().unwrap()), ..Default::default() };
        let text = "M104 S200\nG1 X5 Y2 F600\nG2 X15 Y2 I5 J0 E1\nG3 X5 Y2 I-5 J0 E2\nG3 X15 Y2 I5 J0 E3\n";
        let found = findings_with(text, options);
        assert_eq!(found, [(5, "move outside the bed: Y=-3.000 mm".to_string())]);
    }

    /// A tool number past what anything has is an error, and the machine state keeps the tool
    /// it had (a huge `T` once made the per-tool tables of `stats` ask for 32 GB). The finding
    /// quotes the command as written (regression, a new user's trial: `T99999999999999999999`
    /// was quoted as `T4294967295`, the saturated number).
    #[test]
    fn tools_out_of_range() {
        let found = findings("M104 S200\nT255\nT256\nT4294967295\nt99999999999999999999\n");
        let message = |t: &str| format!("{t} names no tool (at most 256 are read; the tool stays as it was)");
        assert_eq!(
            found,
            [(3, message("T256")), (4, message("T4294967295")), (5, message("T99999999999999999999"))]
        );
        let mut pass = crate::stats::StatsPass::new(None);
        let text = "T2\nG1 X1 E1 F600\nT4294967295\nG1 X2 E2\n";
        let state =
            drive_reader(text.as_bytes(), Reading::new(Path::new("t.gcode")), &mut pass, &mut io::sink())
                .unwrap();
        assert_eq!(state.tool, 2);
        let stats = pass.into_stats(&state);
        assert_eq!(stats.filament.iter().map(|f| f.extruded_mm).collect::<Vec<_>>(), [0.0, 0.0, 2.0]);
    }
}
