//! The scorer: each claim of a diagnosis (a finding, a possible effect, a recurring misfit
//! it says it cannot explain) is right when it names an effect that was put in, on its
//! axis, under a name of the equivalence table, and FALSE otherwise; a truth effect no
//! claim names is missed (a growing backlash is found only by a claim that it grows,
//! [`finds`]). A claim that names a rival the plan cannot tell from it (`rivals`) is
//! right, as "rival named", when the rival is the truth: it does not take the wrong one
//! for certain, and the truth counts as found. Parameters of right claims are checked against the truth within 2σ where
//! the mapping is clear.

use super::generator::{Effect, Grows, mounting_of};
use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnosisResult, Finding, Verdict};

/// What a claim names: the effect and its axis (and the moving axis for an error across).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Name {
    pub effect: &'static str,
    /// The finding's axis (`None`: a finding with no axis).
    pub axis: Option<Axis>,
    /// The moving axis an error across follows (`None`: not checked).
    pub depends_on: Option<Axis>,
    /// The plate's mounting a plate scale names in its signature (`None`: not checked).
    pub mounting: Option<&'static str>,
}

const fn on(effect: &'static str, axis: Axis) -> Name {
    Name {
        effect,
        axis: Some(axis),
        depends_on: None,
        mounting: None,
    }
}

/// The equivalence table: the names under which a truth effect counts as found.
pub fn accepted(e: &Effect) -> Vec<Name> {
    match *e {
        Effect::Backlash { axis, .. } => {
            vec![on("backlash", axis), on("lost_motion_profile", axis)]
        }
        // Its constant part under the names of a play; a growth claimed of a constant
        // play is FALSE.
        Effect::GrowingBacklash { axis, .. } => vec![
            on("backlash", axis),
            on("lost_motion_profile", axis),
            on("backlash_growth", axis),
        ],
        Effect::ServoLag { axis, .. } => vec![on("servo_lag", axis)],
        // Likewise a growing lag, cyclic error or spike: its constant part under the
        // constant's name, its change under the growth's; a growth claimed of a constant
        // effect is FALSE.
        Effect::Growing { axis, grows, .. } => {
            let g = growth(grows);
            let depends_on = match grows {
                Grows::Lateral { moving } => Some(moving),
                _ => None,
            };
            [g.constant, g.growth]
                .map(|effect| Name {
                    effect,
                    axis: Some(axis),
                    depends_on,
                    mounting: None,
                })
                .to_vec()
        }
        Effect::Cyclic { axis, .. } => vec![on("cyclic", axis)],
        // A session's drift may be reported with no axis (its parameters name them).
        Effect::Thermal { axis, .. } => vec![
            on("thermal_drift", axis),
            Name {
                effect: "thermal_drift",
                axis: None,
                depends_on: None,
                mounting: None,
            },
        ],
        Effect::LateralPlay { axis, moving, .. } => vec![Name {
            effect: "direction_coupling",
            axis: Some(axis),
            depends_on: Some(moving),
            mounting: None,
        }],
        Effect::ReversalSpike { axis, .. } => vec![on("reversal_spike", axis)],
        // Or a local anomaly in its reading (see `score`).
        Effect::Knock { axis, .. } => vec![on("transient", axis), on("step", axis)],
        Effect::Vibration { axis, .. } => vec![on("vibration", axis)],
        // A play that changes in time: as a play, or as one that changes.
        Effect::SwellingBacklash { axis, .. } => vec![
            on("backlash", axis),
            on("lost_motion_profile", axis),
            on("backlash_growth", axis),
        ],
        // A plate's scale with its mounting, which the finding's signature names.
        Effect::PlateScale { plane, .. } => vec![Name {
            effect: "plate_scale",
            axis: None,
            depends_on: None,
            mounting: Some(mounting_of(plane)),
        }],
    }
}

