//! The small kernels of the series diagnoses against textbook formulas.

use mtcal_solver::diagnosis::lsq::{Design, solve};
use mtcal_solver::diagnosis::series::drift::first_order_lag;

/// Straight-line fit y = a + b x: b = Sxy/Sxx, std(b) = s/√Sxx, std(a) = s √(1/n + x̄²/Sxx)
/// (any regression textbook), with exact data plus a known alternating residual.
#[test]
fn lsq_matches_the_straight_line_formulas() {
    let x: Vec<f64> = (0..11).map(|i| 100.0 + 10.0 * f64::from(i)).collect();
    let e: Vec<f64> = (0..11)
        .map(|i| if i % 2 == 0 { 0.3 } else { -0.3 })
        .collect();
    let y: Vec<f64> = x.iter().zip(&e).map(|(x, e)| 2.0 - 0.05 * x + e).collect();
    let mut d = Design::new();
    d.push("a", vec![1.0; x.len()]);
    d.push("b", x.clone());
    let f = solve(&d, &y);
    let n = x.len() as f64;
    let xm = x.iter().sum::<f64>() / n;
    let ym = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - xm).powi(2)).sum();
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - xm) * (b - ym)).sum();
    let b = sxy / sxx;
    let a = ym - b * xm;
    assert!(
        (f.coef[1] - b).abs() < 1e-12 && (f.coef[0] - a).abs() < 1e-9,
        "{:?}",
        f.coef
    );
    let sse: f64 = x.iter().zip(&y).map(|(x, y)| (y - a - b * x).powi(2)).sum();
    assert!((f.sse - sse).abs() < 1e-10);
    let s = (sse / (n - 2.0)).sqrt();
    assert!((f.std[1] - s / sxx.sqrt()).abs() < 1e-12);
    assert!((f.std[0] - s * (1.0 / n + xm * xm / sxx).sqrt()).abs() < 1e-9);
    assert_eq!(f.rank, 2);
    assert!(f.cond > 1.0 && f.cond.is_finite());
}

#[test]
fn lsq_reports_rank_loss() {
    let mut d = Design::new();
    d.push("a", vec![1.0, 2.0, 3.0]);
    d.push("2a", vec![2.0, 4.0, 6.0]);
    let f = solve(&d, &[1.0, 2.0, 3.0]);
    assert_eq!(f.rank, 1);
    assert!(f.cond.is_infinite());
    assert!(f.sse < 1e-20, "minimum-norm solution still fits");
}

/// A unit step through τ ẋ = u − x: x(t) = 1 − exp(−t/τ) exactly at the samples (the
/// discretisation is exact for an input held between samples), irregular sampling too.
#[test]
fn first_order_lag_is_exact_for_a_step() {
    let t: Vec<f64> = (0..200)
        .map(|i| f64::from(i) * 30.0 + if i % 3 == 0 { 0.0 } else { 7.0 })
        .collect();
    let u: Vec<f64> = t
        .iter()
        .map(|&ti| if ti > 0.0 { 1.0 } else { 0.0 })
        .collect();
    // u is 0 at t[0] and 1 from t[1] on; with the input held between samples
    // (x_k uses u_{k−1}) the response starts at t[1].
    let tau = 1800.0;
    let x = first_order_lag(&t, &u, tau);
    for k in 1..t.len() {
        let want = 1.0 - (-(t[k] - t[1]) / tau).exp();
        assert!((x[k] - want).abs() < 1e-12, "k {k}: {} vs {want}", x[k]);
    }
}
