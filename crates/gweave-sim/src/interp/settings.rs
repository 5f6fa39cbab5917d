//! The settings a host changes on a running Marlin board and keeps in its EEPROM: steps per unit
//! (`M92`), feed and acceleration limits (`M201`, `M203`, `M204`, `M205`, carried out by the
//! planner), PID gains (`M301`, `M304`), the probe offset (`M851`), firmware retraction
//! (`M207`-`M209`); `M503` reports them, `M500`/`M501`/`M502` save, load and reset them.
//!
//! `M503` prints each group as Marlin 2.1's `MarlinSettings::report` does: a heading
//! `echo:; Steps per unit:` then the command that sets it, `echo:  M92 X80.00 Y80.00 ...`. The
//! EEPROM is a text file holding those commands, one per line; loading it runs them, so that a
//! setting is written and read by exactly one piece of code.

use std::path::PathBuf;

use super::Machine;
use crate::motion::limits::CornerMode;
use crate::motion::marlin_limits::MarlinCorners;
use crate::thermal::heater::HeaterId;

/// Settings the planner and heaters do not hold themselves.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Settings {
    /// Steps per unit X Y Z E (`M92`), as the steppers count them.
    pub steps: [f64; 4],
    /// `M205 S T`: minimum feed and travel feed (mm/s), reported and stored (not modelled). Its
    /// `B`, the minimum segment time, is the planner's (`[motion.corners] min_segment_time_us`).
    pub m205_st: [f64; 2],
    /// `M851 X Y Z`: nozzle to probe, mm.
    pub probe_offset_mm: [f64; 3],
    /// `M207 W F Z` (swap length mm, feed mm/s, lift mm); the length is the modal state's.
    pub retract: [f64; 3],
    /// `M208 S W F`: extra length on recover, swap extra, feed mm/s.
    pub recover: [f64; 3],
    /// `M209 S`: E-only moves become retractions.
    pub auto_retract: bool,
    /// Where `M500` writes: a file next to the session, or none (the EEPROM forgets).
    pub eeprom: Option<PathBuf>,
}

impl Settings {
    pub(super) fn new(steps: [f64; 4]) -> Self {
        // Marlin's Configuration_adv.h: MIN_SEGMENT_TIME_US, RETRACT_*, RETRACT_RECOVER_*.
        Settings {
            steps,
            m205_st: [0.0, 0.0],
            probe_offset_mm: [10.0, 10.0, 0.0],
            retract: [13.0, 45.0, 0.0],
            recover: [0.0, 0.0, 8.0],
            auto_retract: false,
            eeprom: None,
        }
    }
}

impl Machine {
    /// The file `M500` writes and power-on reads (`gweave serve` puts it next to the session).
    /// A file that exists is loaded now, as Marlin loads its EEPROM at power-on.
    pub fn attach_eeprom(&mut self, path: PathBuf) {
        let loaded = self.profile.firmware.eeprom && path.exists();
        self.settings.eeprom = Some(path);
        if loaded {
            self.m501(&mut |_, _| {});
        }
    }

    /// The words `letters` of the line, each if present.
    fn words<const N: usize>(&self, letters: &[u8; N]) -> [Option<f64>; N] {
        let b = self.core.block();
        letters.map(|l| b.get(l))
    }

    /// `M92 X Y Z E`: steps per unit, to the steppers and the saved settings.
    pub(super) fn m92(&mut self) {
        for (axis, v) in self.words(b"XYZE").into_iter().enumerate() {
            if let Some(v) = v {
                self.settings.steps[axis] = v;
                self.core.steppers_mut().set_steps_per_unit(axis, v);
            }
        }
    }

    /// `M207 S W F Z`: the firmware retraction; S (the length) is the modal state's, W F Z are
    /// kept here.
    pub(super) fn m207(&mut self) {
        let [w, f, z] = self.words(b"WFZ");
        set(&mut self.settings.retract[0], w);
        set(&mut self.settings.retract[1], f.map(|f| f / 60.0));
        set(&mut self.settings.retract[2], z);
    }

    /// `M208 S W F`: the recovery after a firmware retraction.
    pub(super) fn m208(&mut self) {
        let [s, w, f] = self.words(b"SWF");
        set(&mut self.settings.recover[0], s);
        set(&mut self.settings.recover[1], w);
        set(&mut self.settings.recover[2], f.map(|f| f / 60.0));
    }

