//! The seed patent's stepwise identification (CN101982726), kept so users can compare it
//! with the joint method of [`crate::identification`].
//!
//! * Step 1 — line runs only (`line_X`, `line_Y`, `line_Z`), with a model that has the
//!   12 translational terms (9 positioning/straightness functions + 3 squareness
//!   constants) and **no angular terms**. Along a line the angular errors act through
//!   their Abbe arms, e = δ(q) + ε(q) × a(q); the step-1 estimate of δ therefore absorbs
//!   (the cubic part of) ε × a, exactly as the patent does.
//! * Step 2 — circle runs only (`circle_cw`, `circle_ccw`): readings minus the step-1
//!   prediction δ̂(q) → the 9 angular functions (roll, pitch, yaw) through their Abbe
//!   arms, ε(q) × a(q), and no squareness.
//!
//! In both steps the per-run zero offsets and the per-mounting plate rotations are
//! handled as in the joint method ([`design::fit`]: offsets centred out, rotations
//! estimated with the errors; step 2 estimates the rotations again from the circles).
//! `free` runs are used by neither step.
//!
//! Uncertainty: step 2 is x̂₂ = A₂⁺(b₂ − P x̂₁), with P the step-1 design on the circle
//! rows. With G = A₂⁺ P (obtained from the same QR reduction, P's columns carried as
//! extra columns: A₂⁺P = R₁₁⁺R₁₂; the circles are reduced over the full model by
//! [`design::fit`]'s per-run path and the factor re-triangularised in that column
//! order), the reported covariance is
//!
//! ```text
//! Σ₂ = σ̂₂² (A₂ᵀA₂)⁺ + G Σ₁ Gᵀ,   cov(x̂₂, x̂₁) = −G Σ₁,
//! ```
//!
//! so step-1 uncertainty **is** propagated into step 2. What no covariance can show is
//! the *bias* of the method: the angular Abbe effects absorbed by step 1 (see
//! docs/stepwise.md for a simulated example: on the seed plan an angle ε with a 100 mm
//! head offset moves the straightness estimate by ε × 100 mm, and step 2 then sees the
//! circles minus that absorbed part).
//!
//! Identifiability is analysed per step ([`crate::observability::analyse`] on each
//! sub-problem); the result document carries the union, and one `reporting` sentence per
//! step gives its rank, condition number and undetermined terms.

use super::{Estimate, thin_session};
use crate::design::{self, ErrorModel, Fit, Layout};
use crate::error::SolverError;
use crate::lsq::{self, LsSolution, Reduced};
use crate::observability::{self, Identifiability};
use crate::session::{Run, Session};
use crate::terms::Term;
use faer::Mat;

/// Which runs a step uses.
fn is_line(session: &Session, p: usize, r: usize) -> bool {
    let rec = &session.planes[p];
    rec.runs[r].test_kind(rec.plane).is_line()
}

fn is_circle(session: &Session, p: usize, r: usize) -> bool {
    let rec = &session.planes[p];
    rec.runs[r].test_kind(rec.plane).is_circle()
}

/// One step's fit with what the report needs.
struct Step {
    model: ErrorModel,
    fit: Fit,
    ident: Identifiability,
    runs: usize,
}

