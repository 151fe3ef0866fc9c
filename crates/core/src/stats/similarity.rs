//! One comparison of two stacks under the spec's metrics: the rows of `similarity.parquet`
//! and the KL maps, for a synthesis job (original vs generated) or a noise floor (original vs
//! an independent draw, or one half vs the other). Pure: no I/O; the caller's rayon pool runs
//! the kernels.

use crate::stats::analysis::{Analysis, Direction};
use crate::stats::cmd::{cmd_terms, Form, Normalised};
use crate::stats::metrics::{
    db, finite_max, finite_mean, kl_maps, map_stem, multiscale_rmse, name, rmse_summaries,
    KlOptions, Metric, Parts,
};
use ndarray::{Array2, ArrayView3, Axis};

/// One row of `similarity.parquet` (without the job columns).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// `kl_pixel`, `kl_area`, `cmd` or `multiscale_rmse`.
    pub metric: &'static str,
    /// Level of a per-level RMSE.
    pub level: Option<usize>,
    /// Direction of a per-level RMSE.
    pub direction: Option<Direction>,
    /// `re` or `im` for KL rows.
    pub component: Option<&'static str>,
    /// What `value` is: `mean` and `max` of a KL map, `distance` (CMD), `rmse` (one level and
    /// direction), `average_level_1` and `average_levels_1_3` (the dissertation's summaries).
    pub statistic: &'static str,
    /// The value (in dB for KL rows when the metric's `db` is set).
    pub value: f64,
    /// Units behind the value: finite KL map cells, compared correlation cells, CMD pixels.
    pub units: usize,
    /// KL parameters of KL rows.
    pub kl: Option<KlOptions>,
    /// Block edge of `kl_area` rows.
    pub block: Option<usize>,
    /// CMD: the forms used for `||R1||`, `||R2||` and `tr(R1 R2)` (`gram` or `full`).
    pub form: Option<String>,
}

/// The result of one comparison.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Table rows.
    pub rows: Vec<Row>,
    /// KL maps by file stem (`kl_pixel_re`, `kl_area_im`, ...).
    pub maps: Vec<(String, Array2<f64>)>,
    /// Samples on each side `(N1, N2)`.
    pub samples: (usize, usize),
}

/// One side of a comparison: a stack and, for `multiscale_rmse`, its analysis.
#[derive(Clone, Copy)]
pub struct Side<'a, T> {
    /// `[N, H, W]`.
    pub stack: ArrayView3<'a, T>,
    /// The analysis of `stack` (needed by `multiscale_rmse`).
    pub analysis: Option<&'a Analysis>,
}

/// Compares `a` (the reference: the original) with `b` under `metrics`.
///
/// # Panics
/// If the image sizes differ, or `multiscale_rmse` is asked without both analyses.
pub fn compare<A: Parts, B: Parts>(a: Side<A>, b: Side<B>, metrics: &[Metric]) -> Comparison {
    let mut out = Comparison {
        rows: vec![],
        maps: vec![],
        samples: (a.stack.dim().0, b.stack.dim().0),
    };
    for m in metrics {
        match *m {
            Metric::KlPixel(o) => kl_rows(&mut out, m.name(), a, b, 1, o, None),
            Metric::KlArea(o, block) => kl_rows(&mut out, m.name(), a, b, block, o, Some(block)),
            Metric::Cmd => out.rows.push(cmd_row(a.stack, b.stack)),
            Metric::MultiscaleRmse => {
                let (x, y) = (
                    a.analysis.expect("analysis of the reference"),
                    b.analysis.expect("analysis of the compared stack"),
                );
                out.rows.extend(rmse_rows(x, y));
            }
        }
    }
    out
}

