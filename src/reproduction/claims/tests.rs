//! Tests of the claims' judge: on hand-made tool values (ties, factors, missing cells,
//! verdicts), and on the printed numbers against the transcriber's own reading.

use super::*;
use crate::reproduction::compare::Spread;
use crate::reproduction::evaluated::{Cell, Evaluated, Stated};

/// A tool cell of `mean` and `sd` over 5 repeats.
fn cell(mean: f64, sd: f64) -> Cell {
    Cell {
        printed: None,
        tool: Some(Summary { mean, sd, n: 5 }),
        difference: None,
        verdict: None,
        tolerance: None,
        first: Some(mean),
    }
}

/// Table `number` evaluated with `rows` of (mean, sd) cells.
fn table(number: u32, rows: &[&[(f64, f64)]]) -> Evaluated {
    Evaluated {
        number,
        sources: vec![("similarity_exponential".into(), 5)],
        cells: rows
            .iter()
            .map(|r| r.iter().map(|&(m, s)| cell(m, s)).collect())
            .collect(),
        spread: Spread::Random,
        differs_because: "",
        protocol: None,
        floor: None,
        missing: Vec::new(),
    }
}

const EXP: &str = "Data Generated with Exponential Correlating function";
const AREA_RE: &str = "Mean KL Divergence By 8x8 Image Area / Real";

fn at(table: u32, row: &str, column: &str) -> CellRef {
    CellRef {
        table,
        row: row.into(),
        column: column.into(),
    }
}

/// "An order of magnitude less": full covariance (Table 8) times 10 below Method 1 (Table 9).
fn order_of_magnitude() -> Claim {
    Claim {
        id: "t".into(),
        section: "4.4.1".into(),
        quote: String::new(),
        reading: String::new(),
        tables: vec![8, 9],
        figures: vec![],
        checks: vec![Check::Less {
            lower: vec![at(8, EXP, AREA_RE)],
            higher: vec![at(9, EXP, AREA_RE)],
            factor: Some(10.0),
        }],
        undecidable: None,
        printed: None,
    }
}

fn four(v: (f64, f64)) -> Vec<(f64, f64)> {
    vec![v; 4]
}

#[test]
fn an_order_of_magnitude_holds_fails_or_ties_with_the_spread() {
    let d = Dissertation::load().unwrap();
    let claim = order_of_magnitude();
    let run = |full: (f64, f64), m1: (f64, f64)| {
        let ev = vec![
            table(8, &[&four(full), &four(full)]),
            table(9, &[&four(m1), &four(m1)]),
        ];
        judge(&d, &Side::Tool(&ev, &[]), &claim).0
    };
    // 10 x 1e-6 = 1e-5, well below 3e-5.
    assert_eq!(run((1e-6, 1e-8), (3e-5, 1e-7)), Outcome::Holds);
    // The case: full covariance 3.07e-4 against Method 1's 3.13e-4.
    assert_eq!(run((3.07e-4, 1e-6), (3.13e-4, 1e-6)), Outcome::Fails);
    // 10 x 3e-6 = 3e-5 against 3.1e-5, with a spread of 1e-6 each: two standard errors of the
    // difference are 2 sqrt(1e-11/5 + 1e-12/5) = 2.97e-6 > 1e-6: a tie.
    assert_eq!(run((3e-6, 1e-7), (3.1e-5, 1e-6)), Outcome::NotDecidable);
    // The same with no spread decides.
    assert_eq!(run((3e-6, 0.0), (3.1e-5, 0.0)), Outcome::Holds);
}

#[test]
fn a_missing_cell_is_not_decidable_and_named() {
    let d = Dissertation::load().unwrap();
    let ev = vec![table(8, &[&four((1e-6, 0.0)), &four((1e-6, 0.0))])];
    let (o, why) = judge(&d, &Side::Tool(&ev, &[]), &order_of_magnitude());
    assert_eq!(o, Outcome::NotDecidable);
    assert!(why.contains("Table 9 is not reproduced"), "{why}");
    let mut gap = table(9, &[&four((3e-5, 0.0)), &four((3e-5, 0.0))]);
    gap.cells[0][2].tool = None;
    let ev = vec![ev[0].clone(), gap];
    let (o, why) = judge(&d, &Side::Tool(&ev, &[]), &order_of_magnitude());
    assert_eq!(o, Outcome::NotDecidable);
    assert!(
        why.contains("not computed") && why.contains("experiments/similarity_exponential.yaml"),
        "{why}"
    );
}