/// The stepwise estimate (see the module documentation); `noise` is the noise estimated
/// floor (µm, [`crate::noise`]), against which each step's residual is judged.
pub fn estimate(
    session: &Session,
    model: &ErrorModel,
    noise: Option<f64>,
) -> Result<Estimate, SolverError> {
    let count = |f: &dyn Fn(&Session, usize, usize) -> bool| -> usize {
        (0..session.planes.len())
            .map(|p| {
                (0..session.planes[p].runs.len())
                    .filter(|&r| !session.planes[p].runs[r].is_empty() && f(session, p, r))
                    .count()
            })
            .sum()
    };
    let n_lines = count(&is_line);
    let n_circles = count(&is_circle);
    if n_lines == 0 {
        return Err(SolverError::InvalidInput(
            "the stepwise method needs line runs (line_X, line_Y, line_Z) for its first step; this session has none: use --method joint".into(),
        ));
    }

    // Step 1: lines → translational terms, no angular terms in the model.
    let m1 = model.restricted(|t: Term| !t.is_angular(), true);
    let fit1 = design::fit(session, &m1, &|p, r| is_line(session, p, r), None);
    let ident1 = observability::analyse(&fit1, &m1);
    let x1 = fit1.error_params().to_vec();

    // Step 2: circles minus the step-1 prediction → angular terms through their arms.
    let m2 = model.restricted(|t: Term| t.is_angular(), false);
    let s2 = circle_residual_session(session, &m1, &x1);
    let fit2all = design::fit(&s2, model, &|p, r| is_circle(&s2, p, r), None);
    let fit2x = reorder_step_two(fit2all, model, &m2, &m1);
    let (fit2, g) = split_step_two(fit2x);
    let ident2 = observability::analyse(&fit2, &m2);

    let step1 = Step {
        model: m1,
        fit: fit1,
        ident: ident1,
        runs: n_lines,
    };
    let step2 = Step {
        model: m2,
        fit: fit2,
        ident: ident2,
        runs: n_circles,
    };
    let fit = combine(session, model, &step1, &step2, &g);
    let ident = combine_identifiability(model, &step1, &step2);
    let mut advice = Vec::new();
    let joint_rank = {
        let thin = thin_session(session, 400);
        let f = design::fit(&thin, model, &|_, _| true, None);
        observability::analyse(&f, model).rank
    };
    advice.push(format!(
        "the stepwise method absorbs the angular errors' Abbe effects along the lines into the translational terms (a bias no uncertainty shows); the joint method (--method joint) models them: on this session its rank is {joint_rank} of {} parameters{}",
        model.len(),
        if joint_rank == model.len() {
            " (all 21 terms separable)"
        } else {
            "; see its advice for the extra head offsets that separate the rest"
        }
    ));
    if let Some(noise) = noise {
        for (n, s) in [(1, &step1), (2, &step2)] {
            let rms = step_rms(s);
            if rms > MISFIT_RATIO * noise {
                advice.push(format!(
                    "stepwise step {n}: residual rms {rms:.3} um exceeds the noise floor {noise:.3} um: {}",
                    if n == 1 {
                        "the lines are not explained by translational terms alone (angular errors seen through Abbe arms that differ between runs, or beyond the model order); the step-1 estimates, and the step-2 angles computed from them, are biased"
                    } else {
                        "the circles are not explained by the angular terms after step 1; the step-2 estimates are biased"
                    }
                ));
            }
        }
    }
    let reporting = vec![
        step_sentence(1, "line runs, model of the 12 translational terms without angular terms", &step1),
        step_sentence(2, "circle runs minus the step-1 prediction, model of the 9 angular terms through their Abbe arms", &step2),
        "stepwise uncertainty: step-1 uncertainty is propagated into step 2 (covariance G Σ1 Gᵀ added, G = A2⁺P); the bias from angular Abbe effects absorbed in step 1 is not part of any std".into(),
        "stepwise nuisance: the reported plate rotations are those of step 1 (lines); step 2 estimates them again from the circles".into(),
    ];
    Ok(Estimate {
        fit,
        ident,
        advice,
        seen_as: Some(seen_as),
        reporting,
    })
}

/// Which step could not separate a group (the joint wording speaks of one fit): all
/// angular terms are step 2's, the rest step 1's.
fn seen_as(terms: &[String]) -> String {
    let angular = terms
        .iter()
        .all(|n| Term::parse(n).is_some_and(Term::is_angular));
    let (step, data) = if angular {
        (2, "the circle readings minus the step-1 prediction")
    } else {
        (1, "the line readings")
    };
    if terms.len() == 1 {
        format!(
            "stepwise step {step}: {} has no effect of its own on {data}",
            terms[0]
        )
    } else {
        format!(
            "stepwise step {step}: {} act on {data} only through one combination: the data determine that combination, not the terms",
            terms.join(" + ")
        )
    }
}

