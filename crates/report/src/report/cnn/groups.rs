//! The CNN trainings read into one shape for the report and the terminal: a training's row,
//! a group of them (the normalisation or the target; methods; x: the training size or the
//! SCR; repeats) summarised over repeats, and the representative training a group's figures
//! show in detail. The tables ([`super::table`]) and figures read these.

use super::super::table::{floats, kept_rows, optional_floats, optional_strings, strings};
use crate::io::results::{col, value, CnnApp};
use anyhow::{Context, Result};
use std::path::Path;

/// One training's row.
#[derive(Debug, Clone)]
pub(super) struct Training {
    pub(super) job: String,
    pub(super) method: String,
    /// Training size, or SCR in dB.
    pub(super) x: f64,
    pub(super) repeat: i64,
    /// Accuracies in %.
    pub(super) test: f64,
    pub(super) train: Option<f64>,
    pub(super) validation: Option<f64>,
    /// The classification's protocol (null for location).
    pub(super) protocol: Option<String>,
    pub(super) test_samples: Option<f64>,
    pub(super) samples_per_second: Option<f64>,
}

/// The trainings of one normalisation (classification) or one target (location).
#[derive(Debug, Clone)]
pub(super) struct Group {
    pub(super) name: String,
    /// Methods in order of first appearance (the spec's order).
    pub(super) methods: Vec<String>,
    /// Distinct x values, ascending.
    pub(super) xs: Vec<f64>,
    pub(super) rows: Vec<Training>,
    /// Whether the figures of single trainings (confusion, training curves, examples) are
    /// drawn for this group: not for a location group tested on another test set than the
    /// table's first, whose trainings (and confusion counts) are the first's.
    pub(super) details: bool,
}

/// The name of a group: `group` (a normalisation or a target), and for a location group
/// tested on every original (`test_set` [`value::ALL`]) that test set.
pub(super) fn group_name(group: &str, test_set: Option<&str>) -> String {
    match test_set {
        Some(value::ALL) => format!("{group} (tested on all originals)"),
        _ => group.to_string(),
    }
}

/// Mean, sample standard deviation (`n - 1`; none for one value), minimum and maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stats {
    pub(super) n: usize,
    pub(super) mean: f64,
    pub(super) std: Option<f64>,
    pub(super) min: f64,
    pub(super) max: f64,
}

impl Stats {
    /// The statistics of `v`, `None` when it is empty.
    pub(super) fn of(v: &[f64]) -> Option<Stats> {
        if v.is_empty() {
            return None;
        }
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = (n > 1)
            .then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
        let min = v.iter().copied().fold(f64::INFINITY, f64::min);
        let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Stats {
            n,
            mean,
            std,
            min,
            max,
        })
    }
}

impl Group {
    /// Rows of `method` at `x`, by repeat.
    pub(super) fn at<'a>(
        &'a self,
        method: &'a str,
        x: f64,
    ) -> impl Iterator<Item = &'a Training> + 'a {
        let mut rows: Vec<&Training> = self
            .rows
            .iter()
            .filter(|r| r.method == method && r.x == x)
            .collect();
        rows.sort_by_key(|r| r.repeat);
        rows.into_iter()
    }

    /// Test accuracy (%) of `method` at `x` over repeats.
    pub(super) fn stats(&self, method: &str, x: f64) -> Option<Stats> {
        Stats::of(&self.at(method, x).map(|r| r.test).collect::<Vec<_>>())
    }

    /// `(x, mean, std)` of `method`'s test accuracy (%) at every x it has.
    pub(super) fn curve(&self, method: &str) -> Vec<(f64, f64, f64)> {
        self.xs
            .iter()
            .filter_map(|&x| {
                self.stats(method, x)
                    .map(|s| (x, s.mean, s.std.unwrap_or(0.0)))
            })
            .collect()
    }

    /// Distinct values of `f` over the group's rows, in order of first appearance.
    pub(super) fn distinct<T: PartialEq>(&self, f: impl Fn(&Training) -> T) -> Vec<T> {
        let mut out = vec![];
        for r in &self.rows {
            let v = f(r);
            if !out.contains(&v) {
                out.push(v);
            }
        }
        out
    }
}

