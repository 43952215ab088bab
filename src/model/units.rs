//! Units of noise coefficients: the one place where °/√h, µg/√Hz and the rest meet SI.
//!
//! Inside imunoise every coefficient is SI (see [`Coefficients`](super::Coefficients)); a unit
//! here is only for reading a specification or printing a result. Each unit knows which term and
//! which sensor it measures, so converting an angle random walk into °/h (a bias unit) is an error
//! rather than a silently wrong number. Factors are written from their definitions (π/180, 3600 s
//! per hour, √3600 = 60 √s per √h, standard gravity), never as rounded literals.

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use crate::units::STANDARD_GRAVITY;

use super::Term;

const DEG: f64 = PI / 180.0;
const HOUR: f64 = 3600.0;
/// √(1 h) in √s.
const SQRT_HOUR: f64 = 60.0;
const ARCSEC: f64 = DEG / 3600.0;
const MICRO_G: f64 = STANDARD_GRAVITY * 1e-6;

/// Which sensor a coefficient belongs to: gyros measure angular rate, accelerometers specific force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sensor {
    Gyro,
    Accel,
}

impl Sensor {
    /// The sensor a channel of `kind` is, if it is an inertial one.
    pub fn of_kind(kind: crate::units::Kind) -> Option<Sensor> {
        match kind {
            crate::units::Kind::Gyro => Some(Sensor::Gyro),
            crate::units::Kind::Accel => Some(Sensor::Accel),
            _ => None,
        }
    }
}

/// A unit of one IEEE coefficient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub enum CoefUnit {
    // Gyro, quantisation (angle).
    #[serde(rename = "rad")]
    Rad,
    #[serde(rename = "deg")]
    Deg,
    #[serde(rename = "arcsec")]
    Arcsec,
    // Gyro, angle random walk.
    /// rad/s/√Hz = rad/√s: the SI unit, and Kalibr's `gyroscope_noise_density`.
    #[serde(rename = "rad/s/sqrt(Hz)")]
    RadPerSPerSqrtHz,
    /// (°/s)/√Hz = °/√s.
    #[serde(rename = "deg/s/sqrt(Hz)")]
    DegPerSPerSqrtHz,
    #[serde(rename = "deg/sqrt(h)")]
    DegPerSqrtH,
    /// (°/h)/√Hz: the datasheet unit of fibre-optic and tactical gyros' noise density.
    #[serde(rename = "deg/h/sqrt(Hz)")]
    DegPerHPerSqrtHz,
    /// (mdps)/√Hz, thousandths of a degree per second: MEMS datasheets'.
    #[serde(rename = "mdps/sqrt(Hz)")]
    MilliDpsPerSqrtHz,
    // Gyro, bias instability.
    #[serde(rename = "rad/s")]
    RadPerS,
    #[serde(rename = "deg/s")]
    DegPerS,
    #[serde(rename = "deg/h")]
    DegPerH,
    // Gyro, rate random walk.
    /// rad/s/√s = rad/s²/√Hz: SI, and Kalibr's `gyroscope_random_walk`.
    #[serde(rename = "rad/s/sqrt(s)")]
    RadPerSPerSqrtS,
    /// °/h/√h.
    #[serde(rename = "deg/h/sqrt(h)")]
    DegPerHPerSqrtH,
    // Gyro, rate ramp.
    #[serde(rename = "rad/s^2")]
    RadPerS2,
    #[serde(rename = "deg/h^2")]
    DegPerH2,
    // Accel, quantisation (velocity).
    #[serde(rename = "m/s")]
    MPerS,
    /// mm/s: the datasheet scale of a velocity quantisation (an SI unit, but not *the* SI unit).
    #[serde(rename = "mm/s")]
    MilliMPerS,
    // Accel, velocity random walk.
    /// m/s²/√Hz = m/s/√s: SI, Kalibr's `accelerometer_noise_density`.
    #[serde(rename = "m/s^2/sqrt(Hz)")]
    MPerS2PerSqrtHz,
    #[serde(rename = "m/s/sqrt(h)")]
    MPerSPerSqrtH,
    #[serde(rename = "ug/sqrt(Hz)")]
    MicroGPerSqrtHz,
    #[serde(rename = "mg/sqrt(Hz)")]
    MilliGPerSqrtHz,
    // Accel, bias instability.
    #[serde(rename = "m/s^2")]
    MPerS2,
    #[serde(rename = "ug")]
    MicroG,
    #[serde(rename = "mg")]
    MilliG,
    // Accel, acceleration random walk.
    /// m/s²/√s = m/s³/√Hz: SI, Kalibr's `accelerometer_random_walk`.
    #[serde(rename = "m/s^2/sqrt(s)")]
    MPerS2PerSqrtS,
    /// µg/√s.
    #[serde(rename = "ug/sqrt(s)")]
    MicroGPerSqrtS,
    /// (m/s²)/√h: an acceleration random walk per root hour.
    #[serde(rename = "m/s^2/sqrt(h)")]
    MPerS2PerSqrtH,
    #[serde(rename = "ug/sqrt(h)")]
    MicroGPerSqrtH,
    #[serde(rename = "mg/sqrt(h)")]
    MilliGPerSqrtH,
    // Accel, ramp.
    #[serde(rename = "m/s^3")]
    MPerS3,
    /// µg/s.
    #[serde(rename = "ug/s")]
    MicroGPerS,
}

