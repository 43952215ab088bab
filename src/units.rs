//! Physical units and sensor kinds of channels.
//!
//! Everything inside imunoise is SI: angular rate in rad/s, acceleration in m/s², temperature in °C
//! (an offset from kelvin that no variance or spectrum can see). Conversion happens once, here, when a
//! column is read; outputs name the SI unit they are in. An unknown unit string is an error, never a guess.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

/// Standard gravity, m/s² (ISO 80000-3, CGPM 1901): the factor between `g` and m/s².
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// What physical quantity a unit measures; decides the SI unit a channel is stored in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    AngularRate,
    Acceleration,
    Temperature,
    Voltage,
    /// Counts, LSB or a plain number: kept as given.
    Dimensionless,
}

impl Quantity {
    /// The unit values of this quantity are stored in after ingest.
    pub fn si_unit(self) -> Unit {
        match self {
            Quantity::AngularRate => Unit::RadPerS,
            Quantity::Acceleration => Unit::MPerS2,
            Quantity::Temperature => Unit::DegC,
            Quantity::Voltage => Unit::Volt,
            Quantity::Dimensionless => Unit::One,
        }
    }
}

/// A unit a column may be recorded in (field metadata `unit`, or `--unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Unit {
    #[serde(rename = "rad/s")]
    RadPerS,
    #[serde(rename = "mrad/s")]
    MilliradPerS,
    #[serde(rename = "deg/s")]
    DegPerS,
    #[serde(rename = "deg/h")]
    DegPerH,
    #[serde(rename = "m/s^2")]
    MPerS2,
    #[serde(rename = "g")]
    G,
    #[serde(rename = "mg")]
    MilliG,
    #[serde(rename = "ug")]
    MicroG,
    #[serde(rename = "degC")]
    DegC,
    #[serde(rename = "K")]
    Kelvin,
    #[serde(rename = "V")]
    Volt,
    #[serde(rename = "mV")]
    MilliVolt,
    #[serde(rename = "1")]
    One,
    /// Increments per sample (incremental-angle and -velocity outputs, Δθ and Δv): read as the
    /// rate over one sample period, the increment times the sample rate (see
    /// [`Unit::per_sample`]).
    #[serde(rename = "rad")]
    Rad,
    #[serde(rename = "mrad")]
    Millirad,
    #[serde(rename = "urad")]
    Microrad,
    #[serde(rename = "deg")]
    Deg,
    #[serde(rename = "arcsec")]
    Arcsec,
    #[serde(rename = "m/s")]
    MPerS,
    #[serde(rename = "mm/s")]
    MmPerS,
}

/// Every accepted spelling, lower-cased, with the unit it means. Kept as one table so that `--help`,
/// the error message for an unknown unit and the parser can never disagree.
const SPELLINGS: &[(&str, Unit)] = &[
    ("rad/s", Unit::RadPerS),
    ("mrad/s", Unit::MilliradPerS),
    ("deg/s", Unit::DegPerS),
    ("°/s", Unit::DegPerS),
    ("dps", Unit::DegPerS),
    ("deg/h", Unit::DegPerH),
    ("°/h", Unit::DegPerH),
    ("deg/hr", Unit::DegPerH),
    ("m/s^2", Unit::MPerS2),
    ("m/s2", Unit::MPerS2),
    ("m/s²", Unit::MPerS2),
    ("g", Unit::G),
    ("mg", Unit::MilliG),
    ("ug", Unit::MicroG),
    ("µg", Unit::MicroG),
    ("μg", Unit::MicroG),
    ("degc", Unit::DegC),
    ("°c", Unit::DegC),
    ("c", Unit::DegC),
    ("k", Unit::Kelvin),
    ("v", Unit::Volt),
    ("mv", Unit::MilliVolt),
    ("1", Unit::One),
    ("counts", Unit::One),
    ("lsb", Unit::One),
    ("rad", Unit::Rad),
    ("mrad", Unit::Millirad),
    ("urad", Unit::Microrad),
    ("µrad", Unit::Microrad),
    ("μrad", Unit::Microrad),
    ("deg", Unit::Deg),
    ("°", Unit::Deg),
    ("arcsec", Unit::Arcsec),
    ("m/s", Unit::MPerS),
    ("mm/s", Unit::MmPerS),
];

