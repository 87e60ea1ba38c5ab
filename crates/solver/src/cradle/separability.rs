//! Which A-dependent terms ball data can tell apart: the rank of the first-order Jacobian
//! of the kinematic model ([`super::model`]) with the terms in question, and the
//! parameters its null directions touch.
//!
//! # What the data see (first order)
//!
//! At each A pose the ball's circle gives the whole small displacement of the C table in
//! the A body frame (x along A, z along C): its rotation ω and translation v. Constant
//! parts are location errors; an instrument frame that is not the machine's adds, in the
//! body frame, a constant turned by −A (a vector u·cos A + (x̂ × u)·sin A-type pattern)
//! to the components across A. So per A the data hold the rotation about A, ω_x(A); the
//! tilt across A, ω_y(A) + i·ω_z(A) up to a constant and a pattern ∝ e^(−iA); the shift
//! along A, v_x(A); and the shift across A up to the same nuisance. The terms act as
//!
//! * A positioning error s_A, k_A (or EAA(A)): ω_x;
//! * tilt about the mount parallel to A, τ_X: ω_x = τ_X and the lever v_y = z_M·τ_X;
//! * tilt about the mount about the table's Y, τ_Y: ω_y = τ_Y and the lever
//!   v_x = −z_M·τ_Y;
//! * shift along A t_X: v_x; sideways shift t_Y: v_y; the spatial tilt about the pivot
//!   (m_B, m_C): ω across A ∝ e^(−2iA).
//!
//! Hence τ_Y is always separable; τ_X and the A positioning error share ω_x and are told
//! apart only by the lever z_M·τ_X, which needs z_M from elsewhere (the lever of τ_Y along
//! A, when no free shift along A is fitted) and no free sideways shift. The analysis
//! below finds these facts from the Jacobian itself.
//!
//! # Method
//!
//! The Jacobian of the ball positions with respect to all the model's parameters
//! (location errors, ball, A-dependent terms) is taken at a linearisation point: the
//! location errors and the shifts zero, the ball and the mount height z_M as fitted, the
//! A-dependent angles scaled together so that the largest is [`LINEAR_URAD`] (so that
//! only their first-order effect remains: second-order effects, (tilt)²·arm, would
//! otherwise separate in exact arithmetic what no measurement can). A term not in the
//! fitted model enters at generic probe values ([`PROBE_URAD`], [`PROBE_MOUNT_MM`]).
//! Lengths enter the ball position linearly, so their columns are exact for any step
//! (10 m here, far above rounding of the small lever columns); angles take central
//! differences of 1 µrad. Columns are scaled to unit norm (a zero column: the parameter has no effect)
//! and decomposed by SVD; singular values below [`RANK_TOL`] of the largest span the null
//! space, and a parameter whose row of the null basis exceeds [`NULL_TOL`] is not
//! separable. The terms sharing those null directions are reported with the reason
//! ([`why`]).

use super::identify::{Obs, jacobian, residuals};
use super::model::{
    Compliance, CradleModel, LocationErrors, ModelSpec, N_RIGID, Tilt, params_from_model,
};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// The largest A-dependent angle at the linearisation point, µrad.
pub const LINEAR_URAD: f64 = 1e-3;
/// Relative singular value below which a direction is not determined by the data.
pub const RANK_TOL: f64 = 1e-6;
/// A parameter's share of a null direction above which it is not separable (the null
/// vectors are unit vectors in column-scaled coordinates).
pub const NULL_TOL: f64 = 1e-3;
/// Angles (µrad, sin and cos − 1 coefficients) a term not in the model is probed with.
pub const PROBE_URAD: [f64; 2] = [1.0, 0.5];
/// Mount height (mm from the pivot) a model without a mount is probed with.
pub const PROBE_MOUNT_MM: f64 = -100.0;

/// An A-dependent term of the model family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// A positioning error s_A·sin A + k_A·(cos A − 1).
    APositioning,
    /// A positioning error as a polynomial EAA(A) (order 1–3).
    AEncoder,
    /// The spatial tilt of the table about the pivot (m_B, m_C).
    PivotTilt,
    /// The C table tilts about its mount about the axis parallel to A (tX_s, tX_c).
    MountX,
    /// The C table tilts about its mount about its Y (tY_s, tY_c).
    MountY,
    /// The mount's height on the C axis, z_M (with a tilt about the mount).
    MountHeight,
    /// The table shifts along A (e_s, e_c).
    Axial,
    /// The table shifts sideways, along its Y (y_s, y_c).
    Lateral,
}

