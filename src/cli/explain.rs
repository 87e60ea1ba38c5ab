//! `mtcal identify DIR --explain`: when the 21-term model misfits, the session is
//! diagnosed (as `mtcal diagnose` does) and, where the diagnosis explains the misfit, the
//! check is decided on the explained model (docs/compensation.md, "The explained model
//! from the command line").
//!
//! | the 21-term model | the diagnosis | what `--explain` gives |
//! |---|---|---|
//! | explains (or unchecked) | not run | the plain identification, value for value |
//! | misfit | `explained` | the explained model: decided on it when its residual is at noise level |
//! | misfit | `partly_explained` | the explained model, not decided: its `model_check` says what remains |
//! | misfit | `consistent` (no finding) | the plain identification, not decided; a note says the diagnosis found nothing |

use super::BadInput;
use mtcal_solver::diagnosis::{DiagnoseOptions, DiagnosisResult, Verdict};
use mtcal_solver::explained::ExplainedModel;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions};
use mtcal_solver::session::Session;
use mtcal_solver::text::{num, with_std};
use std::path::Path;

/// The result `--explain` gives for `plain`, the identification of `session` with `opts`
/// (module table); `path` names the session in errors.
pub fn explained(
    session: &Session,
    opts: &IdentifyOptions,
    plain: IdentificationResult,
    path: &Path,
) -> anyhow::Result<IdentificationResult> {
    if !plain.model_check().is_misfit() {
        return Ok(plain);
    }
    let dopts = DiagnoseOptions {
        order: opts.order,
        ..DiagnoseOptions::default()
    };
    let diagnosis = super::diagnose::with_bar(|p| {
        mtcal_solver::diagnosis::diagnose_session_with_progress(session, &dopts, p)
    })
    .map_err(|e| BadInput(format!("{}: diagnosis: {e}", path.display())))?;
    with_diagnosis(session, opts, plain, &diagnosis)
        .map_err(|e| BadInput(format!("{}: explained model: {e}", path.display())).into())
}

/// The result for `plain` given `diagnosis`, a diagnosis of the same session: the plain
/// result when the diagnosis found nothing (said in a note), else the explained model.
pub fn with_diagnosis(
    session: &Session,
    opts: &IdentifyOptions,
    plain: IdentificationResult,
    diagnosis: &DiagnosisResult,
) -> Result<IdentificationResult, mtcal_solver::error::SolverError> {
    if diagnosis.verdict == Verdict::Consistent || diagnosis.findings.is_empty() {
        super::out::noteln!(
            "--explain: the diagnosis finds no effect the 21-term model leaves out ({}); the \
             check stays not decided (`mtcal diagnose` shows what it looked at)",
            diagnosis.verdict.as_str()
        );
        return Ok(plain);
    }
    mtcal_solver::explained::explain(session, opts, diagnosis)
}

/// The explained model in words: what it adds with value ± σ, its figures, whether the
/// check is decided on it (or what remains), and one action per finding with the number
/// to set and the residual predicted once it is done.
pub fn summary(m: &ExplainedModel) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nexplained model ({}): the 21 terms fitted jointly with {}",
        m.verdict.as_str(),
        m.adds
    );
    let _ = writeln!(
        s,
        "  residual RMS {} µm, held-out RMS {} µm, noise floor {} µm (the 21-term model \
         alone: residual {} µm, held-out {} µm)",
        num(m.residual_rms_um),
        num(m.heldout_rms_um),
        num(m.noise_floor_um),
        num(m.rigid.residual_rms_um),
        num(m.rigid.heldout_rms_um)
    );
    for p in &m.physics {
        let _ = writeln!(s, "  {}: {}", p.name_in_words(), parameters(p));
    }
    for r in &m.remains {
        let _ = writeln!(s, "  remains: {r}");
    }
    let _ = writeln!(
        s,
        "  predicted residual RMS of the 21-term model once every finding is compensated: {} µm",
        num(m.predicted_residual_rms_um)
    );
    if !m.actions.is_empty() {
        let _ = writeln!(s, "\nwhat to do (one action per finding):");
    }
    for (i, a) in m.actions.iter().enumerate() {
        let _ = writeln!(s, "  {}. {}", i + 1, a.text);
        if let Some(v) = &a.set {
            let value = match v.std {
                Some(sd) => with_std(v.value, sd, 2, true),
                None => format!("{:+.2}", v.value),
            };
            let unit = mtcal_solver::text::unit_label(&v.unit);
            let _ = writeln!(s, "     set: {} = {value} {unit} ({})", v.what, v.source);
        }
        let _ = writeln!(
            s,
            "     residual RMS {} µm now, {} µm predicted after it",
            num(a.predicted_rms_um.before),
            num(a.predicted_rms_um.after)
        );
    }
    s
}