impl Unit {
    pub fn quantity(self) -> Quantity {
        match self {
            Unit::RadPerS
            | Unit::MilliradPerS
            | Unit::DegPerS
            | Unit::DegPerH
            | Unit::Rad
            | Unit::Millirad
            | Unit::Microrad
            | Unit::Deg
            | Unit::Arcsec => Quantity::AngularRate,
            Unit::MPerS2 | Unit::G | Unit::MilliG | Unit::MicroG | Unit::MPerS | Unit::MmPerS => {
                Quantity::Acceleration
            }
            Unit::DegC | Unit::Kelvin => Quantity::Temperature,
            Unit::Volt | Unit::MilliVolt => Quantity::Voltage,
            Unit::One => Quantity::Dimensionless,
        }
    }

    /// Whether values are increments over one sample period (Δθ, Δv) rather than rates: a
    /// navigation-grade gyro's or accelerometer's native output. The rate is the increment times
    /// the sample rate (the nominal period, as IEEE Std 952 reads Δθ/Δt); [`Unit::to_si`] gives
    /// the increment's factor, and the reader multiplies by the rate.
    pub fn per_sample(self) -> bool {
        matches!(
            self,
            Unit::Rad
                | Unit::Millirad
                | Unit::Microrad
                | Unit::Deg
                | Unit::Arcsec
                | Unit::MPerS
                | Unit::MmPerS
        )
    }

    /// `si = value · factor + offset`, into [`Quantity::si_unit`] (for a [`Unit::per_sample`]
    /// unit, into the increment's SI unit, rad or m/s, which the sample rate turns into the rate).
    pub fn to_si(self) -> (f64, f64) {
        use std::f64::consts::PI;
        match self {
            Unit::RadPerS | Unit::MPerS2 | Unit::DegC | Unit::Volt | Unit::One => (1.0, 0.0),
            Unit::Rad | Unit::MPerS => (1.0, 0.0),
            Unit::MilliradPerS | Unit::MilliVolt | Unit::Millirad | Unit::MmPerS => (1e-3, 0.0),
            Unit::Microrad => (1e-6, 0.0),
            Unit::Deg => (PI / 180.0, 0.0),
            Unit::Arcsec => (PI / 180.0 / 3600.0, 0.0),
            Unit::DegPerS => (PI / 180.0, 0.0),
            Unit::DegPerH => (PI / 180.0 / 3600.0, 0.0),
            Unit::G => (STANDARD_GRAVITY, 0.0),
            Unit::MilliG => (STANDARD_GRAVITY * 1e-3, 0.0),
            Unit::MicroG => (STANDARD_GRAVITY * 1e-6, 0.0),
            Unit::Kelvin => (1.0, -273.15),
        }
    }

    /// The canonical spelling, as written in outputs.
    pub fn as_str(self) -> &'static str {
        match self {
            Unit::RadPerS => "rad/s",
            Unit::MilliradPerS => "mrad/s",
            Unit::DegPerS => "deg/s",
            Unit::DegPerH => "deg/h",
            Unit::MPerS2 => "m/s^2",
            Unit::G => "g",
            Unit::MilliG => "mg",
            Unit::MicroG => "ug",
            Unit::DegC => "degC",
            Unit::Kelvin => "K",
            Unit::Volt => "V",
            Unit::MilliVolt => "mV",
            Unit::One => "1",
            Unit::Rad => "rad",
            Unit::Millirad => "mrad",
            Unit::Microrad => "urad",
            Unit::Deg => "deg",
            Unit::Arcsec => "arcsec",
            Unit::MPerS => "m/s",
            Unit::MmPerS => "mm/s",
        }
    }

    /// The label for people, with typographic symbols: `m/s²`, `°/h`, `µg`, `°C` (the canonical
    /// [`as_str`](Self::as_str) spelling stays ASCII for files and flags).
    pub fn pretty(self) -> &'static str {
        match self {
            Unit::RadPerS => "rad/s",
            Unit::MilliradPerS => "mrad/s",
            Unit::DegPerS => "°/s",
            Unit::DegPerH => "°/h",
            Unit::MPerS2 => "m/s²",
            Unit::G => "g",
            Unit::MilliG => "mg",
            Unit::MicroG => "µg",
            Unit::DegC => "°C",
            Unit::Kelvin => "K",
            Unit::Volt => "V",
            Unit::MilliVolt => "mV",
            Unit::One => "1",
            Unit::Rad => "rad",
            Unit::Millirad => "mrad",
            Unit::Microrad => "µrad",
            Unit::Deg => "°",
            Unit::Arcsec => "arcsec",
            Unit::MPerS => "m/s",
            Unit::MmPerS => "mm/s",
        }
    }

    /// The accepted spellings, for help texts and error messages.
    pub fn accepted() -> String {
        SPELLINGS
            .iter()
            .map(|(s, _)| *s)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An unrecognised unit string.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown unit {0:?} (accepted: {accepted})", accepted = Unit::accepted())]
pub struct UnknownUnit(pub String);

impl FromStr for Unit {
    type Err = UnknownUnit;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key: String = s.trim().replace(' ', "").to_lowercase();
        // Negative exponents as EuRoC/ASL headers write them: `rad s^-1`, `m s^-2`.
        let divided = [("s^-1", "/s"), ("s^-2", "/s^2")]
            .into_iter()
            .find_map(|(power, per)| {
                key.strip_suffix(power)
                    .filter(|stem| !stem.is_empty() && !stem.ends_with('/'))
                    .map(|stem| format!("{stem}{per}"))
            });
        let find = |key: &str| {
            SPELLINGS
                .iter()
                .find(|(spelling, _)| *spelling == key)
                .map(|(_, unit)| *unit)
        };
        find(&key)
            .or_else(|| divided.as_deref().and_then(find))
            .ok_or_else(|| UnknownUnit(s.to_string()))
    }
}