/// Whether a right claim under `effect` finds truth effect `e`: a growing backlash only
/// when the claim says it grows (its constant part alone, a `backlash`, is right but
/// leaves the growth missed); any name of the table for every other effect.
pub fn finds(e: &Effect, effect: &str) -> bool {
    match e {
        Effect::GrowingBacklash { .. } => effect == "backlash_growth",
        Effect::Growing { grows, .. } => effect == growth(*grows).growth,
        _ => true,
    }
}

/// The catalogue's names of a growing effect: its constant and its growth, the growth's
/// rate and start, and the start's unit per the generator's (a lag's s per ms).
pub struct GrowthNames {
    pub constant: &'static str,
    pub growth: &'static str,
    pub rate: &'static str,
    pub start: &'static str,
    pub start_per_unit: f64,
}

pub fn growth(g: Grows) -> GrowthNames {
    let (constant, rate, start, start_per_unit) = match g {
        Grows::Lag => ("servo_lag", "lag_growth_ms_per_h", "lag_start_s", 1e-3),
        Grows::Cyclic { .. } => (
            "cyclic",
            "amplitude_growth_um_per_h",
            "amplitude_start_um",
            1.0,
        ),
        Grows::Spike { .. } => (
            "reversal_spike",
            "height_growth_um_per_h",
            "height_start_um",
            1.0,
        ),
        Grows::Lateral { .. } => (
            "direction_coupling",
            "shift_growth_um_per_h",
            "shift_start_um",
            1.0,
        ),
    };
    GrowthNames {
        constant,
        growth: match g {
            Grows::Lag => "servo_lag_growth",
            Grows::Cyclic { .. } => "cyclic_growth",
            Grows::Spike { .. } => "reversal_spike_growth",
            Grows::Lateral { .. } => "direction_coupling_growth",
        },
        rate,
        start,
        start_per_unit,
    }
}

fn axis_of(s: &Option<String>) -> Option<Axis> {
    s.as_deref().and_then(Axis::parse)
}

/// Whether a claim of `effect` on `axis` (following `dep`, naming `mounting`) is `n`.
fn matches(
    n: &Name,
    effect: &str,
    mounting: Option<&str>,
    axis: Option<Axis>,
    dep: Option<Axis>,
) -> bool {
    n.effect == effect
        && n.axis == axis
        && (n.depends_on.is_none() || n.depends_on == dep)
        && n.mounting.is_none_or(|m| mounting == Some(m))
}

/// The mounting a plate scale's signature names (`` mounting `xz` ``), if any.
pub fn mounting_named(f: &Finding) -> Option<&str> {
    let sig = f.signature.as_deref()?;
    let rest = sig.split_once("mounting `")?.1;
    Some(rest.split_once('`')?.0)
}

/// A parameter of a right claim checked against its truth.
#[derive(Debug, Clone)]
pub struct ParamCheck {
    pub name: String,
    pub got: f64,
    pub std: Option<f64>,
    pub truth: f64,
    /// |got − truth| ≤ 2σ (false when no σ is reported).
    pub within: bool,
}

