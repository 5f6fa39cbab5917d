//! The firmware a file is read and written for: one type, [`Firmware`], resolved once per run
//! ([`Firmware::resolve`]) from what the configuration says (a profile's `dialect`, a flag) or
//! else the file's flavour ([`crate::gcode::flavour`]), with what differs between firmwares as
//! its methods. Everything that reads or writes firmware-specific G-code asks it: the modal
//! state (the extrusion word, what `G90`/`G91`/`M82`/`M83` do to E, `G10` and `M106` words),
//! the mix pass (how a mix is written), the raster generator (the inkjet fire code), the
//! simulator, the CLI and Python.
//!
//! Sources, by firmware: Marlin's `gcode/gcode.cpp` (`G90`/`G91` set E too, `M82`/`M83` E
//! alone) and `feature/mixing.cpp` (`M163`-`M166`);
//! Klipper's `docs/G-Codes.md` (`G90`/`G91` leave the extrusion mode alone, E relative under
//! `G91`); RepRapFirmware's G-code dictionary (`M82`/`M83` alone decide E, `G10 P S` and `M568`
//! tool temperatures, `M563`/`M567` mixing tools, `M578` inkjet); LinuxCNC's G-code reference
//! (no E axis: PrusaSlicer's `mach3`/`machinekit` flavours extrude with `A` and give an
//! M-code's value as `P`).
//!
//! Two name spaces meet here and must not be confused: a *flavour* is the slicer's name in the
//! file (`gcode_flavor = reprap` is Slic3r's Sprinter/Marlin family, not RepRapFirmware), a
//! *spelling* is gweave's name in a config file or flag (`reprapfirmware`, with the older
//! `reprap` and `rep_rap_firmware` still accepted).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::gcode::arc::{ArcRules, ShortRadius};

/// A firmware family: how it reads G-code and which commands it speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Firmware {
    /// Marlin (and the Sprinter/RepRap family slicers call `reprap`, `marlin2`, ...): `G90`
    /// makes every axis absolute, E included (until `M83`); `G91` makes all relative.
    #[default]
    #[serde(rename = "marlin")]
    Marlin,
    /// Klipper: `G90`/`G91` leave the `M82`/`M83` extrusion mode alone, but E is relative while
    /// `G91` is in force.
    #[serde(rename = "klipper")]
    Klipper,
    /// RepRapFirmware (Duet): only `M82`/`M83` decide E; `G91` leaves extrusion absolute under
    /// `M82`.
    #[serde(rename = "reprapfirmware", alias = "reprap", alias = "rep_rap_firmware")]
    RepRapFirmware,
    /// LinuxCNC-style machines (PrusaSlicer's `mach3` and `machinekit` flavours): no E axis,
    /// the extruder is `A`, and M-codes take their value as `P` (`M104 P200`, `M106 P237.15`).
    /// G90/G91 move A as Marlin's rule moves E.
    #[serde(rename = "linuxcnc", alias = "mach3", alias = "machinekit")]
    LinuxCnc,
}

/// A name that spells no firmware.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown firmware {0:?}: expected marlin, klipper, reprapfirmware or linuxcnc")]
pub struct UnknownFirmware(pub String);

impl Firmware {
    /// Every firmware, in the order the docs list them.
    pub const ALL: [Firmware; 4] =
        [Firmware::Marlin, Firmware::Klipper, Firmware::RepRapFirmware, Firmware::LinuxCnc];

