//! A job's options, each declared once: its name, type, range, default and help.
//!
//! A job (`purge-shift`, `mix`) takes one options type declared with [`job_options!`](crate::job_options). Both
//! front ends are derived from that declaration: the CLI builds its flags from
//! [`JobOptions::SPEC`] (`purge_mm` is `--purge-mm`, with the help, value name, range and
//! aliases stated here), Python reads its keywords by the same names and a test holds the typed
//! wrapper's signature to the same list; the run's header (`; gweave 0.1.0 purge-shift
//! --purge-mm 2.5 (generated)`) is written from the options value ([`JobOptions::header`]), in
//! the CLI's words whichever front end ran it. Adding an option is a line in the declaration
//! and its use.
//!
//! An option's value is checked here once, against its [`Range`] or its type's words, and a
//! refusal is an [`OptionError`] carrying the option's identity: each front end spells it
//! ([`Spelling::Flag`]: `--purge-mm`, [`Spelling::Keyword`]: `purge_mm`).
//!
//! ```
//! use gweave::options::{JobOptions, Spelling, Value};
//! use gweave::post::purge_shift::PurgeShiftOptions;
//! let mut o = PurgeShiftOptions::default();
//! let purge_mm = PurgeShiftOptions::spec("purge_mm").unwrap();
//! o.set(purge_mm, Value::Number(2.5)).unwrap();
//! assert_eq!(o.header(), "--purge-mm 2.5");
//! let err = o.set(purge_mm, Value::Number(1e9)).unwrap_err();
//! assert_eq!(err.spelled(Spelling::Flag), "--purge-mm 1e9 is out of range: 0 to 1000 mm");
//! assert_eq!(err.spelled(Spelling::Keyword), "purge_mm = 1e9 is out of range: 0 to 1000 mm");
//! ```

use std::fmt;
use std::path::{Path, PathBuf};

use serde::de::{value::Error as WordError, DeserializeOwned, IntoDeserializer};
use serde::Serialize;

use crate::range::{short, Range};

/// How an option takes its value, which decides how each front end reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A switch (`--cross-layers`, `cross_layers=True`).
    Flag,
    /// One number within the option's range (`--purge-mm 2.5`, `purge_mm=2.5`).
    Number,
    /// One whole number within the option's range (`--layer 12`, `layer=12`).
    Whole,
    /// One word (`--fallback tower`, `fallback="tower"`).
    Text,
    /// A file (`-c mix.toml`, `config="mix.toml"`).
    Path,
    /// Each use adds one text (`--at-layer 0=Red --at-layer 5=Blue`, `at_layer=["0=Red", ...]`).
    Repeated,
    /// Comma-separated texts, exactly this many unless 0 (`--markers BEGIN,END`).
    Texts(usize),
    /// Exactly this many comma-separated numbers, each within the range (`--tower-at 10,20`).
    Numbers(usize),
}

/// An option's value as a front end read it.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// [`Kind::Flag`].
    Flag(bool),
    /// [`Kind::Number`] and [`Kind::Whole`].
    Number(f64),
    /// [`Kind::Text`].
    Text(String),
    /// [`Kind::Path`].
    Path(PathBuf),
    /// [`Kind::Repeated`] and [`Kind::Texts`].
    Texts(Vec<String>),
    /// [`Kind::Numbers`].
    Numbers(Vec<f64>),
}

/// How a front end shows an option besides its name and help: what it declares in
/// [`job_options!`](crate::job_options) after `=`.
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    /// The value's placeholder in the CLI's help (`MM`, `X,Y`).
    pub value_name: &'static str,
    /// The range of a number (or of each of several).
    pub range: Option<Range>,
    /// The CLI's one-letter flag (`-c`).
    pub short: Option<char>,
    /// Older CLI names still read (`--purge`); the header writes the option's own.
    pub aliases: &'static [&'static str],
    /// Options that cannot be given with this one.
    pub conflicts: &'static [&'static str],
    /// A switch whose CLI flag turns it off (`--no-interweave` sets `interweave` false); Python
    /// takes the keyword itself (`interweave=False`).
    pub negated: bool,
    /// What separates the values of [`Kind::Texts`] and [`Kind::Numbers`] on the command line
    /// and in the header (`,`: `10,20`; `x`: `1200x900`).
    pub separator: char,
}

impl Shape {
    /// An option whose value the CLI's help shows as `value_name` (empty for a switch).
    pub const fn new(value_name: &'static str) -> Self {
        Shape {
            value_name,
            range: None,
            short: None,
            aliases: &[],
            conflicts: &[],
            negated: false,
            separator: ',',
        }
    }
    /// Its numbers within `range`.
    pub const fn range(mut self, range: Range) -> Self {
        self.range = Some(range);
        self
    }
    /// Its whole numbers (an `Option<u32>` field: a count of layers, chords per turn) within
    /// `range`.
    pub const fn whole(mut self, range: Range<u32>) -> Self {
        self.range =
            Some(Range { min: range.min as f64, max: range.max as f64, unit: range.unit, zero: range.zero });
        self
    }
    /// Its CLI flag is `--no-<name>`, which sets it false.
    pub const fn negated(mut self) -> Self {
        self.negated = true;
        self
    }
    /// Its one-letter CLI flag.
    pub const fn short(mut self, letter: char) -> Self {
        self.short = Some(letter);
        self
    }
    /// Older CLI names still read.
    pub const fn aliases(mut self, names: &'static [&'static str]) -> Self {
        self.aliases = names;
        self
    }
    /// Options refused with this one.
    pub const fn conflicts(mut self, names: &'static [&'static str]) -> Self {
        self.conflicts = names;
        self
    }
    /// Its several values separated by `separator` rather than `,` (`WIDTHxHEIGHT`).
    pub const fn separator(mut self, separator: char) -> Self {
        self.separator = separator;
        self
    }
}

