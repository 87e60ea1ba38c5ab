//! The uncertainty budget of a conformance decision (ISO/TR 230-9; the thermal terms as
//! ISO 230-2:2014, annex A, states them): what besides the least-squares fit makes the
//! measured value of a figure uncertain, each contribution as a standard uncertainty
//! (k = 1) in the figure's unit, combined in quadrature into u_c and expanded with
//! k = 2 (U = 2 u_c) for the decision rule of the tolerance module.
//!
//! The inputs are the test's [`Conditions`] (session metadata, docs/datasets.md, or an
//! instrument profile of the service for the instrument). What a contribution amounts to
//! depends on what the figure spans ([`Span`]); L is that length in mm:
//!
//! | contribution | length L (positioning range, ISO 230-2 E, M, A) | radius R (ISO 230-4 F, mean radial) | form (straightness range, ISO 230-4 G, H) | local (ISO 230-2 B, R) | angle, squareness |
//! |---|---|---|---|---|---|
//! | instrument | (a + b·L/1000)/k | (a + b·R/1000)/k | a/k | 0 | squareness: U_sq/k; angle: not stated |
//! | thermal | u_th(L) | u_th(R) | 0 | 0 | 0 |
//! | setup | L·ϑ²/(4√3) | R·ϑ²/(4√3) | 0 | 0 | 0 |
//! | fit | the figure's own u | | | | |
//!
//! * **Instrument**: the calibration certificate's expanded uncertainty
//!   U_cal(L) = a + b·L (a in µm, b in µm per m of length), stated with its coverage
//!   factor k (default 2): u = U_cal/k. A form deviation takes the length-independent
//!   part a/k; a difference at one position (reversal, repeatability) has none (the
//!   calibration error is the same on both sides). Angles: a certificate states no
//!   angular uncertainty for a grid plate or a laser interferometer's linear optics, so
//!   none is included and the budget says so; a squareness takes the certificate's
//!   squareness uncertainty U_sq when stated.
//! * **Thermal** (the nominal differential expansion, NDE, of machine and instrument,
//!   not corrected by mtcal): with ΔT = T − 20 °C, α_m and α_i the expansion
//!   coefficients of the machine and the instrument (µm/(m·K)) and Δα = α_m − α_i, over
//!   a length L the uncorrected NDE is E_NDE = Δα·ΔT·L/1000 µm. Its contributions:
//!   u_NDE = |E_NDE|/√3 (the uncorrected error taken as a rectangular distribution of
//!   half-width |E_NDE|), u_α = |ΔT|·L/1000·√(u(α_m)² + u(α_i)²) (the coefficients'
//!   uncertainties), u_T = |Δα|·u(T)·L/1000 (the temperature measurement):
//!   u_th = √(u_NDE² + u_α² + u_T²). A uniform expansion changes neither a form nor an
//!   angle (0). Without a temperature, or without the instrument's expansion
//!   coefficient, the thermal contribution is not included. When not stated, α_m =
//!   11.5 ± 1.0 µm/(m·K) (steel and cast iron), u(α_i) = 1.0 µm/(m·K) and
//!   u(T) = 0.5 K are assumed, and the budget says which were assumed.
//! * **Setup**: the plate's (or the optics') misalignment ϑ out of the measuring
//!   direction (stated bound, µrad) shortens a length by the cosine error
//!   e = L(1 − cos ϑ) ≈ L·ϑ²/2, between 0 and that bound: a rectangular distribution of
//!   full width e, u = e/(2√3) = L·ϑ²/(4√3). The in-plane rotation of a plate is
//!   estimated with the fit (it is in the fit's u), so forms and angles take 0. Not
//!   stated: not included.
//! * **Fit**: the figure's standard uncertainty from the least-squares covariance (or, for
//!   a figure of a standard, its sampling uncertainty, docs/standards.md).
//!
//! A contribution that cannot be evaluated is kept in the budget with no value and the
//! reason ([`Contribution::u`] `None`): the decision then uses the others, and the
//! verdict says what is not included. Worked example: docs/conventions.md,
//! "Uncertainty budget" (reproduced by the test `worked_example`).

