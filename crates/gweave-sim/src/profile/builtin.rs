//! The example machine profiles of `examples/machines/`, built into the library so that the
//! `gweave` binary and the Python package both carry them: `--machine klipper` (or
//! `machine="klipper"` in Python) works from any folder, with nothing installed beside the
//! program. A path to a file always works too; a value names a built-in profile only when no
//! file of that name exists, so a user's own `klipper` file is never shadowed.
//!
//! ```
//! use gweave_sim::builtin;
//!
//! let klipper = builtin::find("klipper").unwrap();
//! assert_eq!(klipper.profile().unwrap().name, "Klipper cartesian");
//! assert!(builtin::find("no-such-printer").is_none());
//! ```

use std::path::Path;

use super::{MachineProfile, MachineProfileError};

/// One profile shipped inside the program, with the files it names (a thermistor table).
#[derive(Debug)]
pub struct BuiltinProfile {
    /// What `--machine` takes: the file name in `examples/machines/` without `.toml`.
    pub name: &'static str,
    /// The profile's text, comments included, as in `examples/machines/NAME.toml`.
    pub text: &'static str,
    /// Files the profile names, by the name it uses, with their text.
    files: &'static [(&'static str, &'static str)],
}

macro_rules! example {
    ($name:literal $(, $file:literal)*) => {
        BuiltinProfile {
            name: $name,
            text: include_str!(concat!("../../../../examples/machines/", $name, ".toml")),
            files: &[$(($file, include_str!(concat!("../../../../examples/machines/", $file)))),*],
        }
    };
}

/// Every built-in profile; the first is the default machine written out.
pub const BUILTIN: &[BuiltinProfile] = &[
    example!("marlin-ramps"),
    example!("prusa-mk3"),
    example!("klipper"),
    example!("dual-extruder"),
    example!("prusa-mk3-mmu"),
    example!("mixing-4in"),
    example!("rotary"),
    example!("inkjet-c6602"),
    example!("binder-jet"),
    example!("seed-controller", "seed_ntc.csv"),
    example!("gweave-ramps"),
    example!("gweave-ramps-eeb"),
    example!("gweave-mixing"),
    example!("gweave-rotary"),
];

/// The built-in profile called `name`.
pub fn find(name: &str) -> Option<&'static BuiltinProfile> {
    BUILTIN.iter().find(|b| b.name == name)
}

/// The names of every built-in profile, for messages (`marlin-ramps, prusa-mk3, ...`).
pub fn names() -> String {
    BUILTIN.iter().map(|b| b.name).collect::<Vec<_>>().join(", ")
}

impl BuiltinProfile {
    /// The profile, checked, with the files it names taken from the program too.
    pub fn profile(&self) -> Result<MachineProfile, MachineProfileError> {
        MachineProfile::from_toml_reading(self.text, |name| {
            let text = self.files.iter().find(|(n, _)| Path::new(n) == name).map(|(_, t)| t.to_string());
            (name.to_path_buf(), text.ok_or_else(|| "not built into gweave".to_owned()))
        })
    }

    /// What the printer is: the profile's `name`.
    pub fn summary(&self) -> String {
        self.profile().map(|p| p.name).unwrap_or_default()
    }
}