/// A physics entry's parameters, `name = value ± σ` (the held ones said so).
fn parameters(p: &mtcal_solver::explained::Physics) -> String {
    let held = super::diagnose::in_words(&p.held)
        .into_iter()
        .map(|h| format!("{h} (held at the diagnosis's value)"));
    let mut all = super::diagnose::in_words(&p.parameters);
    all.extend(held);
    all.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_solver::Axis;
    use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};

    /// A misfit whose diagnosis finds nothing keeps its plain result. A check whose
    /// diagnosis explains its misfit only partly (the solver's own
    /// diagnosis with its Y finding taken out, verdict `partly_explained`, as
    /// tests/e2e/explained.rs makes it): not decided, the summary says so and what
    /// remains, and lists the action for the finding it has.
    #[test]
    fn a_partly_explained_check_stays_not_decided_and_says_what_remains() {
        let backlash = |axis, lost_motion_um| Effect::Backlash {
            axis,
            lost_motion_um,
        };
        let sim = simulate(
            &random_truth(33),
            &SimOptions {
                plan: Plan::Full,
                seed: 33,
                sample_rate_hz: 5.0,
                effects: vec![backlash(Axis::X, 6.0), backlash(Axis::Y, 3.5)],
                ..Default::default()
            },
        )
        .unwrap();
        let session = sim.session;
        let opts = IdentifyOptions::default();
        let plain = mtcal_solver::identification::identify(&session, &opts).unwrap();
        assert!(plain.model_check().is_misfit());
        let mut d = mtcal_solver::diagnosis::diagnose_session_with_progress(
            &session,
            &DiagnoseOptions::default(),
            &mut |_: &str, _: f64| {},
        )
        .unwrap();
        // A diagnosis that finds nothing leaves the plain result as it is.
        let mut nothing = d.clone();
        nothing.verdict = Verdict::Consistent;
        nothing.findings.clear();
        let same = with_diagnosis(&session, &opts, plain.clone(), &nothing).unwrap();
        assert_eq!(same, plain);
        d.findings
            .retain(|f| !(f.effect == "backlash" && f.axis.as_deref() == Some("Y")));
        d.verdict = Verdict::PartlyExplained;
        let left = "a reversal of Y, about 3.5 µm, in the line passes along Y";
        d.unexplained = vec![left.into()];
        let r = with_diagnosis(&session, &opts, plain, &d).unwrap();
        let check = r.model_check();
        assert!(check.is_misfit() && !check.decided_on_explained_model());
        let text = crate::cli::identify::summary(&r);
        assert!(
            text.contains("no verdict and no compensation table from this model; not decided"),
            "{text}"
        );
        assert!(
            text.contains("only partly") && text.contains(left),
            "{text}"
        );
        assert!(text.contains(&format!("  remains: {left}")), "{text}");
        assert!(
            text.contains("explained model (partly_explained)"),
            "{text}"
        );
        assert!(
            text.contains("set X's backlash compensation to +"),
            "{text}"
        );
        assert!(!text.contains("set Y's backlash"), "{text}");
    }
}
