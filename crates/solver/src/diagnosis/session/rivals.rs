//! Rival explanations: an admitted effect whose known rival the session's plan cannot
//! tell from it.
//!
//! Each pair of [`PAIRS`] is two mechanisms that read alike on some plans: a servo lag
//! and a lost motion at one feed, a lasting step and a slow transient, a drift in time
//! and a lost motion that grows in time. Once the engine has chosen an effect (the
//! parsimonious choice: fewer parameters unless more earn the held-out gain), each
//! rival available on the same model is fitted on the same model in its place
//! (`Ctx::try_candidate`); when its ΔBIC is within [`RIVAL_BIC`] of the effect's, the
//! plan's samples do not separate them, and the finding names the rival and the test
//! that would. The finding stays the engine's choice, never the more flexible rival.

use super::SessionProblem;
use super::context::State;
use super::trial::Trial;
use crate::diagnosis::Rival;
use crate::diagnosis::catalogue::{self, Candidate};

/// Below this difference of ΔBIC between an effect and its rival, fitted each on the
/// same model, the plan does not separate them: the engine's own threshold for
/// admitting an effect ("very strong" evidence, odds of about 150 to one).
pub(super) const RIVAL_BIC: f64 = 10.0;

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

/// Whether the effect `effect` (a catalogue name) has known rivals.
pub(super) fn has_rivals(effect: &str) -> bool {
    PAIRS.iter().any(|p| p.rival_of(effect).is_some())
}

impl SessionProblem<'_> {
    /// The rivals of the trial `t` of candidate `c` on the model `s` that the plan does
    /// not separate from it (module documentation).
    pub(super) fn rivals(&self, s: &State, c: &Candidate, t: &Trial) -> Vec<Rival> {
        if !has_rivals(c.effect) {
            return Vec::new();
        }
        let available = <Self as crate::diagnosis::engine::Greedy>::candidates(self, s);
        let mut out = Vec::new();
        for (p, rival) in PAIRS
            .iter()
            .filter_map(|p| Some((p, p.rival_of(c.effect)?)))
        {
            let best = available
                .iter()
                .filter(|r| r.effect == rival && same_place(c, r))
                .filter_map(|r| Some((r, self.ctx.try_candidate(s, r)?)))
                .min_by(|a, b| a.1.dbic.total_cmp(&b.1.dbic));
            let Some((r, rt)) = best else { continue };
            let gap = rt.dbic - t.dbic;
            if gap >= RIVAL_BIC {
                continue;
            }
            out.push(Rival {
                effect: catalogue::reported_name(r.effect).into(),
                axis: r.axis.or(r.direction).map(|a| a.to_string()),
                why: format!(
                    "{}: on this plan's samples its fit is within ΔBIC {gap:+.1} of this one's (separated from {RIVAL_BIC:.0} on)",
                    p.why
                ),
                separating_test: p.test.into(),
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnosis::Finding;

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