/// Where a `--machine` value comes from.
#[derive(Debug)]
pub enum MachineSource<'a> {
    /// A profile file (or a path that does not exist and names no built-in profile: reading it
    /// gives the error).
    File(&'a Path),
    /// A built-in profile, named where no file of that name exists.
    Builtin(&'static BuiltinProfile),
}

impl<'a> MachineSource<'a> {
    /// A file when one exists at `value`, else the built-in profile of that name, else the file
    /// (whose reading fails and says so).
    pub fn of(value: &'a Path) -> Self {
        match value.to_str().and_then(find) {
            Some(b) if !value.exists() => MachineSource::Builtin(b),
            _ => MachineSource::File(value),
        }
    }

    /// The profile; a missing file is named with the built-in names beside it.
    pub fn load(&self) -> Result<MachineProfile, LoadError> {
        match self {
            MachineSource::Builtin(b) => {
                b.profile().map_err(|source| LoadError::Profile { path: None, source })
            }
            MachineSource::File(path) => {
                let text = gweave::settings::read_text(path).map_err(|source| {
                    // `slicer` names the limits a slicer wrote into the file, `estimate`'s only,
                    // not a file: said as such, not as a missing file.
                    if path.as_os_str() == "slicer" && source.kind() == std::io::ErrorKind::NotFound {
                        LoadError::SlicerLimits
                    } else {
                        LoadError::Read { path: path.to_path_buf(), source }
                    }
                })?;
                MachineProfile::from_toml_in(&text, path.parent().unwrap_or(Path::new("")))
                    .map_err(|source| LoadError::Profile { path: Some(path.to_path_buf()), source })
            }
        }
    }
}

/// A `--machine` value (`machine=` in Python): a profile file, or a built-in profile's name
/// where no such file exists; the default printer (RAMPS 1.4 on Marlin) without one. What `sim`,
/// `estimate`, `serve`, `check` and `raster` load, from either front end.
pub fn load_machine(value: Option<&Path>) -> Result<MachineProfile, LoadError> {
    value.map_or_else(|| Ok(MachineProfile::default()), |v| MachineSource::of(v).load())
}

/// Why a machine profile could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file cannot be read (for a missing one, the message lists the built-in names).
    #[error("{}", not_found(path, source))]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// `slicer` (the limits a slicer wrote into the file, which `estimate` reads) given to a
    /// command that runs a machine.
    #[error(
        "--machine slicer (the limits the slicer wrote into the file) is for `gweave estimate` only: \
         this command runs a machine; built in: {}; see `gweave machine list`",
        names()
    )]
    SlicerLimits,
    /// The profile is refused (`path`: the file it came from, `None` for a built-in one).
    #[error("{}{}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default(), gweave::with_causes(source))]
    Profile {
        /// The file, if it came from one.
        path: Option<std::path::PathBuf>,
        /// Why.
        source: MachineProfileError,
    },
}

/// `reading PATH: ERROR`, and for a missing file, the names `--machine` also takes.
pub fn not_found(path: &Path, e: &std::io::Error) -> String {
    let mut message = format!("reading {}: {e}", path.display());
    if e.kind() == std::io::ErrorKind::NotFound {
        message.push_str(&format!(
            " (neither a file nor a built-in profile; built in: {}; see `gweave machine list`)",
            names()
        ));
    }
    message
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A new user's trial: `sim --machine slicer` looked for a file called `slicer`; the
    /// message says the name is `estimate`'s only.
    #[test]
    fn the_slicers_limits_are_named_estimates_only() {
        let err = load_machine(Some(Path::new("slicer"))).unwrap_err();
        assert!(matches!(err, LoadError::SlicerLimits), "{err}");
        let said = err.to_string();
        assert!(
            said.starts_with(
                "--machine slicer (the limits the slicer wrote into the file) is for `gweave estimate` only"
            ),
            "{said}"
        );
        assert!(said.contains("prusa-mk3"), "{said}");
    }

    #[test]
    fn every_builtin_profile_loads() {
        for b in BUILTIN {
            let p = b.profile().unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert!(!p.name.is_empty() && !b.summary().is_empty(), "{}", b.name);
        }
        let seed = find("seed-controller").unwrap().profile().unwrap();
        assert!(seed.thermal.thermistor_table_entries.is_some());
    }

    /// Regression: the controller core's profiles (gweave-ramps, gweave-mixing) were added to
    /// examples/machines/ after this list was written, so `--machine gweave-ramps` was "neither a
    /// file nor a built-in profile" from any other folder.
    #[test]
    fn every_example_machine_is_built_in() {
        let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines");
        let mut examples: Vec<String> = std::fs::read_dir(folder)
            .unwrap()
            .filter_map(|e| e.unwrap().file_name().to_str()?.strip_suffix(".toml").map(str::to_owned))
            .collect();
        examples.sort();
        let mut built_in: Vec<String> = BUILTIN.iter().map(|b| b.name.to_owned()).collect();
        built_in.sort();
        assert_eq!(built_in, examples);
    }

    #[test]
    fn the_default_machine_is_the_first_builtin() {
        let written = BUILTIN[0].profile().unwrap();
        assert_eq!(
            MachineProfile { name: MachineProfile::default().name, ..written },
            MachineProfile::default()
        );
    }

    #[test]
    fn machine_klipper_is_a_name_not_a_missing_file() {
        let p = MachineSource::of(Path::new("klipper")).load().unwrap();
        assert_eq!(p.name, "Klipper cartesian");
        let mk3 = MachineSource::of(Path::new("prusa-mk3")).load().unwrap();
        assert_eq!((mk3.bed.x_mm, mk3.bed.y_min_mm, mk3.motion.steps.e), (255.0, -4.0, 280.0));
        let missing = MachineSource::of(Path::new("klipperr")).load().unwrap_err().to_string();
        assert!(missing.contains("reading klipperr: "), "{missing}");
        assert!(missing.contains("built in: marlin-ramps, prusa-mk3, klipper,"), "{missing}");
    }
}
