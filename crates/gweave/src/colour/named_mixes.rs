//! Named mixes: the mixing post-processor seed's 17-colour CMY(K) palette plus user definitions.
//!
//! The built-in palette is Annex A of the mixing seed (docs/seeds.md) (a 4-in/1-out mixing extruder,
//! 2016): inputs E0 cyan, E1 magenta, E2 yellow, E3 white or a second material.
//! Its ratios are kept as printed; two of them sum to 0.99 (Orange 0 : 0.17 :
//! 0.82, Brown 0.33 each) and are normalised like any mix. The seed called
//! E3 alone "Key" (the K of CMYK, which is black), yet loaded it with white or a
//! second material: we call it "White", what the default filament is, and keep
//! "Key" as another name for it ([`ALIASES`]).
//!
//! Users add or override mixes in TOML, by ratios or by a colour to solve for:
//!
//! ```toml
//! [mix.Pink]
//! ratios = [0, 0.6, 0.1, 0.3]
//!
//! [mix.Salmon]
//! colour = "#ff88aa"
//! ```
//!
//! Names are matched without regard to case (`"spring green"` finds `Spring Green`).

use std::collections::{BTreeMap, HashMap};

use serde::Deserialize;

use super::mix::{Mix, MixError};
use super::mixing::MixingModel;
use super::solve::{solve, Solution, OUT_OF_GAMUT_DE};
use super::srgb::Srgb8;

/// The mixing post-processor seed's Annex A (`docs/seeds.md`): name and ratios for E0 cyan, E1 magenta, E2 yellow, E3 white.
pub const SEED_PALETTE: [(&str, [f64; 4]); 17] = [
    ("Cyan", [1.0, 0.0, 0.0, 0.0]),
    ("Ocean", [0.83, 0.17, 0.0, 0.0]),
    ("Blue", [0.5, 0.5, 0.0, 0.0]),
    ("Violet", [0.17, 0.83, 0.0, 0.0]),
    ("Magenta", [0.0, 1.0, 0.0, 0.0]),
    ("Raspberry", [0.0, 0.83, 0.17, 0.0]),
    ("Red", [0.0, 0.5, 0.5, 0.0]),
    ("Orange", [0.0, 0.17, 0.82, 0.0]),
    ("Yellow", [0.0, 0.0, 1.0, 0.0]),
    ("Spring Green", [0.17, 0.0, 0.83, 0.0]),
    ("Green", [0.5, 0.0, 0.5, 0.0]),
    ("Turquoise", [0.83, 0.0, 0.17, 0.0]),
    ("Cyan-Brown", [0.5, 0.25, 0.25, 0.0]),
    ("Magenta-Brown", [0.25, 0.5, 0.25, 0.0]),
    ("Yellow-Brown", [0.25, 0.25, 0.5, 0.0]),
    ("Brown", [0.33, 0.33, 0.33, 0.0]),
    ("White", [0.0, 0.0, 0.0, 1.0]),
];

/// The colour each seed name that names a hue means, for the gamut check of
/// [`Palette::name_out_of_gamut`]: our estimate of a typical PLA filament sold under that name
/// (from vendor swatches, as `super::pigments::CMYW_FILAMENTS`). Cyan, Magenta, Yellow and White are the
/// filaments themselves; the browns of one hue are not checked.
pub const NAMED_COLOURS: [(&str, Srgb8); 10] = [
    ("Ocean", Srgb8::new(0x00, 0x77, 0xa8)),
    ("Blue", Srgb8::new(0x1f, 0x4e, 0x9c)),
    ("Violet", Srgb8::new(0x6c, 0x3b, 0x8e)),
    ("Raspberry", Srgb8::new(0xb0, 0x19, 0x5a)),
    ("Red", Srgb8::new(0xc8, 0x10, 0x2e)),
    ("Orange", Srgb8::new(0xf2, 0x6a, 0x21)),
    ("Spring Green", Srgb8::new(0x7b, 0xc1, 0x43)),
    ("Green", Srgb8::new(0x2e, 0x9a, 0x47)),
    ("Turquoise", Srgb8::new(0x1f, 0xa5, 0xa0)),
    ("Brown", Srgb8::new(0x7a, 0x4b, 0x2a)),
];

