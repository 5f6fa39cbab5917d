//! `--dialect` for the firmware ([`gweave::firmware::Firmware`]): its one spelling and the older
//! ones as hidden aliases, so `--help` lists the names the docs use and old scripts still run.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use gweave::firmware::Firmware;

/// A parser accepting the firmwares `choices` lists (each with its help line) by name or alias.
pub fn firmware_parser(choices: &[(Firmware, &'static str)]) -> impl TypedValueParser<Value = Firmware> {
    let values = choices
        .iter()
        .map(|&(f, help)| PossibleValue::new(f.name()).help(help).aliases(f.aliases().iter().copied()));
    // Every listed value is a name or an alias, which parse.
    PossibleValuesParser::new(values).map(|name| name.parse::<Firmware>().unwrap_or_default())
}

/// The firmwares with an inkjet fire command, for `raster --dialect`.
pub fn inkjet_firmware() -> impl TypedValueParser<Value = Firmware> {
    firmware_parser(&[
        (Firmware::Marlin, "`M700 P S` (Marlin hpc6602)"),
        (Firmware::RepRapFirmware, "`M578 P S` (RepRapFirmware; `reprap` still accepted)"),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `raster --dialect` takes the one spelling and the old ones, and only firmwares that fire.
    #[test]
    fn raster_dialect_takes_the_spelling_and_the_old_ones() {
        let command = || {
            clap::Command::new("t").arg(clap::Arg::new("d").long("dialect").value_parser(inkjet_firmware()))
        };
        let rrf = Firmware::RepRapFirmware;
        for (name, want) in [
            ("marlin", Firmware::Marlin),
            ("reprapfirmware", rrf),
            ("reprap", rrf),
            ("rep_rap_firmware", rrf),
        ] {
            let matches = command().try_get_matches_from(["t", "--dialect", name]).unwrap();
            assert_eq!(matches.get_one::<Firmware>("d"), Some(&want), "{name}");
        }
        assert!(command().try_get_matches_from(["t", "--dialect", "klipper"]).is_err());
    }
}
