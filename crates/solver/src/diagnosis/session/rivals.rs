//! Rival explanations: an admitted effect whose known rival the session's plan cannot
//! tell from it.
//!
//! Each pair of [`PAIRS`] is two mechanisms that read alike on some plans: a servo lag
//! and a lost motion at one feed, a lasting step and a slow transient, a drift in time
//! and a lost motion that grows in time. Once the engine has chosen an effect (the
//! parsimonious choice: fewer parameters unless more earn the held-out gain), each
//! rival available on the same model is fitted on the same model in its place
//! (`Ctx::try_candidate`) and the two are judged on the data term alone, Δχ² =
//! n·ln(SSR_rival / SSR_effect) (twice the log-likelihood ratio, σ profiled out; no BIC
//! penalty), by [`standing`]: a rival the data do not put [`RIVAL_DATA`] behind the
//! effect is named with the test that would separate them; one with fewer parameters
//! (or as many and clearly preferred by the data) leaves the effect undetermined, never
//! the more flexible explanation taken for the simpler one the data prefer. Its misfit
//! then stays the undecided pair's: no later effect on its axis (or without an axis) is
//! taken to explain it.

use super::context::State;
use super::trial::Trial;
use super::{Note, SessionProblem};
use crate::diagnosis::catalogue::{self, Candidate};
use crate::diagnosis::effects::{self, Sorted};
use crate::diagnosis::engine::Admission;
use crate::diagnosis::{Finding, Rival};

/// Below this data term Δχ² of a rival over an effect, fitted each on the same model,
/// the plan does not separate them: the engine's own threshold of evidence (a
/// likelihood ratio of e⁵, about 150 to one), here without the parameters' penalty.
pub(super) const RIVAL_DATA: f64 = 10.0;

/// How a rival stands against the effect found, on the data term.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Standing {
    /// Δχ² ≥ [`RIVAL_DATA`]: the data put the rival behind the effect; not named.
    Separated,
    /// Not separated: the rival is named, the effect stays the engine's choice.
    Named,
    /// Not separated and no more flexible than the effect (fewer parameters, or as many
    /// and the data prefer it by [`RIVAL_DATA`] or more): named, and the effect is left
    /// undetermined.
    Prevails,
}

/// The rule of the module documentation: `dchi2` = n·ln(SSR_rival / SSR_effect), `k`
/// and `k_rival` the parameters each adds to the model.
fn standing(dchi2: f64, k: usize, k_rival: usize) -> Standing {
    if dchi2 >= RIVAL_DATA {
        Standing::Separated
    } else if k_rival < k || (k_rival == k && dchi2 <= -RIVAL_DATA) {
        Standing::Prevails
    } else {
        Standing::Named
    }
}

/// Two explanations that read alike on some plans, each the other's rival (catalogue
/// names), why they read alike, and the test that separates them.
struct Pair {
    one: &'static str,
    other: &'static str,
    why: &'static str,
    test: &'static str,
}

impl Pair {
    /// The rival of `effect` in this pair, if `effect` is one of the two.
    fn rival_of(&self, effect: &str) -> Option<&'static str> {
        if self.one == effect {
            Some(self.other)
        } else if self.other == effect {
            Some(self.one)
        } else {
            None
        }
    }
}

/// The rival pairs (docs/diagnosis-catalogue.md, "rival" column).
const PAIRS: &[Pair] = &[
    Pair {
        one: "backlash",
        other: "servo_lag",
        why: "at one constant feed a lag's error −v·τ is an offset with the direction of travel, as a play's −d·b/2; only the starts and stops of the motion differ",
        test: "lines or circles at a second feed (a lag's error scales with the feed, a play's does not)",
    },
    Pair {
        one: "servo_lag",
        other: "lost_motion_profile",
        why: "on circles at one feed and radius a lag reads as a lost motion varying along the travel, b(x) = 2·v·τ·√(1 − (x/R)²)",
        test: "circles at a second feed or radius, or lines over the same travel at the circles' feed",
    },
    Pair {
        one: "step",
        other: "transient",
        why: "a decay much longer than the recording after the event reads as a lasting offset",
        test: "a longer recording after the event (a standstill, or the next runs of its test)",
    },
    Pair {
        one: "thermal_drift",
        other: catalogue::lost_motion_growth::NAME,
        why: "a drift in time and a lost motion growing in time both change the readings over the session; they differ only between the two directions of travel",
        test: "both directions of travel recorded over the same positions at the session's start and end",
    },
];