#[test]
fn within_rises_and_verdicts() {
    let d = Dissertation::load().unwrap();
    let col2 = "Mean Image KL Divergence / 2nd-Order Model";
    let col4 = "Mean Image KL Divergence / 4th-Order Model";
    let within = |m: f64| Claim {
        checks: vec![Check::Within {
            a: vec![at(1, "Plant A, No Wind", col2)],
            b: vec![at(1, "Plant A, No Wind", col4)],
            margin: Some(m),
            relative: None,
        }],
        ..order_of_magnitude()
    };
    let row: &[(f64, f64)] = &[(-21.5, 0.05), (-21.9, 0.05)];
    let ev = vec![table(1, &[row; 6])];
    let tool = Side::Tool(&ev, &[]);
    assert_eq!(judge(&d, &tool, &within(1.0)).0, Outcome::Holds);
    assert_eq!(judge(&d, &tool, &within(0.2)).0, Outcome::Fails);
    assert_eq!(judge(&d, &tool, &within(0.4)).0, Outcome::NotDecidable);
    // The printed cells differ by 0.37 dB.
    assert_eq!(judge(&d, &Side::Printed, &within(1.0)).0, Outcome::Holds);
    assert_eq!(judge(&d, &Side::Printed, &within(0.3)).0, Outcome::Fails);

    let rows = [
        "Plant A, No Wind",
        "Plant A, Light Wind",
        "Plant B, No Wind",
    ];
    let rises = Claim {
        checks: vec![Check::Rises {
            cells: rows.iter().map(|r| at(1, r, col2)).collect(),
        }],
        ..order_of_magnitude()
    };
    let up = vec![table(
        1,
        &[
            &[(1.0, 0.0), (0.0, 0.0)],
            &[(2.0, 0.0), (0.0, 0.0)],
            &[(3.0, 0.0), (0.0, 0.0)],
        ],
    )];
    assert_eq!(judge(&d, &Side::Tool(&up, &[]), &rises).0, Outcome::Holds);
    let down = vec![table(
        1,
        &[
            &[(1.0, 0.0), (0.0, 0.0)],
            &[(3.0, 0.0), (0.0, 0.0)],
            &[(2.0, 0.0), (0.0, 0.0)],
        ],
    )];
    assert_eq!(judge(&d, &Side::Tool(&down, &[]), &rises).0, Outcome::Fails);

    // Table 24: H1 printed "Verified", H4 "Not Verified".
    let h = |row: usize| {
        let t = d.table(24).unwrap();
        Claim {
            checks: vec![Check::Verdict {
                cells: vec![at(24, &t.rows[row], "Conclusion")],
            }],
            ..order_of_magnitude()
        }
    };
    let shares = vec![table(
        24,
        &[&[(0.8, 0.0)], &[(1.0, 0.0)], &[(0.0, 0.0)], &[(0.6, 0.0)]],
    )];
    let tool = Side::Tool(&shares, &[]);
    assert_eq!(judge(&d, &tool, &h(0)).0, Outcome::Holds);
    assert_eq!(judge(&d, &tool, &h(2)).0, Outcome::Fails);
    // H4 not verified in 2 of 5 (verified in 3): the printed "not verified" is not reached.
    assert_eq!(judge(&d, &tool, &h(3)).0, Outcome::Fails);
}

/// Every committed claim resolves, and the judge's verdict on the printed numbers is the
/// one its transcriber computed independently (reproduction/claims.yaml's `printed`).
#[test]
fn the_committed_claims_resolve_and_agree_on_the_printed_numbers() {
    let d = Dissertation::load().unwrap();
    let claims = Claims::load(&d).unwrap();
    assert!(claims.claims.len() >= 20, "{} claims", claims.claims.len());
    let mut compared = 0;
    for c in &claims.claims {
        let Some(want) = c.printed.as_deref() else {
            continue;
        };
        let (got, text) = judge(&d, &Side::Printed, c);
        let want = match want {
            "holds" => Outcome::Holds,
            "fails" | "mixed" => Outcome::Fails,
            other => panic!("claim {}: printed {other:?}", c.id),
        };
        assert_eq!(got, want, "claim {} on the printed numbers: {text}", c.id);
        compared += 1;
    }
    assert!(
        compared >= 10,
        "only {compared} claims carry a printed reading"
    );
}