/// A copy of the session holding only the circle runs, each reading minus the step-1
/// prediction of the translational errors (other runs emptied, indices kept).
fn circle_residual_session(session: &Session, m1: &ErrorModel, x1: &[f64]) -> Session {
    let mut out = Session {
        machine_id: session.machine_id.clone(),
        measured_at: session.measured_at.clone(),
        topology: session.topology.clone(),
        conditions: session.conditions.clone(),
        notes: session.notes.clone(),
        planes: Vec::with_capacity(session.planes.len()),
    };
    let mut row = vec![0.0; m1.len()];
    for (p, rec) in session.planes.iter().enumerate() {
        let (u_ax, v_ax) = rec.plane.axes();
        let mut runs = Vec::with_capacity(rec.runs.len());
        for (r, run) in rec.runs.iter().enumerate() {
            if !is_circle(session, p, r) {
                runs.push(Run {
                    number: run.number,
                    test: run.test,
                    ..Run::default()
                });
                continue;
            }
            let mut run2 = run.clone();
            // Keep the label so an emptied neighbour cannot change the inference.
            run2.test = Some(run.test_kind(rec.plane));
            for i in 0..run.len() {
                for (comp, dir) in [(0, u_ax), (1, v_ax)] {
                    m1.error_row(run.pos_mm[i], rec.head_offset_mm, dir, &mut row);
                    let pred: f64 = row.iter().zip(x1).map(|(a, b)| a * b).sum();
                    if comp == 0 {
                        run2.du_um[i] -= pred;
                    } else {
                        run2.dv_um[i] -= pred;
                    }
                }
            }
            runs.push(run2);
        }
        out.planes.push(crate::session::PlaneRecord {
            file: rec.file.clone(),
            plane: rec.plane,
            head_offset_mm: rec.head_offset_mm,
            mounting: rec.mounting.clone(),
            runs,
        });
    }
    out
}

/// The circle rows' reduction over the full model's columns (the fast per-run path of
/// [`design::fit`]), re-triangularised with its columns ordered
/// [rotations | step-2 parameters | step-1 parameters]: one small QR of the permuted
/// [R | Qᵀb] (k × (k + 1)); the residual outside the column space is unchanged. The
/// step-1 columns are the matrix P, carried as extra columns.
fn reorder_step_two(f: Fit, full: &ErrorModel, m2: &ErrorModel, m1: &ErrorModel) -> Fit {
    let nr = f.layout.n_rot();
    let order: Vec<usize> = (0..nr)
        .chain(param_map(full, m2).into_iter().map(|j| nr + j))
        .chain(param_map(full, m1).into_iter().map(|j| nr + j))
        .collect();
    let k = order.len();
    debug_assert_eq!(k, f.layout.total());
    let red = &f.reduced;
    let m = Mat::<f64>::from_fn(k, k + 1, |i, j| {
        if j < k {
            red.r[(i, order[j])]
        } else {
            red.qtb[i]
        }
    });
    let rr = m.qr().thin_R().to_owned();
    crate::upper_state::clear();
    let layout = Layout {
        n_err: m2.len(),
        n_extra: m1.len(),
        ..f.layout
    };
    Fit {
        layout,
        reduced: Reduced {
            r: Mat::from_fn(k, k, |i, j| if j >= i { rr[(i, j)] } else { 0.0 }),
            qtb: (0..k).map(|i| rr[(i, k)]).collect(),
            rss: red.rss,
            rows: red.rows,
        },
        solution: f.solution,
        offsets_eliminated: f.offsets_eliminated,
        compressed_runs: f.compressed_runs,
    }
}

/// From the step-2 fit with P as extra columns: the fit of [rotations | angular terms]
/// alone (the leading block of the same QR factor), and G = A₂⁺P (rows: rotations then
/// angular parameters; columns: step-1 error parameters).
fn split_step_two(fx: Fit) -> (Fit, Mat<f64>) {
    let k = fx.layout.n_rot() + fx.layout.n_err;
    let np = fx.layout.n_extra;
    let red = &fx.reduced;
    // ‖b‖² outside span(A₂) = outside span([A₂ | P]) + the part reached only through P.
    let rss = red.rss + red.qtb[k..].iter().map(|v| v * v).sum::<f64>();
    let lead = Reduced {
        r: Mat::from_fn(k, k, |i, j| red.r[(i, j)]),
        qtb: red.qtb[..k].to_vec(),
        rss,
        rows: red.rows,
    };
    let solution = lsq::solve(&lead, fx.offsets_eliminated);
    let mut g = Mat::<f64>::zeros(k, np);
    for c in 0..np {
        let col = Reduced {
            r: lead.r.clone(),
            qtb: (0..k).map(|i| red.r[(i, k + c)]).collect(),
            rss: 0.0,
            rows: red.rows,
        };
        let s = lsq::solve(&col, fx.offsets_eliminated);
        for i in 0..k {
            g[(i, c)] = s.x[i];
        }
    }
    let layout = Layout {
        n_extra: 0,
        ..fx.layout
    };
    (
        Fit {
            layout,
            reduced: lead,
            solution,
            offsets_eliminated: fx.offsets_eliminated,
            compressed_runs: fx.compressed_runs,
        },
        g,
    )
}

/// Index in the full model's parameters of each parameter of a sub-model.
fn param_map(full: &ErrorModel, sub: &ErrorModel) -> Vec<usize> {
    sub.params
        .iter()
        .map(|p| {
            full.params
                .iter()
                .position(|q| q == p)
                .expect("sub-model parameter in the full model")
        })
        .collect()
}

