//! What the virtual board's firmware was built with: the `[firmware]` table of the machine
//! profile.
//!
//! A Marlin board answers a host according to the features compiled into it: `M115` lists them
//! as `Cap:` lines, a command whose feature is absent is `echo:Unknown command: "M600"`. Hosts read
//! the list and behave accordingly (OctoPrint stops polling `M105` when `AUTOREPORT_TEMP` is
//! there, shows its SD panel when `SDCARD` is, answers `//action:prompt_begin` dialogs when
//! `PROMPT_SUPPORT` is). The defaults are a common current Marlin 2.1 build for a printer with a
//! display and an SD slot (the options of `Configuration.h`/`Configuration_adv.h` in the
//! comments). Which commands a key gates is said once, by the rows of the command registry
//! (`interp/commands.rs`) that need its [`Feature`], and shown beside each command in
//! docs/gcode.md's table of the virtual printer's commands; this table says only what a key
//! changes that is not a whole command:
//!
//! ```toml
//! [firmware]
//! kind = "marlin"              # the Marlin model; "gweave": gweave's own controller core
//! eeprom = true                # EEPROM_SETTINGS (a file next to the session)
//! sdcard = true                # SDSUPPORT
//! long_filenames = true        # LONG_FILENAME_HOST_SUPPORT: long names in M20 L (EXTENDED_M20)
//! lfn_write = false            # LONG_FILENAME_WRITE_SUPPORT: M28 creates a long name
//! autoreport_temp = true       # AUTO_REPORT_TEMPERATURES
//! autoreport_pos = false       # AUTO_REPORT_POSITION
//! autoreport_sd = true         # AUTO_REPORT_SD_STATUS: M27 S<seconds>
//! host_action_commands = true  # HOST_ACTION_COMMANDS: //action:...
//! prompt_support = true        # HOST_PROMPT_SUPPORT: //action:prompt_... dialogs
//! emergency_parser = true      # EMERGENCY_PARSER: M108 M112 M410 M876 act at once
//! advanced_pause = true        # ADVANCED_PAUSE_FEATURE (with host prompts)
//! fw_retract = true            # FWRETRACT
//! arcs = true                  # ARC_SUPPORT
//! psu_control = false          # PSU_CONTROL
//! buzzer = true                # a speaker
//! set_progress = true          # SET_PROGRESS_MANUALLY
//! pin_control = true           # DIRECT_PIN_CONTROL
//! probe = false                # a bed probe (Z_PROBE)
//! linear_advance = false       # LIN_ADVANCE (off in Marlin's shipped configuration)
//! mesh = [3, 3]                # bed levelling (AUTO_BED_LEVELING_BILINEAR grid); [] none
//! extrude_max_mm = 200         # PREVENT_LENGTHY_EXTRUDE, EXTRUDE_MAXLENGTH; 0: not built in
//! ```
//!
//! ```
//! use gweave_sim::{BuildOptions, Feature};
//!
//! let fw = BuildOptions::default();
//! assert!(fw.has(Feature::Sdcard) && fw.has(Feature::AdvancedPause) && !fw.has(Feature::PsuControl));
//! assert!(fw.capability_lines().contains(&"Cap:SDCARD:1".to_owned()));
//! ```

use gweave::range;
use serde::{Deserialize, Serialize};

