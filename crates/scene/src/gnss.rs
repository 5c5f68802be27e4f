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
