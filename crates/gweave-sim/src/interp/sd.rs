//! The virtual SD card: a folder on the host computer, read and written with Marlin's SD
//! commands (`Marlin/src/gcode/sd/`, `Marlin/src/sd/cardreader.cpp`).
//!
//! Files are listed by their 8.3 DOS name, as the FAT card shows them to Marlin: a name that
//! fits 8.3 is its upper-case self (`PART.GCO`), a longer one gets the Windows short form
//! `FIXTUR~1.GCO` (numbered in name order) and keeps its long name for `M20 L` and `M33`. Only
//! files whose DOS extension starts with `G` are G-code to Marlin and listed.
//!
//! Printing from the card (`M23` then `M24`) runs the file's lines on the same machine and clock
//! as the host's commands, one line per [`Machine::sd_step`], without `ok`s; `gweave serve` runs
//! those steps while the host is quiet. `M27` reports `SD printing byte <pos>/<size>`, `M27 S<n>`
//! every n seconds; the end prints `Done printing file`. An upload (`M28 <name>` ... `M29`)
//! writes every following line, checked by the serial protocol as usual, into the file.
//!
//! The folder is on the host's file system, where a name can be a symbolic link to anywhere
//! (`LINK.GCO -> ../outside/victim.gco`), made by whoever can write the folder. A FAT card has
//! no links, and the board reaches nothing outside its card, so the card never follows one:
//! a link is not listed, not selected, not deleted and not written ([`open_to_read`],
//! [`create`]), even if it appears between the listing and the open.
//!
//! Each SD command has its own row in the registry (`commands::COMMANDS`: codes, help, gating,
//! ranges) and its own handler here (`m20` ... `m928`).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufRead, BufReader, Seek, SeekFrom, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Component, Path, PathBuf};

use super::commands::Call;
use super::pause::PromptReason;
use super::Machine;

/// The longest line read from a file on the card, bytes: Marlin's `MAX_CMD_SIZE` buffer is
/// smaller; a longer line (not G-code) is skipped past without holding it in memory.
const MAX_SD_LINE: usize = 256;

/// One file as the card lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Entry {
    /// The 8.3 name, upper case.
    dos: String,
    /// The name in the folder.
    long: String,
    size: u64,
}

/// A file opened for printing.
#[derive(Debug)]
struct Printing {
    dos: String,
    long: String,
    reader: BufReader<File>,
    size: u64,
    pos: u64,
    /// `M24` started it and `M25` has not paused it.
    running: bool,
}

/// The card.
#[derive(Debug, Default)]
pub(super) struct SdCard {
    /// The folder, once `gweave serve` attached one.
    dir: Option<PathBuf>,
    mounted: bool,
    open: Option<Printing>,
    /// `M28` upload or `M928` log: the file being written, and whether lines also run (log).
    writing: Option<(File, bool)>,
    /// `M27 S`: period (0: off) and next report time, s.
    report_s: f64,
    next_report_s: f64,
}

impl SdCard {
    fn entries(&self) -> Vec<Entry> {
        let Some(dir) = &self.dir else { return Vec::new() };
        let Ok(read) = std::fs::read_dir(dir) else { return Vec::new() };
        let mut files: Vec<(String, u64)> = read
            .filter_map(Result::ok)
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .filter_map(|e| Some((e.file_name().into_string().ok()?, e.metadata().ok()?.len())))
            .filter(|(name, _)| !name.starts_with('.'))
            .collect();
        files.sort();
        let mut taken: Vec<String> = Vec::new();
        let mut out = Vec::new();
        for (long, size) in files {
            let dos = dos_name(&long, &taken);
            taken.push(dos.clone());
            if dos.rsplit_once('.').is_some_and(|(_, ext)| ext.starts_with('G')) {
                out.push(Entry { dos, long, size });
            }
        }
        out
    }