use serde::{Deserialize, Serialize};

/// The reference temperature of dimensional metrology (ISO 1), °C.
pub const REFERENCE_TEMPERATURE_C: f64 = 20.0;
/// Expansion coefficient of the machine assumed when not stated (steel, cast iron),
/// µm/(m·K), and its standard uncertainty.
pub const DEFAULT_MACHINE_EXPANSION_PPM_PER_K: f64 = 11.5;
pub const DEFAULT_MACHINE_EXPANSION_U_PPM_PER_K: f64 = 1.0;
/// Standard uncertainty of the instrument's expansion coefficient assumed when its
/// value is stated without one, µm/(m·K).
pub const DEFAULT_INSTRUMENT_EXPANSION_U_PPM_PER_K: f64 = 1.0;
/// Standard uncertainty of the temperature assumed when not stated, K.
pub const DEFAULT_TEMPERATURE_U_K: f64 = 0.5;
/// Coverage factor of a certificate that does not state one.
pub const DEFAULT_CERTIFICATE_K: f64 = 2.0;

/// The measuring instrument as its calibration certificate states it (session metadata
/// `instrument`, or an instrument profile of the service).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Instrument {
    /// Make and model, e.g. `KGM 282`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    /// Date of the calibration (`YYYY-MM-DD`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_date: Option<String>,
    /// The certificate's number or reference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub certificate: Option<String>,
    /// Expanded calibration uncertainty, length-independent part a, µm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_u_um: Option<f64>,
    /// Expanded calibration uncertainty, part proportional to length b, µm per m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_u_um_per_m: Option<f64>,
    /// Coverage factor of the certificate's uncertainties (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_k: Option<f64>,
    /// Expanded uncertainty of the instrument's squareness (a grid plate's), µrad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub squareness_u_urad: Option<f64>,
    /// Thermal expansion coefficient of the instrument (the plate's, the scale's),
    /// µm/(m·K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expansion_ppm_per_k: Option<f64>,
    /// Its standard uncertainty, µm/(m·K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expansion_u_ppm_per_k: Option<f64>,
}

impl Instrument {
    /// Checks the numbers; the message names the field (prefixed with `at`).
    pub fn validate(&self, at: &str) -> Result<(), String> {
        nonneg(at, "calibration_u_um", self.calibration_u_um)?;
        nonneg(at, "calibration_u_um_per_m", self.calibration_u_um_per_m)?;
        nonneg(at, "squareness_u_urad", self.squareness_u_urad)?;
        nonneg(at, "expansion_u_ppm_per_k", self.expansion_u_ppm_per_k)?;
        if let Some(k) = self.calibration_k
            && !(k.is_finite() && (1.0..=10.0).contains(&k))
        {
            return Err(format!(
                "{at}calibration_k: a coverage factor in [1, 10], got {k}"
            ));
        }
        expansion(at, "expansion_ppm_per_k", self.expansion_ppm_per_k)?;
        if let Some(d) = &self.calibration_date
            && !is_date(d)
        {
            return Err(format!(
                "{at}calibration_date: a date YYYY-MM-DD, got {d:?}"
            ));
        }
        Ok(())
    }

    /// Whether the certificate's uncertainty is stated (the instrument contribution can
    /// be evaluated).
    pub fn has_calibration(&self) -> bool {
        self.calibration_u_um.is_some() || self.calibration_u_um_per_m.is_some()
    }

    fn k(&self) -> f64 {
        self.calibration_k.unwrap_or(DEFAULT_CERTIFICATE_K)
    }