    /// The one spelling in config files, flags, reports and docs.
    pub fn name(self) -> &'static str {
        match self {
            Firmware::Marlin => "marlin",
            Firmware::Klipper => "klipper",
            Firmware::RepRapFirmware => "reprapfirmware",
            Firmware::LinuxCnc => "linuxcnc",
        }
    }

    /// Older spellings still accepted (kept so every existing config and flag works).
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            Firmware::Marlin | Firmware::Klipper => &[],
            Firmware::RepRapFirmware => &["reprap", "rep_rap_firmware"],
            Firmware::LinuxCnc => &["mach3", "machinekit"],
        }
    }

    /// The firmware a slicer's flavour names (`;FLAVOR:` or `gcode_flavor`, any case), if it
    /// names one gweave reads differently from Marlin: `klipper`, `reprapfirmware`, `mach3`,
    /// `machinekit`. Every other flavour (`marlin`, `marlin2`, `reprap`, `Griffin`,
    /// `repetier`, ...) reads as Marlin does, so `None` leaves the caller's default.
    pub fn from_flavour(flavour: &str) -> Option<Firmware> {
        let is = |name: &str| flavour.eq_ignore_ascii_case(name);
        if is("klipper") {
            Some(Firmware::Klipper)
        } else if is("reprapfirmware") {
            Some(Firmware::RepRapFirmware)
        } else if is("mach3") || is("machinekit") {
            Some(Firmware::LinuxCnc)
        } else {
            None
        }
    }

    /// The firmware of a run: the configured one (a profile's key, a flag) if set, else the
    /// one the file's flavour names, else Marlin.
    pub fn resolve(configured: Option<Firmware>, flavour: Option<&str>) -> Firmware {
        configured.or_else(|| flavour.and_then(Firmware::from_flavour)).unwrap_or_default()
    }

    /// The word that drives the extruder: `E`, or `A` on LinuxCNC (where `E` means nothing).
    pub fn extrusion_letter(self) -> u8 {
        match self {
            Firmware::Marlin | Firmware::Klipper | Firmware::RepRapFirmware => b'E',
            Firmware::LinuxCnc => b'A',
        }
    }

    /// Whether M-codes give their value as `P` (LinuxCNC): there `M106 P` is the fan speed,
    /// not Marlin's fan index.
    pub fn values_in_p(self) -> bool {
        match self {
            Firmware::Marlin | Firmware::Klipper | Firmware::RepRapFirmware => false,
            Firmware::LinuxCnc => true,
        }
    }

    /// The extrusion mode after `G90` (`absolute`) or `G91`, from the mode before it
    /// (`absolute_e`, `M82`): Marlin's `G90`/`G91` set it too, Klipper and RepRapFirmware
    /// leave it alone.
    pub fn absolute_e_after_g90_g91(self, absolute: bool, absolute_e: bool) -> bool {
        match self {
            Firmware::Marlin | Firmware::LinuxCnc => absolute,
            Firmware::Klipper | Firmware::RepRapFirmware => absolute_e,
        }
    }

    /// Whether E moves relative under these modes: under `M83`, or under `G91` except on
    /// RepRapFirmware, where only `M82`/`M83` decide it.
    pub fn relative_e(self, absolute: bool, absolute_e: bool) -> bool {
        let g91_moves_e = match self {
            Firmware::Marlin | Firmware::Klipper | Firmware::LinuxCnc => true,
            Firmware::RepRapFirmware => false,
        };
        !absolute_e || (!absolute && g91_moves_e)
    }

    /// Whether `G10 S<t>` alone is a tool temperature (RepRapFirmware) rather than a firmware
    /// retraction (Marlin's `G10 S1` is the longer swap retraction).
    pub fn g10_s_is_a_temperature(self) -> bool {
        match self {
            Firmware::Marlin | Firmware::Klipper | Firmware::LinuxCnc => false,
            Firmware::RepRapFirmware => true,
        }
    }

    /// How it reads G2/G3: which forms it takes, and what it does with a radius too short to
    /// reach the end point (sources in [`crate::gcode::arc`]).
    pub(crate) fn arcs(self) -> ArcRules {
        let rules = ArcRules { by_radius: true, in_relative: true, short_radius: ShortRadius::HalfCircle };
        match self {
            Firmware::Marlin => rules,
            Firmware::Klipper => ArcRules { by_radius: false, in_relative: false, ..rules },
            Firmware::RepRapFirmware => {
                ArcRules { short_radius: ShortRadius::HalfCircleWithin { share: 0.02 }, ..rules }
            }
            Firmware::LinuxCnc => {
                ArcRules { short_radius: ShortRadius::RefusedPast { mm: 0.005, inch: 0.0005 }, ..rules }
            }
        }
    }

    /// The M-code that fires an inkjet head, `M<code> P<head> S<nozzle bits>`: Marlin's
    /// hpc6602 branch `M700`, RepRapFirmware's `M578`; `None` where the firmware has none.
    pub fn inkjet_fire_code(self) -> Option<u32> {
        match self {
            Firmware::Marlin => Some(700),
            Firmware::RepRapFirmware => Some(578),
            Firmware::Klipper | Firmware::LinuxCnc => None,
        }
    }

    /// How a mix is written for this firmware when the profile does not choose: RepRapFirmware's
    /// tools (`M563`/`M567`), Marlin's virtual tools (`M163`/`M164`) for every other (Klipper and
    /// LinuxCNC have no mixing extruder of their own).
    pub fn mix_commands(self) -> MixCommands {
        match self {
            Firmware::Marlin | Firmware::Klipper | Firmware::LinuxCnc => MixCommands::Marlin,
            Firmware::RepRapFirmware => MixCommands::RepRapFirmware,
        }
    }
}

