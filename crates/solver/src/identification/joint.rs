//! The joint method: one least-squares problem over every run and mounting
//! ([`design::fit`]), its rank analysis, and advice on the extra tests that would
//! separate what the plan cannot.

use super::Estimate;
use crate::design::{self, ErrorModel};
use crate::observability::{self, Identifiability};
use crate::session::Session;

/// The joint estimate over every run.
pub fn estimate(session: &Session, model: &ErrorModel) -> Estimate {
    let fit = design::fit(session, model, &|_, _| true, None);
    let ident = observability::analyse(&fit, model);
    let advice = advice(session, model, &ident);
    Estimate {
        fit,
        ident,
        advice,
        seen_as: None,
        reporting: vec![],
    }
}

/// Concrete advice: which extra tests would resolve the confounded terms, checked by
/// recomputing the rank with the extra tests added to the plan.
fn advice(session: &Session, model: &ErrorModel, ident: &Identifiability) -> Vec<String> {
    if ident.groups.is_empty() {
        return vec![];
    }
    // A structure-only copy of the session, thinned for speed.
    let thin = thin_session(session, 400);
    let rank_with = |extra_offsets: &[[f64; 3]], keep_mounting: bool| -> usize {
        let mut s = thin.clone();
        for (k, d) in extra_offsets.iter().enumerate() {
            for p in &thin.planes {
                let mut p2 = p.clone();
                p2.head_offset_mm = [
                    p.head_offset_mm[0] + d[0],
                    p.head_offset_mm[1] + d[1],
                    p.head_offset_mm[2] + d[2],
                ];
                p2.file = format!("{}@extra{k}", p.file);
                if !keep_mounting {
                    p2.mounting = format!("{}@extra{k}", p.mounting);
                }
                s.planes.push(p2);
            }
        }
        let f = design::fit(&s, model, &|_, _| true, None);
        observability::analyse(&f, model).rank
    };
    let candidates: [(&str, Vec<[f64; 3]>, bool); 4] = [
        (
            "repeat every plane's tests with a second head offset 100 mm longer (t_z - 100 mm), keeping each plate's mounting (keyed riser)",
            vec![[0.0, 0.0, -100.0]],
            true,
        ),
        (
            "repeat every plane's tests with the head offset 40 mm sideways in X (t_x + 40 mm), keeping each plate's mounting",
            vec![[40.0, 0.0, 0.0]],
            true,
        ),
        (
            "repeat every plane's tests at two more head offsets, t_z - 100 mm and t_x + 40 mm, keeping each plate's mounting (keyed riser)",
            vec![[0.0, 0.0, -100.0], [40.0, 0.0, 0.0]],
            true,
        ),
        (
            "repeat every plane's tests at two more head offsets, t_z - 100 mm and t_x + 40 mm, as new mountings",
            vec![[0.0, 0.0, -100.0], [40.0, 0.0, 0.0]],
            false,
        ),
    ];
    let base = ident.rank;
    let full = ident.parameters;
    let mut best: Option<(usize, &str)> = None;
    for (text, offs, keep) in &candidates {
        let r = rank_with(offs, *keep);
        if r > base && best.is_none_or(|(b, _)| r > b) {
            best = Some((r, text));
        }
        if r == full {
            break;
        }
    }
    match best {
        Some((r, text)) => vec![format!(
            "{text}: the rank rises from {base} to {r} of {full} parameters{}",
            if r == full {
                " (all 21 terms separable)"
            } else {
                ""
            }
        )],
        None => {
            vec!["no added head offset raises the rank: measure the missing axis or plane".into()]
        }
    }
}

/// Every `step`-th sample of every run (structure only: used for rank questions).
pub fn thin_session(session: &Session, max_per_run: usize) -> Session {
    let mut s = session.clone();
    for p in &mut s.planes {
        for r in &mut p.runs {
            let step = r.len().div_ceil(max_per_run.max(1)).max(1);
            let keep: Vec<usize> = (0..r.len()).step_by(step).collect();
            r.t_s = keep.iter().map(|&i| r.t_s[i]).collect();
            r.pos_mm = keep.iter().map(|&i| r.pos_mm[i]).collect();
            r.du_um = keep.iter().map(|&i| r.du_um[i]).collect();
            r.dv_um = keep.iter().map(|&i| r.dv_um[i]).collect();
            r.temp_c = r
                .temp_c
                .as_ref()
                .map(|t| keep.iter().map(|&i| t[i]).collect());
        }
    }
    s
}