    /// The entry a host names, by its DOS or long name (case-insensitive, `/` prefix allowed).
    fn find(&self, name: &str) -> Option<Entry> {
        let name = name.trim().trim_start_matches('/');
        self.entries()
            .into_iter()
            .find(|e| e.dos.eq_ignore_ascii_case(name) || e.long.eq_ignore_ascii_case(name))
    }
}

impl Machine {
    /// Gives the board an SD card: the files of `dir`.
    pub fn attach_sd(&mut self, dir: PathBuf) {
        self.sd.dir = Some(dir);
        self.sd.mounted = true;
    }

    /// Whether an SD print is running (started and not paused).
    pub fn sd_printing(&self) -> bool {
        self.sd.open.as_ref().is_some_and(|p| p.running)
    }

    /// While an upload is open every line goes into the file: true when `line` was taken.
    pub(super) fn sd_write_line(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> bool {
        let Some((file, log)) = self.sd.writing.as_mut() else { return false };
        let text = super::command_text(line);
        let is_m29 = text.len() >= 3 && text[..3].eq_ignore_ascii_case(b"M29");
        if is_m29 {
            self.sd.writing = None;
            out(self.now_s(), "Done saving file.");
            return true;
        }
        let written = file.write_all(text).and_then(|()| file.write_all(b"\n"));
        let log = *log;
        if let Err(e) = written {
            self.sd.writing = None;
            self.refuse(format!("SD write failed: {e}"), out);
            return true;
        }
        // M928 logs the commands and also runs them.
        !log
    }

    /// Starts or resumes the selected file, with the print job timer.
    pub(super) fn sd_resume(&mut self) {
        if let Some(p) = self.sd.open.as_mut() {
            p.running = true;
            self.job_timer_start();
        }
    }

    fn sd_select(&mut self, name: &str, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        let opened = self.sd.find(name).and_then(|e| {
            let dir = self.sd.dir.as_ref()?;
            let file = open_to_read(dir, &e.long).ok()?;
            Some(Printing {
                dos: e.dos,
                long: e.long,
                reader: BufReader::new(file),
                size: e.size,
                pos: 0,
                running: false,
            })
        });
        match opened {
            Some(p) => {
                out(now, &format!("File opened: {} Size: {}", p.dos, p.size));
                out(now, "File selected");
                self.sd.open = Some(p);
            }
            None => out(now, &format!("echo:open failed, File: {name}.")),
        }
    }

    fn m27(&mut self, arg: &str, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        if let Some(s) = self.report_period_s() {
            if self.profile.firmware.autoreport_sd {
                self.sd.report_s = if s.is_finite() && s > 0.0 { s } else { 0.0 };
                self.sd.next_report_s = now + self.sd.report_s;
            }
            return;
        }
        if has_flag(arg, 'C') {
            match &self.sd.open {
                Some(p) => out(now, &format!("Current file: {} {}", p.dos, p.long)),
                None => out(now, "Current file: (no file)"),
            }
            return;
        }
        out(now, &sd_status(self.sd.open.as_ref()));
    }

    fn sd_open_write(&mut self, arg: &str, log: bool, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        let name = arg.trim().trim_start_matches('/');
        let fits = is_dos_name(name);
        let allowed = fits || self.profile.firmware.lfn_write;
        let file = self.sd.dir.as_ref().filter(|_| allowed).and_then(|dir| {
            let stored = if fits { name.to_ascii_uppercase() } else { name.to_owned() };
            create(dir, &stored).ok()
        });
        match file {
            Some(f) => {
                self.sd.writing = Some((f, log));
                out(now, &format!("Writing to file: {name}"));
            }
            None => out(now, &format!("echo:open failed, File: {name}.")),
        }
    }

    fn sd_delete(&mut self, arg: &str, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        let removed = self.sd.find(arg).and_then(|e| {
            let dir = self.sd.dir.as_ref()?;
            std::fs::remove_file(dir.join(&e.long)).ok()
        });
        match removed {
            Some(()) => out(now, &format!("File deleted:{}", arg.trim())),
            None => out(now, &format!("Deletion failed, File: {}.", arg.trim())),
        }
    }

    /// Runs the next line of the SD print (or ends it), as the board does between host commands.
    pub fn sd_step(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Some(p) = self.sd.open.as_mut().filter(|p| p.running) else { return };
        let mut line = Vec::new();
        let read = read_line(&mut p.reader, &mut line);
        match read {
            Ok(0) | Err(_) => {
                self.sd.open = None;
                // Marlin runs its SD_FINISHED_RELEASECOMMAND after the last move.
                self.core.drain();
                self.sync(out);
                out(self.now_s(), "Done printing file");
            }
            Ok(n) => {
                p.pos += n as u64;
                if !super::command_text(&line).is_empty() {
                    self.execute(&line, out);
                }
            }
        }
    }

    /// The SD status auto-report (`M27 S`), when due.
    pub(super) fn timed_sd_reports(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        let period = self.sd.report_s;
        if period > 0.0 && self.sd.next_report_s <= now + 1e-9 {
            // Marlin's auto-report prints only while a file is open.
            if self.sd.open.is_some() {
                out(now, &sd_status(self.sd.open.as_ref()));
            }
            let late = ((now - self.sd.next_report_s) / period).floor() + 1.0;
            self.sd.next_report_s += late * period;
        }
    }
}

// The SD commands' handlers, one per row of the registry (`commands::COMMANDS`), as Marlin has one
// file per command under `Marlin/src/gcode/sd/`. Every one but `M21` needs the card mounted:
// without it Marlin answers `echo:No media` and does nothing.

/// Whether the card is mounted; if not, the reply says so.
fn mounted(m: &Machine, out: &mut dyn FnMut(f64, &str)) -> bool {
    if !m.sd.mounted {
        out(m.now_s(), "echo:No media");
    }
    m.sd.mounted
}

/// The file name or flags of an SD command: the rest of the line after the code (Marlin's
/// `parser.string_arg`).
fn argument(c: &Call<'_>) -> String {
    let text = String::from_utf8_lossy(super::command_text(c.line)).into_owned();
    text.get(3..).unwrap_or("").trim_start_matches(|ch: char| ch.is_ascii_digit()).trim().to_owned()
}

/// `M20 [L]`: the file list, with the long names if asked and built with them.
pub(super) fn m20(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    let now = m.now_s();
    let long = m.profile.firmware.long_filenames && has_flag(&argument(c), 'L');
    out(now, "Begin file list");
    for e in m.sd.entries() {
        let l = if long { format!(" {}", e.long) } else { String::new() };
        out(now, &format!("{} {}{l}", e.dos, e.size));
    }
    out(now, "End file list");
}

/// `M21`: mount the card (the folder must still be there).
pub(super) fn m21(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.sd.mounted = m.sd.dir.as_deref().is_some_and(Path::is_dir);
    out(m.now_s(), if m.sd.mounted { "echo:SD card ok" } else { "echo:SD init fail" });
}

/// `M22`: release the card, closing the file printed or written.
pub(super) fn m22(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    m.sd.mounted = false;
    m.sd.open = None;
    m.sd.writing = None;
    out(m.now_s(), "echo:SD card released");
}

/// `M23 <name>`: select a file to print.
pub(super) fn m23(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.sd_select(&argument(c), out);
    }
}

