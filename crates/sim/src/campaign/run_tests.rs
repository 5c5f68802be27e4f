//! Tests of the campaign runner (`run.rs`).

use super::*;
use crate::campaign::strategy_run::strategy_seed;

/// Issue 34, fair comparisons: the planner seed differed by strategy name,
/// so F5x4 and NP5x4 planned from different random draws and a difference
/// between them could be the seed's. Now the same shape gets the same
/// seeds on a site; only the prediction differs.
#[test]
fn f_and_np_of_one_shape_share_their_seeds_on_a_site() {
    let s = |n: &str| Strategy::parse(n).unwrap();
    assert_eq!(
        strategy_seed(42, 7, &s("F5x4")),
        strategy_seed(42, 7, &s("NP5x4"))
    );
    assert_ne!(
        strategy_seed(42, 7, &s("F5x4")),
        strategy_seed(42, 7, &s("F1x20"))
    );
    assert_ne!(
        strategy_seed(42, 7, &s("F5x4")),
        strategy_seed(42, 8, &s("F5x4"))
    );
}