impl Term {
    pub const ALL: [Term; 8] = [
        Term::APositioning,
        Term::AEncoder,
        Term::PivotTilt,
        Term::MountX,
        Term::MountY,
        Term::MountHeight,
        Term::Axial,
        Term::Lateral,
    ];

    /// The term in words.
    pub fn describe(self) -> &'static str {
        match self {
            Term::APositioning => "A positioning error s_A·sin A + k_A·(cos A − 1)",
            Term::AEncoder => "A positioning error EAA(A), polynomial",
            Term::PivotTilt => "tilt of the table about the pivot (m_B, m_C)",
            Term::MountX => "tilt of the C table about its mount, about X (parallel to A)",
            Term::MountY => "tilt of the C table about its mount, about its Y",
            Term::MountHeight => "height z_M of the C table's mount on the C axis",
            Term::Axial => "shift of the table along A",
            Term::Lateral => "sideways shift of the table (along its Y)",
        }
    }

    /// Whether `spec` carries the term.
    pub fn in_spec(self, spec: &ModelSpec) -> bool {
        match self {
            Term::APositioning => spec.a_harmonic,
            Term::AEncoder => spec.eaa_order > 0,
            Term::PivotTilt => spec.tilt != Tilt::None,
            Term::MountX => spec.mount_x,
            Term::MountY => spec.mount_y,
            Term::MountHeight => spec.has_mount(),
            Term::Axial => spec.axial,
            Term::Lateral => spec.lateral,
        }
    }

    /// `spec` with the term added (EAA at order 3; the mount height comes with a tilt
    /// about the mount and is not added alone).
    pub fn add_to(self, spec: &ModelSpec) -> Option<ModelSpec> {
        let mut s = *spec;
        match self {
            Term::APositioning => s.a_harmonic = true,
            Term::AEncoder => s.eaa_order = 3,
            Term::PivotTilt => s.tilt = Tilt::Pivot,
            Term::MountX => s.mount_x = true,
            Term::MountY => s.mount_y = true,
            Term::MountHeight => return None,
            Term::Axial => s.axial = true,
            Term::Lateral => s.lateral = true,
        }
        Some(s)
    }

    /// The term's parameters in `spec` (which must carry it).
    pub fn parameters(self, spec: &ModelSpec) -> Vec<&'static str> {
        match self {
            Term::APositioning => vec!["s_A", "k_A"],
            Term::AEncoder => ["e_1", "e_2", "e_3"]
                .into_iter()
                .take(spec.eaa_order.clamp(1, 3))
                .collect(),
            Term::PivotTilt => vec!["m_B", "m_C"],
            Term::MountX => vec!["tX_s", "tX_c"],
            Term::MountY => vec!["tY_s", "tY_c"],
            Term::MountHeight => vec!["z_M"],
            Term::Axial => vec!["e_s", "e_c"],
            Term::Lateral => vec!["y_s", "y_c"],
        }
    }

    /// The term a parameter belongs to (`None` for location errors and the ball).
    pub fn of_parameter(name: &str) -> Option<Term> {
        Some(match name {
            "s_A" | "k_A" => Term::APositioning,
            "e_1" | "e_2" | "e_3" => Term::AEncoder,
            "m_B" | "m_C" => Term::PivotTilt,
            "tX_s" | "tX_c" => Term::MountX,
            "tY_s" | "tY_c" => Term::MountY,
            "z_M" => Term::MountHeight,
            "e_s" | "e_c" => Term::Axial,
            "y_s" | "y_c" => Term::Lateral,
            _ => return None,
        })
    }

    /// Whether the term turns the table about the direction of A.
    fn turns_about_a(self) -> bool {
        matches!(self, Term::APositioning | Term::AEncoder)
    }
}