/// Every unit with its sensor, term, SI factor and accepted spellings (lower case, spaces
/// removed). One table, so parser, printer and conversions cannot disagree.
const TABLE: &[(CoefUnit, Sensor, Term, f64, &[&str])] = {
    use CoefUnit::*;
    use Sensor::{Accel as A, Gyro as G};
    use Term::{
        BiasInstability as B, Quantization as Q, RandomWalk as N, RateRamp as R,
        RateRandomWalk as K,
    };
    &[
        (Rad, G, Q, 1.0, &["rad"]),
        (Deg, G, Q, DEG, &["deg", "°"]),
        (Arcsec, G, Q, ARCSEC, &["arcsec", "\""]),
        (
            RadPerSPerSqrtHz,
            G,
            N,
            1.0,
            &["rad/s/sqrt(hz)", "rad/s/√hz", "rad/sqrt(s)", "rad/√s"],
        ),
        (
            DegPerSPerSqrtHz,
            G,
            N,
            DEG,
            &[
                "deg/s/sqrt(hz)",
                "(deg/s)/sqrt(hz)",
                "°/s/√hz",
                "(°/s)/√hz",
                "deg/sqrt(s)",
                "°/√s",
            ],
        ),
        (
            DegPerSqrtH,
            G,
            N,
            DEG / SQRT_HOUR,
            &["deg/sqrt(h)", "deg/sqrt(hr)", "°/√h", "°/√hr"],
        ),
        (
            DegPerHPerSqrtHz,
            G,
            N,
            DEG / HOUR,
            &[
                "deg/h/sqrt(hz)",
                "(deg/h)/sqrt(hz)",
                "deg/hr/sqrt(hz)",
                "°/h/√hz",
                "(°/h)/√hz",
            ],
        ),
        (
            MilliDpsPerSqrtHz,
            G,
            N,
            DEG * 1e-3,
            &["mdps/sqrt(hz)", "mdps/√hz", "mdeg/s/sqrt(hz)"],
        ),
        (RadPerS, G, B, 1.0, &["rad/s"]),
        (DegPerS, G, B, DEG, &["deg/s", "°/s"]),
        (
            DegPerH,
            G,
            B,
            DEG / HOUR,
            &["deg/h", "deg/hr", "°/h", "°/hr"],
        ),
        (
            RadPerSPerSqrtS,
            G,
            K,
            1.0,
            &[
                "rad/s/sqrt(s)",
                "rad/s/√s",
                "rad/s^2/sqrt(hz)",
                "rad/s²/√hz",
            ],
        ),
        (
            DegPerHPerSqrtH,
            G,
            K,
            DEG / HOUR / SQRT_HOUR,
            &["deg/h/sqrt(h)", "deg/hr/sqrt(hr)", "°/h/√h", "°/hr/√hr"],
        ),
        (RadPerS2, G, R, 1.0, &["rad/s^2", "rad/s²"]),
        (
            DegPerH2,
            G,
            R,
            DEG / (HOUR * HOUR),
            &["deg/h^2", "deg/hr^2", "°/h²", "°/h^2"],
        ),
        (MPerS, A, Q, 1.0, &["m/s"]),
        (MilliMPerS, A, Q, 1e-3, &["mm/s"]),
        (
            MPerS2PerSqrtHz,
            A,
            N,
            1.0,
            &["m/s^2/sqrt(hz)", "m/s²/√hz", "m/s/sqrt(s)", "m/s/√s"],
        ),
        (
            MPerSPerSqrtH,
            A,
            N,
            1.0 / SQRT_HOUR,
            &["m/s/sqrt(h)", "m/s/sqrt(hr)", "m/s/√h"],
        ),
        (
            MicroGPerSqrtHz,
            A,
            N,
            MICRO_G,
            &["ug/sqrt(hz)", "µg/√hz", "μg/√hz", "µg/sqrt(hz)"],
        ),
        (
            MilliGPerSqrtHz,
            A,
            N,
            MICRO_G * 1e3,
            &["mg/sqrt(hz)", "mg/√hz"],
        ),
        (MPerS2, A, B, 1.0, &["m/s^2", "m/s²"]),
        (MicroG, A, B, MICRO_G, &["ug", "µg", "μg"]),
        (MilliG, A, B, MICRO_G * 1e3, &["mg"]),
        (
            MPerS2PerSqrtS,
            A,
            K,
            1.0,
            &["m/s^2/sqrt(s)", "m/s²/√s", "m/s^3/sqrt(hz)", "m/s³/√hz"],
        ),
        (
            MicroGPerSqrtS,
            A,
            K,
            MICRO_G,
            &["ug/sqrt(s)", "µg/√s", "μg/√s"],
        ),
        (
            MPerS2PerSqrtH,
            A,
            K,
            1.0 / SQRT_HOUR,
            &["m/s^2/sqrt(h)", "m/s²/√h", "m/s^2/sqrt(hr)"],
        ),
        (
            MicroGPerSqrtH,
            A,
            K,
            MICRO_G / SQRT_HOUR,
            &["ug/sqrt(h)", "µg/√h", "μg/√h", "ug/sqrt(hr)"],
        ),
        (
            MilliGPerSqrtH,
            A,
            K,
            MICRO_G * 1e3 / SQRT_HOUR,
            &["mg/sqrt(h)", "mg/√h", "mg/sqrt(hr)"],
        ),
        (MPerS3, A, R, 1.0, &["m/s^3", "m/s³"]),
        (MicroGPerS, A, R, MICRO_G, &["ug/s", "µg/s", "μg/s"]),
    ]
};