/// One option of a job, declared once in [`job_options!`](crate::job_options).
#[derive(Debug, Clone, Copy)]
pub struct OptionSpec {
    /// The Python keyword and the field (`purge_mm`); the CLI flag is [`OptionSpec::flag`].
    pub name: &'static str,
    /// How it takes its value (from the field's type).
    pub kind: Kind,
    /// The doc comment of the field, as written.
    pub doc: &'static str,
    /// Its default as a word, where the default is a value (`mix`) rather than "unset".
    pub default: fn() -> Option<String>,
    /// Value name, range, short flag, aliases, conflicts.
    pub shape: Shape,
}

impl OptionSpec {
    /// The CLI's long flag, without the dashes (`purge-mm`; `no-interweave` for a negated
    /// switch).
    pub fn flag(&self) -> String {
        let flag = self.name.replace('_', "-");
        if self.shape.negated {
            format!("no-{flag}")
        } else {
            flag
        }
    }

    /// `value` (as [`JobOptions::values`] gives it) is one the CLI says with this option's flag:
    /// given, and for a switch the way its flag turns it (`--helical` on, `--no-interweave`
    /// off). A switch given the other way (`keep_arc_length=False` over a settings file's) only
    /// restores a default: it conflicts with nothing and the header leaves it out.
    pub fn said(&self, value: &Option<Value>) -> bool {
        match value {
            None => false,
            Some(Value::Flag(on)) => *on != self.shape.negated,
            Some(_) => true,
        }
    }

    /// The help text, one paragraph: the doc comment's lines joined.
    pub fn help(&self) -> String {
        self.doc.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
    }

    /// A value as the CLI types it (`2.5`, `10,20`), read and checked.
    pub fn parse(&self, text: &str) -> Result<Value, OptionError> {
        let refuse = |problem| OptionError { option: self.name, problem };
        let number = |word: &str| -> Result<f64, OptionError> {
            let word = word.trim();
            word.parse().map_err(|e| refuse(Problem::Invalid(format!("{word:?}: {e}"))))
        };
        let value = match self.kind {
            Kind::Flag => Value::Flag(true),
            Kind::Number | Kind::Whole => Value::Number(number(text)?),
            Kind::Text => Value::Text(text.to_owned()),
            Kind::Path => Value::Path(PathBuf::from(text)),
            Kind::Repeated => Value::Texts(vec![text.to_owned()]),
            Kind::Texts(_) => Value::Texts(text.split(self.shape.separator).map(str::to_owned).collect()),
            Kind::Numbers(_) => {
                Value::Numbers(text.split(self.shape.separator).map(number).collect::<Result<_, _>>()?)
            }
        };
        self.check(value)
    }

    /// `value` within the option's range and count, as both front ends check it.
    pub fn check(&self, value: Value) -> Result<Value, OptionError> {
        let refuse = |problem| Err(OptionError { option: self.name, problem });
        let count = match (self.kind, &value) {
            (Kind::Texts(n) | Kind::Numbers(n), Value::Texts(v)) if n > 0 => Some((n, v.len())),
            (Kind::Numbers(n), Value::Numbers(v)) => Some((n, v.len())),
            _ => None,
        };
        if let Some((expected, got)) = count.filter(|(n, got)| n != got) {
            return refuse(Problem::Count { expected, got, value_name: self.shape.value_name });
        }
        let numbers = match &value {
            Value::Number(v) => std::slice::from_ref(v),
            Value::Numbers(v) => v.as_slice(),
            _ => &[],
        };
        match self
            .shape
            .range
            .and_then(|range| Some((*numbers.iter().find(|v| !range.contains(**v))?, range)))
        {
            Some((value, range)) => refuse(Problem::OutOfRange { value, range }),
            None => Ok(value),
        }
    }
}

/// How a front end names an option in a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spelling {
    /// The CLI's flag: `--purge-mm`.
    Flag,
    /// Python's keyword (and the settings file's key): `purge_mm`.
    Keyword,
}

impl Spelling {
    /// The option `name` (`purge_mm`) in this spelling.
    pub fn name(self, name: &str) -> String {
        match self {
            Spelling::Flag => format!("--{}", name.replace('_', "-")),
            Spelling::Keyword => name.to_owned(),
        }
    }
}