/// Why two terms enter the ball data only together (first order), in a clause.
fn relation(a: Term, b: Term) -> Option<&'static str> {
    use Term::*;
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    Some(match (a, b) {
        (x, MountX) if x.turns_about_a() => {
            "a tilt about the mount parallel to A turns the table about A as an A positioning \
             error does; only its lever, a sideways shift z_M·τ_X, tells them apart"
        }
        (x, MountHeight) if x.turns_about_a() => {
            "with the rotation about A shared with an A positioning error, the tilt about X \
             gives z_M only through its lever z_M·τ_X"
        }
        (x, Lateral) if x.turns_about_a() => {
            "an A positioning error with a sideways shift is the same motion as a tilt about \
             the mount parallel to A"
        }
        (MountX, Lateral) | (MountHeight, Lateral) => {
            "the lever of the tilt about X, z_M·τ_X, is a sideways shift of the table"
        }
        (MountY, Axial) | (MountHeight, Axial) => {
            "the lever of the tilt about Y, −z_M·τ_Y, is a shift of the table along A"
        }
        (MountX, MountHeight) | (MountY, MountHeight) | (MountX, MountY) => {
            "the tilts and the mount height enter the levers only as their products"
        }
        _ => return None,
    })
}

/// Why `term` cannot be told from the terms `with` (sentences from [`relation`]; a
/// generic sentence when no known relation applies).
pub fn why(term: Term, with: &[Term]) -> String {
    let mut clauses: Vec<&str> = vec![];
    for &t in with {
        if let Some(c) = relation(term, t)
            && !clauses.contains(&c)
        {
            clauses.push(c);
        }
    }
    if clauses.is_empty() {
        for (i, &a) in with.iter().enumerate() {
            for &b in &with[i + 1..] {
                if let Some(c) = relation(a, b)
                    && !clauses.contains(&c)
                {
                    clauses.push(c);
                }
            }
        }
    }
    if clauses.is_empty() {
        let names: Vec<&str> = with.iter().map(|t| t.describe()).collect();
        format!(
            "it enters the ball data only in combination with {} (a null direction of the \
             first-order Jacobian)",
            names.join(" and ")
        )
    } else {
        clauses.join("; ")
    }
}

/// The first-order Jacobian's verdict on one model.
#[derive(Debug, Clone)]
pub struct FirstOrder {
    pub spec: ModelSpec,
    /// Rank and number of parameters.
    pub rank: usize,
    pub n_params: usize,
    /// Smallest singular value relative to the largest (column-scaled; 0 with a column
    /// of no effect).
    pub smallest: f64,
    /// Per parameter: not separable (a zero column or a share of a null direction).
    pub undetermined: Vec<bool>,
    /// Per null direction, the parameters it touches.
    pub null_groups: Vec<Vec<usize>>,
}

impl FirstOrder {
    pub fn full_rank(&self) -> bool {
        self.rank == self.n_params
    }

    /// The A-dependent terms whose parameters are not separable.
    pub fn undetermined_terms(&self) -> Vec<Term> {
        let names = self.spec.names();
        let mut v: Vec<Term> = (0..self.n_params)
            .filter(|&k| self.undetermined[k])
            .filter_map(|k| Term::of_parameter(names[k]))
            .collect();
        v.sort();
        v.dedup();
        v
    }
}

/// The linearisation point of `spec` from a fitted model (module docs).
fn linearisation(fitted: &CradleModel, fitted_spec: &ModelSpec, spec: &ModelSpec) -> Vec<f64> {
    let mut m = *fitted;
    m.location = LocationErrors::default();
    let c = &m.compliance;
    let largest = [
        c.sin_urad.as_slice(),
        &c.cos_urad,
        &c.mount_x_urad,
        &c.mount_y_urad,
        &m.eaa_urad,
        &PROBE_URAD,
    ]
    .concat()
    .into_iter()
    .fold(0.0f64, |a, x| a.max(x.abs()));
    let lambda = LINEAR_URAD / largest;
    let probe = |v: [f64; 2], fitted: bool| {
        let v = if fitted { v } else { PROBE_URAD };
        v.map(|x| x * lambda)
    };
    let c = &mut m.compliance;
    if !fitted_spec.has_mount() {
        c.centre_height_mm = PROBE_MOUNT_MM;
    }
    c.mount_x_urad = probe(c.mount_x_urad, fitted_spec.mount_x);
    c.mount_y_urad = probe(c.mount_y_urad, fitted_spec.mount_y);
    let [sa, ka, mb, mc] = c.observable();
    let [sa, ka] = probe([sa, ka], fitted_spec.a_harmonic);
    let [mb, mc] = probe([mb, mc], fitted_spec.tilt != Tilt::None);
    let spatial = Compliance::from_observable([sa, ka, mb, mc]);
    (c.sin_urad, c.cos_urad) = (spatial.sin_urad, spatial.cos_urad);
    // Shifts enter linearly: their values only turn other columns (second order).
    (c.axial_um, c.lateral_um) = ([0.0; 2], [0.0; 2]);
    let e = if fitted_spec.eaa_order > 0 {
        m.eaa_urad
    } else {
        [PROBE_URAD[0], PROBE_URAD[1], 0.25]
    };
    m.eaa_urad = e.map(|x| x * lambda);
    params_from_model(&m, spec)
}