impl fmt::Display for Firmware {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Firmware {
    type Err = UnknownFirmware;
    /// A spelling or an alias, as config files read them (exact case).
    fn from_str(s: &str) -> Result<Self, UnknownFirmware> {
        Firmware::ALL
            .into_iter()
            .find(|f| f.name() == s || f.aliases().contains(&s))
            .ok_or_else(|| UnknownFirmware(s.to_owned()))
    }
}

/// How a mix is told to the firmware (the mix profile's `dialect`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum MixCommands {
    /// Marlin MIXING_EXTRUDER: `M163 S<i> P<f>` ... `M164 S<t>`, then `T<t>`.
    #[default]
    #[serde(rename = "marlin")]
    Marlin,
    /// Marlin with direct mixing: `M165 A B C D H I` sets the active tool's mix at each change.
    #[serde(rename = "marlin-direct")]
    MarlinDirect,
    /// RepRapFirmware: `M563 P<t> D0:1:.. H<h>` and `M567 P<t> E<a:b:..>`, then `T<t>`.
    #[serde(rename = "reprapfirmware", alias = "reprap", alias = "rep_rap_firmware")]
    RepRapFirmware,
}

impl MixCommands {
    /// The firmware these commands are for.
    pub fn firmware(self) -> Firmware {
        match self {
            MixCommands::Marlin | MixCommands::MarlinDirect => Firmware::Marlin,
            MixCommands::RepRapFirmware => Firmware::RepRapFirmware,
        }
    }

    /// Whether a mix is stored in a numbered tool and selected with `T<t>` (Marlin's virtual
    /// tools, RepRapFirmware's tools), rather than set on the active tool at each change
    /// (`M165`, direct mixing): only the first needs `hardware.virtual_tools`.
    pub fn uses_tools(self) -> bool {
        match self {
            MixCommands::Marlin | MixCommands::RepRapFirmware => true,
            MixCommands::MarlinDirect => false,
        }
    }

    /// The most inputs a mix can name, when the command has a fixed set of words: `M165` has
    /// six, `A B C D H I` (Marlin's `gcode/feature/mixing/M163-M165.cpp`); `M163 S<i>` and
    /// `M567 E<a:b:..>` take any number.
    pub fn max_inputs(self) -> Option<usize> {
        match self {
            MixCommands::MarlinDirect => Some(6),
            MixCommands::Marlin | MixCommands::RepRapFirmware => None,
        }
    }

    /// Whether a tool must be defined (`M563 P<t> D.. H..`) before its mix is set: on
    /// RepRapFirmware a tool is not mixing until it is; Marlin's virtual tools always exist.
    pub fn defines_tools(self) -> bool {
        match self {
            MixCommands::RepRapFirmware => true,
            MixCommands::Marlin | MixCommands::MarlinDirect => false,
        }
    }
}

/// The mixing M-codes, of every firmware: one list, for every reader that must recognise them
/// (the mixing state, purge-shift's change groups, the simulator).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MixingCode {
    /// Marlin `M163 S<input> P<factor>`: one input's factor in the collector.
    M163,
    /// Marlin `M164 S<tool>`: the collector, normalised, stored as a virtual tool.
    M164,
    /// Marlin `M165 A B C D H I`: the active tool's mix in one line.
    M165,
    /// Marlin `M166`: a gradient mix over heights (set up once, not a change of mix).
    M166,
    /// RepRapFirmware `M563 P<tool> D<drives> H<heater>`: a tool fed by several drives.
    M563,
    /// RepRapFirmware `M567 P<tool> E<a:b:..>`: a tool's mix, not normalised.
    M567,
}

impl MixingCode {
    /// The mixing command `M<number>` is, if it is one.
    pub fn of_m(number: u32) -> Option<MixingCode> {
        match number {
            163 => Some(MixingCode::M163),
            164 => Some(MixingCode::M164),
            165 => Some(MixingCode::M165),
            166 => Some(MixingCode::M166),
            563 => Some(MixingCode::M563),
            567 => Some(MixingCode::M567),
            _ => None,
        }
    }

