//! The acquisition strategies of the paper's Table 1: triplet strategies
//! (`F5x4`, `F1x20`, `NP5x4`, ...), the Grid baseline, and their unions.

use serde::{Deserialize, Serialize};

use crate::error::{Result, SimError};

/// A triplet strategy: `iterations` planning calls of `per_iteration`
/// triplets each, with or without confidence prediction.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Strategy {
    /// Name as written in the config (`F5x4`).
    pub name: String,
    /// Planning iterations (geometry updated between them).
    pub iterations: usize,
    /// Triplets per planning call (k).
    pub per_iteration: usize,
    /// Whether the planner reads predicted confidence (F) or not (NP).
    pub prediction: bool,
}

impl Strategy {
    /// Parses `F<i>x<k>` or `NP<i>x<k>` (i, k >= 1).
    pub fn parse(name: &str) -> Result<Self> {
        let bad = || {
            SimError::InvalidArgument(format!(
                "strategy '{name}': expected F<iterations>x<triplets> or NP<iterations>x<triplets>, e.g. F5x4"
            ))
        };
        let (prediction, rest) = if let Some(r) = name.strip_prefix("NP") {
            (false, r)
        } else if let Some(r) = name.strip_prefix('F') {
            (true, r)
        } else {
            return Err(bad());
        };
        let (i, k) = rest.split_once('x').ok_or_else(bad)?;
        let iterations: usize = i.parse().map_err(|_| bad())?;
        let per_iteration: usize = k.parse().map_err(|_| bad())?;
        // checked: the numbers come from a file and their product may overflow.
        let total = iterations.checked_mul(per_iteration);
        if iterations == 0 || per_iteration == 0 || total.is_none_or(|t| t > 1000) {
            return Err(bad());
        }
        Ok(Strategy {
            name: name.to_string(),
            iterations,
            per_iteration,
            prediction,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (found by fuzzing, `tests/fuzz`): `F18446744073709551615x3`
    /// overflowed `iterations * triplets` and panicked instead of an error.
    #[test]
    fn huge_strategy_numbers_are_an_error_not_an_overflow() {
        let e = Strategy::parse("F18446744073709551615x3").unwrap_err();
        assert!(e.to_string().contains("F18446744073709551615x3"), "{e}");
    }

    #[test]
    fn parses_the_paper_names_and_refuses_others() {
        let f = Strategy::parse("F5x4").unwrap();
        assert_eq!((f.iterations, f.per_iteration, f.prediction), (5, 4, true));
        let np = Strategy::parse("NP1x20").unwrap();
        assert_eq!(
            (np.iterations, np.per_iteration, np.prediction),
            (1, 20, false)
        );
        for bad in ["G5x4", "F5", "F0x4", "Fx4", "NP5x", "F5x4x1"] {
            assert!(Strategy::parse(bad).is_err(), "{bad}");
        }
    }
}