    /// `KGM 282 s/n 1234, calibrated 2026-03-01` (what is known of it).
    pub fn describe(&self) -> String {
        let mut s = self.model.clone().unwrap_or_else(|| "instrument".into());
        if let Some(n) = &self.serial {
            s.push_str(&format!(" s/n {n}"));
        }
        if let Some(d) = &self.calibration_date {
            s.push_str(&format!(", calibrated {d}"));
        }
        s
    }
}

/// `YYYY-MM-DD` with a plausible month and day.
pub fn is_date(s: &str) -> bool {
    let b = s.as_bytes();
    if b.len() != 10 || b[4] != b'-' || b[7] != b'-' {
        return false;
    }
    let num = |r: std::ops::Range<usize>| s[r].parse::<u32>().ok();
    matches!(
        (num(0..4), num(5..7), num(8..10)),
        (Some(_), Some(1..=12), Some(1..=31))
    ) && s.is_ascii()
}

/// What the test's records state about how it was made: the inputs of the uncertainty
/// budget and the facts a signed report names. Every field is optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Conditions {
    /// Who made the test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operator: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instrument: Option<Instrument>,
    /// Temperature of the machine during the test, °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    /// Where the temperature comes from: `stated` (session.json) or `logged` (the mean
    /// of the plane files' `temp_c` column).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_source: Option<String>,
    /// Standard uncertainty of that temperature, K.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_u_k: Option<f64>,
    /// Expansion coefficient of the machine's scales, µm/(m·K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine_expansion_ppm_per_k: Option<f64>,
    /// Its standard uncertainty, µm/(m·K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine_expansion_u_ppm_per_k: Option<f64>,
    /// Bound on the misalignment of the instrument out of the measuring direction (a
    /// plate's tilt), µrad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alignment_urad: Option<f64>,
}

impl Conditions {
    /// The conditions of the worked example of docs/conventions.md ("Uncertainty
    /// budget"): a certificate U_cal = 0.5 µm + 1.0 µm/m (k = 2), T = 22.0 ± 0.2 °C
    /// (stated), α_machine = 11.5 ± 1.0 and α_instrument = 8.0 ± 0.5 µm/(m·K), a
    /// misalignment bound ϑ = 500 µrad; operator and instrument named as a signed report
    /// names them.
    pub fn worked_example() -> Conditions {
        Conditions {
            operator: Some("A. Keller".into()),
            instrument: Some(Instrument {
                model: Some("grid encoder".into()),
                serial: Some("1234".into()),
                calibration_date: Some("2026-03-01".into()),
                certificate: Some("C-77".into()),
                calibration_u_um: Some(0.5),
                calibration_u_um_per_m: Some(1.0),
                calibration_k: Some(2.0),
                squareness_u_urad: None,
                expansion_ppm_per_k: Some(8.0),
                expansion_u_ppm_per_k: Some(0.5),
            }),
            temperature_c: Some(22.0),
            temperature_source: Some("stated".into()),
            temperature_u_k: Some(0.2),
            machine_expansion_ppm_per_k: Some(11.5),
            machine_expansion_u_ppm_per_k: Some(1.0),
            alignment_urad: Some(500.0),
        }
    }

    /// Checks the numbers; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(i) = &self.instrument {
            i.validate("instrument.")?;
        }
        nonneg("", "temperature_u_k", self.temperature_u_k)?;
        nonneg(
            "",
            "machine_expansion_u_ppm_per_k",
            self.machine_expansion_u_ppm_per_k,
        )?;
        nonneg("", "alignment_urad", self.alignment_urad)?;
        expansion(
            "",
            "machine_expansion_ppm_per_k",
            self.machine_expansion_ppm_per_k,
        )?;
        if let Some(t) = self.temperature_c
            && !t.is_finite()
        {
            return Err(format!("temperature_c: a finite number, got {t}"));
        }
        Ok(())
    }
}

