//! GNSS classes: how precisely a receiver knows where it is. The planner's
//! `[safety] gnss`, the simulator's flights and a model's `frame.json`
//! (the class of the positions it was aligned to) share this type.

use serde::{Deserialize, Serialize};

/// A GNSS class: the 1-sigma position error of the receiver. In TOML
/// `"rtk"`, `"standard"` or `{ horizontal_m = .., vertical_m = .. }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawGnss", into = "RawGnss")]
pub enum GnssClass {
    /// RTK fix: about 2 cm horizontal, 3 cm vertical.
    Rtk,
    /// A consumer multirotor's GNSS (no corrections): about 1.5 m
    /// horizontal, 3 m vertical, mostly a slowly varying bias.
    Standard,
    /// Given numbers.
    Custom(GnssSigmas),
}

/// A GNSS class given by its numbers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSigmas {
    /// Horizontal RMS error (2D), metres.
    pub horizontal_m: f64,
    /// Vertical 1-sigma error, metres.
    pub vertical_m: f64,
}

/// How a GNSS class is written in TOML.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum RawGnss {
    Name(String),
    Sigmas(GnssSigmas),
}

impl TryFrom<RawGnss> for GnssClass {
    type Error = String;
    fn try_from(r: RawGnss) -> Result<Self, String> {
        match r {
            RawGnss::Name(n) if n == "rtk" => Ok(GnssClass::Rtk),
            RawGnss::Name(n) if n == "standard" => Ok(GnssClass::Standard),
            RawGnss::Name(n) => Err(format!(
                "unknown GNSS class {n:?}: expected \"rtk\", \"standard\" or \
                 {{ horizontal_m = .., vertical_m = .. }}"
            )),
            RawGnss::Sigmas(s) => Ok(GnssClass::Custom(s)),
        }
    }
}

impl From<GnssClass> for RawGnss {
    fn from(g: GnssClass) -> Self {
        match g {
            GnssClass::Rtk => RawGnss::Name("rtk".into()),
            GnssClass::Standard => RawGnss::Name("standard".into()),
            GnssClass::Custom(s) => RawGnss::Sigmas(s),
        }
    }
}

impl Default for GnssClass {
    /// Standard GNSS: the class most users fly with.
    fn default() -> Self {
        GnssClass::Standard
    }
}

impl GnssClass {
    /// (horizontal RMS, vertical 1-sigma), metres.
    pub fn sigmas_m(&self) -> (f64, f64) {
        match self {
            GnssClass::Rtk => (0.02, 0.03),
            GnssClass::Standard => (1.5, 3.0),
            GnssClass::Custom(s) => (s.horizontal_m, s.vertical_m),
        }
    }

    /// How the class is named in messages.
    pub fn label(&self) -> String {
        let (h, v) = self.sigmas_m();
        match self {
            GnssClass::Rtk => format!("RTK GNSS {h}/{v} m"),
            GnssClass::Standard => format!("standard GNSS {h}/{v} m"),
            GnssClass::Custom(_) => format!("GNSS {h}/{v} m"),
        }
    }
}

impl std::str::FromStr for GnssClass {
    type Err = String;

    /// `rtk`, `standard`, or `H,V` (horizontal RMS and vertical 1-sigma in
    /// metres), as a command line gives it.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "rtk" => return Ok(GnssClass::Rtk),
            "standard" => return Ok(GnssClass::Standard),
            _ => {}
        }
        let bad = || {
            format!(
                "invalid GNSS class {s:?}: expected rtk, standard or H,V (horizontal RMS and \
                 vertical 1-sigma in metres, e.g. 0.5,1.0)"
            )
        };
        let (h, v) = s.split_once(',').ok_or_else(bad)?;
        let num = |t: &str| {
            t.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 0.0)
        };
        match (num(h), num(v)) {
            (Some(horizontal_m), Some(vertical_m)) => Ok(GnssClass::Custom(GnssSigmas {
                horizontal_m,
                vertical_m,
            })),
            _ => Err(bad()),
        }
    }
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn a_command_line_names_a_class_or_gives_its_numbers() {
        assert_eq!("rtk".parse::<GnssClass>(), Ok(GnssClass::Rtk));
        assert_eq!("standard".parse::<GnssClass>(), Ok(GnssClass::Standard));
        assert_eq!(
            "0.5, 1".parse::<GnssClass>().map(|g| g.sigmas_m()),
            Ok((0.5, 1.0))
        );
        for bad in ["", "RTK-ish", "0.5", "a,b", "-1,2", "nan,1"] {
            let e = bad.parse::<GnssClass>().unwrap_err();
            assert!(e.contains("expected rtk, standard or H,V"), "{bad}: {e}");
        }
    }
}
