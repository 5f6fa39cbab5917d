//! The mixing commands (`M163`, `M164`, `M165`, `T<n>`) and the virtual tools in EEPROM and in
//! `M503`; what they mean is in [`crate::mixing`].

use super::commands::Done;
use super::Controller;
use crate::gcode::words::{Command, Words};
use crate::limits::{MIX_INPUTS, MIX_TOOLS};
use crate::mixing::{MixError, MIX_UNITS};
use crate::serial::out::{line, Reply};
use crate::Io;

/// `M165`'s letters, inputs 0 to 3 (Marlin's `A B C D H I`, of which a 4-input hotend uses 4).
const M165_LETTERS: [u8; MIX_INPUTS] = *b"ABCD";

impl Controller<'_> {
    /// A mixing command on a mixing hotend. A command refused changes nothing and says why in
    /// the out-of-range words of the other commands (`echo:M163 S = 7.00 is out of range: 0.00
    /// to 3.00`), then `ok`: a host goes on.
    pub(super) fn mixing_command(&mut self, io: &mut impl Io, w: &Words) -> Done {
        let Command { letter, code } = w.command;
        let index = |l: u8| {
            w.get(l)
                .map(|v| if v >= 0.0 && v == (v as u16) as f32 { usize::from(v as u16) } else { usize::MAX })
        };
        let result = match (letter, code) {
            (b'M', 163) => match (index(b'S'), w.get(b'P')) {
                (Some(input), Some(weight)) => self.mixer.set_weight(input, weight).map_err(|e| (b'S', e)),
                // Nothing to set: Marlin ignores it too.
                _ => Ok(()),
            },
            (b'M', 164) => self.mixer.store(index(b'S')).map_err(|e| (b'S', e)),
            (b'M', 165) => self.mixer.set_active(M165_LETTERS.map(|l| w.get(l))).map_err(|e| (b'A', e)),
            _ => self.mixer.select(usize::from(code)).map_err(|e| (b'T', e)),
        };
        if let Err((word, why)) = result {
            let mut r = Reply::new();
            r.s(b"echo:").s(&[letter]).u32(u32::from(code));
            let high = match why {
                MixError::AllZero => {
                    r.s(b": a mix of all zeros is not stored").send(io);
                    return Done::Ok;
                }
                MixError::Input => self.mixer.inputs() - 1,
                MixError::Tool => MIX_TOOLS - 1,
            };
            let value = if word == b'T' { f32::from(code) } else { w.get(word).unwrap_or(0.0) };
            r.s(&[b' ', word]).s(b" = ").f2(value).s(b" is out of range: 0.00 to ").f2(high as f32).send(io);
        }
        Done::Ok
    }

    pub(super) fn save_tools(&self, io: &mut impl Io) {
        if self.mixer.inputs() > 0 {
            self.mixer.save(io);
        }
    }

    pub(super) fn load_tools(&mut self, io: &mut impl Io) {
        if self.mixer.inputs() > 0 {
            let _ = self.mixer.load(io);
        }
    }

    /// `M503`'s part for the virtual tools: for each, the `M163` lines and the `M164` that set
    /// it (weights as fractions of 1, four decimals), so a host can send them back.
    pub(super) fn report_tools(&self, io: &mut impl Io) {
        let inputs = self.mixer.inputs();
        if inputs == 0 {
            return;
        }
        line(io, b"echo:; Mixing virtual tools:");
        for t in 0..MIX_TOOLS {
            let mix = self.mixer.tool(t);
            for (k, &units) in mix[..inputs].iter().enumerate() {
                let mut r = Reply::new();
                r.s(b"echo:  M163 S").u32(k as u32).s(b" P").u32(u32::from(units / MIX_UNITS)).s(b".");
                // Four decimals of units / 10 000, by hand (no float formatting in the core).
                let frac = units % MIX_UNITS;
                for div in [1000, 100, 10, 1] {
                    r.s(&[b'0' + (frac / div % 10) as u8]);
                }
                r.send(io);
            }
            Reply::new().s(b"echo:  M164 S").u32(t as u32).send(io);
        }
    }
}