/// The truth values of the parameters a claim under `effect` reports, where the mapping
/// from the generator's physics to the catalogue's parameter is clear.
pub fn truth_params(e: &Effect, effect: &str) -> Vec<(String, f64)> {
    match (e, effect) {
        (Effect::Backlash { um, .. }, "backlash") => vec![("lost_motion_um".into(), *um)],
        (Effect::Vibration { amp_um, hz, .. }, "vibration") => vec![
            ("amplitude_um".into(), *amp_um),
            ("frequency_hz".into(), *hz),
        ],
        (Effect::Backlash { um, .. }, "lost_motion_profile") => {
            vec![
                ("mean_lost_motion_um".into(), *um),
                ("variation_um".into(), 0.0),
            ]
        }
        (
            Effect::GrowingBacklash {
                from_um, per_h_um, ..
            },
            "backlash_growth",
        ) => vec![
            ("growth_um_per_h".into(), *per_h_um),
            ("lost_motion_start_um".into(), *from_um),
        ],
        (Effect::ServoLag { ms, .. }, "servo_lag") => vec![("lag_s".into(), ms * 1e-3)],
        (Effect::PlateScale { ppm, .. }, "plate_scale") => vec![("scale_ppm".into(), *ppm)],
        (
            Effect::Growing {
                grows, from, per_h, ..
            },
            e,
        ) if e == growth(*grows).growth => {
            let g = growth(*grows);
            vec![
                (g.rate.into(), *per_h),
                (g.start.into(), from * g.start_per_unit),
            ]
        }
        (
            Effect::Cyclic {
                amp_um, period_mm, ..
            },
            "cyclic",
        ) => vec![
            ("amplitude_um".into(), *amp_um),
            ("period_mm".into(), *period_mm),
        ],
        (
            Effect::Thermal {
                axis,
                scale_ppm,
                tau_s,
                ..
            },
            "thermal_drift",
        ) => vec![
            (format!("scale_ppm_{axis}"), *scale_ppm),
            ("time_constant_s".into(), *tau_s),
        ],
        (Effect::LateralPlay { shift_um, .. }, "direction_coupling") => {
            vec![("shift_um".into(), *shift_um)]
        }
        (
            Effect::ReversalSpike {
                height_um,
                decay_mm,
                ..
            },
            "reversal_spike",
        ) => vec![
            ("height_um".into(), *height_um),
            ("decay_mm".into(), *decay_mm),
        ],
        // A plain decay is the transient's form; a ringing one is not (no clear mapping).
        (
            Effect::Knock {
                size_um,
                decay_s,
                ring_hz,
                ..
            },
            "transient",
        ) if *ring_hz == 0.0 => vec![
            ("amplitude_um".into(), *size_um),
            ("decay_s".into(), *decay_s),
        ],
        _ => Vec::new(),
    }
}

/// One claim of a diagnosis and its class.
#[derive(Debug, Clone)]
pub struct Claim {
    /// `lost_motion_profile (Y)`, `direction_coupling (Y, following X)`; `possible …`
    /// for an effect listed as possible.
    pub label: String,
    /// Index of the truth effect it names; `None`: FALSE.
    pub truth: Option<usize>,
    /// It names the truth only as a rival of the effect it found.
    pub rival_named: bool,
    pub params: Vec<ParamCheck>,
}

/// The score of one session.
#[derive(Debug, Clone)]
pub struct Score {
    pub claims: Vec<Claim>,
    /// Truth effects no claim names (descriptions).
    pub missed: Vec<String>,
    pub verdict: String,
}

impl Score {
    /// The labels of the FALSE claims, each once, in order.
    pub fn false_labels(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for c in self.claims.iter().filter(|c| c.truth.is_none()) {
            if !out.contains(&c.label) {
                out.push(c.label.clone());
            }
        }
        out
    }

    /// No false claim and no missed effect.
    pub fn right(&self) -> bool {
        self.missed.is_empty() && self.claims.iter().all(|c| c.truth.is_some())
    }

    /// (within 2σ, checked) over the right claims' parameters.
    pub fn params(&self) -> (usize, usize) {
        let all = self.claims.iter().flat_map(|c| &c.params);
        let n = all.clone().count();
        (all.filter(|p| p.within).count(), n)
    }
}

/// The text a diagnosis gives when it calls its unexplained anomalies recurring.
pub const RECURRING: &str = "a misfit that recurs";

