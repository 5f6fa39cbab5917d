//! `M700 P<head> S<nozzles>`: fire an inkjet head after the queued moves; what it means and
//! the printhead's timing are in [`crate::inkjet`].

use super::commands::Done;
use super::{Controller, Wait};
use crate::gcode::words::Words;
use crate::inkjet::ALL_NOZZLES;
use crate::serial::out::{line, Reply};
use crate::Io;

impl Controller<'_> {
    /// `M700`: checks the head and the mask, then waits ([`Wait::Fire`]) for the moves and the
    /// head's refill time. A refusal fires nothing and says why in an `Error:` line.
    pub(super) fn inkjet_command(&mut self, io: &mut impl Io, w: &Words) -> Done {
        let heads = self.settings.inkjet_heads;
        let Some(p) = w.get(b'P') else {
            line(io, b"Error:M700 needs P<head>: nothing fired");
            return Done::Ok;
        };
        let head = whole(p).filter(|&h| h < u16::from(heads));
        let nozzles = whole(w.get(b'S').unwrap_or(0.0)).filter(|&s| s <= ALL_NOZZLES);
        let (Some(head), Some(nozzles)) = (head, nozzles) else {
            let (letter, value, high) = match head {
                None => (b'P', p, f32::from(heads) - 1.0),
                Some(_) => (b'S', w.get(b'S').unwrap_or(0.0), f32::from(ALL_NOZZLES)),
            };
            let mut r = Reply::new();
            r.s(b"Error:M700 ").s(&[letter]).s(b" = ").f2(value).s(b" is not a whole number from 0.00 to ");
            r.f2(high).s(b": nothing fired").send(io);
            return Done::Ok;
        };
        // At once if nothing moves and the head has refilled (a turn of the main loop saved per
        // column), else when it has.
        if self.fire_when_ready(io, head as u8, nozzles) {
            return Done::Ok;
        }
        self.wait = Wait::Fire { head: head as u8, nozzles };
        Done::Quiet
    }

    /// The waiting `M700`: fires when the moves have ended and the head has refilled. Returns
    /// whether it fired.
    pub(super) fn fire_when_ready(&mut self, io: &mut impl Io, head: u8, nozzles: u16) -> bool {
        let now = self.inputs.now_ms;
        if self.moving() || !self.inkjet.ready(usize::from(head), now) {
            return false;
        }
        io.inkjet_fire(head, nozzles);
        self.inkjet.fired(usize::from(head), now);
        true
    }
}

/// `v` as a whole number, if it is one (0 to 65535).
fn whole(v: f32) -> Option<u16> {
    (v >= 0.0 && v == f32::from(v as u16)).then_some(v as u16)
}