/// A computed statement of the text (`figures:`).
fn stated(quantity: &str, printed: Option<f64>, mean: f64, sd: f64) -> Stated {
    Stated {
        quantity: quantity.into(),
        tool: Summary { mean, sd, n: 5 },
        printed,
        verdict: None,
        computed: "a difference".into(),
        differs_because: String::new(),
        unit: None,
        repeats: 5,
        given: 5,
        bounded: 0,
        exact: false,
        missing: Vec::new(),
    }
}

#[test]
fn stated_numbers_and_orderings() {
    let d = Dissertation::load().unwrap();
    let q = "Constant target location: target sensitivity improvement";
    let claim = |quantity: &str, nth: usize, margin: Option<f64>| Claim {
        checks: vec![Check::Stated {
            quantity: quantity.into(),
            nth,
            margin,
        }],
        ..order_of_magnitude()
    };
    let gains = [
        stated(&format!("{q} (a)"), Some(3.0), 14.09, 1.36),
        stated(&format!("{q} (b)"), Some(3.0), 3.2, 0.3),
    ];
    let tool = Side::Tool(&[], &gains);
    assert_eq!(judge(&d, &tool, &claim(q, 0, Some(1.5))).0, Outcome::Fails);
    assert_eq!(judge(&d, &tool, &claim(q, 1, Some(1.5))).0, Outcome::Holds);
    let (o, why) = judge(&d, &tool, &claim(q, 2, Some(1.5)));
    assert_eq!(o, Outcome::NotDecidable);
    assert!(why.contains("no computed statement 2"), "{why}");
    let s = "Stochastic target location";
    let links = [
        stated(s, None, 4.0, 1.0),
        stated(s, None, -3.0, 1.0),
        stated(s, None, 0.2, 1.0),
    ];
    let tool = Side::Tool(&[], &links);
    assert_eq!(judge(&d, &tool, &claim(s, 0, None)).0, Outcome::Holds);
    assert_eq!(judge(&d, &tool, &claim(s, 1, None)).0, Outcome::Fails);
    assert_eq!(
        judge(&d, &tool, &claim(s, 2, None)).0,
        Outcome::NotDecidable
    );
    assert_eq!(
        judge(&d, &Side::Printed, &claim(s, 0, None)).0,
        Outcome::NotDecidable
    );
}

/// A stated number the tool only bounds from below (the level reached at the lowest SCR
/// swept): a bound above the stated number fails the claim, one below it cannot tell; a
/// statement whose run folders are missing is not decidable, naming them.
#[test]
fn lower_bounds_and_missing_folders() {
    let d = Dissertation::load().unwrap();
    let q = "Constant target location: target sensitivity improvement";
    let claim = Claim {
        checks: vec![Check::Stated {
            quantity: q.into(),
            nth: 0,
            margin: Some(1.5),
        }],
        ..order_of_magnitude()
    };
    let bounded = |mean: f64| Stated {
        bounded: 2,
        ..stated(q, Some(3.0), mean, 0.5)
    };
    let above = [bounded(16.5)];
    let (o, why) = judge(&d, &Side::Tool(&[], &above), &claim);
    assert_eq!(o, Outcome::Fails);
    assert!(why.contains("a lower bound in 2 of 5"), "{why}");
    let below = [bounded(1.0)];
    assert_eq!(
        judge(&d, &Side::Tool(&[], &below), &claim).0,
        Outcome::NotDecidable
    );
    let missing = [Stated {
        repeats: 0,
        given: 0,
        missing: vec!["out/cnn_location_gain/seed-1 (not run)".into()],
        ..stated(q, Some(3.0), f64::NAN, 0.0)
    }];
    let (o, why) = judge(&d, &Side::Tool(&[], &missing), &claim);
    assert_eq!(o, Outcome::NotDecidable);
    assert!(
        why.contains("out/cnn_location_gain/seed-1 (not run)"),
        "{why}"
    );
}
