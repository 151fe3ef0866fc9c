//! The sections of `docs/reproduction.md` that do not come from the run folders ([`super::render`]
//! writes the rest): the constructions the dissertation's text leaves open, with the tool's
//! choice and the other reading, and the stand-in plants' calibration from the committed fit
//! record.

use super::compare::{num, short_num};
use std::fmt::Write as _;

/// Where the dissertation's text leaves a construction open: (section, what it says, what the
/// tool does, where the other reading is). docs/definitions.md gives each in full.
const CONSTRUCTIONS: &[(&str, &str, &str, &str)] = &[
    (
        "4.2.4",
        "Method 1's filter of a negative correlation has its signs \"chosen so that\" the 1-, \
         2- and 4-pixel shifts correlate negatively; the signs are not printed",
        "Thue-Morse signs `(-1)^popcount(|d|)` (what an exhaustive search over sign patterns \
         finds; lag-1 reach about -0.507, targets beyond clamp and are counted)",
        "`synthesis.negative_signs: alternating` (`(-1)^d`: lag 1 exactly negated)",
    ),
    (
        "4.2.3",
        "the filtered data are scaled by the sample variance of the generated images",
        "scaled by the filter's exact standard deviation (independent of the samples drawn)",
        "none (a difference of sampling noise only)",
    ),
    (
        "4.3.1",
        "the worked example of Method 2's solver states two sets of target correlations \
         (0.3, -0.25, 0.2, then 0.3, -0.2, 0.1 as reached) and one set of parameters",
        "both sets solved (below, \"Numbers the text states for figures\"), the parameters \
         compared with the solution for the set stated as reached",
        "the first set's solution, on the same line",
    ),
    (
        "4.4.2",
        "how many samples each method generated for the plants' similarity tables is not \
         printed",
        "as many as the originals, 100 (`experiments/similarity_plants.yaml`): only then can \
         the printed correlation matrix distances be reached. The full covariance baseline \
         draws from the sample covariance of 100 images (rank 99 at most), whose distance to \
         its own source is about `1 - (1 + r/M)^(-1/2)` for effective rank `r` and `M` draws: \
         at most 0.045 for `M = 1000`, against the printed 0.25-0.27; on white data (100 \
         originals) the tool measures 0.286 for full covariance and 0.976 for Methods 1 and 2 \
         with `M = 100`, 0.045 and 0.932 with `M = 1000`, the printed values being 0.25-0.27 \
         and 0.970-0.976",
        "`synthesis.samples: 1000` (the size of the other similarity specs)",
    ),
    (
        "5.1.3",
        "H2 reads the mean correlating function",
        "its magnitude",
        "the real part, in the same table (`hypotheses.parquet`, `correlating_function.parquet`)",
    ),
    (
        "5.1.5",
        "H4 (correlation falls with the level) was judged \"not verified\" from levels 2-3",
        "judged at every level, and over all levels",
        "the per-level rows of levels 2 and 3 in `hypotheses.parquet`",
    ),
    (
        "5.3.4",
        "the networks' training settings are not given (MATLAB's `trainNetwork`)",
        "MATLAB's `sgdm` defaults: 30 epochs, mini-batch 128, shuffled once, the last partial \
         batch left out, so 100 and 250 training samples both take 30 steps and 1000 take 210 \
         (and in the location experiment `original` trains 30 steps on 128 of its 250 \
         samples, the 2500 generated training samples 570)",
        "`training.protocol: equal_steps` (every network of a section as many steps as its \
         largest set takes: 210 in classification, 570 in location; reshuffled every epoch, \
         `original` on all its originals): the third reading of Tables 20 and 22 and of \
         Fig. 73's gain",
    ),
];

/// Sizes the text states only in captions, each read there and used by the specs: (where,
/// what the caption says, the spec that uses it).
const STATED_SIZES: &[(&str, &str, &str)] = &[
    (
        "Appendix B, Figs. 103-112, Tables 25-26",
        "\"(1000 Samples)\": the exponential originals and each generated set",
        "`experiments/similarity_exponential.yaml`: 1000 originals, `synthesis.samples: 1000`",
    ),
    (
        "Appendix B, Figs. 113-116, Tables 27-28",
        "\"(100 Samples)\": the non-exponential originals and each generated set",
        "`experiments/similarity_nonexponential.yaml`: 100 originals, `synthesis.samples: 100`",
    ),
];