/// A stated number that must be finite and ≥ 0 (the message names `at` + `name`).
fn nonneg(at: &str, name: &str, v: Option<f64>) -> Result<(), String> {
    match v {
        Some(v) if !(v.is_finite() && v >= 0.0) => {
            Err(format!("{at}{name}: a finite number >= 0, got {v}"))
        }
        _ => Ok(()),
    }
}

/// A stated expansion coefficient: finite, within ±100 µm/(m·K).
fn expansion(at: &str, name: &str, v: Option<f64>) -> Result<(), String> {
    match v {
        Some(a) if !(a.is_finite() && a.abs() <= 100.0) => {
            Err(format!("{at}{name}: µm/(m·K) within ±100, got {a}"))
        }
        _ => Ok(()),
    }
}

/// What a figure spans, which decides the contributions it takes (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Span {
    /// A length along an axis, mm: a positioning range, ISO 230-2 E, M, A.
    Length { mm: f64 },
    /// A radius, mm: ISO 230-4 mean radial deviation and F.
    Radius { mm: f64 },
    /// A form deviation: a straightness range, ISO 230-4 G and H.
    Form,
    /// A difference at one position: ISO 230-2 B and R.
    Local,
    /// An angular deviation (roll, pitch, yaw), µrad.
    Angle,
    /// A squareness, µrad.
    Squareness,
    /// A figure stored without what it spans (only its fit uncertainty is known).
    Unknown,
}

/// Where a contribution comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema), schema(as = BudgetSource))]
#[serde(rename_all = "snake_case")]
pub enum Source {
    Instrument,
    Thermal,
    Setup,
    Fit,
}

impl Source {
    pub const ALL: [Source; 4] = [
        Source::Instrument,
        Source::Thermal,
        Source::Setup,
        Source::Fit,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Source::Instrument => "instrument",
            Source::Thermal => "thermal",
            Source::Setup => "setup",
            Source::Fit => "fit",
        }
    }
}

/// One line of a budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Contribution {
    pub source: Source,
    /// Standard uncertainty (k = 1) in the figure's unit; absent when it could not be
    /// evaluated (then `basis` says why, and it is not included).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
    /// How it was evaluated (the formula with its numbers), or why it is not included.
    pub basis: String,
}

/// The budget of one figure: its contributions, their combination and what is missing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ItemBudget {
    pub contributions: Vec<Contribution>,
    /// u_c = √(Σ u²) over the included contributions.
    pub combined_u: f64,
    /// The sources not included (each contribution's `basis` says why).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_included: Vec<Source>,
}

/// The budget's inputs for one result: its conditions and where the instrument's
/// calibration came from.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Budget {
    pub conditions: Conditions,
    /// Where the instrument's data come from: `session` (the session's metadata) or
    /// `profile` (the service's instrument profile of its serial); absent without one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instrument_from: Option<String>,
    /// The values assumed because the conditions do not state them, one sentence each.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub assumed: Vec<String>,
}

/// √3, for rectangular distributions.
const SQRT3: f64 = 1.732_050_807_568_877_2;