/// A palette name is out of the filaments' gamut when the nearest mix they make is more than
/// this CIEDE2000 from the colour the name means ([`NAMED_COLOURS`]). Twice the
/// `OUT_OF_GAMUT_DE` of a `#rrggbb` target: a name asks for a family of colours, not one, and a
/// difference of 10 is about the step from a colour to its neighbour with another name (a blue
/// to a violet). With the default filaments only Blue (nearest #6165ae, 11.8) and Brown (a dark
/// brown: these light filaments have no black; 10.9) are out.
pub const NAME_GAMUT_DE: f64 = 10.0;

/// A palette name whose colour the filaments cannot print ([`Palette::name_out_of_gamut`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NameOutOfGamut {
    /// The colour the name means.
    pub meant: Srgb8,
    /// The palette's ratios' predicted colour.
    pub predicted: Srgb8,
    /// The mix nearest `meant` these filaments make, and how far it is.
    pub nearest: Solution,
}

/// Other names for palette entries: the seed's, where ours differ.
pub const ALIASES: [(&str, &str); 1] = [("Key", "White")];

/// Why a mix definition was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixSpecError {
    /// A colour gives both ratios and a target colour.
    #[error("give either `ratios` or `colour`, not both")]
    Both,
    /// A colour gives neither ratios nor a target colour.
    #[error("give `ratios` or `colour`")]
    Neither,
    /// The ratios are not a valid mix.
    #[error(transparent)]
    Ratios(#[from] MixError),
}

/// Palette errors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PaletteError {
    /// A name that is neither in the palette nor an alias.
    #[error("no colour named {0:?} in the palette")]
    UnknownName(String),
    /// A named mix of the configuration is invalid.
    #[error("mix {name:?}: {source}")]
    Mix {
        /// The mix's name.
        name: String,
        /// Why it is invalid.
        #[source]
        source: MixError,
    },
    /// The palette's TOML cannot be read.
    #[error("palette TOML: {0}")]
    Toml(#[from] toml::de::Error),
}

/// How a named colour is defined.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "RawMixSpec")]
pub enum MixSpec {
    /// Fixed ratios, one per input.
    Ratios(Mix),
    /// A target colour; the ratios come from `solve` for the loaded filaments.
    Colour(Srgb8),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMixSpec {
    ratios: Option<Vec<f64>>,
    colour: Option<Srgb8>,
}

impl TryFrom<RawMixSpec> for MixSpec {
    type Error = MixSpecError;
    fn try_from(raw: RawMixSpec) -> Result<Self, Self::Error> {
        match (raw.ratios, raw.colour) {
            (Some(r), None) => Ok(Self::Ratios(Mix::new(&r)?)),
            (None, Some(c)) => Ok(Self::Colour(c)),
            (Some(_), Some(_)) => Err(MixSpecError::Both),
            (None, None) => Err(MixSpecError::Neither),
        }
    }
}

/// The `[mix.<name>]` tables of a configuration file.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaletteConfig {
    /// The named colours, by name.
    #[serde(default)]
    pub mix: BTreeMap<String, MixSpec>,
}

/// One named colour.
#[derive(Debug, Clone, PartialEq)]
pub struct PaletteEntry {
    /// The colour's name, as written in the palette.
    pub name: String,
    /// How the colour is given: ratios or a target colour.
    pub spec: MixSpec,
}

/// A named colour made concrete for a set of filaments.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    /// The colour's name.
    pub name: String,
    /// The mix that prints it with these filaments.
    pub mix: Mix,
    /// What the mixing model predicts the mix prints as.
    pub predicted: Srgb8,
    /// The wanted colour, for entries defined by colour.
    pub target: Option<Srgb8>,
    /// CIEDE2000 between target and prediction, for entries defined by colour.
    pub delta_e: Option<f64>,
    /// The target is further than `OUT_OF_GAMUT_DE` from anything the filaments make.
    pub out_of_gamut: bool,
}

/// Named mixes in definition order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Palette {
    entries: Vec<PaletteEntry>,
    /// Each entry's index by its name in lower case: a profile of 20 000 mixes took 92 s when
    /// every insert and look-up compared names one by one.
    by_name: HashMap<String, usize>,
}

impl Palette {
    /// The seed's 17 colours, in Annex A order.
    pub fn seed() -> Self {
        let mut palette = Self::default();
        for (name, ratios) in SEED_PALETTE {
            let mix = Mix::new(&ratios).expect("seed ratios are valid");
            palette.insert(name, MixSpec::Ratios(mix));
        }
        palette
    }