/// The trainings of `app` in `dir`, split into groups (in order of first appearance), keeping
/// the rows that pass `filters` (see [`kept_rows`]). `Ok(None)` when the file is missing or no
/// row passes.
///
/// # Errors
/// If the file cannot be read or lacks a column, or (when `strict`) a filter names a column
/// the file lacks.
pub(super) fn load(
    dir: &Path,
    app: CnnApp,
    filters: &[(String, Vec<String>)],
    strict: bool,
) -> Result<Option<Vec<Group>>> {
    let path = app.table().path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(None);
    };
    let Some(keep) = kept_rows(&df, &path, filters, strict)? else {
        return Ok(None);
    };
    let context = || format!("reading {}", path.display());
    let job = strings(&df, col::JOB).with_context(context)?;
    let method = strings(&df, col::METHOD).with_context(context)?;
    let group = strings(&df, app.group_column()).with_context(context)?;
    let x = floats(&df, app.x_column()).with_context(context)?;
    let repeat = floats(&df, col::REPEAT).with_context(context)?;
    let test = floats(&df, col::TEST_ACCURACY).with_context(context)?;
    let train = optional_floats(&df, col::TRAIN_ACCURACY)?;
    let validation = optional_floats(&df, col::VALIDATION_ACCURACY)?;
    let test_samples = optional_floats(&df, col::TEST_SAMPLES)?;
    let speed = optional_floats(&df, col::TRAIN_SAMPLES_PER_SECOND)?;
    let protocol = optional_strings(&df, col::PROTOCOL)?;
    let test_set = optional_strings(&df, col::TEST_SET)?;
    let first_set = (0..df.height())
        .find(|&i| keep[i])
        .and_then(|i| test_set[i].clone());
    let mut groups: Vec<Group> = vec![];
    for i in (0..df.height()).filter(|&i| keep[i]) {
        let (Some(g), Some(m), Some(x), Some(t)) = (&group[i], &method[i], x[i], test[i]) else {
            continue;
        };
        let row = Training {
            job: job[i].clone().unwrap_or_default(),
            method: m.clone(),
            x,
            repeat: repeat[i].unwrap_or(0.0) as i64,
            test: 100.0 * t,
            train: train[i].map(|v| 100.0 * v),
            validation: validation[i].map(|v| 100.0 * v),
            protocol: protocol[i].clone(),
            test_samples: test_samples[i],
            samples_per_second: speed[i],
        };
        let name = group_name(g, test_set[i].as_deref());
        let at = match groups.iter().position(|x| x.name == name) {
            Some(k) => k,
            None => {
                groups.push(Group {
                    name,
                    methods: vec![],
                    xs: vec![],
                    rows: vec![],
                    details: test_set[i] == first_set,
                });
                groups.len() - 1
            }
        };
        let grp = &mut groups[at];
        if !grp.methods.contains(m) {
            grp.methods.push(m.clone());
        }
        if !grp.xs.contains(&x) {
            grp.xs.push(x);
        }
        grp.rows.push(row);
    }
    for g in &mut groups {
        g.xs.sort_by(f64::total_cmp);
    }
    Ok((!groups.is_empty()).then_some(groups))
}

/// The training a group's figures show in detail (confusion matrix, training curves, example
/// images): the best generated method (highest mean test accuracy at the largest x for
/// classification; highest mean over the SCR sweep for location; `original` when nothing else
/// was trained), at the largest training size (classification) or at the lowest SCR where its
/// mean accuracy reaches 50 % (location; the highest SCR if it never does), first repeat.
#[derive(Debug, Clone)]
pub(super) struct Representative {
    pub(super) method: String,
    pub(super) x: f64,
    pub(super) job: String,
    pub(super) repeat: i64,
}