/// A job's error as a front end reports it, one way for every job: the message with the
/// options it names spelled the front end's way, and whether the system refused a file or an
/// operation, which a front end raises as its I/O error (Python's `OSError` for the errno).
pub trait JobFailure: std::error::Error + Sized + 'static {
    /// The message, an option named as `spelling` names it (`--purge-mm`, `purge_mm`).
    fn spelled(&self, spelling: Spelling) -> String;

    /// The file the system refused and its error, if that is what failed.
    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        None
    }

    /// Whether the system refused something that names no file (a write): an I/O error among
    /// the causes.
    fn io_failed(&self) -> bool {
        causes(self).any(|c| c.is::<std::io::Error>())
    }

    /// [`JobFailure::spelled`], then each cause the message does not already say,
    /// `: `-separated (`reading x.png: invalid PNG signature`), for a front end that shows one
    /// line.
    fn said(&self, spelling: Spelling) -> String {
        let mut text = self.spelled(spelling);
        // What is said so far in the engine's own words, which a cause's text is held to (the
        // spelled text may name its options otherwise).
        let mut known = self.to_string();
        for cause in causes(self) {
            let cause = cause.to_string();
            if !known.contains(&cause) {
                text = format!("{text}: {cause}");
                known = format!("{known}: {cause}");
            }
        }
        text
    }
}

/// The causes of `e`, nearest first.
fn causes<'e>(
    e: &'e (dyn std::error::Error + 'static),
) -> impl Iterator<Item = &'e (dyn std::error::Error + 'static)> {
    std::iter::successors(e.source(), |c| c.source())
}

impl JobFailure for crate::Error {
    fn spelled(&self, _: Spelling) -> String {
        self.to_string()
    }

    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        match self {
            crate::Error::Io { path, source } => Some((path, source)),
            _ => None,
        }
    }
}

/// A sentence that names options (`nothing to do: give a schedule (at_layer, at_z)...`) with
/// each option's identity kept, so that each front end writes it as it spells it
/// ([`Said::spelled`]): the CLI `--at-layer`, Python `at_layer`. `Display` uses the keyword.
///
/// ```
/// use gweave::options::{Said, Spelling};
/// let said = Said::new("add a tool map for T1 (").option("map").text(" T1=<mix>)");
/// assert_eq!(said.spelled(Spelling::Flag), "add a tool map for T1 (--map T1=<mix>)");
/// assert_eq!(said.spelled(Spelling::Keyword), "add a tool map for T1 (map T1=<mix>)");
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Said(Vec<(String, Option<&'static str>)>);

impl Said {
    /// A sentence beginning with `text`.
    pub fn new(text: impl Into<String>) -> Self {
        Said(vec![(text.into(), None)])
    }
    /// Then `text`.
    pub fn text(mut self, text: impl Into<String>) -> Self {
        self.0.push((text.into(), None));
        self
    }
    /// Then the option `name` (`at_layer`), as the reader's front end spells it.
    pub fn option(mut self, name: &'static str) -> Self {
        self.0.push((String::new(), Some(name)));
        self
    }
    /// The sentence, its options spelled as `spelling` spells them.
    pub fn spelled(&self, spelling: Spelling) -> String {
        self.0
            .iter()
            .map(|(text, option)| option.map_or_else(|| text.clone(), |o| spelling.name(o)))
            .collect()
    }
}

impl fmt::Display for Said {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.spelled(Spelling::Keyword))
    }
}

/// What is wrong with an option's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Problem {
    /// A number outside the option's range.
    OutOfRange {
        /// The number given.
        value: f64,
        /// The option's range.
        range: Range,
    },
    /// Not as many comma-separated values as the option takes.
    Count {
        /// How many it takes.
        expected: usize,
        /// How many were given.
        got: usize,
        /// Their placeholder (`X,Y`).
        value_name: &'static str,
    },
    /// A value the option's type cannot read (its own message).
    Invalid(String),
    /// Given with an option it excludes (that option's name).
    Conflict(&'static str),
}

/// An option refused: its identity and why; each front end spells the option its own way
/// ([`OptionError::spelled`]); `Display` uses the keyword.
#[derive(Debug, Clone, PartialEq)]
pub struct OptionError {
    /// The option (`purge_mm`).
    pub option: &'static str,
    /// What is wrong.
    pub problem: Problem,
}

impl OptionError {
    /// The message, the option named as `spelling` names it.
    pub fn spelled(&self, spelling: Spelling) -> String {
        let name = spelling.name(self.option);
        match &self.problem {
            Problem::OutOfRange { value, range } => {
                range.check(&name, *value).err().map_or_else(String::new, |e| e.to_string())
            }
            Problem::Conflict(other) => format!("{name} and {}: give one of them", spelling.name(other)),
            _ => format!("{name}: {}", self.reason()),
        }
    }

    /// The message without the option's name, for a front end that names it itself (clap's
    /// "invalid value '1e9' for '--purge-mm \<MM>': out of range: 0 to 1000 mm").
    pub fn reason(&self) -> String {
        match &self.problem {
            Problem::OutOfRange { range, .. } => format!("out of range: {range}"),
            Problem::Count { expected, got, value_name } => {
                format!("takes {expected} values ({value_name}), not {got}")
            }
            Problem::Invalid(why) => why.clone(),
            Problem::Conflict(other) => format!("cannot be given with {other}"),
        }
    }
}

impl fmt::Display for OptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.spelled(Spelling::Keyword))
    }
}

impl std::error::Error for OptionError {}

/// A job's options type, implemented by [`job_options!`](crate::job_options).
pub trait JobOptions: Default + Sized {
    /// The command it belongs to, as the CLI names it (`purge-shift`).
    const COMMAND: &'static str;
    /// Every option, in declaration order.
    const SPEC: &'static [OptionSpec];