/// Scores `r` against `truth`: see the module documentation.
pub fn score(truth: &[Effect], r: &DiagnosisResult) -> Score {
    let mut claims = Vec::new();
    let mut found = vec![false; truth.len()];
    let all = r
        .findings
        .iter()
        .map(|f| (f, false))
        .chain(r.possible.iter().map(|f| (f, true)));
    for (f, possible) in all {
        claims.push(classify(truth, f, possible, &mut found));
    }
    // A knock is found when the diagnosis names a local anomaly in its reading (a place
    // of the misfit, or what it leaves unexplained).
    let places = r
        .unexplained
        .iter()
        .chain(r.mismatch.iter().map(|m| &m.where_));
    for (i, e) in truth.iter().enumerate() {
        if let Effect::Knock { axis, .. } = e {
            let reading = format!("in the {axis} reading");
            if places
                .clone()
                .any(|u| u.contains("local anomaly") && u.contains(&reading))
            {
                found[i] = true;
            }
        }
    }
    let missed: Vec<String> = truth
        .iter()
        .zip(&found)
        .filter(|(_, f)| !**f)
        .map(|(e, _)| e.describe())
        .collect();
    // What it leaves unexplained is a claim too: with every effect put in found, a
    // remainder is physics that is not there, unless it is a knock's one-off anomaly;
    // calling anomalies a misfit that recurs is never right of a knock. An effect named
    // by possible claims alone (undetermined, or left to a rival) is not in the model:
    // what is left unexplained is its own misfit, no claim of other physics.
    let recurring = r.unexplained.iter().any(|u| u.contains(RECURRING));
    let knock = truth.iter().any(|e| matches!(e, Effect::Knock { .. }));
    // A play that widens and narrows is outside the catalogue: what it leaves is there.
    let outside = truth
        .iter()
        .any(|e| matches!(e, Effect::SwellingBacklash { .. }));
    let only_possible = (0..truth.len()).any(|i| {
        let mut by = claims.iter().filter(|c| c.truth == Some(i)).peekable();
        by.peek().is_some() && by.all(|c| c.label.starts_with("possible "))
    });
    if r.verdict == Verdict::PartlyExplained
        && missed.is_empty()
        && !only_possible
        && !outside
        && (recurring || !knock)
    {
        claims.push(Claim {
            label: if recurring {
                "unexplained: a misfit that recurs".into()
            } else {
                "unexplained: a remainder".into()
            },
            truth: None,
            rival_named: false,
            params: Vec::new(),
        });
    }
    Score {
        claims,
        missed,
        verdict: r.verdict.as_str().to_string(),
    }
}

fn classify(truth: &[Effect], f: &Finding, possible: bool, found: &mut [bool]) -> Claim {
    let (axis, dep) = (axis_of(&f.axis), axis_of(&f.depends_on));
    let mut label = match (f.axis_label(), mounting_named(f)) {
        (Some(a), _) => format!("{} ({a})", f.effect),
        (None, Some(m)) if f.effect == "plate_scale" => format!("{} ({m})", f.effect),
        (None, _) => f.effect.clone(),
    };
    if possible {
        label = format!("possible {label}");
    }
    for r in &f.rivals {
        let axis = r
            .axis
            .as_deref()
            .map_or(String::new(), |a| format!(" ({a})"));
        label = format!("{label} [rival {}{axis}]", r.effect);
    }
    // The first truth effect it names, preferring one not yet found.
    let hits: Vec<usize> = (0..truth.len())
        .filter(|&i| {
            accepted(&truth[i])
                .iter()
                .any(|n| matches(n, &f.effect, mounting_named(f), axis, dep))
        })
        .collect();
    let Some(&i) = hits.iter().find(|&&i| !found[i]).or(hits.first()) else {
        // Not the truth itself: right when a rival it names is.
        let rival = (0..truth.len()).find(|&i| {
            f.rivals.iter().any(|r| {
                accepted(&truth[i])
                    .iter()
                    .any(|n| matches(n, &r.effect, None, axis_of(&r.axis), dep))
            })
        });
        if let Some(i) = rival {
            found[i] |= finds(&truth[i], "");
        }
        return Claim {
            label,
            truth: rival,
            rival_named: rival.is_some(),
            params: Vec::new(),
        };
    };
    found[i] |= finds(&truth[i], &f.effect);
    // A drift reported with no axis finds every warm-up whose axis it scales.
    let mut named = vec![i];
    if f.effect == "thermal_drift" && axis.is_none() {
        for (j, e) in truth.iter().enumerate() {
            if let Effect::Thermal { axis: a, .. } = e
                && j != i
                && drift_scales(f, *a)
            {
                found[j] = true;
                named.push(j);
            }
        }
    }
    let mut params: Vec<(String, f64)> = Vec::new();
    for (name, t) in named
        .iter()
        .flat_map(|&j| truth_params(&truth[j], &f.effect))
    {
        if params.iter().all(|(n, _)| *n != name) {
            params.push((name, t));
        }
    }
    let params = params
        .into_iter()
        .filter_map(|(name, t)| {
            let got = *f.parameters.get(&name)?;
            let std = f.parameters.get(&format!("std_{name}")).copied();
            Some(ParamCheck {
                within: std.is_some_and(|s| (got - t).abs() <= 2.0 * s),
                name,
                got,
                std,
                truth: t,
            })
        })
        .collect();
    Claim {
        label,
        truth: Some(i),
        rival_named: false,
        params,
    }
}