impl Budget {
    /// The budget of a result's conditions; the instrument of `conditions` came from
    /// `instrument_from` (`session` or `profile`).
    pub fn new(conditions: Conditions, instrument_from: Option<&str>) -> Budget {
        let mut assumed = vec![];
        let c = &conditions;
        let thermal_evaluated = c.temperature_c.is_some()
            && c.instrument
                .as_ref()
                .is_some_and(|i| i.expansion_ppm_per_k.is_some());
        if thermal_evaluated {
            if c.machine_expansion_ppm_per_k.is_none() {
                assumed.push(format!(
                    "machine expansion coefficient {DEFAULT_MACHINE_EXPANSION_PPM_PER_K} ± \
                     {DEFAULT_MACHINE_EXPANSION_U_PPM_PER_K} µm/(m·K) (steel, cast iron)"
                ));
            } else if c.machine_expansion_u_ppm_per_k.is_none() {
                assumed.push(format!(
                    "uncertainty of the machine's expansion coefficient \
                     {DEFAULT_MACHINE_EXPANSION_U_PPM_PER_K} µm/(m·K)"
                ));
            }
            if c.instrument
                .as_ref()
                .is_some_and(|i| i.expansion_u_ppm_per_k.is_none())
            {
                assumed.push(format!(
                    "uncertainty of the instrument's expansion coefficient \
                     {DEFAULT_INSTRUMENT_EXPANSION_U_PPM_PER_K} µm/(m·K)"
                ));
            }
            if c.temperature_u_k.is_none() {
                assumed.push(format!(
                    "uncertainty of the temperature {DEFAULT_TEMPERATURE_U_K} K"
                ));
            }
        }
        if c.instrument
            .as_ref()
            .is_some_and(|i| i.has_calibration() && i.calibration_k.is_none())
        {
            assumed.push(format!(
                "coverage factor of the certificate k = {DEFAULT_CERTIFICATE_K}"
            ));
        }
        let instrument_from = c
            .instrument
            .as_ref()
            .and(instrument_from)
            .map(str::to_string);
        Budget {
            conditions,
            instrument_from,
            assumed,
        }
    }

    /// The calibrated instrument, when its certificate's uncertainty is stated.
    fn calibrated(&self) -> Option<&Instrument> {
        self.conditions
            .instrument
            .as_ref()
            .filter(|i| i.has_calibration())
    }

    /// Whether the instrument's uncertainty can be included at all.
    pub fn has_instrument(&self) -> bool {
        self.calibrated().is_some()
    }

    /// The budget of a figure spanning `span`, whose own (fit) standard uncertainty is
    /// `fit_u`.
    pub fn item(&self, span: Span, fit_u: Option<f64>) -> ItemBudget {
        let contributions = vec![
            self.instrument(span),
            self.thermal(span),
            self.setup(span),
            match fit_u {
                Some(u) if u.is_finite() && u >= 0.0 => Contribution {
                    source: Source::Fit,
                    u: Some(u),
                    basis: "standard uncertainty of the figure from the fit (or the readings' \
                            scatter)"
                        .into(),
                },
                _ => Contribution {
                    source: Source::Fit,
                    u: None,
                    basis: "the figure comes without an uncertainty".into(),
                },
            },
        ];
        let combined_u = contributions
            .iter()
            .filter_map(|c| c.u)
            .map(|u| u * u)
            .sum::<f64>()
            .sqrt();
        let not_included = contributions
            .iter()
            .filter(|c| c.u.is_none())
            .map(|c| c.source)
            .collect();
        ItemBudget {
            contributions,
            combined_u,
            not_included,
        }
    }

    fn instrument(&self, span: Span) -> Contribution {
        let c = |u: Option<f64>, basis: String| Contribution {
            source: Source::Instrument,
            u,
            basis,
        };
        let Some(i) = self.calibrated() else {
            return c(
                None,
                "no calibration certificate stated (session metadata `instrument` or an \
                 instrument profile of the service): the instrument's uncertainty is not \
                 included"
                    .into(),
            );
        };
        let (a, b, k) = (
            i.calibration_u_um.unwrap_or(0.0),
            i.calibration_u_um_per_m.unwrap_or(0.0),
            i.k(),
        );
        let over = |l: f64, what: &str| {
            let big_u = a + b * l / 1000.0;
            c(
                Some(big_u / k),
                format!(
                    "certificate: U = a + b·{what} = {a} + {b} × {} m = {} µm (k = {k}); u = U/k",
                    g(l / 1000.0),
                    g(big_u)
                ),
            )
        };
        match span {
            Span::Length { mm } => over(mm, "L"),
            Span::Radius { mm } => over(mm, "R"),
            Span::Form => c(
                Some(a / k),
                format!("certificate: length-independent part a = {a} µm (k = {k}); u = a/k"),
            ),
            Span::Local => c(
                Some(0.0),
                "a difference at one position: the calibration error is the same on both sides"
                    .into(),
            ),
            Span::Squareness => match i.squareness_u_urad {
                Some(s) => c(
                    Some(s / k),
                    format!("certificate: squareness U = {s} µrad (k = {k}); u = U/k"),
                ),
                None => c(
                    None,
                    "the certificate states no squareness uncertainty: not included".into(),
                ),
            },
            Span::Angle => c(
                None,
                "the certificate states no angular uncertainty: not included".into(),
            ),
            Span::Unknown => c(
                None,
                "the figure was stored without the length it spans: not included".into(),
            ),
        }
    }