/// The sections listing [`STATED_SIZES`] and [`CONSTRUCTIONS`].
pub(super) fn constructions(s: &mut String) {
    let _ = writeln!(
        s,
        "## Constructions the text leaves open
"
    );
    let _ = writeln!(
        s,
        "Where the dissertation does not say enough to build something one way, the tool \
         chooses, says so here, and keeps the other reading one spec key away (or in the same \
         table).\n"
    );
    let _ = writeln!(s, "| § | the dissertation | the tool | the other reading |");
    let _ = writeln!(s, "|---|---|---|---|");
    for (section, text, tool, other) in CONSTRUCTIONS {
        let _ = writeln!(s, "| {section} | {text} | {tool} | {other} |");
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "Sizes stated only in captions (the specs use them):\n\n| where | the caption | the tool |\n|---|---|---|"
    );
    for (at, caption, tool) in STATED_SIZES {
        let _ = writeln!(s, "| {at} | {caption} | {tool} |");
    }
    let _ = writeln!(s);
}

/// The section on the stand-in plants' calibration, from the committed fit record: the
/// fitted parameters before and after, and each fitted table's residual.
pub(super) fn calibration(s: &mut String) {
    use crate::physics::vegetation::calibration::record;
    let r = record();
    let _ = writeln!(
        s,
        "## The stand-in plants' calibration
"
    );
    let _ = writeln!(
        s,
        "The measured plants are not public; the simulated stand-in's free parameters are \
         fitted to published statistics (`{}`, seed {}, {} samples a simulation; record in \
         reproduction/plant_calibration.json, method in docs/definitions.md section 10). No \
         fit reads Tables 20 and 22 or Figs. 73-74.\n",
        r.command, r.seed, r.samples
    );
    let _ = writeln!(
        s,
        "Plants A-C, to Table 16 (mean pixel variance; physical preset: gain 1, motion 1):\n"
    );
    let _ = writeln!(
        s,
        "| plant | gain | motion | Table 16 (none, light) | fitted (none, light) |"
    );
    let _ = writeln!(s, "|---|---:|---:|---|---|");
    for f in &r.fits {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}, {} | {}, {} |",
            f.plant,
            num(f.gain),
            num(f.motion),
            short_num(f.target[0]),
            short_num(f.target[1]),
            num(f.achieved[0]),
            num(f.achieved[1])
        );
    }
    let kl = super::compare::similarity_fit_tables()
        .range(13..=15)
        .next()
        .is_some();
    let _ = writeln!(
        s,
        "\nPlants D and E, to Tables 29-36 (correlation matrix distance and multiscale \
         correlation RMSE of the three generation methods, light and medium wind, {} samples \
         generated a method; physical preset: motion 1, receiver noise -40 dB){}. The residual \
         of a table is the root mean square over its cells of the log ratio tool / printed \
         (for a distance printed above 1/2, of the distances from 1): 0.1 is about 10 %. \
         Tables 11-12 repeat the fitted cells:\n",
        r.similarity.first().map_or(0, |f| f.generated_samples),
        if kl {
            " and to the KL divergence Tables 13-15 (the reproduction's estimator, \
             `--kl`)"
        } else {
            ""
        }
    );
    let _ = writeln!(s, "| plant | motion | noise (dB) | objective before | after | residual by table (before -> after) |");
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|");
    for f in &r.similarity {
        let tables: Vec<String> = f
            .tables
            .iter()
            .map(|t| format!("{}: {:.2} -> {:.2}", t.table, t.before, t.after))
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            f.plant,
            num(f.motion),
            num(f.noise_db),
            num(f.objective[0]),
            num(f.objective[1]),
            tables.join("; ")
        );
    }
    let _ = writeln!(s);
}