/// The first-order rank analysis of `spec` at the fitted model of `fitted_spec`
/// (module docs) for the commanded poses of `obs`.
pub fn first_order(
    obs: &[Obs],
    fitted: &CradleModel,
    fitted_spec: &ModelSpec,
    spec: &ModelSpec,
) -> FirstOrder {
    let q = linearisation(fitted, fitted_spec, spec);
    let pivot = fitted.pivot_mm;
    let steps: Vec<f64> = spec
        .steps()
        .iter()
        .map(|&h| if h >= 1e-3 { 1e4 } else { h })
        .collect();
    let f = |q: &[f64]| residuals(obs, pivot, spec, q);
    let j = jacobian(&f, &q, 3 * obs.len(), &steps);
    analyse(spec, &j)
}

fn analyse(spec: &ModelSpec, j: &DMatrix<f64>) -> FirstOrder {
    let p = j.ncols();
    let norms: Vec<f64> = j.column_iter().map(|c| c.norm()).collect();
    let biggest = norms.iter().cloned().fold(0.0, f64::max);
    // A column of no effect (relative to the largest) is its own null direction.
    let live: Vec<usize> = (0..p).filter(|&k| norms[k] > 1e-12 * biggest).collect();
    let mut undetermined = vec![true; p];
    let mut null_groups: Vec<Vec<usize>> = (0..p)
        .filter(|k| !live.contains(k))
        .map(|k| vec![k])
        .collect();
    let js = DMatrix::from_fn(j.nrows(), live.len(), |r, c| {
        j[(r, live[c])] / norms[live[c]]
    });
    let svd = js.svd(false, true);
    let vt = svd.v_t.expect("V requested");
    let sv = &svd.singular_values;
    let smax = sv.max();
    let null: Vec<usize> = (0..sv.len())
        .filter(|&i| sv[i] <= RANK_TOL * smax)
        .collect();
    for (c, &k) in live.iter().enumerate() {
        undetermined[k] = null.iter().any(|&i| vt[(i, c)].abs() > NULL_TOL);
    }
    for &i in &null {
        null_groups.push(
            live.iter()
                .enumerate()
                .filter(|&(c, _)| vt[(i, c)].abs() > NULL_TOL)
                .map(|(_, &k)| k)
                .collect(),
        );
    }
    let smallest = if live.len() < p { 0.0 } else { sv.min() / smax };
    FirstOrder {
        spec: *spec,
        rank: live.len() - null.len(),
        n_params: p,
        smallest,
        undetermined,
        null_groups,
    }
}

/// One term of the family against the chosen model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TermSeparability {
    pub term: Term,
    pub description: String,
    /// Its parameters (in the chosen model, or those it would add).
    pub parameters: Vec<String>,
    pub in_model: bool,
    /// In the model: its parameters are separable from every other parameter of the
    /// chosen model (always, since a model that is not is never chosen). Not in the
    /// model: it would be separable if added.
    pub separable: bool,
    /// In the model: the smallest sets of other terms of the family that, added to the
    /// model, would make it inseparable. Not in the model and not separable: the model's
    /// terms it cannot be told from.
    pub confounded_with: Vec<Vec<Term>>,
    /// Why, in sentences (empty when nothing confounds it).
    pub why: String,
}

/// What the ball data can separate among the A-dependent terms, for the chosen model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SeparabilityReport {
    /// Rank of the chosen model's first-order Jacobian and its number of parameters.
    pub rank: usize,
    pub n_params: usize,
    /// Its smallest singular value relative to the largest, column-scaled.
    pub smallest_singular_value: f64,
    pub terms: Vec<TermSeparability>,
    /// How the verdicts were reached, in a sentence.
    pub method: String,
}

/// The terms that can join `spec` (one at a time).
fn addable(spec: &ModelSpec) -> Vec<Term> {
    Term::ALL
        .into_iter()
        .filter(|t| !t.in_spec(spec) && t.add_to(spec).is_some())
        .collect()
}