    /// Sets the option `spec` (one of [`JobOptions::SPEC`]) to `value`, checked against its
    /// range and type.
    fn set(&mut self, spec: &OptionSpec, value: Value) -> Result<(), OptionError>;

    /// The option called `name` (`purge_mm`), if there is one.
    fn spec(name: &str) -> Option<&'static OptionSpec> {
        Self::SPEC.iter().find(|s| s.name == name)
    }

    /// Each option's value in [`JobOptions::SPEC`]'s order; `None` where it is left at its
    /// default.
    fn values(&self) -> Vec<Option<Value>>;

    /// Refuses two options given that exclude each other (`purge_mm` and `purge_mm3`).
    fn check_conflicts(&self) -> Result<(), OptionError> {
        let values = self.values();
        let given = |name: &str| Self::SPEC.iter().zip(&values).any(|(s, v)| s.name == name && s.said(v));
        for (spec, value) in Self::SPEC.iter().zip(&values) {
            if let Some(other) = spec.shape.conflicts.iter().find(|o| spec.said(value) && given(o)) {
                return Err(OptionError { option: spec.name, problem: Problem::Conflict(other) });
            }
        }
        Ok(())
    }

    /// Checks the options as the declaration states them: each value within its range and
    /// count ([`OptionSpec::check`], as [`JobOptions::set`] checks a value read), then no two
    /// given that exclude each other. For options made in code (a struct literal), which no
    /// front end has read: the one check, with the messages a front end's would give.
    fn check(&self) -> Result<(), OptionError> {
        for (spec, value) in Self::SPEC.iter().zip(self.values()) {
            if let Some(value) = value {
                spec.check(value)?;
            }
        }
        self.check_conflicts()
    }

    /// The options given, in the CLI's words and [`JobOptions::SPEC`]'s order, for the run's
    /// header: `-c mix.toml --at-layer 0=Red --purge-mm 25`.
    fn header(&self) -> String {
        let quote =
            |a: String| if a.is_empty() || a.contains([' ', '\t', '\'', '"']) { format!("{a:?}") } else { a };
        let mut words = Vec::new();
        for (spec, value) in Self::SPEC.iter().zip(self.values()) {
            let flag = spec.shape.short.map_or_else(|| format!("--{}", spec.flag()), |c| format!("-{c}"));
            if !spec.said(&value) {
                continue;
            }
            let each: Vec<String> = match value {
                None => continue,
                Some(Value::Flag(_)) => {
                    words.push(flag);
                    continue;
                }
                Some(Value::Texts(t)) if spec.kind == Kind::Repeated => t,
                Some(value) => vec![word(&value, spec.shape.separator)],
            };
            for word in each {
                words.extend([flag.clone(), quote(word)]);
            }
        }
        words.join(" ")
    }
}

/// `value` as one word of the command line (`2.5`, `10,20`, `1200x900`), its several values
/// joined by `separator`.
fn word(value: &Value, separator: char) -> String {
    let join = |words: Vec<String>| words.join(&separator.to_string());
    match value {
        Value::Flag(on) => on.to_string(),
        Value::Number(v) => short(*v),
        Value::Text(t) => t.clone(),
        Value::Path(p) => p.display().to_string(),
        Value::Texts(t) => join(t.clone()),
        Value::Numbers(v) => join(v.iter().copied().map(short).collect()),
    }
}

/// The default of a field as its option's word, given the field at its declared default: a
/// value (`0.5`, `after`, `false`), or `None` for an unset field.
pub fn default_word<F: OptionField>(field: &F, separator: char) -> Option<String> {
    field.to_value().map(|v| word(&v, separator))
}

/// A field's value for the header: `None` where it equals the declared default (`value`,
/// `default` as [`OptionField::to_value`] gives them).
pub fn unless_default(value: Option<Value>, default: Option<Value>) -> Option<Value> {
    value.filter(|v| Some(v) != default.as_ref())
}

/// The options of `parts` one after another, as one list of `N` (their lengths' sum): the
/// [`JobOptions::SPEC`] of a job that shares a group of options with others
/// ([`job_options!`](crate::job_options)'s `..group: Type,`).
pub const fn joined<const N: usize>(parts: &[&[OptionSpec]]) -> [OptionSpec; N] {
    let unset = OptionSpec { name: "", kind: Kind::Flag, doc: "", default: no_word, shape: Shape::new("") };
    let mut all = [unset; N];
    let (mut part, mut at, mut i) = (0, 0, 0);
    while part < parts.len() {
        while at < parts[part].len() {
            all[i] = parts[part][at];
            (at, i) = (at + 1, i + 1);
        }
        (part, at) = (part + 1, 0);
    }
    assert!(i == N, "N is the sum of the parts' lengths");
    all
}

fn no_word() -> Option<String> {
    None
}

/// A field type an option can have: how it takes a [`Value`] and gives it back.
pub trait OptionField: Sized {
    /// How its value is given.
    const KIND: Kind;
    /// The field from a checked value of its kind.
    fn from_value(value: Value) -> Result<Self, Problem>;
    /// Its value, `None` when unset; a type whose default is a value always has one (the
    /// header leaves it out at the declared default: [`unless_default`]).
    fn to_value(&self) -> Option<Value>;
}

fn wrong_kind(value: &Value) -> Problem {
    Problem::Invalid(format!("not a value of this option's kind: {value:?}"))
}