/// The build features of the virtual board (see the module documentation for the defaults).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BuildOptions {
    /// Which firmware the board runs.
    pub kind: FirmwareKind,
    /// `EEPROM_SETTINGS`: the settings are saved and loaded.
    pub eeprom: bool,
    /// `SDSUPPORT`: an SD card.
    pub sdcard: bool,
    /// `LONG_FILENAME_HOST_SUPPORT`: long names, listed by `M20 L` (`EXTENDED_M20`).
    pub long_filenames: bool,
    /// `LONG_FILENAME_WRITE_SUPPORT`: `M28` creates a file under a long name.
    pub lfn_write: bool,
    /// `AUTO_REPORT_TEMPERATURES`: temperatures reported every few seconds.
    pub autoreport_temp: bool,
    /// `AUTO_REPORT_POSITION`: the position reported every few seconds.
    pub autoreport_pos: bool,
    /// `AUTO_REPORT_SD_STATUS`: `M27 S<seconds>`.
    pub autoreport_sd: bool,
    /// `HOST_ACTION_COMMANDS`: `//action:paused`, `//action:resumed`...
    pub host_action_commands: bool,
    /// `HOST_PROMPT_SUPPORT`: `//action:prompt_begin`... dialogs the host answers.
    pub prompt_support: bool,
    /// `EMERGENCY_PARSER`.
    pub emergency_parser: bool,
    /// `ADVANCED_PAUSE_FEATURE`: the filament change (with host prompts).
    pub advanced_pause: bool,
    /// `FWRETRACT`: retraction done by the firmware, with its settings.
    pub fw_retract: bool,
    /// `ARC_SUPPORT`: arcs.
    pub arcs: bool,
    /// `PSU_CONTROL`: the power supply switched on by G-code (`SOFTWARE_POWER`).
    pub psu_control: bool,
    /// A speaker or buzzer.
    pub buzzer: bool,
    /// `SET_PROGRESS_MANUALLY`: the host sets the progress (`BUILD_PERCENT`).
    pub set_progress: bool,
    /// `DIRECT_PIN_CONTROL`: pins set and read by G-code.
    pub pin_control: bool,
    /// A bed probe (`Z_PROBE`).
    pub probe: bool,
    /// `LIN_ADVANCE`: the extruder's pressure advance.
    pub linear_advance: bool,
    /// Bed levelling grid points in X and Y (`GRID_MAX_POINTS_X/Y`); empty when the board has
    /// no levelling.
    pub mesh: Vec<u8>,
    /// `PREVENT_LENGTHY_EXTRUDE` with its `EXTRUDE_MAXLENGTH`, mm of filament: a move that
    /// would feed more in one go (a stray digit, `E1000000`) runs without its E part, as a cold
    /// extrusion does, and the board says `echo: too long extrusion prevented`. 0: not built in.
    pub extrude_max_mm: u32,
    /// What `M0` does: Marlin's stop, or the controller seed's end of program.
    pub m0: ProgramStop,
}

/// Which firmware the virtual board runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FirmwareKind {
    /// The Marlin model of this crate (or Klipper's, by the profile's corners), with the build
    /// options of this table.
    #[default]
    Marlin,
    /// gweave's own controller core, the firmware of the ATmega2560 + RAMPS board
    /// (`crate::core_board`, docs/firmware.md); the other options of this table are not read.
    Gweave,
}

/// What `M0` (program stop) does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProgramStop {
    /// Marlin: finish the queued moves, switch the motors off; the program goes on.
    #[default]
    Marlin,
    /// The controller seed's end of program: finish the moves, home the axes, switch the
    /// motors off and close the serial link; nothing after it runs.
    Seed,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            kind: FirmwareKind::Marlin,
            eeprom: true,
            sdcard: true,
            long_filenames: true,
            lfn_write: false,
            autoreport_temp: true,
            autoreport_pos: false,
            autoreport_sd: true,
            host_action_commands: true,
            prompt_support: true,
            emergency_parser: true,
            advanced_pause: true,
            fw_retract: true,
            arcs: true,
            psu_control: false,
            buzzer: true,
            set_progress: true,
            pin_control: true,
            probe: false,
            linear_advance: false,
            mesh: vec![3, 3],
            extrude_max_mm: 200,
            m0: ProgramStop::Marlin,
        }
    }
}

/// A `[firmware]` value that cannot be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BuildOptionsError {
    /// The mesh is not two sizes of 2 to 15 points.
    #[error("firmware.mesh must be [] or two grid sizes of 2 to 15 points (GRID_MAX_POINTS_X/Y), got {0:?}")]
    Mesh(Vec<u8>),
    /// `EXTRUDE_MAXLENGTH` past the longest move there is.
    #[error("firmware.extrude_max_mm = {0} is out of range: 0 (not built in) to 10000 mm")]
    ExtrudeMax(u32),
    /// A feature that needs another one.
    #[error("firmware.{0} needs firmware.{1}")]
    Needs(&'static str, &'static str),
}

impl BuildOptions {
    /// Checks the values that depend on each other.
    pub fn validate(&self) -> Result<(), BuildOptionsError> {
        let mesh_ok =
            self.mesh.is_empty() || (self.mesh.len() == 2 && self.mesh.iter().all(|n| (2..=15).contains(n)));
        if !mesh_ok {
            return Err(BuildOptionsError::Mesh(self.mesh.clone()));
        }
        if self.extrude_max_mm > range::LEN_MM.max as u32 {
            return Err(BuildOptionsError::ExtrudeMax(self.extrude_max_mm));
        }
        let needs = [
            (self.long_filenames, !self.sdcard, "long_filenames", "sdcard"),
            (self.lfn_write, !self.long_filenames, "lfn_write", "long_filenames"),
            (self.autoreport_sd, !self.sdcard, "autoreport_sd", "sdcard"),
            (self.prompt_support, !self.host_action_commands, "prompt_support", "host_action_commands"),
        ];
        match needs.iter().find(|(on, missing, ..)| *on && *missing) {
            Some(&(_, _, what, needed)) => Err(BuildOptionsError::Needs(what, needed)),
            None => Ok(()),
        }
    }