/// Separability of every term of the family against the chosen model `spec` fitted as
/// `fitted` (module docs): for each set of at most two absent terms, the rank of the
/// model with them.
pub fn separability(obs: &[Obs], fitted: &CradleModel, spec: &ModelSpec) -> SeparabilityReport {
    let own = first_order(obs, fitted, spec, spec);
    let absent = addable(spec);
    let mut sets: Vec<Vec<Term>> = absent.iter().map(|&t| vec![t]).collect();
    for (i, &a) in absent.iter().enumerate() {
        for &b in &absent[i + 1..] {
            sets.push(vec![a, b]);
        }
    }
    // Verdict of the model with each set added.
    let verdicts: Vec<(Vec<Term>, FirstOrder)> = sets
        .into_iter()
        .map(|set| {
            let s = set
                .iter()
                .fold(*spec, |s, t| t.add_to(&s).expect("addable"));
            let fo = first_order(obs, fitted, spec, &s);
            (set, fo)
        })
        .collect();
    let mut terms = vec![];
    for term in Term::ALL {
        let in_model = term.in_spec(spec);
        if in_model {
            let mut conf: Vec<Vec<Term>> = vec![];
            for (set, fo) in &verdicts {
                if fo.full_rank() || !fo.undetermined_terms().contains(&term) {
                    continue;
                }
                if conf.iter().any(|c| c.iter().all(|t| set.contains(t))) {
                    continue;
                }
                conf.push(set.clone());
            }
            let undetermined_here = own.undetermined_terms().contains(&term);
            // One sentence per reason, however many sets share it.
            let mut reasons: Vec<String> = vec![];
            for set in &conf {
                for r in why(term, set).split("; ") {
                    if !reasons.iter().any(|x| x == r) {
                        reasons.push(r.to_string());
                    }
                }
            }
            let why = reasons.join("; ");
            terms.push(TermSeparability {
                term,
                description: term.describe().into(),
                parameters: term
                    .parameters(spec)
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
                in_model,
                separable: !undetermined_here,
                confounded_with: conf,
                why,
            });
        } else if let Some(s) = term.add_to(spec) {
            let (_, fo) = verdicts
                .iter()
                .find(|(set, _)| set.len() == 1 && set[0] == term)
                .expect("single-term set");
            let und = fo.undetermined_terms();
            let separable = !und.contains(&term);
            // The mount height comes with a tilt about the mount: not a separate culprit.
            let with: Vec<Term> = und
                .into_iter()
                .filter(|t| *t != term && !(term_brings_mount(term) && *t == Term::MountHeight))
                .collect();
            let with = if separable { vec![] } else { with };
            terms.push(TermSeparability {
                term,
                description: term.describe().into(),
                parameters: term.parameters(&s).iter().map(|s| s.to_string()).collect(),
                in_model,
                separable,
                why: if separable {
                    String::new()
                } else {
                    why(term, &with)
                },
                confounded_with: if with.is_empty() { vec![] } else { vec![with] },
            });
        } else {
            // The mount height without a tilt about the mount: no effect.
            terms.push(TermSeparability {
                term,
                description: term.describe().into(),
                parameters: vec!["z_M".into()],
                in_model,
                separable: false,
                confounded_with: vec![],
                why: "it is the lever of a tilt about the mount: without one it has no effect"
                    .into(),
            });
        }
    }
    SeparabilityReport {
        rank: own.rank,
        n_params: own.n_params,
        smallest_singular_value: own.smallest,
        terms,
        method: format!(
            "rank of the first-order Jacobian (location errors and shifts zero, A-dependent \
             angles scaled to at most {LINEAR_URAD:e} µrad, terms not in the model probed at \
             {PROBE_URAD:?} µrad and a mount at {PROBE_MOUNT_MM} mm), columns scaled to unit \
             norm, singular values below {RANK_TOL:e} of the largest taken as null; the model \
             with every set of one or two other terms of the family"
        ),
    }
}

fn term_brings_mount(t: Term) -> bool {
    matches!(t, Term::MountX | Term::MountY)
}

/// Whether `spec`'s A-dependent parameters are all separable at the fitted model (a
/// candidate that is not is never chosen).
pub fn separable(obs: &[Obs], fitted: &CradleModel, spec: &ModelSpec) -> bool {
    let fo = first_order(obs, fitted, spec, spec);
    (N_RIGID..fo.n_params).all(|k| !fo.undetermined[k])
}