macro_rules! field {
    ($ty:ty, $kind:expr, $pattern:pat => $field:expr, $this:ident => $value:expr) => {
        impl OptionField for $ty {
            const KIND: Kind = $kind;
            fn from_value(value: Value) -> Result<Self, Problem> {
                match value {
                    $pattern => Ok($field),
                    other => Err(wrong_kind(&other)),
                }
            }
            fn to_value(&self) -> Option<Value> {
                let $this = self;
                $value
            }
        }
    };
}

field!(bool, Kind::Flag, Value::Flag(b) => b, b => Some(Value::Flag(*b)));
// Unset, or a switch given either way (`keep_arc_length=False` turns a settings file's on off).
field!(Option<bool>, Kind::Flag, Value::Flag(b) => Some(b), b => b.map(Value::Flag));
field!(Option<f64>, Kind::Number, Value::Number(v) => Some(v), v => v.map(Value::Number));
// A number or count whose default is a value (`threshold: f64 = ... => 0.5`): always said; the
// header leaves it out at its declared default.
field!(f64, Kind::Number, Value::Number(v) => v, v => Some(Value::Number(*v)));
field!(Option<u32>, Kind::Whole, Value::Number(v) => Some(whole(v)?), v => v.map(|v| Value::Number(v.into())));
field!(u32, Kind::Whole, Value::Number(v) => whole(v)?, v => Some(Value::Number((*v).into())));
// Three letters (axial, rotary, radial axes): `X,A,Z` or `XAZ`, either case.
field!(Option<[char; 3]>, Kind::Texts(0), Value::Texts(t) => Some(letters(&t)?),
    t => t.map(|t| Value::Texts(t.iter().map(char::to_string).collect())));
field!(Option<String>, Kind::Text, Value::Text(t) => Some(t), t => t.clone().map(Value::Text));
field!(Option<PathBuf>, Kind::Path, Value::Path(p) => Some(p), p => p.clone().map(Value::Path));
field!(Vec<String>, Kind::Repeated, Value::Texts(t) => t,
    t => (!t.is_empty()).then(|| Value::Texts(t.clone())));
field!(Option<Vec<String>>, Kind::Texts(0), Value::Texts(t) => Some(t), t => t.clone().map(Value::Texts));
field!(Option<[String; 2]>, Kind::Texts(2), Value::Texts(t) => Some(pair(t)?),
    t => t.clone().map(|t| Value::Texts(t.into())));
field!(Option<[f64; 2]>, Kind::Numbers(2), Value::Numbers(v) => Some(pair(v)?),
    v => v.map(|v| Value::Numbers(v.into())));

/// `v` as a whole number (a layer, a pixel count); its range is the option's, checked before.
pub fn whole(v: f64) -> Result<u32, Problem> {
    if v.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&v) {
        Ok(v as u32)
    } else {
        Err(Problem::Invalid(format!("{} is not a whole number", short(v))))
    }
}

fn letters(texts: &[String]) -> Result<[char; 3], Problem> {
    let all: Vec<char> =
        texts.iter().flat_map(|t| t.trim().chars()).map(|c| c.to_ascii_uppercase()).collect();
    all.try_into()
        .map_err(|_| Problem::Invalid(format!("takes 3 letters (X,A,Z), not {:?}", texts.join(","))))
}

fn pair<T>(v: Vec<T>) -> Result<[T; 2], Problem> {
    let got = v.len();
    v.try_into().map_err(|_| Problem::Count { expected: 2, got, value_name: "A,B" })
}

/// An enumeration read by its settings-file word (`perceived`, `reprapfirmware`): with
/// [`word_option!`](crate::word_option) it is an option of [`Kind::Text`], bare (its default is a value) or in an
/// `Option` (unset by default).
pub trait Word: Serialize + DeserializeOwned + Default + PartialEq {
    /// Reads the word as the settings file does.
    fn read(text: &str) -> Result<Self, Problem> {
        Self::deserialize(text.into_deserializer()).map_err(|e: WordError| Problem::Invalid(e.to_string()))
    }
    /// The word for the value.
    fn word(&self) -> String {
        serde_json::to_value(self).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
    }
}

/// Makes a [`Word`] type an option field, bare and in an `Option`.
#[macro_export]
macro_rules! word_option {
    ($ty:ty) => {
        impl $crate::options::Word for $ty {}
        impl $crate::options::OptionField for $ty {
            const KIND: $crate::options::Kind = $crate::options::Kind::Text;
            fn from_value(value: $crate::options::Value) -> Result<Self, $crate::options::Problem> {
                match value {
                    $crate::options::Value::Text(t) => <$ty as $crate::options::Word>::read(&t),
                    other => Err($crate::options::Problem::Invalid(format!("{other:?}"))),
                }
            }
            fn to_value(&self) -> Option<$crate::options::Value> {
                Some($crate::options::Value::Text($crate::options::Word::word(self)))
            }
        }
        impl $crate::options::OptionField for Option<$ty> {
            const KIND: $crate::options::Kind = $crate::options::Kind::Text;
            fn from_value(value: $crate::options::Value) -> Result<Self, $crate::options::Problem> {
                <$ty as $crate::options::OptionField>::from_value(value).map(Some)
            }
            fn to_value(&self) -> Option<$crate::options::Value> {
                self.as_ref().map(|v| $crate::options::Value::Text($crate::options::Word::word(v)))
            }
        }
    };
}