    /// The bed levelling grid, when the board has one.
    pub fn grid(&self) -> Option<(usize, usize)> {
        match self.mesh[..] {
            [x, y] => Some((usize::from(x), usize::from(y))),
            _ => None,
        }
    }

    /// The `Cap:` lines of `M115`, in Marlin 2.1's order (`Marlin/src/gcode/host/M115.cpp`).
    /// Capabilities the virtual board never has (binary transfer, runout sensor, lights, ...)
    /// are listed as `0`, as Marlin lists its absent ones.
    pub fn capability_lines(&self) -> Vec<String> {
        let levelling = self.grid().is_some();
        let caps: [(&str, bool); 31] = [
            ("SERIAL_XON_XOFF", false),
            ("BINARY_FILE_TRANSFER", false),
            ("EEPROM", self.eeprom),
            ("VOLUMETRIC", true),
            ("AUTOREPORT_POS", self.autoreport_pos),
            ("AUTOREPORT_TEMP", self.autoreport_temp),
            ("PROGRESS", false),
            ("PRINT_JOB", true),
            ("AUTOLEVEL", levelling && self.probe),
            ("RUNOUT", false),
            ("Z_PROBE", self.probe),
            ("LEVELING_DATA", levelling),
            ("BUILD_PERCENT", self.set_progress),
            ("SOFTWARE_POWER", self.psu_control),
            ("TOGGLE_LIGHTS", false),
            ("CASE_LIGHT_BRIGHTNESS", false),
            ("EMERGENCY_PARSER", self.emergency_parser),
            ("HOST_ACTION_COMMANDS", self.host_action_commands),
            ("PROMPT_SUPPORT", self.prompt_support),
            ("SDCARD", self.sdcard),
            ("MULTI_VOLUME", false),
            ("REPEAT", false),
            ("SD_WRITE", self.sdcard),
            ("AUTOREPORT_SD_STATUS", self.autoreport_sd),
            ("LONG_FILENAME", self.long_filenames),
            ("LFN_WRITE", self.lfn_write),
            ("CUSTOM_FIRMWARE_UPLOAD", false),
            ("EXTENDED_M20", self.long_filenames),
            ("THERMAL_PROTECTION", true),
            ("MOTION_MODES", false),
            ("ARCS", self.arcs),
        ];
        // SDCARD's MULTI_VOLUME line is printed only on boards with SD support.
        let tail = [
            ("BABYSTEPPING", false),
            ("CHAMBER_TEMPERATURE", false),
            ("COOLER_TEMPERATURE", false),
            ("MEATPACK", false),
            ("CONFIG_EXPORT", false),
        ];
        caps.iter()
            .filter(|(name, _)| *name != "MULTI_VOLUME" || self.sdcard)
            .chain(tail.iter())
            .map(|(name, on)| format!("Cap:{name}:{}", u8::from(*on)))
            .collect()
    }

    /// Whether this build has `feature` (the `[firmware]` key a command's row in the registry,
    /// `interp/commands.rs`, says it needs).
    pub fn has(&self, feature: Feature) -> bool {
        match feature {
            Feature::Always => true,
            Feature::Eeprom => self.eeprom,
            Feature::Sdcard => self.sdcard,
            Feature::LongFilenames => self.long_filenames,
            Feature::AutoreportTemp => self.autoreport_temp,
            Feature::AutoreportPos => self.autoreport_pos,
            Feature::PromptSupport => self.prompt_support,
            Feature::AdvancedPause => self.advanced_pause,
            Feature::FwRetract => self.fw_retract,
            Feature::Arcs => self.arcs,
            Feature::PsuControl => self.psu_control,
            Feature::Buzzer => self.buzzer,
            Feature::SetProgress => self.set_progress,
            Feature::PinControl => self.pin_control,
            Feature::Probe => self.probe,
            Feature::LinearAdvance => self.linear_advance,
            Feature::Mesh => self.grid().is_some(),
        }
    }
}