/// `M24`: start or resume the selected file. Marlin 2.1's M24/M25
/// (`Marlin/src/gcode/sd/M24_M25.cpp`) run the job timer and tell the host with a prompt.
pub(super) fn m24(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.sd_resume();
        m.prompt(PromptReason::Info, "Resuming SD", &["Dismiss"], out);
    }
}

/// `M25`: pause the SD print.
pub(super) fn m25(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    if let Some(p) = m.sd.open.as_mut() {
        p.running = false;
    }
    m.job_timer_pause();
    m.prompt(PromptReason::PauseResume, "Pause SD", &["Resume"], out);
}

/// `M26 S<byte>`: where the print goes on in the selected file; past its end, the end (the row
/// declares S a byte position).
pub(super) fn m26(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    if let (Some(p), Some(s)) = (m.sd.open.as_mut(), m.core.block().get(b'S')) {
        let pos = (s.max(0.0) as u64).min(p.size);
        if p.reader.seek(SeekFrom::Start(pos)).is_ok() {
            p.pos = pos;
        }
    }
}

/// `M27 [C] [S<s>]`: the print's status, the file's name, or a status every s seconds.
pub(super) fn m27(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.m27(&argument(c), out);
    }
}

/// `M28 <name>`: the following lines go into the file until `M29` ([`Machine::sd_write_line`]).
pub(super) fn m28(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.sd_open_write(&argument(c), false, out);
    }
}