fn row(unit: CoefUnit) -> &'static (CoefUnit, Sensor, Term, f64, &'static [&'static str]) {
    TABLE
        .iter()
        .find(|r| r.0 == unit)
        .expect("every unit has a row in TABLE")
}

/// A value and a unit that measure different things.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UnitError {
    #[error(
        "{unit} is a unit of {} ({unit_term}), not of {} ({term})",
        .unit_term.name(*.sensor == Sensor::Gyro),
        .term.name(*.sensor == Sensor::Gyro)
    )]
    Mismatch {
        unit: CoefUnit,
        sensor: Sensor,
        unit_term: Term,
        term: Term,
    },
    #[error("unit {unit} belongs to a {unit_sensor:?}, the channel is a {sensor:?}")]
    WrongSensor {
        unit: CoefUnit,
        unit_sensor: Sensor,
        sensor: Sensor,
    },
    #[error("unknown coefficient unit {0:?}")]
    Unknown(String),
}

impl CoefUnit {
    /// The sensor this unit belongs to.
    pub fn sensor(self) -> Sensor {
        row(self).1
    }

    /// The term this unit measures.
    pub fn term(self) -> Term {
        row(self).2
    }

    /// One of this unit in the SI unit of its term.
    pub fn si_factor(self) -> f64 {
        row(self).3
    }