    fn thermal(&self, span: Span) -> Contribution {
        let c = |u: Option<f64>, basis: String| Contribution {
            source: Source::Thermal,
            u,
            basis,
        };
        let l = match span {
            Span::Length { mm } | Span::Radius { mm } => mm,
            Span::Form | Span::Local | Span::Angle | Span::Squareness => {
                return c(
                    Some(0.0),
                    "a uniform expansion changes neither a form, a difference at one position \
                     nor an angle"
                        .into(),
                );
            }
            Span::Unknown => {
                return c(
                    None,
                    "the figure was stored without the length it spans: not included".into(),
                );
            }
        };
        let cond = &self.conditions;
        let Some(t) = cond.temperature_c else {
            return c(
                None,
                "temperature not recorded (session.json temperature_c or a temp_c column): \
                 not included"
                    .into(),
            );
        };
        let Some((ai, u_ai)) = cond.instrument.as_ref().and_then(|i| {
            Some((
                i.expansion_ppm_per_k?,
                i.expansion_u_ppm_per_k
                    .unwrap_or(DEFAULT_INSTRUMENT_EXPANSION_U_PPM_PER_K),
            ))
        }) else {
            return c(
                None,
                "the instrument's expansion coefficient is not stated: not included".into(),
            );
        };
        let am = cond
            .machine_expansion_ppm_per_k
            .unwrap_or(DEFAULT_MACHINE_EXPANSION_PPM_PER_K);
        let u_am = cond
            .machine_expansion_u_ppm_per_k
            .unwrap_or(DEFAULT_MACHINE_EXPANSION_U_PPM_PER_K);
        let u_t = cond.temperature_u_k.unwrap_or(DEFAULT_TEMPERATURE_U_K);
        let th = thermal(l, t, u_t, am, u_am, ai, u_ai);
        c(
            Some(th.u),
            format!(
                "ΔT = {} K, Δα = {} − {} µm/(m·K), L = {} mm: E_NDE = {} µm, u_NDE = |E_NDE|/√3 = {}, \
                 u_α = {}, u_T = {}; u = √(u_NDE² + u_α² + u_T²)",
                g(t - REFERENCE_TEMPERATURE_C),
                g(am),
                g(ai),
                g(l),
                g(th.e_nde),
                g(th.u_nde),
                g(th.u_alpha),
                g(th.u_temperature)
            ),
        )
    }

    fn setup(&self, span: Span) -> Contribution {
        let c = |u: Option<f64>, basis: String| Contribution {
            source: Source::Setup,
            u,
            basis,
        };
        let l = match span {
            Span::Length { mm } | Span::Radius { mm } => mm,
            Span::Form | Span::Local | Span::Angle | Span::Squareness => {
                return c(
                    Some(0.0),
                    "the in-plane rotation of the instrument is estimated with the fit; a \
                     tilt changes a form or an angle only to second order"
                        .into(),
                );
            }
            Span::Unknown => {
                return c(
                    None,
                    "the figure was stored without the length it spans: not included".into(),
                );
            }
        };
        match self.conditions.alignment_urad {
            Some(a) => {
                let e = cosine_error_um(l, a);
                c(
                    Some(e / (2.0 * SQRT3)),
                    format!(
                        "misalignment ϑ ≤ {} µrad over L = {} mm: cosine error L·ϑ²/2 = {} µm, \
                         u = (L·ϑ²/2)/(2√3)",
                        g(a),
                        g(l),
                        g(e)
                    ),
                )
            }
            None => c(
                None,
                "the instrument's alignment is not stated (session.json alignment_urad): not \
                 included"
                    .into(),
            ),
        }
    }
}