/// `M29` outside an upload (an upload's own ends it in [`Machine::sd_write_line`]): nothing to
/// close.
pub(super) fn m29(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    mounted(m, out);
}

/// `M30 <name>`: delete a file.
pub(super) fn m30(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.sd_delete(&argument(c), out);
    }
}

/// `M32 [S<pos>] [P1] !<name>#`: select a file and start it at once.
pub(super) fn m32(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    let arg = argument(c);
    let name = arg.split('!').nth(1).map_or(arg.as_str(), |n| n.split('#').next().unwrap_or(n));
    m.sd_select(name.trim(), out);
    if let Some(p) = m.sd.open.as_mut() {
        p.running = true;
    }
}

/// `M33 <name>`: a file's long name.
pub(super) fn m33(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if !mounted(m, out) {
        return;
    }
    if let Some(e) = m.sd.find(&argument(c)) {
        out(m.now_s(), &e.long);
    }
}

/// `M524`: abort the SD print.
pub(super) fn m524(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) && m.sd.open.take().is_some() {
        out(m.now_s(), "echo:Print Aborted");
    }
}

/// `M928 <name>`: the following lines go into the file until `M29`, and run too (a log).
pub(super) fn m928(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if mounted(m, out) {
        m.sd_open_write(&argument(c), true, out);
    }
}

fn sd_status(open: Option<&Printing>) -> String {
    match open {
        Some(p) => format!("SD printing byte {}/{}", p.pos, p.size),
        None => "Not SD printing".to_owned(),
    }
}

/// Opens the card's file `name` to print it; never through a symbolic link (`O_NOFOLLOW`: a
/// link put in place after the listing is refused by the open itself), and only a regular
/// file (`O_NONBLOCK` so that a FIFO put in its place cannot block the board; it does nothing
/// to a regular file).
fn open_to_read(dir: &Path, name: &str) -> io::Result<File> {
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(nix::libc::O_NOFOLLOW | nix::libc::O_NONBLOCK)
        .open(dir.join(one_name(name)?))?;
    if !file.metadata()?.is_file() {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "not a file"));
    }
    Ok(file)
}

/// Creates the card's file `name` for an upload (`M28`) or a log (`M928`), empty, replacing
/// the card's file of that name. Never through a link: a symbolic link of that name is
/// refused; an existing file is removed and a new one created exclusively (`O_CREAT|O_EXCL`
/// fails on any name that exists again, a link included), so that a file hard-linked
/// elsewhere keeps its bytes there, as two files on a card are two files.
fn create(dir: &Path, name: &str) -> io::Result<File> {
    let path = dir.join(one_name(name)?);
    match fs::symlink_metadata(&path) {
        Ok(meta) if meta.is_file() => fs::remove_file(&path)?,
        Ok(_) => return Err(io::Error::new(io::ErrorKind::InvalidInput, "not a file")),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    OpenOptions::new().write(true).create_new(true).custom_flags(nix::libc::O_NOFOLLOW).open(path)
}

/// `name` if it is one plain name in the card's folder (no `/`, `.`, `..`, or empty name),
/// else an error: what a host sends must not reach outside the card.
fn one_name(name: &str) -> io::Result<&str> {
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(_)), None) if !name.contains('/') => Ok(name),
        _ => Err(io::Error::new(io::ErrorKind::InvalidInput, "not a name on the card")),
    }
}