    /// The seed palette with the `[mix.<name>]` tables of `text` added on top.
    pub fn from_toml_str(text: &str) -> Result<Self, PaletteError> {
        let config: PaletteConfig = toml::from_str(text)?;
        Ok(Self::seed().with_config(config))
    }

    /// Add the user's mixes (in name order); a name already present is replaced.
    pub fn with_config(mut self, config: PaletteConfig) -> Self {
        for (name, spec) in config.mix {
            self.insert(&name, spec);
        }
        self
    }

    /// Add a mix, or replace the one with the same name (ignoring case).
    pub fn insert(&mut self, name: &str, spec: MixSpec) {
        let entry = PaletteEntry { name: name.to_owned(), spec };
        match self.by_name.get(&name.to_lowercase()) {
            Some(&i) => self.entries[i] = entry,
            None => {
                self.by_name.insert(name.to_lowercase(), self.entries.len());
                self.entries.push(entry);
            }
        }
    }

    /// Look a colour up by name, ignoring case; a name the user defined wins over an alias.
    pub fn get(&self, name: &str) -> Option<&PaletteEntry> {
        let find = |name: &str| self.by_name.get(&name.to_lowercase()).map(|&i| &self.entries[i]);
        find(name).or_else(|| {
            let lower = name.to_lowercase();
            let (_, to) = ALIASES.iter().find(|(alias, _)| alias.to_lowercase() == lower)?;
            find(to)
        })
    }

    /// For a name of the seed palette that still has the seed's ratios and names a hue
    /// ([`NAMED_COLOURS`]): the nearest colour `model`'s filaments make to the one the name
    /// means, when it is more than [`NAME_GAMUT_DE`] away (else `None`). The seed's ratios were
    /// chosen for its own filaments: the seed's "Blue", cyan and magenta 1:1, prints purple with
    /// ours, and no mix of them prints a blue.
    pub fn name_out_of_gamut(&self, name: &str, model: &MixingModel) -> Option<NameOutOfGamut> {
        let entry = self.get(name)?;
        let lower = entry.name.to_lowercase();
        let same_name = |listed: &str| listed.to_lowercase() == lower;
        let (_, ratios) = SEED_PALETTE.iter().find(|(seed, _)| same_name(seed))?;
        let MixSpec::Ratios(mix) = &entry.spec else { return None };
        if mix.ratios() != Mix::new(ratios).ok()?.ratios() {
            return None;
        }
        let (_, meant) = NAMED_COLOURS.iter().find(|(named, _)| same_name(named))?;
        let predicted = model.predict(mix).ok()?;
        let nearest = solve(model, *meant);
        (nearest.delta_e > NAME_GAMUT_DE).then_some(NameOutOfGamut { meant: *meant, predicted, nearest })
    }

    /// Every named colour, in palette order.
    pub fn entries(&self) -> &[PaletteEntry] {
        &self.entries
    }

    /// Ratios and predicted colour of `name` for the filaments of `model`.
    pub fn resolve(&self, name: &str, model: &MixingModel) -> Result<Resolved, PaletteError> {
        let entry = self.get(name).ok_or_else(|| PaletteError::UnknownName(name.to_owned()))?;
        resolve_entry(entry, model)
    }

    /// Every entry resolved, in palette order.
    pub fn resolve_all(&self, model: &MixingModel) -> Result<Vec<Resolved>, PaletteError> {
        self.entries.iter().map(|e| resolve_entry(e, model)).collect()
    }
}

