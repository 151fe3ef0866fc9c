//! A derivative-free minimiser for the few-parameter fits of the project (the stand-in plants'
//! calibration to the dissertation's similarity tables): the Nelder-Mead simplex method with
//! the standard coefficients (reflection 1, expansion 2, contraction 1/2, shrink 1/2; Nelder
//! and Mead 1965, as in Lagarias et al. 1998). Deterministic: the same function and start give
//! the same steps.

/// The result of [`nelder_mead`].
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// The best point found.
    pub x: Vec<f64>,
    /// The function's value there.
    pub value: f64,
    /// Evaluations of the function.
    pub evaluations: usize,
}

/// Minimises `f` from `start`, the first simplex being `start` and `start + step[i] e_i`;
/// stops after `max_evaluations` evaluations or when the simplex's values span less than
/// `tolerance`. `f` may fail (its error is returned at once); a non-finite value counts as
/// worse than every finite one.
///
/// # Errors
/// The first error of `f`.
///
/// # Panics
/// If `step` and `start` differ in length or are empty.
pub fn nelder_mead<E>(
    mut f: impl FnMut(&[f64]) -> Result<f64, E>,
    start: &[f64],
    step: &[f64],
    max_evaluations: usize,
    tolerance: f64,
) -> Result<Minimum, E> {
    assert!(!start.is_empty() && start.len() == step.len());
    let n = start.len();
    let evaluations = std::cell::Cell::new(0usize);
    let mut eval = |x: &[f64]| -> Result<f64, E> {
        evaluations.set(evaluations.get() + 1);
        let v = f(x)?;
        Ok(if v.is_finite() { v } else { f64::INFINITY })
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((start.to_vec(), eval(start)?));
    for i in 0..n {
        let mut x = start.to_vec();
        x[i] += step[i];
        let v = eval(&x)?;
        simplex.push((x, v));
    }
    loop {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        if evaluations.get() >= max_evaluations || (worst - best).abs() < tolerance {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|p| p.0[j]).sum::<f64>() / n as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|j| centroid[j] + t * (simplex[n].0[j] - centroid[j]))
                .collect()
        };
        let reflected = along(-1.0);
        let fr = eval(&reflected)?;
        if fr < best {
            let expanded = along(-2.0);
            let fe = eval(&expanded)?;
            simplex[n] = if fe < fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (reflected, fr);
        } else {
            let (t, bound) = if fr < worst { (-0.5, fr) } else { (0.5, worst) };
            let contracted = along(t);
            let fc = eval(&contracted)?;
            if fc < bound {
                simplex[n] = (contracted, fc);
            } else {
                let x0 = simplex[0].0.clone();
                for p in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = (0..n).map(|j| x0[j] + 0.5 * (p.0[j] - x0[j])).collect();
                    let v = eval(&x)?;
                    *p = (x, v);
                }
            }
        }
    }
    let (x, value) = simplex.swap_remove(0);
    Ok(Minimum {
        x,
        value,
        evaluations: evaluations.get(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_shifted_quadratic_and_of_rosenbrock() {
        let q = |x: &[f64]| -> Result<f64, ()> {
            Ok((x[0] - 1.5).powi(2) + 3.0 * (x[1] + 0.25).powi(2) + 2.0)
        };
        let m = nelder_mead(q, &[0.0, 0.0], &[0.5, 0.5], 400, 1e-14).unwrap();
        assert!(
            (m.x[0] - 1.5).abs() < 1e-5 && (m.x[1] + 0.25).abs() < 1e-5,
            "{m:?}"
        );
        assert!((m.value - 2.0).abs() < 1e-10);
        let rosen = |x: &[f64]| -> Result<f64, ()> {
            Ok(100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2))
        };
        let m = nelder_mead(rosen, &[-1.2, 1.0], &[0.1, 0.1], 2000, 1e-16).unwrap();
        assert!(
            (m.x[0] - 1.0).abs() < 1e-3 && (m.x[1] - 1.0).abs() < 2e-3,
            "{m:?}"
        );
    }

    #[test]
    fn stops_at_the_evaluation_budget_and_passes_errors_on() {
        let mut calls = 0;
        let f = |x: &[f64]| -> Result<f64, ()> {
            calls += 1;
            Ok(x[0].abs())
        };
        let m = nelder_mead(f, &[5.0], &[1.0], 7, 0.0).unwrap();
        // one step evaluates at most n + 2 = 3 points past the budget
        assert!(m.evaluations <= 7 + 3 && m.evaluations == calls, "{m:?}");
        let failing = |x: &[f64]| if x[0] > 0.5 { Err("too far") } else { Ok(0.0) };
        assert_eq!(
            nelder_mead(failing, &[0.0], &[1.0], 10, 0.0).unwrap_err(),
            "too far"
        );
    }

    #[test]
    fn a_non_finite_value_is_worse_than_any_finite_one() {
        let f = |x: &[f64]| -> Result<f64, ()> {
            Ok(if x[0] < 0.0 {
                f64::NAN
            } else {
                (x[0] - 2.0).powi(2)
            })
        };
        let m = nelder_mead(f, &[0.5], &[-1.0], 200, 1e-12).unwrap();
        assert!((m.x[0] - 2.0).abs() < 1e-4, "{m:?}");
    }
}