/// The build option a command needs, named in its row of the registry (`interp/commands.rs`):
/// a board built without it answers the command as Marlin does one it was not compiled with,
/// `echo:Unknown command: "M600"`. Each is a key of the `[firmware]` table ([`Feature::key`]);
/// which commands need it is said by their rows alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Built into every board.
    Always,
    /// `eeprom`.
    Eeprom,
    /// `sdcard`.
    Sdcard,
    /// `long_filenames`.
    LongFilenames,
    /// `autoreport_temp`.
    AutoreportTemp,
    /// `autoreport_pos`.
    AutoreportPos,
    /// `prompt_support`.
    PromptSupport,
    /// `advanced_pause`.
    AdvancedPause,
    /// `fw_retract`.
    FwRetract,
    /// `arcs`.
    Arcs,
    /// `psu_control`.
    PsuControl,
    /// `buzzer`.
    Buzzer,
    /// `set_progress`.
    SetProgress,
    /// `pin_control`.
    PinControl,
    /// `probe`.
    Probe,
    /// `linear_advance`.
    LinearAdvance,
    /// `mesh` not empty.
    Mesh,
}

impl Feature {
    /// The `[firmware]` key that builds it in, as the `?` reply and docs/gcode.md name it beside
    /// the command (`None`: every board has it).
    pub fn key(self) -> Option<&'static str> {
        Some(match self {
            Feature::Always => return None,
            Feature::Eeprom => "eeprom",
            Feature::Sdcard => "sdcard",
            Feature::LongFilenames => "long_filenames",
            Feature::AutoreportTemp => "autoreport_temp",
            Feature::AutoreportPos => "autoreport_pos",
            Feature::PromptSupport => "prompt_support",
            Feature::AdvancedPause => "advanced_pause",
            Feature::FwRetract => "fw_retract",
            Feature::Arcs => "arcs",
            Feature::PsuControl => "psu_control",
            Feature::Buzzer => "buzzer",
            Feature::SetProgress => "set_progress",
            Feature::PinControl => "pin_control",
            Feature::Probe => "probe",
            Feature::LinearAdvance => "linear_advance",
            Feature::Mesh => "mesh",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m115_lists_marlin_2_1_capabilities_in_order() {
        let lines = BuildOptions::default().capability_lines();
        assert_eq!(lines.first().map(String::as_str), Some("Cap:SERIAL_XON_XOFF:0"));
        assert_eq!(lines.last().map(String::as_str), Some("Cap:CONFIG_EXPORT:0"));
        for cap in [
            "Cap:EEPROM:1",
            "Cap:AUTOREPORT_TEMP:1",
            "Cap:EMERGENCY_PARSER:1",
            "Cap:HOST_ACTION_COMMANDS:1",
            "Cap:PROMPT_SUPPORT:1",
            "Cap:SDCARD:1",
            "Cap:AUTOREPORT_SD_STATUS:1",
            "Cap:EXTENDED_M20:1",
            "Cap:THERMAL_PROTECTION:1",
            "Cap:LEVELING_DATA:1",
            "Cap:AUTOREPORT_POS:0",
        ] {
            assert!(lines.iter().any(|l| l == cap), "{cap} in {lines:?}");
        }
        let bare = BuildOptions {
            sdcard: false,
            long_filenames: false,
            autoreport_sd: false,
            ..BuildOptions::default()
        };
        let lines = bare.capability_lines();
        assert!(lines.contains(&"Cap:SDCARD:0".to_owned()));
        assert!(!lines.iter().any(|l| l.starts_with("Cap:MULTI_VOLUME")));
    }

    #[test]
    fn firmware_table_checks_what_depends_on_what() {
        assert_eq!(BuildOptions::default().validate(), Ok(()));
        let fw = BuildOptions { sdcard: false, ..BuildOptions::default() };
        assert_eq!(fw.validate(), Err(BuildOptionsError::Needs("long_filenames", "sdcard")));
        let fw = BuildOptions { mesh: vec![3], ..BuildOptions::default() };
        assert_eq!(fw.validate(), Err(BuildOptionsError::Mesh(vec![3])));
        let fw: BuildOptions =
            toml::from_str("sdcard = false\nlong_filenames = false\nautoreport_sd = false\n").unwrap();
        assert!(!fw.has(Feature::Sdcard) && !fw.has(Feature::LongFilenames) && fw.has(Feature::Always));
        assert!(toml::from_str::<BuildOptions>("sd_card = true\n").is_err());
    }
}