/// Whether a word of `arg` is the flag `letter` (`M20 L T`, `M27 C`).
fn has_flag(arg: &str, letter: char) -> bool {
    arg.split_whitespace().any(|w| w.len() == 1 && w.starts_with(|c: char| c.eq_ignore_ascii_case(&letter)))
}

/// One line of the file, at most [`MAX_SD_LINE`] bytes kept: the bytes consumed (0 at the end).
fn read_line(reader: &mut impl BufRead, line: &mut Vec<u8>) -> std::io::Result<usize> {
    let mut consumed = 0;
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            return Ok(consumed);
        }
        let end = buf.iter().position(|&b| b == b'\n');
        let take = end.map_or(buf.len(), |i| i + 1);
        let room = MAX_SD_LINE.saturating_sub(line.len());
        line.extend_from_slice(&buf[..take.min(room)]);
        reader.consume(take);
        consumed += take;
        if end.is_some() {
            return Ok(consumed);
        }
    }
}

/// Whether `name` is a valid 8.3 name as it is (no long name needed).
fn is_dos_name(name: &str) -> bool {
    let (base, ext) = name.rsplit_once('.').unwrap_or((name, ""));
    let ok = |s: &str| s.chars().all(|c| c.is_ascii_alphanumeric() || "_-~!#$%&'(){}^@`".contains(c));
    (1..=8).contains(&base.len()) && ext.len() <= 3 && ok(base) && ok(ext)
}

/// The 8.3 name FAT gives `long`, unique among `taken`: the name itself in upper case when it
/// fits, else the first six usable characters, `~N` and the first three of the extension.
fn dos_name(long: &str, taken: &[String]) -> String {
    if is_dos_name(long) {
        return long.to_ascii_uppercase();
    }
    let (base, ext) = long.rsplit_once('.').unwrap_or((long, ""));
    let clean = |s: &str, n: usize| -> String {
        s.chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
            .take(n)
            .collect::<String>()
            .to_ascii_uppercase()
    };
    let ext = clean(ext, 3);
    (1..)
        .map(|n| {
            let tail = format!("~{n}");
            let base = clean(base, 8 - tail.len());
            if ext.is_empty() {
                format!("{base}{tail}")
            } else {
                format!("{base}{tail}.{ext}")
            }
        })
        .find(|d| !taken.contains(d))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sd_names_are_fat_short_names() {
        assert_eq!(dos_name("part.gco", &[]), "PART.GCO");
        assert_eq!(dos_name("fixture.gcode", &[]), "FIXTUR~1.GCO");
        assert_eq!(dos_name("fixture two.gcode", &["FIXTUR~1.GCO".to_owned()]), "FIXTUR~2.GCO");
        assert!(has_flag("L T", 'l') && !has_flag("LT", 'L'));
    }

    /// The opens themselves refuse a link, so that one put in place between the listing and
    /// the open (where `M20` and `M23` check) is not followed either; and a name never reaches
    /// outside the folder.
    #[test]
    fn the_card_opens_no_link_and_no_name_outside_it() {
        let dir = tempfile::tempdir().unwrap();
        let card = dir.path().join("card");
        fs::create_dir(&card).unwrap();
        fs::write(dir.path().join("victim.gco"), "G28\n").unwrap();
        std::os::unix::fs::symlink("../victim.gco", card.join("LINK.GCO")).unwrap();
        assert!(open_to_read(&card, "LINK.GCO").is_err());
        assert!(create(&card, "LINK.GCO").is_err());
        for name in ["../victim.gco", "..", ".", "", "a/b.gco", "/victim.gco"] {
            assert!(open_to_read(&card, name).is_err() && create(&card, name).is_err(), "{name:?}");
        }
        assert_eq!(fs::read_to_string(dir.path().join("victim.gco")).unwrap(), "G28\n");
        assert!(fs::symlink_metadata(card.join("LINK.GCO")).unwrap().file_type().is_symlink());
    }
}