/// Makes a type read from its text (`FromStr`, written back with `Display`: `iso`, `10-20`) an
/// option of [`Kind::Text`] in an `Option` (unset by default), and with `default` bare too (its
/// `Default` is a value the header leaves out: `--colour-by tool`).
#[macro_export]
macro_rules! text_option {
    ($ty:ty) => {
        impl $crate::options::OptionField for Option<$ty> {
            const KIND: $crate::options::Kind = $crate::options::Kind::Text;
            fn from_value(value: $crate::options::Value) -> Result<Self, $crate::options::Problem> {
                match value {
                    $crate::options::Value::Text(t) => t
                        .parse::<$ty>()
                        .map(Some)
                        .map_err(|e| $crate::options::Problem::Invalid(e.to_string())),
                    other => Err($crate::options::Problem::Invalid(format!("{other:?}"))),
                }
            }
            fn to_value(&self) -> Option<$crate::options::Value> {
                self.as_ref().map(|v| $crate::options::Value::Text(v.to_string()))
            }
        }
    };
    ($ty:ty, default) => {
        $crate::text_option!($ty);
        impl $crate::options::OptionField for $ty {
            const KIND: $crate::options::Kind = $crate::options::Kind::Text;
            fn from_value(value: $crate::options::Value) -> Result<Self, $crate::options::Problem> {
                <Option<$ty> as $crate::options::OptionField>::from_value(value)
                    .map(Option::unwrap_or_default)
            }
            fn to_value(&self) -> Option<$crate::options::Value> {
                Some($crate::options::Value::Text(self.to_string()))
            }
        }
    };
}