    /// `M209 S`: auto-retract on or off.
    pub(super) fn m209(&mut self) {
        if let [Some(s)] = self.words(b"S") {
            self.settings.auto_retract = s != 0.0;
        }
    }

    /// `M503`: the settings, as Marlin reports them.
    pub(super) fn m503(&mut self, out: &mut dyn FnMut(f64, &str)) {
        for l in self.report_lines() {
            out(self.now_s(), &l);
        }
    }

    /// `M851 X Y Z`: the probe offsets, set, or reported without words.
    pub(super) fn m851(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let [x, y, z] = self.words(b"XYZ");
        if x.is_none() && y.is_none() && z.is_none() {
            let [x, y, z] = self.settings.probe_offset_mm;
            out(self.now_s(), &format!("echo:Probe Offset X{x:.2} Y{y:.2} Z{z:.2}"));
        }
        for (slot, v) in self.settings.probe_offset_mm.iter_mut().zip([x, y, z]) {
            set(slot, v);
        }
    }

    /// `M304 [P] [I] [D]`: the bed's PID gains, set or reported.
    pub(super) fn m304(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let (p, i, d) = (b.get(b'P'), b.get(b'I'), b.get(b'D'));
        let result = self.thermal.pid_gains(HeaterId::Bed).and_then(|g| {
            let gains = crate::thermal::control::PidGains {
                kp: p.unwrap_or(g.kp),
                ki: i.unwrap_or(g.ki),
                kd: d.unwrap_or(g.kd),
            };
            self.thermal.set_pid_gains(HeaterId::Bed, gains).map(|()| gains)
        });
        match result {
            Ok(g) if p.is_none() && i.is_none() && d.is_none() => out(self.now_s(), &g.report_line(true)),
            Ok(_) => {}
            Err(e) => self.refuse(e.to_string(), out),
        }
    }

    /// The commands that set every setting to its present value (the EEPROM's content).
    fn setting_commands(&self) -> Vec<(&'static str, String)> {
        let m = self.core.profile();
        let [sx, sy, sz, se] = self.settings.steps;
        let f = m.max_feed_mm_s;
        let a = m.max_accel_mm_s2;
        let acc = m.accel;
        let [s, t] = self.settings.m205_st;
        let b = match m.corners {
            CornerMode::Marlin { min_segment_time_us, .. } => min_segment_time_us,
            CornerMode::Klipper(_) | CornerMode::Constant {} => 0.0,
        };
        // Marlin prints the corner rule it was built with: J for junction deviation, X Y Z E
        // for classic jerk (MarlinSettings::report, M205).
        const JERK: &str = "Advanced (B<min_segment_time_us> S<min_feedrate> T<min_travel_feedrate> \
                            X<max_x_jerk> Y<max_y_jerk> Z<max_z_jerk> E<max_e_jerk>):";
        const JD: &str =
            "Advanced (B<min_segment_time_us> S<min_feedrate> T<min_travel_feedrate> J<junc_dev>):";
        let (heading, corner) = match m.corners.marlin_corners() {
            Some(MarlinCorners::Jerk(j)) => {
                (JERK, format!(" X{:.2} Y{:.2} Z{:.2} E{:.2}", j.x, j.y, j.z, j.e))
            }
            Some(MarlinCorners::JunctionDeviation(jd)) => (JD, format!(" J{jd:.3}")),
            None => (JD, " J0.000".to_owned()),
        };
        let mut lines = vec![
            ("Steps per unit:", format!("M92 X{sx:.2} Y{sy:.2} Z{sz:.2} E{se:.2}")),
            ("Max feedrates (units/s):", format!("M203 X{:.2} Y{:.2} Z{:.2} E{:.2}", f.x, f.y, f.z, f.e)),
            ("Max Acceleration (units/s2):", format!("M201 X{:.2} Y{:.2} Z{:.2} E{:.2}", a.x, a.y, a.z, a.e)),
            (
                "Acceleration (units/s2) (P<print-accel> R<retract-accel> T<travel-accel>):",
                format!("M204 P{:.2} R{:.2} T{:.2}", acc.print_mm_s2, acc.retract_mm_s2, acc.travel_mm_s2),
            ),
            (heading, format!("M205 B{b:.2} S{s:.2} T{t:.2}{corner}")),
        ];
        if let Ok(g) = self.thermal.pid_gains(HeaterId::Hotend(0)) {
            lines.push(("Hotend PID:", format!("M301 P{:.2} I{:.2} D{:.2}", g.kp, g.ki, g.kd)));
        }
        if let Ok(g) = self.thermal.pid_gains(HeaterId::Bed) {
            lines.push(("Bed PID:", format!("M304 P{:.2} I{:.2} D{:.2}", g.kp, g.ki, g.kd)));
        }
        let fw = &self.profile.firmware;
        if fw.fw_retract {
            let [w, rf, z] = self.settings.retract;
            let [rs, rw, recf] = self.settings.recover;
            let len = self.core.state().fw_retract_mm;
            lines.push((
                "Retract (S<length> F<units/m> Z<lift>):",
                format!("M207 S{len:.2} W{w:.2} F{:.2} Z{z:.2}", rf * 60.0),
            ));
            lines.push((
                "Recover (S<length> F<units/m>):",
                format!("M208 S{rs:.2} W{rw:.2} F{:.2}", recf * 60.0),
            ));
            lines.push((
                "Auto-Retract: S=0 to disable, 1 to interpret E-only moves as retract/recover",
                format!("M209 S{}", u8::from(self.settings.auto_retract)),
            ));
        }
        if fw.probe {
            let [x, y, z] = self.settings.probe_offset_mm;
            lines.push(("Z-Probe Offset:", format!("M851 X{x:.2} Y{y:.2} Z{z:.2}")));
        }
        lines
    }