/// Whether a drift finding scales `axis`: its scale along it (or the scale's span over
/// the session, when the time constant is undetermined) at least 2σ from zero.
fn drift_scales(f: &Finding, axis: Axis) -> bool {
    let scale = format!("scale_ppm_{axis}");
    [format!("span_{scale}"), scale].iter().any(|name| {
        let std = f.parameters.get(&format!("std_{name}"));
        f.parameters
            .get(name)
            .zip(std)
            .is_some_and(|(v, s)| v.abs() >= 2.0 * s)
    })
}

/// One line of what is wrong with the FALSE claim `label` of a session of `truth`.
pub fn explain(label: &str, truth: &[Effect]) -> String {
    let put_in = if truth.is_empty() {
        "a clean session".to_string()
    } else {
        truth
            .iter()
            .map(Effect::describe)
            .collect::<Vec<_>>()
            .join("; ")
    };
    let what = label.trim_start_matches("possible ");
    let effect = what.split(" (").next().unwrap_or(what);
    let axis = what
        .split_once(" (")
        .map_or("", |(_, a)| a.trim_end_matches(')'));
    let lag_only = |a: &str| {
        truth.iter().any(|e| matches!(e, Effect::ServoLag { axis, .. } if axis.to_string() == a))
            && !truth.iter().any(|e| {
                matches!(e, Effect::Backlash { axis, .. } | Effect::GrowingBacklash { axis, .. } if axis.to_string() == a)
            })
    };
    let why = match effect {
        "unexplained: a misfit that recurs"
            if truth.iter().all(|e| matches!(e, Effect::Knock { .. })) =>
        {
            "a one-off knock's anomalies, all in its run, called a misfit that recurs".to_string()
        }
        "unexplained: a misfit that recurs" => {
            "every effect put in is named, yet a misfit that recurs is claimed".to_string()
        }
        "unexplained: a remainder" => {
            "every effect put in is named, yet a remainder is left unexplained".to_string()
        }
        "lost_motion_profile" | "backlash" if lag_only(axis) => {
            format!("lost motion on {axis}, whose only effect is a servo lag (no play)")
        }
        "lost_motion_profile" | "backlash" => format!("lost motion on {axis}: no play there"),
        "backlash_growth" => {
            format!("a lost motion growing in time on {axis}: no play there grows")
        }
        "servo_lag_growth"
        | "cyclic_growth"
        | "reversal_spike_growth"
        | "direction_coupling_growth" => {
            format!("{effect} ({axis}): no effect there changes in time")
        }
        "step" => format!("a one-off step along {axis}: no event was put in"),
        "transient" => format!("a transient along {axis}: no knock was put in"),
        "vibration" => format!("a vibration along {axis}: nothing periodic in time was put in"),
        "model_order" => {
            format!("model order along {axis}: the geometry is within the rigid model")
        }
        "velocity_coupling" => format!("velocity coupling ({axis}): no error follows a velocity"),
        "direction_coupling" => format!("direction coupling ({axis}): no lateral play there"),
        "thermal_drift" => "thermal drift: nothing drifts in time".to_string(),
        "servo_lag" => format!("servo lag on {axis}: no lag was put in"),
        "reversal_spike" => format!("reversal spike on {axis}: no reversal transient was put in"),
        "cyclic" => format!("cyclic error on {axis}: none was put in"),
        "plate_scale" => format!("a plate scale of mounting {axis}: that plate reads true"),
        other => format!("{other}: not put in"),
    };
    format!("{why} (truth: {put_in})")
}