/// The thermal contributions over a length (module docs), µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thermal {
    pub e_nde: f64,
    pub u_nde: f64,
    pub u_alpha: f64,
    pub u_temperature: f64,
    pub u: f64,
}

/// The thermal contributions over `l_mm` at temperature `t_c` (u(T) = `u_t`), machine
/// coefficient `am` ± `u_am`, instrument `ai` ± `u_ai` (µm/(m·K)).
pub fn thermal(l_mm: f64, t_c: f64, u_t: f64, am: f64, u_am: f64, ai: f64, u_ai: f64) -> Thermal {
    let l_m = l_mm / 1000.0;
    let dt = t_c - REFERENCE_TEMPERATURE_C;
    let da = am - ai;
    let e_nde = da * dt * l_m;
    let u_nde = e_nde.abs() / SQRT3;
    let u_alpha = dt.abs() * l_m * u_am.hypot(u_ai);
    let u_temperature = da.abs() * u_t * l_m;
    Thermal {
        e_nde,
        u_nde,
        u_alpha,
        u_temperature,
        u: (u_nde * u_nde + u_alpha * u_alpha + u_temperature * u_temperature).sqrt(),
    }
}

/// Cosine error of a misalignment of `urad` over `l_mm`, µm: L·ϑ²/2.
pub fn cosine_error_um(l_mm: f64, urad: f64) -> f64 {
    let th = urad * 1e-6;
    l_mm * 1000.0 * th * th / 2.0
}