fn resolve_entry(entry: &PaletteEntry, model: &MixingModel) -> Result<Resolved, PaletteError> {
    match &entry.spec {
        MixSpec::Ratios(mix) => {
            let predicted = model
                .predict(mix)
                .map_err(|source| PaletteError::Mix { name: entry.name.clone(), source })?;
            Ok(Resolved {
                name: entry.name.clone(),
                mix: mix.clone(),
                predicted,
                target: None,
                delta_e: None,
                out_of_gamut: false,
            })
        }
        MixSpec::Colour(target) => {
            let s = solve(model, *target);
            Ok(Resolved {
                name: entry.name.clone(),
                mix: s.mix,
                predicted: s.predicted,
                target: Some(*target),
                delta_e: Some(s.delta_e),
                out_of_gamut: s.delta_e > OUT_OF_GAMUT_DE,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::pigments::CMYW_FILAMENTS;
    use crate::colour::Lab;
    use ::palette::GetHue;

    fn ratios(p: &Palette, name: &str) -> Vec<f64> {
        match &p.get(name).unwrap().spec {
            MixSpec::Ratios(m) => m.ratios().to_vec(),
            MixSpec::Colour(c) => panic!("{name} is defined by colour {c}"),
        }
    }

    #[test]
    fn palette_blue_out_of_gamut_is_said() {
        // Issue 39: "Blue" printed purple (#74419f) with no word that no mix prints blue.
        let model = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let p = Palette::seed();
        let blue = p.name_out_of_gamut("blue", &model).unwrap();
        assert_eq!(
            (blue.meant, blue.predicted),
            (Srgb8::new(0x1f, 0x4e, 0x9c), Srgb8::new(0x74, 0x41, 0x9f))
        );
        // Measured: #6165ae at dE00 11.8, cyan-heavy (0.67 : 0.29 : 0.04 : 0).
        assert_eq!(blue.nearest.predicted, Srgb8::new(0x61, 0x65, 0xae));
        assert!((11.0..12.5).contains(&blue.nearest.delta_e), "{}", blue.nearest.delta_e);
        // Reachable names are not flagged, nor the filaments, nor a name the user redefined.
        let out: Vec<&str> = NAMED_COLOURS
            .iter()
            .map(|(n, _)| *n)
            .filter(|n| p.name_out_of_gamut(n, &model).is_some())
            .collect();
        assert_eq!(out, ["Blue", "Brown"]);
        assert_eq!(p.name_out_of_gamut("Cyan", &model), None);
        let mut mine = Palette::seed();
        mine.insert("Blue", MixSpec::Ratios(Mix::new(&[0.7, 0.3, 0.0, 0.0]).unwrap()));
        assert_eq!(mine.name_out_of_gamut("Blue", &model), None);
        // A blue filament on E3 reaches it.
        let with_blue = MixingModel::new(&[
            CMYW_FILAMENTS[0],
            CMYW_FILAMENTS[1],
            CMYW_FILAMENTS[2],
            Srgb8::new(0x1f, 0x4e, 0x9c),
        ])
        .unwrap();
        assert_eq!(p.name_out_of_gamut("Blue", &with_blue), None);
    }

    #[test]
    fn seed_palette_has_annex_a() {
        let p = Palette::seed();
        let names: Vec<&str> = p.entries().iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names.len(), 17);
        assert_eq!(names[0], "Cyan");
        assert_eq!(names[16], "White");
        // The seed's name for it still works.
        assert_eq!(p.get("key").unwrap().name, "White");
        assert_eq!(ratios(&p, "ocean"), [0.83, 0.17, 0.0, 0.0]);
        assert_eq!(ratios(&p, "SPRING GREEN"), [0.17, 0.0, 0.83, 0.0]);
        assert_eq!(ratios(&p, "cyan-brown"), [0.5, 0.25, 0.25, 0.0]);
        assert_eq!(ratios(&p, "White"), [0.0, 0.0, 0.0, 1.0]);
        // Printed as 0.17 : 0.82, which sums to 0.99.
        let orange = ratios(&p, "Orange");
        assert!((orange[1] - 17.0 / 99.0).abs() < 1e-12 && (orange[2] - 82.0 / 99.0).abs() < 1e-12);
        assert!(p.get("Pink").is_none());
    }

    #[test]
    fn seed_colours_print_the_hues_they_are_named_after() {
        let model = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let p = Palette::seed();
        // Around the CMY ring the predicted hue must turn one way, once round.
        // (Absolute hues are the model's weak point: its "Orange" is a red-orange.)
        let ring = [
            "Magenta",
            "Raspberry",
            "Red",
            "Orange",
            "Yellow",
            "Spring Green",
            "Green",
            "Turquoise",
            "Cyan",
            "Ocean",
            "Blue",
            "Violet",
            "Magenta",
        ];
        let hue =
            |name| Lab::from(p.resolve(name, &model).unwrap().predicted).get_hue().into_positive_degrees();
        let mut turned = 0.0;
        for pair in ring.windows(2) {
            let step = (hue(pair[1]) - hue(pair[0])).rem_euclid(360.0);
            assert!(step > 0.0 && step < 180.0, "{pair:?} turns by {step}");
            turned += step;
        }
        assert!((turned - 360.0).abs() < 1e-9, "{turned}");
        let green = hue("Green");
        assert!((120.0..165.0).contains(&green), "Green hue {green}");
        let key = p.resolve("key", &model).unwrap();
        assert_eq!(key.predicted, CMYW_FILAMENTS[3]);
        assert_eq!((key.target, key.delta_e), (None, None));
    }

    /// Regression: a mix profile of 20 000 mixes took 92 s (10 000: 20 s) because every insert
    /// and look-up compared the name with every entry's, lower-casing both each time.
    #[test]
    fn a_palette_of_20000_mixes_builds_and_finds_in_linear_time() {
        let mix = Mix::new(&[1.0, 0.0, 0.0, 0.0]).unwrap();
        let config = PaletteConfig {
            mix: (0..20_000).map(|i| (format!("Mix{i}"), MixSpec::Ratios(mix.clone()))).collect(),
        };
        let started = std::time::Instant::now();
        let p = Palette::seed().with_config(config);
        assert!((0..20_000).all(|i| p.get(&format!("mix{i}")).is_some_and(|e| e.name == format!("Mix{i}"))));
        assert_eq!(p.entries().len(), 17 + 20_000);
        assert_eq!(p.get("key").unwrap().name, "White", "aliases still resolve");
        // Linear: about 0.1 s in a debug build; the quadratic search took minutes.
        assert!(started.elapsed() < std::time::Duration::from_secs(10), "{:?}", started.elapsed());
    }

    #[test]
    fn user_mixes_from_toml() {
        let text = r##"
            [mix.Pink]
            ratios = [0, 0.6, 0.1, 0.3]

            [mix.Salmon]
            colour = "#ff88aa"

            [mix.blue]
            ratios = [3, 1, 0, 0]
        "##;
        let p = Palette::from_toml_str(text).unwrap();
        assert_eq!(p.entries().len(), 19);
        assert_eq!(ratios(&p, "pink"), [0.0, 0.6, 0.1, 0.3]);
        assert_eq!(ratios(&p, "Blue"), [0.75, 0.25, 0.0, 0.0]);
        assert_eq!(p.get("salmon").unwrap().spec, MixSpec::Colour(Srgb8::new(0xff, 0x88, 0xaa)));
        let model = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let salmon = p.resolve("Salmon", &model).unwrap();
        assert_eq!(salmon.target, Some(Srgb8::new(0xff, 0x88, 0xaa)));
        let de = salmon.delta_e.unwrap();
        assert_eq!(salmon.out_of_gamut, de > OUT_OF_GAMUT_DE);
        // Pink is mostly white with magenta, a little yellow, no cyan.
        assert!(de < 2.0, "{salmon:?}");
        let w = salmon.mix.ratios();
        assert!(w[0] == 0.0 && w[1] > 0.1 && w[2] < w[1] && w[3] > 0.5, "{salmon:?}");
    }

    #[test]
    fn bad_definitions_are_rejected() {
        for text in [
            "[mix.X]\nratios = [1, 0]\ncolour = \"#000000\"",
            "[mix.X]\n",
            "[mix.X]\nratios = [0, 0, 0, 0]",
            "[mix.X]\nratios = [1, -1, 0, 0]",
            "[mix.X]\ncolour = \"red\"",
            "[mix.X]\nratio = [1, 0, 0, 0]",
            "[colours.X]\nratios = [1, 0, 0, 0]",
        ] {
            assert!(matches!(Palette::from_toml_str(text), Err(PaletteError::Toml(_))), "accepted: {text}");
        }
        let err = Palette::from_toml_str("[mix.X]\nratios = [0, 0]").unwrap_err();
        assert!(err.to_string().contains("all ratios are zero"), "{err}");
    }

    #[test]
    fn resolve_errors() {
        let model = MixingModel::new(&CMYW_FILAMENTS[..3]).unwrap();
        let p = Palette::seed();
        assert_eq!(p.resolve("Pink", &model), Err(PaletteError::UnknownName("Pink".into())));
        assert!(matches!(
            p.resolve("Red", &model),
            Err(PaletteError::Mix { source: MixError::InputCount { expected: 3, found: 4 }, .. })
        ));
    }
}