/// The two steps as one fit over the full model's columns [rotations | errors]:
/// rotations from step 1; error parameters from their step; covariance with step-1
/// uncertainty propagated into step 2; null space the union of the steps' (embedded).
fn combine(session: &Session, full: &ErrorModel, s1: &Step, s2: &Step, g: &Mat<f64>) -> Fit {
    let layout = Layout::new(session, full.len(), 0);
    let nr = layout.n_rot();
    let k = layout.total();
    // Column of each step variable in the combined layout (step-2 rotations: none).
    let map1: Vec<Option<usize>> = (0..nr)
        .map(Some)
        .chain(param_map(full, &s1.model).into_iter().map(|j| Some(nr + j)))
        .collect();
    let map2: Vec<Option<usize>> = (0..nr)
        .map(|_| None)
        .chain(param_map(full, &s2.model).into_iter().map(|j| Some(nr + j)))
        .collect();
    let (a, b) = (&s1.fit.solution, &s2.fit.solution);
    let mut x = vec![0.0; k];
    let mut norms = vec![1.0; k];
    for (sol, map) in [(a, &map1), (b, &map2)] {
        for (i, m) in map.iter().enumerate() {
            if let Some(c) = m {
                x[*c] = sol.x[i];
                norms[*c] = sol.column_norms[i];
            }
        }
    }
    // Σ₁ over step-1 variables; G maps step-1 *error* parameters (columns) to step-2
    // variables (rows): H = [0 | G] over all step-1 variables.
    let n1 = map1.len();
    let nr1 = nr;
    let h = |i2: usize, j1: usize| if j1 < nr1 { 0.0 } else { g[(i2, j1 - nr1)] };
    // HΣ₁ (n2 × n1).
    let n2 = map2.len();
    let hs = Mat::<f64>::from_fn(n2, n1, |i, j| {
        (0..n1).map(|l| h(i, l) * a.cov[(l, j)]).sum()
    });
    let mut cov = Mat::<f64>::zeros(k, k);
    for i in 0..n1 {
        for j in 0..n1 {
            if let (Some(ci), Some(cj)) = (map1[i], map1[j]) {
                cov[(ci, cj)] = a.cov[(i, j)];
            }
        }
    }
    for i in 0..n2 {
        let Some(ci) = map2[i] else { continue };
        for j in 0..n2 {
            let Some(cj) = map2[j] else { continue };
            let prop: f64 = (0..n1).map(|l| hs[(i, l)] * h(j, l)).sum();
            cov[(ci, cj)] = b.cov[(i, j)] + prop;
        }
        for j in 0..n1 {
            if let Some(cj) = map1[j] {
                cov[(ci, cj)] = -hs[(i, j)];
                cov[(cj, ci)] = -hs[(i, j)];
            }
        }
    }
    let null1 = a.null_space.ncols();
    let null2 = b.null_space.ncols();
    let mut null_space = Mat::<f64>::zeros(k, null1 + null2);
    for (off, sol, map) in [(0, a, &map1), (null1, b, &map2)] {
        for c in 0..sol.null_space.ncols() {
            for (i, m) in map.iter().enumerate() {
                if let Some(r) = m {
                    null_space[(*r, off + c)] = sol.null_space[(i, c)];
                }
            }
        }
    }
    let mut singular_values: Vec<f64> = a
        .singular_values
        .iter()
        .chain(&b.singular_values)
        .copied()
        .collect();
    singular_values.sort_by(|p, q| q.total_cmp(p));
    let rss = a.rss + b.rss;
    let rows = s1.fit.reduced.rows + s2.fit.reduced.rows;
    let dof = a.dof + b.dof;
    Fit {
        layout,
        reduced: Reduced {
            r: Mat::zeros(k, k),
            qtb: vec![0.0; k],
            rss,
            rows,
        },
        solution: LsSolution {
            x,
            cov,
            singular_values,
            rank: a.rank + b.rank,
            null_space,
            column_norms: norms,
            sigma2: rss / dof,
            rss,
            dof,
        },
        offsets_eliminated: s1.fit.offsets_eliminated + s2.fit.offsets_eliminated,
        compressed_runs: s1.fit.compressed_runs + s2.fit.compressed_runs,
    }
}