impl Group {
    pub(super) fn representative(&self, app: CnnApp) -> Option<Representative> {
        let generated: Vec<&String> = self.methods.iter().filter(|m| *m != "original").collect();
        let candidates = if generated.is_empty() {
            self.methods.iter().collect()
        } else {
            generated
        };
        let last = *self.xs.last()?;
        let score = |m: &str| -> f64 {
            match app {
                CnnApp::Classification => self.stats(m, last).map_or(f64::NEG_INFINITY, |s| s.mean),
                CnnApp::Location => {
                    let c = self.curve(m);
                    c.iter().map(|p| p.1).sum::<f64>() / c.len().max(1) as f64
                }
            }
        };
        // The first of the best, in the spec's order.
        let mut best: Option<(&String, f64)> = None;
        for m in candidates {
            let s = score(m);
            if best.is_none_or(|(_, b)| s > b) {
                best = Some((m, s));
            }
        }
        let method = best?.0.clone();
        let x = match app {
            CnnApp::Classification => last,
            CnnApp::Location => self
                .curve(&method)
                .iter()
                .find(|p| p.1 >= 50.0)
                .map_or(last, |p| p.0),
        };
        let first = self.at(&method, x).next()?;
        Some(Representative {
            job: first.job.clone(),
            repeat: first.repeat,
            method,
            x,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, x: f64, repeat: i64, test: f64) -> Training {
        Training {
            job: format!("{method}.{x}.r{repeat}"),
            method: method.into(),
            x,
            repeat,
            test,
            train: None,
            validation: None,
            protocol: None,
            test_samples: None,
            samples_per_second: None,
        }
    }

    fn group(rows: Vec<Training>) -> Group {
        let mut g = Group {
            name: "g".into(),
            methods: vec![],
            xs: vec![],
            rows: vec![],
            details: true,
        };
        for r in rows {
            if !g.methods.contains(&r.method) {
                g.methods.push(r.method.clone());
            }
            if !g.xs.contains(&r.x) {
                g.xs.push(r.x);
            }
            g.rows.push(r);
        }
        g.xs.sort_by(f64::total_cmp);
        g
    }

    #[test]
    fn stats_use_the_sample_standard_deviation() {
        let s = Stats::of(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!((s.n, s.mean, s.min, s.max), (4, 2.5, 1.0, 4.0));
        // sqrt(((1.5^2 + 0.5^2) * 2) / 3)
        assert!((s.std.unwrap() - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(Stats::of(&[7.0]).unwrap().std, None);
        assert!(Stats::of(&[]).is_none());
    }

    #[test]
    fn the_representative_is_the_best_generated_method() {
        // Classification: method2 beats method1 at the largest size; original is better
        // still but is not generated.
        let g = group(vec![
            row("original", 100.0, 0, 99.0),
            row("method1", 100.0, 0, 60.0),
            row("method2", 100.0, 1, 80.0),
            row("method2", 100.0, 0, 70.0),
            row("method1", 40.0, 0, 90.0),
            row("method2", 40.0, 0, 10.0),
        ]);
        let r = g.representative(CnnApp::Classification).unwrap();
        assert_eq!((r.method.as_str(), r.x, r.repeat), ("method2", 100.0, 0));
        assert_eq!(r.job, "method2.100.r0");
        // Location: best mean over the sweep, at the lowest SCR reaching 50 %.
        let g = group(vec![
            row("original", -10.0, 0, 10.0),
            row("original", 0.0, 0, 40.0),
            row("original", 10.0, 0, 90.0),
            row("method1", -10.0, 0, 20.0),
            row("method1", 0.0, 0, 60.0),
            row("method1", 10.0, 0, 99.0),
        ]);
        let r = g.representative(CnnApp::Location).unwrap();
        assert_eq!((r.method.as_str(), r.x), ("method1", 0.0));
        // Never 50 %: the highest SCR.
        let g = group(vec![
            row("original", -10.0, 0, 4.0),
            row("original", 0.0, 0, 8.0),
        ]);
        let r = g.representative(CnnApp::Location).unwrap();
        assert_eq!((r.method.as_str(), r.x), ("original", 0.0));
    }
}
