//! The CNN tables of the reproduction (Tables 20 and 22: classification accuracy by training
//! size), each read two ways: under the dissertation's protocol (the networks predict the same
//! 100 originals per class the methods were fitted on, `experiments/cnn_classification_dissertation.yaml`)
//! and under held-out testing (fitted on 80 originals per class, tested on the other 20,
//! `experiments/cnn_classification_full.yaml`). Each spec repeats every training itself (its
//! `repeats`, other initial weights and generated sets), so it runs once and the spread is that
//! of its repeats ([`Query::each_row`]).

use super::compare::Spread;
use super::extract::{Key, Query, Recipe};
use crate::io::results::{self, col};

/// The spec of the dissertation's protocol.
pub const DISSERTATION: &str = "cnn_classification_dissertation";
/// The spec of held-out testing.
pub const HELD_OUT: &str = "cnn_classification_full";

/// The printed rows' methods (the last row, `original`, has one cell: 100 samples).
const METHODS: [&str; 4] = ["method1", "method2", "full_covariance", "original"];
/// The printed columns' training sizes.
pub const SIZES: [i64; 4] = [100, 250, 500, 1000];

const WHY: &str = "The measured plants are not public: the classes are the tool's simulated \
    stand-in plants D and E (docs/definitions.md section 10), calibrated to the similarity \
    Tables 29-36 (never to these tables) and to no published variance; the dissertation gives neither its number of repeats nor its training settings \
    (the tool's: MATLAB's sgdm defaults, docs/cnn.md); the originals' row is read at 100 \
    training samples in all (25 a class), the column the dissertation prints it in";

/// The test accuracy (%) of `method` in `spec`, normalised by `normalise`, at training size
/// `size` (every size where `None`): every repeat's row.
pub fn accuracy(
    spec: &'static str,
    normalise: &'static str,
    method: &'static str,
    size: Option<i64>,
) -> Query {
    let mut filters = vec![
        (col::NORMALISE, Key::S(normalise)),
        (col::METHOD, Key::S(method)),
    ];
    filters.extend(size.map(|n| (col::TRAIN_SIZE, Key::I(n))));
    Query {
        spec,
        table: results::CLASSIFICATION,
        filters,
        column: col::TEST_ACCURACY,
        scale: 100.0,
        all_verified: false,
        each_row: true,
    }
}

/// Tables 20 (zero mean) and 22 (zero mean, unit variance), each under both protocols.
pub fn recipes() -> Vec<Recipe> {
    let mut r = Vec::new();
    for (number, normalise) in [(20, "zero_mean"), (22, "zero_mean_unit_variance")] {
        for (spec, protocol) in [
            (
                DISSERTATION,
                "the dissertation's protocol: the methods fitted on the 100 originals of each \
                 class, the networks tested on the same 400",
            ),
            (
                HELD_OUT,
                "held-out testing: the methods fitted on 80 originals of each class, the \
                 networks tested on the other 80 (20 a class)",
            ),
        ] {
            let cells = METHODS
                .iter()
                .map(|&m| {
                    SIZES
                        .iter()
                        .map(|&n| {
                            (m != "original" || n == 100)
                                .then(|| accuracy(spec, normalise, m, Some(n)))
                        })
                        .collect()
                })
                .collect();
            r.push(Recipe {
                number,
                spread: Spread::Random,
                cells,
                differs_because: WHY,
                protocol: Some(protocol),
            });
        }
    }
    r
}