    /// Whether `M<number>` sets a mix (`M163`-`M165`, `M567`): what the mixing state follows.
    pub fn sets_a_mix(number: u32) -> bool {
        matches!(
            MixingCode::of_m(number),
            Some(MixingCode::M163 | MixingCode::M164 | MixingCode::M165 | MixingCode::M567)
        )
    }

    /// Whether `M<number>` is accepted and needs no simulation: a gradient (`M166`) or a tool
    /// definition (`M563`).
    pub fn sets_nothing_to_follow(number: u32) -> bool {
        matches!(MixingCode::of_m(number), Some(MixingCode::M166 | MixingCode::M563))
    }

    /// Whether `M<number>` belongs with a tool change that is next to it (every mixing code
    /// but the gradient `M166`, which is set up once for the heights to come).
    pub fn goes_with_a_tool_change(number: u32) -> bool {
        MixingCode::of_m(number).is_some_and(|c| c != MixingCode::M166)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_spelling_and_the_old_ones() {
        for f in Firmware::ALL {
            assert_eq!(f.name().parse::<Firmware>(), Ok(f));
            let toml: Firmware = serde::Deserialize::deserialize(serde::de::value::StrDeserializer::<
                serde::de::value::Error,
            >::new(f.name()))
            .unwrap();
            assert_eq!(toml, f);
            for alias in f.aliases() {
                assert_eq!(alias.parse::<Firmware>(), Ok(f), "{alias}");
            }
        }
        assert_eq!("rep_rap_firmware".parse(), Ok(Firmware::RepRapFirmware));
        assert_eq!(
            "rrf".parse::<Firmware>().unwrap_err().to_string(),
            "unknown firmware \"rrf\": expected marlin, klipper, reprapfirmware or linuxcnc"
        );
    }

    /// A slicer's `reprap` flavour is the Sprinter/Marlin family, not RepRapFirmware.
    #[test]
    fn flavours_name_firmware_as_slicers_mean_them() {
        assert_eq!(Firmware::from_flavour("reprap"), None);
        assert_eq!(Firmware::from_flavour("RepRapFirmware"), Some(Firmware::RepRapFirmware));
        assert_eq!(Firmware::from_flavour("machinekit"), Some(Firmware::LinuxCnc));
        assert_eq!(Firmware::resolve(None, Some("klipper")), Firmware::Klipper);
        assert_eq!(Firmware::resolve(Some(Firmware::Marlin), Some("klipper")), Firmware::Marlin);
        assert_eq!(Firmware::resolve(None, Some("Griffin")), Firmware::Marlin);
    }

    #[test]
    fn what_differs() {
        let letters = Firmware::ALL.map(|f| f.extrusion_letter());
        assert_eq!(letters, [b'E', b'E', b'E', b'A']);
        assert_eq!(Firmware::ALL.map(|f| f.inkjet_fire_code()), [Some(700), None, Some(578), None]);
        // After M83 then G90: Marlin's E is absolute again, the others' stays relative.
        let e_abs = Firmware::ALL.map(|f| f.absolute_e_after_g90_g91(true, false));
        assert_eq!(e_abs, [true, false, false, true]);
        // M82 then G91: E relative except on RepRapFirmware.
        assert_eq!(Firmware::ALL.map(|f| f.relative_e(false, true)), [true, true, false, true]);
        assert_eq!(Firmware::RepRapFirmware.mix_commands(), MixCommands::RepRapFirmware);
        assert_eq!(Firmware::Klipper.mix_commands(), MixCommands::Marlin);
    }

    #[test]
    fn what_each_mix_dialect_needs() {
        let all = [MixCommands::Marlin, MixCommands::MarlinDirect, MixCommands::RepRapFirmware];
        assert_eq!(all.map(MixCommands::uses_tools), [true, false, true]);
        assert_eq!(all.map(MixCommands::max_inputs), [None, Some(6), None]);
        assert_eq!(all.map(MixCommands::defines_tools), [false, false, true]);
    }

    #[test]
    fn mixing_codes() {
        let sets: Vec<u32> = (0..1000).filter(|&n| MixingCode::sets_a_mix(n)).collect();
        assert_eq!(sets, [163, 164, 165, 567]);
        let with_t: Vec<u32> = (0..1000).filter(|&n| MixingCode::goes_with_a_tool_change(n)).collect();
        assert_eq!(with_t, [163, 164, 165, 563, 567]);
        let quiet: Vec<u32> = (0..1000).filter(|&n| MixingCode::sets_nothing_to_follow(n)).collect();
        assert_eq!(quiet, [166, 563]);
    }
}