fn kl_rows<A: Parts, B: Parts>(
    out: &mut Comparison,
    metric: &'static str,
    a: Side<A>,
    b: Side<B>,
    block: usize,
    o: KlOptions,
    block_col: Option<usize>,
) {
    let maps = kl_maps(a.stack, b.stack, block, &o);
    for (map, component) in maps.into_iter().zip(["re", "im"]) {
        let (mean, nan) = finite_mean(&map);
        let units = map.len() - nan;
        for (statistic, v) in [("mean", mean), ("max", finite_max(&map))] {
            out.rows.push(Row {
                metric,
                level: None,
                direction: None,
                component: Some(component),
                statistic,
                value: if o.db { db(v) } else { v },
                units,
                kl: Some(o),
                block: block_col,
                form: None,
            });
        }
        out.maps.push((map_stem(metric, component), map));
    }
}

fn rmse_rows(x: &Analysis, y: &Analysis) -> Vec<Row> {
    let per_level = multiscale_rmse(x, y);
    let row = |level, direction, statistic, value, units| Row {
        metric: name::MULTISCALE_RMSE,
        level,
        direction,
        component: None,
        statistic,
        value,
        units,
        kl: None,
        block: None,
        form: None,
    };
    let mut rows: Vec<Row> = per_level
        .iter()
        .map(|r| row(Some(r.level), Some(r.direction), "rmse", r.rmse, r.cells))
        .collect();
    let cells = |max: usize| {
        per_level
            .iter()
            .filter(|r| r.level <= max)
            .map(|r| r.cells)
            .sum()
    };
    let (l1, l13) = rmse_summaries(&per_level);
    rows.push(row(None, None, "average_level_1", l1, cells(1)));
    if let Some(v) = l13 {
        rows.push(row(None, None, "average_levels_1_3", v, cells(3)));
    }
    rows
}

/// Pixels usable by the CMD: finite in every sample and with non-zero variance, in both stacks.
pub fn usable_pixels<A: Parts, B: Parts>(a: ArrayView3<A>, b: ArrayView3<B>) -> Vec<usize> {
    let (ua, ub) = (pixel_usable(a), pixel_usable(b));
    (0..ua.len()).filter(|&p| ua[p] && ub[p]).collect()
}

fn pixel_usable<T: Parts>(x: ArrayView3<T>) -> Vec<bool> {
    let (n, h, w) = x.dim();
    let first: Vec<(f64, f64)> = x.index_axis(Axis(0), 0).iter().map(|v| v.parts()).collect();
    let mut ok = vec![true; h * w];
    let mut varies = vec![false; h * w];
    for s in 0..n {
        for (p, v) in x.index_axis(Axis(0), s).iter().enumerate() {
            let (re, im) = v.parts();
            if !(re.is_finite() && im.is_finite()) {
                ok[p] = false;
            } else if (re, im) != first[p] {
                varies[p] = true;
            }
        }
    }
    ok.iter().zip(&varies).map(|(&o, &v)| o && v).collect()
}

/// Builds the CMD's normalised matrix of a stack over `pixels`.
pub fn normalised<T: Parts>(x: ArrayView3<T>, pixels: &[usize]) -> Normalised {
    let (n, _, w) = x.dim();
    Normalised::from_fn(n, pixels, |s, p| x[[s, p / w, p % w]].parts())
}

fn cmd_row<A: Parts, B: Parts>(a: ArrayView3<A>, b: ArrayView3<B>) -> Row {
    let pixels = usable_pixels(a, b);
    let (value, form) = if pixels.is_empty() {
        (f64::NAN, None)
    } else {
        let t = cmd_terms(&normalised(a, &pixels), &normalised(b, &pixels));
        let name = |f: Form| match f {
            Form::Gram => "gram",
            Form::Full => "full",
        };
        let form = format!("{}/{}/{}", name(t.form1), name(t.form2), name(t.form_cross));
        (t.distance(), Some(form))
    };
    Row {
        metric: name::CMD,
        level: None,
        direction: None,
        component: None,
        statistic: "distance",
        value,
        units: pixels.len(),
        kl: None,
        block: None,
        form,
    }
}
