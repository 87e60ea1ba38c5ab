//! The explained model's section of a result page and a check report: what the model adds
//! to the 21 terms, its figures, the physics with σ and one action per finding with the
//! residual predicted once it is done (docs/results.md, "The explained model").

use super::num;
use maud::{Markup, html};
use mtcal_solver::diagnosis::Verdict;
use mtcal_solver::explained::ExplainedModel;
use mtcal_solver::identification::IdentificationResult;

/// The section (nothing for a result without an explained model).
pub fn section(d: &IdentificationResult) -> Markup {
    let Some(m) = &d.explained else {
        return html! {};
    };
    let check = d.model_check();
    let decided = m.verdict == Verdict::Explained && check.decided_on_explained_model();
    html! {
        section.card #explained {
            h2 { @if decided { "Decided on the explained model" } @else { "Explained model: not decided" } }
            p { (check.statement) "." }
            dl.facts {
                dt { "adds to the 21 terms" } dd { (m.adds) }
                dt { "residual RMS" } dd { (num(m.residual_rms_um)) " µm (21 terms alone " (num(m.rigid.residual_rms_um)) " µm)" }
                dt { "held-out RMS" } dd { (num(m.heldout_rms_um)) " µm (21 terms alone " (num(m.rigid.heldout_rms_um)) " µm)" }
                dt { "noise floor" } dd { (num(m.noise_floor_um)) " µm" }
                dt { "every finding compensated" } dd { "predicted residual RMS " (num(m.predicted_residual_rms_um)) " µm" }
            }
            @if !m.remains.is_empty() {
                h3 { "What remains" }
                ul { @for r in &m.remains { li { (r) } } }
            }
            table.physics {
                thead { tr { th { "finding" } th { "parameters (u, k = 1)" } } }
                tbody {
                    @for p in &m.physics {
                        tr {
                            td { (p.name_in_words()) }
                            td { (parameters(p)) }
                        }
                    }
                }
            }
            (actions(m))
        }
    }
}

/// The fitted parameters of `p` with their u, then those held at the diagnosis's values.
pub fn parameters(p: &mtcal_solver::explained::Physics) -> String {
    p.parameters
        .iter()
        .filter(|(k, _)| !k.starts_with("std_"))
        .map(|(k, v)| match p.parameters.get(&format!("std_{k}")) {
            Some(u) => format!("{k} = {} (u = {})", num(*v), num(*u)),
            None => format!("{k} = {}", num(*v)),
        })
        .chain(
            p.held
                .iter()
                .filter(|(k, _)| !k.starts_with("std_"))
                .map(|(k, v)| format!("{k} = {} (the diagnosis's)", num(*v))),
        )
        .collect::<Vec<_>>()
        .join(", ")
}

/// The actions, one per finding: what to do and the residual predicted once it is done.
pub fn actions(m: &ExplainedModel) -> Markup {
    html! {
        @if !m.actions.is_empty() {
            div #actions {
                h3 { "Actions" }
                ol.actions {
                    @for a in &m.actions {
                        li data-finding=(a.finding) {
                            (a.text) " — predicted residual RMS after it "
                            (num(a.predicted_rms_um.after)) " µm (now "
                            (num(a.predicted_rms_um.before)) " µm)"
                            @if let Some(s) = &a.set { "; source: " (s.source) }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_solver::axis::Axis;
    use mtcal_solver::diagnosis::{DiagnoseOptions, diagnose_session};
    use mtcal_solver::identification::IdentifyOptions;
    use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};

    /// A machine with 6 µm of X backlash: the section says the check is decided on the
    /// explained model, lists the backlash with the simulated lost motion and the action
    /// with the value to set.
    #[test]
    fn the_explained_section_names_the_decision_and_the_action() {
        let out = simulate(
            &random_truth(31),
            &SimOptions {
                plan: Plan::Full,
                seed: 31,
                sample_rate_hz: 5.0,
                effects: vec![Effect::Backlash {
                    axis: Axis::X,
                    lost_motion_um: 6.0,
                }],
                ..Default::default()
            },
        )
        .unwrap();
        let d = diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap();
        let r = mtcal_solver::explained::explain(&out.session, &IdentifyOptions::default(), &d)
            .unwrap();
        let html = section(&r).into_string();
        assert!(html.contains("Decided on the explained model"), "{html}");
        assert!(html.contains("backlash (X)"), "{html}");
        let at = html
            .find("backlash compensation to +")
            .expect("the backlash action");
        let rest = &html[at + "backlash compensation to +".len()..];
        let set: f64 = rest[..rest.find(' ').unwrap()].parse().unwrap();
        assert!((set - 6.0).abs() < 0.05, "{set}");
        assert!(html.contains("predicted residual RMS after it"), "{html}");
        // A result without an explained model shows nothing.
        let plain =
            mtcal_solver::identification::identify(&out.session, &IdentifyOptions::default())
                .unwrap();
        assert!(section(&plain).into_string().is_empty());
    }
}