    /// Canonical spelling.
    pub fn as_str(self) -> &'static str {
        row(self).4[0]
    }

    /// The ASCII label written in reports and tables (`deg/sqrt(h)`, `ug/sqrt(Hz)`, …); it parses
    /// back with [`FromStr`].
    pub fn label(self) -> String {
        match serde_json::to_value(self) {
            Ok(serde_json::Value::String(s)) => s,
            _ => self.as_str().to_string(),
        }
    }

    /// The label with typographic symbols for humans (`°/√h`, `µg/√Hz`, `m/s²`).
    pub fn pretty(self) -> String {
        self.label()
            .replace("sqrt(", "√")
            .replace([')', '('], "")
            .replace("deg", "°")
            .replace("ug", "µg")
            .replace("^2", "²")
            .replace("^3", "³")
    }

    /// `value` in this unit, in SI.
    pub fn to_si(self, value: f64) -> f64 {
        value * self.si_factor()
    }

    /// SI `value` in this unit.
    pub fn from_si(self, value: f64) -> f64 {
        value / self.si_factor()
    }

    /// The SI unit of `term` for `sensor`.
    pub fn si(sensor: Sensor, term: Term) -> CoefUnit {
        Self::find(sensor, term, |factor| factor == 1.0)
    }

    /// The two units results are printed in: the datasheet one (°/√h, °/h, µg, …) and the
    /// spectral-density one ((°/s)/√Hz, µg/√Hz, …) or SI, so either habit can read the report.
    pub fn display_pair(sensor: Sensor, term: Term) -> (CoefUnit, CoefUnit) {
        use CoefUnit::*;
        match (sensor, term) {
            (Sensor::Gyro, Term::Quantization) => (Arcsec, Rad),
            (Sensor::Gyro, Term::RandomWalk) => (DegPerSqrtH, DegPerSPerSqrtHz),
            (Sensor::Gyro, Term::BiasInstability) => (DegPerH, DegPerS),
            (Sensor::Gyro, Term::RateRandomWalk) => (DegPerHPerSqrtH, RadPerSPerSqrtS),
            (Sensor::Gyro, Term::RateRamp) => (DegPerH2, RadPerS2),
            (Sensor::Accel, Term::Quantization) => (MilliMPerS, MPerS),
            (Sensor::Accel, Term::RandomWalk) => (MPerSPerSqrtH, MicroGPerSqrtHz),
            (Sensor::Accel, Term::BiasInstability) => (MicroG, MPerS2),
            (Sensor::Accel, Term::RateRandomWalk) => (MicroGPerSqrtS, MPerS2PerSqrtS),
            (Sensor::Accel, Term::RateRamp) => (MicroGPerS, MPerS3),
        }
    }

    /// Converts `value` in this unit to `to`, refusing units of another term or sensor.
    pub fn convert(self, value: f64, to: CoefUnit) -> Result<f64, UnitError> {
        if self.sensor() != to.sensor() {
            return Err(UnitError::WrongSensor {
                unit: to,
                unit_sensor: to.sensor(),
                sensor: self.sensor(),
            });
        }
        if self.term() != to.term() {
            return Err(UnitError::Mismatch {
                unit: to,
                sensor: to.sensor(),
                unit_term: to.term(),
                term: self.term(),
            });
        }
        Ok(to.from_si(self.to_si(value)))
    }

    /// Checks that this unit measures `term` of a `sensor`, as a specification reader must before
    /// calling [`CoefUnit::to_si`].
    pub fn check(self, sensor: Sensor, term: Term) -> Result<(), UnitError> {
        if self.sensor() != sensor {
            return Err(UnitError::WrongSensor {
                unit: self,
                unit_sensor: self.sensor(),
                sensor,
            });
        }
        if self.term() != term {
            return Err(UnitError::Mismatch {
                unit: self,
                sensor,
                unit_term: self.term(),
                term,
            });
        }
        Ok(())
    }

    fn find(sensor: Sensor, term: Term, pick: impl Fn(f64) -> bool) -> CoefUnit {
        TABLE
            .iter()
            .find(|r| r.1 == sensor && r.2 == term && pick(r.3))
            .map(|r| r.0)
            .expect("every sensor and term has an SI unit")
    }
}

impl fmt::Display for CoefUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for CoefUnit {
    type Err = UnitError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key: String = s.trim().replace(' ', "").to_lowercase();
        TABLE
            .iter()
            .find(|r| r.4.contains(&key.as_str()))
            .map(|r| r.0)
            .ok_or_else(|| UnitError::Unknown(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a / b - 1.0).abs() < 1e-12
    }

    #[test]
    fn every_spelling_parses_back_and_every_term_has_si() {
        for r in TABLE {
            for s in r.4 {
                assert_eq!(s.parse::<CoefUnit>().unwrap(), r.0, "{s}");
            }
        }
        for sensor in [Sensor::Gyro, Sensor::Accel] {
            for term in Term::ALL {
                let si = CoefUnit::si(sensor, term);
                assert_eq!(
                    (si.term(), si.sensor(), si.si_factor()),
                    (term, sensor, 1.0)
                );
                let (a, b) = CoefUnit::display_pair(sensor, term);
                assert_eq!((a.term(), b.term()), (term, term));
                // Two different unit systems, each labelled as what it is (accel Q was m/s twice).
                assert_ne!(a, b, "{sensor:?} {term:?}");
                assert_ne!(a.label(), b.label(), "{sensor:?} {term:?}");
                for u in [a, b] {
                    assert_eq!(u.label().parse::<CoefUnit>().unwrap(), u);
                }
            }
        }
    }