/// Whether rival candidate `r` is about the same axis and direction as `c` (where both
/// name one).
fn same_place(c: &Candidate, r: &Candidate) -> bool {
    let agree = |a: Option<_>, b: Option<_>| a.is_none() || b.is_none() || a == b;
    agree(c.axis, r.axis) && agree(c.direction, r.direction)
}

/// The axis of candidate `c`'s error: its direction for an error across the moving axis,
/// its axis or direction otherwise (`None`: an effect without one).
fn error_axis(c: &Candidate) -> Option<crate::axis::Axis> {
    match c.effect {
        "direction_coupling" | "direction_coupling_growth" | "velocity_coupling" => c.direction,
        _ => c.axis.or(c.direction),
    }
}

/// Whether the effect `effect` (a catalogue name) has known rivals.
pub(super) fn has_rivals(effect: &str) -> bool {
    PAIRS.iter().any(|p| p.rival_of(effect).is_some())
}

impl SessionProblem<'_> {
    /// The rivals of the trial `t` of candidate `c` on the model `s` that the plan does
    /// not separate from it, and whether one leaves it undetermined (module
    /// documentation).
    pub(super) fn rivals(&self, s: &State, c: &Candidate, t: &Trial) -> (Vec<Rival>, bool) {
        if !has_rivals(c.effect) {
            return (Vec::new(), false);
        }
        let available = <Self as crate::diagnosis::engine::Greedy>::candidates(self, s);
        let n = self.ctx.d.rows() as f64;
        let (mut out, mut undetermined) = (Vec::new(), false);
        for (p, rival) in PAIRS
            .iter()
            .filter_map(|p| Some((p, p.rival_of(c.effect)?)))
        {
            let best = available
                .iter()
                .filter(|r| r.effect == rival && same_place(c, r))
                .filter_map(|r| Some((r, self.ctx.try_candidate(s, r)?)))
                .min_by(|a, b| a.1.ssr.total_cmp(&b.1.ssr));
            let Some((r, rt)) = best else { continue };
            let dchi2 = n * (rt.ssr / t.ssr).ln();
            let (k, k_rival) = (t.ncols + t.extra_params, rt.ncols + rt.extra_params);
            let how = match standing(dchi2, k, k_rival) {
                Standing::Separated => continue,
                Standing::Named => "",
                Standing::Prevails => {
                    undetermined = true;
                    "; no more flexible and not behind, it leaves this one undetermined"
                }
            };
            out.push(Rival {
                effect: catalogue::reported_name(r.effect).into(),
                axis: r.axis.or(r.direction).map(|a| a.to_string()),
                why: format!(
                    "{}: on this plan's samples its data term differs from this one's by Δχ² {dchi2:+.1} ({k_rival} parameter(s) against {k}; separated from Δχ² +{RIVAL_DATA:.0} on){how}",
                    p.why
                ),
                separating_test: p.test.into(),
            });
        }
        (out, undetermined)
    }

    /// A determined finding `f` of the trial `t` against its rivals: it names those the
    /// plan does not separate from it, and is set aside as possible (its principal
    /// parameters undetermined, the rivals' test deciding them) when one prevails.
    pub(super) fn against_rivals(
        &self,
        s: &State,
        c: &Candidate,
        t: &Trial,
        f: Finding,
    ) -> Admission<Note> {
        let mut undecided = self.undecided.lock().expect("undecided axes");
        let here = error_axis(c);
        if let Some(u) = undecided.iter().find(|&&u| here.is_none() || u == here) {
            let on = u.map_or(String::new(), |a| format!(" on {a}"));
            return Admission::SetAside(Note::Rejected(format!(
                "{} not taken: the misfit{on} is that of a finding left undetermined for its rival (see the possible findings), which no other effect is taken to explain",
                c.label()
            )));
        }
        let (rivals, undetermined) = self.rivals(s, c, t);
        if !undetermined {
            return Admission::Add(Note::Finding(Finding { rivals, ..f }));
        }
        undecided.push(here);
        let decide = format!(
            "the data do not prefer it to {}, which explains them as well or better with no more parameters; {} would decide it",
            rivals
                .iter()
                .map(|r| r.effect.replace('_', " "))
                .collect::<Vec<_>>()
                .join(" or "),
            rivals
                .iter()
                .map(|r| r.separating_test.as_str())
                .collect::<Vec<_>>()
                .join("; or "),
        );
        let f = Finding { rivals, ..f };
        match effects::form_rejected(f, &decide) {
            Sorted::Determined(f) | Sorted::Possible(f) => Admission::SetAside(Note::Possible(f)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair is told apart both ways: the rival of a rival is the effect.
    #[test]
    fn pairs_are_symmetric() {
        for p in PAIRS {
            assert_eq!(p.rival_of(p.one), Some(p.other));
            assert_eq!(p.rival_of(p.other), Some(p.one));
            assert!(has_rivals(p.one) && has_rivals(p.other), "{}", p.one);
        }
        assert!(!has_rivals("cyclic"));
    }

    /// The rule on the data term: a rival the data put 10 behind is not named; one
    /// within is named; one with fewer parameters, or as many and preferred by 10 or
    /// more, leaves the effect undetermined; a more flexible rival never does.
    #[test]
    fn standing_on_the_data_term() {
        use Standing::*;
        // A lost motion profile (9) over a lag (2) the data prefer by 3263: undetermined.
        assert_eq!(standing(-3263.0, 9, 2), Prevails);
        // Lines at one feed: a play (1) and a lag (2) within 2: the play stays, the lag named.
        assert_eq!(standing(-1.8, 1, 2), Named);
        assert_eq!(standing(9.9, 1, 2), Named);
        // A lag (2) and a play (1) within the margin: the simpler play prevails.
        assert_eq!(standing(1.8, 2, 1), Prevails);
        // Separated by the data from 10 on, whatever the parameters.
        assert_eq!(standing(10.0, 2, 1), Separated);
        assert_eq!(standing(3333.0, 9, 2), Separated);
        // As many parameters: named within the margin, prevails when preferred by it.
        assert_eq!(standing(-9.9, 1, 1), Named);
        assert_eq!(standing(-10.0, 1, 1), Prevails);
        // A more flexible rival fitting better stays named only.
        assert_eq!(standing(-500.0, 2, 9), Named);
    }

    /// A stored finding without rivals reads with none and writes none; one with a rival
    /// round-trips, and prints it in one line.
    #[test]
    fn rivals_round_trip() {
        let doc = serde_json::json!({
            "effect": "backlash", "axis": "X", "parameters": {"lost_motion_um": 33.0},
            "physics": "p", "evidence": "e",
            "residual_rms_um": {"before": 1.0, "after": 0.2},
            "heldout_rms_um": {"before": 1.0, "after": 0.2},
        });
        let f: Finding = serde_json::from_value(doc).expect("a finding");
        assert!(f.rivals.is_empty());
        assert!(!serde_json::to_string(&f).unwrap().contains("rivals"));
        let f = Finding {
            rivals: vec![Rival {
                effect: "servo_lag".into(),
                axis: Some("X".into()),
                why: PAIRS[0].why.into(),
                separating_test: PAIRS[0].test.into(),
            }],
            ..f
        };
        let back: Finding =
            serde_json::from_str(&serde_json::to_string(&f).unwrap()).expect("round trip");
        assert_eq!(back, f);
        assert!(f.rivals[0].in_words().starts_with(
            "servo lag (X) — would be told apart by lines or circles at a second feed"
        ));
    }
}