/// A number in a budget's or a verdict's sentence ([`crate::text::short`]).
pub(crate) use crate::text::short as g;

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Budget {
        Budget::new(Conditions::worked_example(), Some("session"))
    }

    /// The worked example of docs/conventions.md ("Uncertainty budget"), by hand:
    /// a positioning range over L = 100 mm with u_fit = 0.010 µm.
    #[test]
    fn worked_example() {
        let b = example();
        assert!(b.assumed.is_empty(), "{:?}", b.assumed);
        let item = b.item(Span::Length { mm: 100.0 }, Some(0.010));
        let u = |s: Source| {
            item.contributions
                .iter()
                .find(|c| c.source == s)
                .unwrap()
                .u
                .unwrap()
        };
        // Instrument: U = 0.5 + 1.0 × 0.1 = 0.6 µm, k = 2 → 0.3 µm.
        assert!((u(Source::Instrument) - 0.3).abs() < 1e-12);
        // Thermal: ΔT = 2 K, Δα = 3.5 µm/(m·K), L = 0.1 m.
        // E_NDE = 3.5 × 2 × 0.1 = 0.7 µm; u_NDE = 0.7/√3 = 0.40415 µm;
        // u_α = 2 × 0.1 × √(1² + 0.5²) = 0.22361 µm; u_T = 3.5 × 0.2 × 0.1 = 0.07 µm;
        // u_th = √(0.163333 + 0.05 + 0.0049) = 0.46715 µm.
        let th = thermal(100.0, 22.0, 0.2, 11.5, 1.0, 8.0, 0.5);
        assert!((th.e_nde - 0.7).abs() < 1e-12);
        assert!((th.u_nde - 0.404_145).abs() < 1e-6);
        assert!((th.u_alpha - 0.223_607).abs() < 1e-6);
        assert!((th.u_temperature - 0.07).abs() < 1e-12);
        assert!((u(Source::Thermal) - 0.467_154).abs() < 1e-6);
        // Setup: ϑ = 500 µrad: L·ϑ²/2 = 100 000 µm × 2.5e-7 / 2 = 0.0125 µm; u = 0.0125/(2√3).
        assert!((cosine_error_um(100.0, 500.0) - 0.0125).abs() < 1e-12);
        assert!((u(Source::Setup) - 0.003_608).abs() < 1e-6);
        assert_eq!(u(Source::Fit), 0.010);
        // u_c = √(0.09 + 0.218233 + 0.000013 + 0.0001) = 0.55529 µm; U = 1.1106 µm.
        assert!(
            (item.combined_u - 0.555_290).abs() < 1e-5,
            "{}",
            item.combined_u
        );
        assert!(item.not_included.is_empty());
    }

    #[test]
    fn what_a_span_takes() {
        let b = example();
        let item = |s| b.item(s, Some(0.1));
        // A form: instrument a/k, nothing thermal or from the setup.
        let f = item(Span::Form);
        assert!((f.combined_u - (0.25f64.powi(2) + 0.01).sqrt()).abs() < 1e-12);
        // A difference at one position: the fit alone.
        assert!((item(Span::Local).combined_u - 0.1).abs() < 1e-12);
        // An angle: the certificate states nothing angular: not included, said.
        let a = item(Span::Angle);
        assert_eq!(a.not_included, vec![Source::Instrument]);
        assert!((a.combined_u - 0.1).abs() < 1e-12);
        // A radius of 50 mm: U = 0.5 + 0.05 = 0.55 µm → 0.275 µm.
        let r = item(Span::Radius { mm: 50.0 });
        assert!((r.contributions[0].u.unwrap() - 0.275).abs() < 1e-12);
    }

    #[test]
    fn nothing_stated_nothing_included_and_said() {
        let b = Budget::new(Conditions::default(), None);
        assert!(!b.has_instrument());
        let item = b.item(Span::Length { mm: 100.0 }, Some(0.2));
        assert_eq!(
            item.not_included,
            vec![Source::Instrument, Source::Thermal, Source::Setup]
        );
        assert_eq!(item.combined_u, 0.2);
        assert!(item.contributions[0].basis.contains("not included"));
        // A temperature alone: the thermal part needs the instrument's coefficient.
        let b = Budget::new(
            Conditions {
                temperature_c: Some(25.0),
                ..Conditions::default()
            },
            None,
        );
        let item = b.item(Span::Length { mm: 100.0 }, Some(0.2));
        assert!(item.not_included.contains(&Source::Thermal));
    }

    #[test]
    fn defaults_are_said_to_be_assumed() {
        let mut c = example().conditions;
        c.machine_expansion_ppm_per_k = None;
        c.temperature_u_k = None;
        let b = Budget::new(c, Some("profile"));
        assert_eq!(b.assumed.len(), 2, "{:?}", b.assumed);
        let th = thermal(100.0, 22.0, 0.5, 11.5, 1.0, 8.0, 0.5);
        let item = b.item(Span::Length { mm: 100.0 }, None);
        assert!((item.contributions[1].u.unwrap() - th.u).abs() < 1e-12);
        assert_eq!(item.not_included, vec![Source::Fit]);
    }

    #[test]
    fn validation_names_the_field() {
        let mut c = example().conditions;
        c.instrument.as_mut().unwrap().calibration_u_um = Some(-1.0);
        assert!(
            c.validate()
                .unwrap_err()
                .contains("instrument.calibration_u_um")
        );
        let mut c = example().conditions;
        c.instrument.as_mut().unwrap().calibration_date = Some("2026-13-01".into());
        assert!(c.validate().unwrap_err().contains("calibration_date"));
        let mut c = example().conditions;
        c.alignment_urad = Some(f64::NAN);
        assert!(c.validate().unwrap_err().contains("alignment_urad"));
        assert!(example().conditions.validate().is_ok());
        assert_eq!(g(0.46715432), "0.4672");
        assert_eq!(g(100.0), "100");
        assert_eq!(g(0.1), "0.1");
    }
}