/// The union of the two steps' identifiability over the full model.
fn combine_identifiability(full: &ErrorModel, s1: &Step, s2: &Step) -> Identifiability {
    let mut param_determined = vec![false; full.len()];
    let mut groups = Vec::new();
    for s in [s1, s2] {
        let map = param_map(full, &s.model);
        for (i, &j) in map.iter().enumerate() {
            param_determined[j] = s.ident.param_determined[i];
        }
        groups.extend(
            s.ident
                .groups
                .iter()
                .map(|gr| gr.iter().map(|&i| map[i]).collect::<Vec<_>>()),
        );
    }
    Identifiability {
        rank: s1.ident.rank + s2.ident.rank,
        parameters: full.len(),
        param_determined,
        rotation_determined: s1.ident.rotation_determined.clone(),
        groups,
        condition_number: s1.ident.condition_number.max(s2.ident.condition_number),
    }
}

/// A step's residual rms above this multiple of the noise floor is
/// reported as a misfit (the rms of a correct model is within a few per cent of it).
pub const MISFIT_RATIO: f64 = 1.1;

/// Residual rms of a step (µm).
fn step_rms(s: &Step) -> f64 {
    (s.fit.solution.rss / s.fit.reduced.rows.max(1) as f64).sqrt()
}

/// One sentence per step: data, model, rank, conditioning, undetermined terms.
fn step_sentence(n: usize, what: &str, s: &Step) -> String {
    let mut undetermined: Vec<String> = Vec::new();
    for gr in &s.ident.groups {
        for name in observability::group_terms(&s.model, gr) {
            if !undetermined.contains(&name) {
                undetermined.push(name);
            }
        }
    }
    format!(
        "stepwise step {n} ({what}; {} runs): rank {} of {} parameters, condition number {:.3e}, residual rms {:.4} um; {}",
        s.runs,
        s.ident.rank,
        s.ident.parameters,
        s.ident.condition_number,
        step_rms(s),
        if undetermined.is_empty() {
            "every term of the step determined".to_string()
        } else {
            format!("not determined: {}", undetermined.join(", "))
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{ExtraColumns, RowMeta};
    use crate::simulate::{Plan, SimOptions, random_truth, simulate};

    /// P as extra columns of the dense row-by-row path.
    struct StepOneColumns<'a>(&'a ErrorModel);
    impl ExtraColumns for StepOneColumns<'_> {
        fn count(&self) -> usize {
            self.0.len()
        }
        fn fill(&self, row: &RowMeta, out: &mut [f64]) {
            self.0.error_row(row.q, row.head_offset, row.dir, out);
        }
    }

    /// The re-triangularised fast reduction gives the same step-2 solution, covariance
    /// and G = A₂⁺P as the dense rows with P as extra columns.
    #[test]
    fn reordered_reduction_equals_dense_extra_columns() {
        let opts = SimOptions {
            plan: Plan::Full,
            sample_rate_hz: 5.0,
            ..Default::default()
        };
        let s = &simulate(&random_truth(9), &opts).unwrap().session;
        let full =
            crate::identification::prepare(s, &crate::identification::IdentifyOptions::default())
                .unwrap();
        let m1 = full.restricted(|t| !t.is_angular(), true);
        let m2 = full.restricted(|t| t.is_angular(), false);
        let circles = |p, r| is_circle(s, p, r);
        let fast = reorder_step_two(design::fit(s, &full, &circles, None), &full, &m2, &m1);
        assert!(fast.compressed_runs > 0);
        let dense = design::fit(s, &m2, &circles, Some(&StepOneColumns(&m1)));
        assert_eq!(dense.compressed_runs, 0);
        let (ff, gf) = split_step_two(fast);
        let (fd, gd) = split_step_two(dense);
        assert_eq!(ff.solution.rank, fd.solution.rank);
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-7 * scale;
        let xs = fd.solution.x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in ff.solution.x.iter().zip(&fd.solution.x) {
            assert!(close(*a, *b, xs), "{a} vs {b}");
        }
        assert!(close(ff.solution.rss, fd.solution.rss, fd.solution.rss));
        let k = gd.nrows();
        let gs = (0..k)
            .flat_map(|i| (0..gd.ncols()).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(gd[(i, j)].abs()));
        for i in 0..k {
            for j in 0..gd.ncols() {
                assert!(close(gf[(i, j)], gd[(i, j)], gs), "G[{i},{j}]");
            }
            let cs = fd.solution.cov[(i, i)].abs().max(1e-30);
            assert!(close(ff.solution.cov[(i, i)], fd.solution.cov[(i, i)], cs));
        }
    }
}