    /// `M503`: Marlin's settings report, each group under its heading.
    pub(super) fn report_lines(&self) -> Vec<String> {
        let mut lines = vec![
            "echo:; Linear Units:".to_owned(),
            "echo:  G21 ; (mm)".to_owned(),
            "echo:; Temperature Units:".to_owned(),
            "echo:  M149 C ; Units in Celsius".to_owned(),
        ];
        for (heading, command) in self.setting_commands() {
            lines.push(format!("echo:; {heading}"));
            lines.push(format!("echo:  {command}"));
        }
        lines
    }

    pub(super) fn m500(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Some(path) = self.settings.eeprom.clone() else {
            return;
        };
        let text: String = self.setting_commands().into_iter().map(|(_, c)| c + "\n").collect();
        match std::fs::write(&path, &text) {
            Ok(()) => {
                out(self.now_s(), &format!("echo:Settings Stored ({} bytes; crc {})", text.len(), crc(&text)))
            }
            Err(e) => self.refuse(format!("EEPROM write failed: {e}"), out),
        }
    }

    pub(super) fn m501(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Some(path) = self.settings.eeprom.clone() else {
            return;
        };
        let Ok(text) = gweave::settings::read_text(&path) else {
            // Marlin finds an empty EEPROM and keeps (then saves) its defaults.
            out(self.now_s(), "echo:EEPROM version mismatch (EEPROM=? Marlin=V86)");
            return;
        };
        self.replay(text.lines());
        out(
            self.now_s(),
            &format!("echo:V86 stored settings retrieved ({} bytes; crc {})", text.len(), crc(&text)),
        );
    }

    /// `M502`: the settings of a fresh board of this profile.
    pub(super) fn m502(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Ok(fresh) = Machine::new(self.profile.clone()) else { return };
        let commands: Vec<String> = fresh.setting_commands().into_iter().map(|(_, c)| c).collect();
        self.settings = Settings { eeprom: self.settings.eeprom.take(), ..fresh.settings };
        self.replay(commands.iter().map(String::as_str));
        out(self.now_s(), "echo:Hardcoded Default Settings Loaded");
    }

    /// Runs setting commands (the EEPROM's lines) without replies.
    fn replay<'a>(&mut self, lines: impl Iterator<Item = &'a str>) {
        for line in lines {
            self.execute(line.as_bytes(), &mut |_, _| {});
        }
    }
}

fn set(slot: &mut f64, value: Option<f64>) {
    if let Some(v) = value {
        *slot = v;
    }
}

/// A 16-bit sum of the stored text, shown as Marlin shows its EEPROM's CRC.
fn crc(text: &str) -> u16 {
    text.bytes().fold(0u16, |c, b| c.rotate_left(1) ^ u16::from(b))
}