/// A unit with a factor in front: `0.00875 deg/s` says one stored count is 0.00875 °/s (a raw
/// sensor's scale, where a CSV header or `--unit` is the only place to say it); a plain unit has
/// the factor 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaledUnit {
    pub factor: f64,
    pub unit: Unit,
}

impl From<Unit> for ScaledUnit {
    fn from(unit: Unit) -> Self {
        ScaledUnit { factor: 1.0, unit }
    }
}

impl fmt::Display for ScaledUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.factor == 1.0 {
            write!(f, "{}", self.unit)
        } else {
            write!(f, "{} {}", self.factor, self.unit)
        }
    }
}

impl FromStr for ScaledUnit {
    type Err = UnknownUnit;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let text = s.trim();
        if let Some((number, rest)) = text.split_once(char::is_whitespace) {
            if let Ok(factor) = number.parse::<f64>() {
                if !(factor.is_finite() && factor != 0.0) {
                    return Err(UnknownUnit(format!(
                        "{s} (the factor must be finite and non-zero)"
                    )));
                }
                return Ok(ScaledUnit {
                    factor,
                    unit: rest.parse()?,
                });
            }
        }
        text.parse::<Unit>().map(ScaledUnit::from)
    }
}

/// What a channel is: decides what later stages do with it (noise model for gyro/accel, regressor for
/// temperature/aux).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    Gyro,
    Accel,
    Temperature,
    Aux,
}