    #[test]
    fn textbook_conversions() {
        use CoefUnit::*;
        // 1 °/√h = (π/180)/60 rad/√s; 1 (°/s)/√Hz = 60 °/√h.
        assert!(close(DegPerSqrtH.to_si(1.0), PI / 180.0 / 60.0));
        assert!(close(
            DegPerSPerSqrtHz.convert(1.0, DegPerSqrtH).unwrap(),
            60.0
        ));
        // 1 °/h = 4.848 136 811e-6 rad/s.
        assert!(close(DegPerH.to_si(1.0), 4.848_136_811_095_36e-6));
        // 1 °/s = 3600 °/h.
        assert!(close(DegPerS.convert(1.0, DegPerH).unwrap(), 3600.0));
        // 1 °/h/√h = 1/(3600·60) °/s/√s.
        assert!(close(DegPerHPerSqrtH.to_si(1.0), PI / 180.0 / 216_000.0));
        assert!(close(DegPerH2.to_si(1.0), PI / 180.0 / 3600.0_f64.powi(2)));
        assert!(close(Arcsec.to_si(1.0), PI / 648_000.0));
        // 1 m/s/√h = 1/60 m/s/√s; 100 µg/√Hz = 9.80665e-4 m/s/√s.
        assert!(close(MPerSPerSqrtH.to_si(1.0), 1.0 / 60.0));
        assert!(close(MicroGPerSqrtHz.to_si(100.0), 9.80665e-4));
        assert!(close(MicroG.to_si(1.0), 9.80665e-6));
        assert!(close(MilliG.convert(1.0, MicroG).unwrap(), 1000.0));
        assert!(close(MPerS.convert(0.002, MilliMPerS).unwrap(), 2.0));
    }

    /// The README's list of coefficient units is the table's.
    #[test]
    fn the_readme_lists_every_coefficient_unit() {
        let readme = include_str!("../../README.md");
        let start = readme
            .find("Coefficient units (any letter case")
            .expect("the list");
        let list = &readme[start..start + readme[start..].find("\n\n").unwrap_or(2000)];
        for r in TABLE {
            let label = r.0.label();
            let listed = list
                .split([',', ';', ' ', '\n'])
                .any(|w| w.trim_end_matches('.') == label);
            assert!(listed, "README's unit list lacks {label}");
        }
    }

    /// Datasheet spellings of noise densities and random walks convert as their definitions say:
    /// (°/h)/√Hz is 1/60 °/√h, 1 mdps/√Hz is 3.6 °/h/√Hz, 1 mg/√h is 1000/60 µg/√s.
    #[test]
    fn datasheet_densities_convert() {
        use CoefUnit::*;
        for (value, from, to, want) in [
            (60.0, DegPerHPerSqrtHz, DegPerSqrtH, 1.0),
            (1.0, MilliDpsPerSqrtHz, DegPerHPerSqrtHz, 3.6),
            (1.0, MilliGPerSqrtHz, MicroGPerSqrtHz, 1e3),
            (1.0, MilliGPerSqrtH, MicroGPerSqrtS, 1e3 / 60.0),
            (60.0, MPerS2PerSqrtH, MPerS2PerSqrtS, 1.0),
            (60.0, MicroGPerSqrtH, MicroGPerSqrtS, 1.0),
        ] {
            let got = from.convert(value, to).unwrap();
            assert!(
                (got / want - 1.0).abs() < 1e-12,
                "{value} {from} = {got} {to}"
            );
        }
        assert_eq!(
            "0.5 deg/h/sqrt(Hz)"
                .split_once(' ')
                .unwrap()
                .1
                .parse::<CoefUnit>()
                .unwrap(),
            DegPerHPerSqrtHz
        );
    }

    #[test]
    fn refuses_units_of_another_term_or_sensor() {
        use CoefUnit::*;
        let err = DegPerSqrtH.convert(1.0, DegPerH).unwrap_err();
        assert!(matches!(err, UnitError::Mismatch { .. }), "{err}");
        assert!(err.to_string().contains("bias instability"), "{err}");
        let err = DegPerH.convert(1.0, MicroG).unwrap_err();
        assert!(matches!(err, UnitError::WrongSensor { .. }), "{err}");
        assert!(DegPerH.check(Sensor::Gyro, Term::BiasInstability).is_ok());
        assert!(DegPerH.check(Sensor::Accel, Term::BiasInstability).is_err());
        assert!("furlong".parse::<CoefUnit>().is_err());
    }
}