/// Declares a job's options type: each field is an option, its doc comment the help, its type
/// the kind of value ([`OptionField`]), and after `=` its [`Shape`] (value name, range, short
/// flag, aliases, conflicts), then for a number or count whose default is a value, `=> value`
/// (`threshold: f64 = Shape::new("0..1") => 0.5`: the CLI shows and parses that default,
/// Python's keyword has it, the header leaves it out). The struct gets [`JobOptions`],
/// `Default` (every option unset or at its default) and `PartialEq`.
///
/// Options several jobs share are declared once as a type of their own (`rotary wrap` and
/// `rotary tube` share the machine's), named first as `..machine: MachineOptions,`: the job's
/// field `machine` holds them, and they come first in its [`JobOptions::SPEC`], its flags and
/// its header.
///
/// ```
/// gweave::job_options! {
///     /// Options of a job.
///     pub struct DemoOptions for "demo" {
///         /// Purge per change, mm.
///         purge_mm: Option<f64> = gweave::options::Shape::new("MM").range(gweave::range::PURGE_MM),
///     }
/// }
/// gweave::job_options! {
///     /// A job sharing `DemoOptions`.
///     pub struct MoreOptions for "more" {
///         ..demo: DemoOptions,
///         /// Layers.
///         layer_count: Option<u32> = gweave::options::Shape::new("N").whole(gweave::range::LAYER_NUMBER),
///     }
/// }
/// use gweave::options::JobOptions;
/// assert_eq!(DemoOptions::SPEC[0].help(), "Purge per change, mm.");
/// let names: Vec<&str> = MoreOptions::SPEC.iter().map(|s| s.name).collect();
/// assert_eq!(names, ["purge_mm", "layer_count"]);
/// let mut more = MoreOptions::default();
/// more.set(&MoreOptions::SPEC[0], gweave::options::Value::Number(2.0)).unwrap();
/// assert_eq!(more.demo.purge_mm, Some(2.0));
/// ```
#[macro_export]
macro_rules! job_options {
    (
        $(#[doc = $doc:literal])*
        pub struct $name:ident for $command:literal {
            $(..$group:ident: $group_ty:ty,)*
            $(
                $(#[doc = $help:literal])*
                $field:ident: $ty:ty = $shape:expr $(=> $default:expr)?,
            )*
        }
    ) => {
        $(#[doc = $doc])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $(#[doc = concat!("The options shared with other jobs (`", stringify!($group_ty), "`).")]
            pub $group: $group_ty,)*
            $( $(#[doc = $help])* pub $field: $ty, )*
        }

        impl Default for $name {
            /// Every option unset, or at its declared default.
            fn default() -> Self {
                $name {
                    $($group: Default::default(),)*
                    $($field: $crate::__option_default!($ty $(, $default)?),)*
                }
            }
        }

        impl $crate::options::JobOptions for $name {
            const COMMAND: &'static str = $command;
            const SPEC: &'static [$crate::options::OptionSpec] = {
                use $crate::options::OptionSpec;
                const OWN: &[OptionSpec] = &[$(
                    OptionSpec {
                        name: stringify!($field),
                        kind: <$ty as $crate::options::OptionField>::KIND,
                        doc: concat!($($help, "\n"),*),
                        default: || {
                            let default = <$name as Default>::default();
                            $crate::options::default_word(&default.$field, ($shape).separator)
                        },
                        shape: $shape,
                    },
                )*];
                const N: usize = 0 $(+ <$group_ty as $crate::options::JobOptions>::SPEC.len())* + OWN.len();
                const ALL: [OptionSpec; N] =
                    $crate::options::joined(&[$(<$group_ty as $crate::options::JobOptions>::SPEC,)* OWN]);
                &ALL
            };

            fn set(
                &mut self,
                spec: &$crate::options::OptionSpec,
                value: $crate::options::Value,
            ) -> Result<(), $crate::options::OptionError> {
                $(if <$group_ty as $crate::options::JobOptions>::spec(spec.name).is_some() {
                    return $crate::options::JobOptions::set(&mut self.$group, spec, value);
                })*
                let value = spec.check(value)?;
                let refuse = |problem| $crate::options::OptionError { option: spec.name, problem };
                match spec.name {
                    $(stringify!($field) => {
                        self.$field = $crate::options::OptionField::from_value(value).map_err(refuse)?;
                    })*
                    _ => {}
                }
                Ok(())
            }

            fn values(&self) -> Vec<Option<$crate::options::Value>> {
                let mut values: Vec<Option<$crate::options::Value>> = Vec::new();
                $(values.extend($crate::options::JobOptions::values(&self.$group));)*
                let default = <$name as Default>::default();
                values.extend([$($crate::options::unless_default(
                    $crate::options::OptionField::to_value(&self.$field),
                    $crate::options::OptionField::to_value(&default.$field),
                )),*]);
                values
            }
        }
    };
}

/// A field's default in [`job_options!`](crate::job_options): the declared one (`=> 0.5`), else
/// its type's (unset).
#[doc(hidden)]
#[macro_export]
macro_rules! __option_default {
    ($ty:ty) => {
        <$ty as Default>::default()
    };
    ($ty:ty, $default:expr) => {
        $default
    };
}

#[cfg(test)]
#[allow(unreachable_pub)] // `job_options!` declares public types, private to the tests here.
mod tests {
    use super::*;
    use crate::range::LAYER_NUMBER;

    crate::job_options! {
        /// A group two jobs share.
        pub struct Shared for "shared" {
            /// Axes.
            axes: Option<[char; 3]> = Shape::new("X,A,Z"),
        }
    }

    crate::job_options! {
        /// A job with the group, a count and both kinds of switch.
        pub struct Job for "job" {
            ..shared: Shared,
            /// Layers.
            layer_count: Option<u32> = Shape::new("N").whole(LAYER_NUMBER).aliases(&["layers"]),
            /// Reverse every layer.
            interweave: Option<bool> = Shape::new("").negated(),
            /// Keep arcs.
            keep: Option<bool> = Shape::new(""),
            /// Wind helically.
            helical: bool = Shape::new("").conflicts(&["axes", "keep"]),
        }
    }

    fn set(job: &mut Job, name: &str, text: &str) -> Result<(), OptionError> {
        let spec = Job::spec(name).unwrap();
        job.set(spec, spec.parse(text)?)
    }

    #[test]
    fn a_group_comes_first_and_is_set_through_its_field() {
        let names: Vec<String> = Job::SPEC.iter().map(OptionSpec::flag).collect();
        assert_eq!(names, ["axes", "layer-count", "no-interweave", "keep", "helical"]);
        let mut job = Job::default();
        set(&mut job, "axes", "x, y ,z").unwrap();
        set(&mut job, "layer_count", "4").unwrap();
        assert_eq!((job.shared.axes, job.layer_count), (Some(['X', 'Y', 'Z']), Some(4)));
        set(&mut job, "axes", "XAZ").unwrap();
        assert_eq!(job.header(), "--axes X,A,Z --layer-count 4");
        job.helical = true;
        let err = job.check_conflicts().unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--helical and --axes: give one of them");
    }

    #[test]
    fn a_count_is_whole_and_within_its_range() {
        let mut job = Job::default();
        let err = set(&mut job, "layer_count", "2.5").unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "layer_count: 2.5 is not a whole number");
        let err = set(&mut job, "layer_count", "2000000").unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--layer-count 2000000 is out of range: 0 to 1000000");
        let err = set(&mut job, "axes", "X,A").unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), r#"--axes: takes 3 letters (X,A,Z), not "X,A""#);
        assert_eq!(job, Job::default(), "a refused value leaves the option unset");
    }

    #[test]
    fn a_switch_is_written_as_the_cli_says_it() {
        let spec = |name| Job::spec(name).unwrap();
        let mut job = Job::default();
        job.set(spec("interweave"), Value::Flag(true)).unwrap();
        job.set(spec("keep"), Value::Flag(false)).unwrap();
        assert_eq!((job.interweave, job.keep), (Some(true), Some(false)));
        assert_eq!(job.header(), "", "the CLI has no flag for either: the settings' default");
        job.set(spec("interweave"), Value::Flag(false)).unwrap();
        job.set(spec("keep"), Value::Flag(true)).unwrap();
        assert_eq!(job.header(), "--no-interweave --keep");
        // Regression: `keep_arc_length=False, helical=True` (a settings file's arc length turned
        // off to wind helically) was refused as a conflict.
        let off = Job { keep: Some(false), helical: true, ..Job::default() };
        assert_eq!(off.check_conflicts(), Ok(()));
        assert_eq!(((spec("helical").default)(), (spec("keep").default)()), (Some("false".into()), None));
    }

    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    pub enum Side {
        #[default]
        Left,
        Right,
    }
    impl std::str::FromStr for Side {
        type Err = String;
        fn from_str(s: &str) -> Result<Self, String> {
            match s {
                "left" => Ok(Side::Left),
                "right" => Ok(Side::Right),
                _ => Err(format!("unknown side {s:?} (left or right)")),
            }
        }
    }
    impl fmt::Display for Side {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(if *self == Side::Left { "left" } else { "right" })
        }
    }
    crate::text_option!(Side, default);

    crate::job_options! {
        /// Options of a test job.
        pub struct Demo for "demo" {
            /// A side [default: left].
            side: Side = Shape::new("SIDE"),
            /// Another, unset by default.
            other: Option<Side> = Shape::new("SIDE"),
            /// A layer.
            layer: Option<u32> = Shape::new("N").range(Range::new(0.0, 10.0, "")),
            /// A size.
            size: Option<[f64; 2]> = Shape::new("WxH").separator('x'),
            /// A fraction whose default is a value.
            fraction: f64 = Shape::new("F").range(Range::new(0.0, 1.0, "")) => 0.5,
            /// A count whose default is a value.
            count: u32 = Shape::new("N").whole(LAYER_NUMBER) => 4,
        }
    }

    #[test]
    fn a_default_that_is_a_value_is_the_fields_its_word_and_left_out_of_the_header() {
        let mut o = Demo::default();
        assert_eq!((o.fraction, o.count), (0.5, 4));
        let (fraction, count) = (Demo::spec("fraction").unwrap(), Demo::spec("count").unwrap());
        assert_eq!(((fraction.default)(), (count.default)()), (Some("0.5".into()), Some("4".into())));
        o.set(fraction, Value::Number(0.5)).unwrap();
        assert_eq!(o.header(), "", "given at its default: the same run");
        o.set(fraction, fraction.parse("0.25").unwrap()).unwrap();
        o.set(count, count.parse("12").unwrap()).unwrap();
        assert_eq!(o.header(), "--fraction 0.25 --count 12");
        let err = o.set(count, Value::Number(2.5)).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "count: 2.5 is not a whole number");
        let err = o.set(fraction, Value::Number(2.0)).unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--fraction 2 is out of range: 0 to 1");
        assert_eq!((o.fraction, o.count), (0.25, 12), "a refused value leaves the option as it was");
    }

    #[test]
    fn a_text_option_reads_its_words_and_the_header_leaves_its_default_out() {
        let mut o = Demo::default();
        let side = Demo::spec("side").unwrap();
        assert_eq!((side.default)().as_deref(), Some("left"));
        o.set(side, side.parse("right").unwrap()).unwrap();
        let other = Demo::spec("other").unwrap();
        assert_eq!((other.default)(), None);
        let err = o.set(other, Value::Text("up".into())).unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), r#"--other: unknown side "up" (left or right)"#);
        assert_eq!(o.header(), "--side right");
        o.side = Side::Left;
        assert_eq!(o.header(), "");
    }

    #[test]
    fn a_whole_number_option_refuses_a_fraction_and_its_range() {
        let mut o = Demo::default();
        let layer = Demo::spec("layer").unwrap();
        o.set(layer, Value::Number(3.0)).unwrap();
        assert_eq!(o.layer, Some(3));
        let err = o.set(layer, Value::Number(2.5)).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "layer: 2.5 is not a whole number");
        let err = o.set(layer, Value::Number(11.0)).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "layer = 11 is out of range: 0 to 10");
    }

    #[test]
    fn numbers_split_and_join_at_their_separator() {
        let mut o = Demo::default();
        let size = Demo::spec("size").unwrap();
        o.set(size, size.parse("640x480").unwrap()).unwrap();
        assert_eq!(o.size, Some([640.0, 480.0]));
        assert_eq!(o.header(), "--size 640x480");
    }

    /// Every job's error reaches a front end one way (issue 40: four `failed` functions in
    /// Python, four in the CLI): the message spelled, each cause not already said, and the file
    /// the system refused.
    #[test]
    fn a_jobs_failure_says_its_causes_once_and_names_the_refused_file() {
        #[derive(Debug, thiserror::Error)]
        enum Failed {
            #[error("reading layer.png")]
            Read(#[source] std::io::Error),
            #[error("settings: {0}")]
            Said(#[source] OptionError),
        }
        impl JobFailure for Failed {
            fn spelled(&self, spelling: Spelling) -> String {
                match self {
                    Failed::Said(e) => format!("settings: {}", e.spelled(spelling)),
                    e => e.to_string(),
                }
            }
        }
        let denied = || std::io::Error::new(std::io::ErrorKind::PermissionDenied, "denied");
        let read = Failed::Read(denied());
        assert_eq!(
            (read.said(Spelling::Keyword), read.io_failed()),
            ("reading layer.png: denied".into(), true)
        );
        let range = Range::new(0.0, 1.0, "");
        let option = OptionError { option: "purge_mm", problem: Problem::OutOfRange { value: 2.0, range } };
        let said = Failed::Said(option);
        assert_eq!(said.said(Spelling::Flag), "settings: --purge-mm 2 is out of range: 0 to 1");
        assert!(!said.io_failed() && said.refused_file().is_none());
        let engine = crate::Error::io(Path::new("/x/part.gcode"), denied());
        let (path, source) = engine.refused_file().unwrap();
        assert_eq!((path, source.kind()), (Path::new("/x/part.gcode"), std::io::ErrorKind::PermissionDenied));
    }
}