impl Kind {
    /// The kind a unit implies when no `kind` is given.
    pub fn implied_by(unit: Option<Unit>) -> Kind {
        match unit.map(Unit::quantity) {
            Some(Quantity::AngularRate) => Kind::Gyro,
            Some(Quantity::Acceleration) => Kind::Accel,
            Some(Quantity::Temperature) => Kind::Temperature,
            _ => Kind::Aux,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Gyro => "gyro",
            Kind::Accel => "accel",
            Kind::Temperature => "temperature",
            Kind::Aux => "aux",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An unrecognised kind string.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown channel kind {0:?} (accepted: gyro, accel, temperature, aux)")]
pub struct UnknownKind(pub String);

impl FromStr for Kind {
    type Err = UnknownKind;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_lowercase().as_str() {
            "gyro" | "gyroscope" => Ok(Kind::Gyro),
            "accel" | "accelerometer" => Ok(Kind::Accel),
            "temperature" | "temp" => Ok(Kind::Temperature),
            "aux" => Ok(Kind::Aux),
            _ => Err(UnknownKind(s.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spelling_parses_to_a_unit_whose_canonical_name_parses_back() {
        for (spelling, unit) in SPELLINGS {
            assert_eq!(spelling.parse::<Unit>().unwrap(), *unit);
            assert_eq!(unit.as_str().parse::<Unit>().unwrap(), *unit);
        }
    }

    /// EuRoC/ASL headers' exponents: `rad s^-1` is rad/s, `m s^-2` is m/s², `deg s^-1` °/s;
    /// nothing else changes meaning.
    #[test]
    fn negative_exponents_read_as_divisions() {
        assert_eq!("rad s^-1".parse::<Unit>().unwrap(), Unit::RadPerS);
        assert_eq!("m s^-2".parse::<Unit>().unwrap(), Unit::MPerS2);
        assert_eq!("deg s^-1".parse::<Unit>().unwrap(), Unit::DegPerS);
        assert_eq!("m s^-1".parse::<Unit>().unwrap(), Unit::MPerS);
        assert!("s^-1".parse::<Unit>().is_err());
        assert!("rad/s^-1".parse::<Unit>().is_err());
        assert!("g s^-2".parse::<Unit>().is_err());
    }

    /// The README's list of units is the parser's: every accepted spelling is in it.
    #[test]
    fn the_readme_lists_every_accepted_spelling() {
        let readme = include_str!("../README.md");
        let start = readme
            .find("Units (any letter case):")
            .expect("the README's unit list");
        let list = readme[start..]
            .split("Kinds:")
            .next()
            .unwrap()
            .to_lowercase();
        for (spelling, _) in SPELLINGS {
            let listed = list
                .split(|c: char| c == ',' || c == '(' || c == ')' || c.is_whitespace())
                .any(|w| w.trim_end_matches(['.', ':']) == *spelling);
            assert!(listed, "README's unit list lacks {spelling}");
        }
    }

    /// A count's worth in a unit: the factor multiplies, the unit is the unit; a plain unit has
    /// factor 1; a factor of 0 or a bad unit is refused.
    #[test]
    fn a_unit_may_carry_a_factor() {
        let s: ScaledUnit = "0.00875 deg/s".parse().unwrap();
        assert_eq!((s.factor, s.unit), (0.00875, Unit::DegPerS));
        let s: ScaledUnit = " 6.1e-5  g ".parse().unwrap();
        assert_eq!((s.factor, s.unit), (6.1e-5, Unit::G));
        let s: ScaledUnit = "m/s^2".parse().unwrap();
        assert_eq!((s.factor, s.unit), (1.0, Unit::MPerS2));
        assert!("0 deg/s".parse::<ScaledUnit>().is_err());
        assert!("2 furlongs".parse::<ScaledUnit>().is_err());
    }

    /// Increments per sample read as rates of their quantity (a gyro's Δθ, an accelerometer's
    /// Δv); rates are not increments.
    #[test]
    fn increments_are_rates_per_sample() {
        assert!(Unit::Arcsec.per_sample() && Unit::MPerS.per_sample());
        assert!(!Unit::DegPerS.per_sample() && !Unit::MPerS2.per_sample());
        assert_eq!(Kind::implied_by(Some(Unit::Microrad)), Kind::Gyro);
        assert_eq!(Kind::implied_by(Some(Unit::MmPerS)), Kind::Accel);
        assert_eq!(Unit::Arcsec.to_si().0, Unit::DegPerH.to_si().0);
    }

    #[test]
    fn conversions_match_their_definitions() {
        let (f, _) = Unit::DegPerH.to_si();
        // 1 deg/h = 4.84813681e-6 rad/s (π/648000).
        assert!((f - 4.848_136_811_095_36e-6).abs() < 1e-18);
        assert_eq!(Unit::MilliG.to_si().0, 9.80665e-3);
        assert_eq!(Unit::Kelvin.to_si(), (1.0, -273.15));
    }

    #[test]
    fn unknown_unit_is_an_error_that_lists_the_accepted_ones() {
        let err = "furlong/fortnight".parse::<Unit>().unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("furlong/fortnight") && msg.contains("deg/s"),
            "{msg}"
        );
    }

    #[test]
    fn pretty_labels_name_the_same_unit_as_the_canonical_ones() {
        for (_, unit) in SPELLINGS {
            // Every pretty label is itself an accepted spelling of the same unit.
            assert_eq!(unit.pretty().parse::<Unit>().unwrap(), *unit, "{unit}");
        }
    }

    #[test]
    fn kind_follows_unit_when_not_given() {
        assert_eq!(Kind::implied_by(Some(Unit::DegPerS)), Kind::Gyro);
        assert_eq!(Kind::implied_by(Some(Unit::MilliG)), Kind::Accel);
        assert_eq!(Kind::implied_by(Some(Unit::Kelvin)), Kind::Temperature);
        assert_eq!(Kind::implied_by(None), Kind::Aux);
    }
}
