//! `mtcal compare BASELINE.json OTHER.json [--step-mm S] [--json]`: how a machine changed
//! between two identification results (each the document `mtcal identify --json` prints,
//! or a stored result as the API returns it). The solver's result arithmetic
//! (`crates/solver/src/comparison.rs`), as the service's diff route uses it: every term
//! in the reporting convention, only over the travel both checks measured, each difference
//! with its standard uncertainty; the drift figure of the fleet page.

use super::BadInput;
use super::export::read_identification;
use mtcal_solver::comparison::{self, CheckFunctions, Drift, TermDiff};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The earlier (baseline) identification result.
    pub baseline: PathBuf,
    /// The later identification result.
    pub other: PathBuf,
    /// Spacing of the compared positions, mm (multiples of it inside the common travel).
    #[arg(long, default_value_t = 5.0)]
    pub step_mm: f64,
    /// Print the comparison as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The comparison document (`--json`).
#[derive(Serialize)]
struct Comparison {
    drift: Drift,
    /// other − baseline per term over the travel both measured.
    terms: BTreeMap<String, TermDiff>,
    /// other − baseline per squareness, µrad (null when either did not identify it).
    squareness: BTreeMap<String, Option<f64>>,
    /// Standard uncertainty of each squareness difference, µrad (u² = u_baseline² +
    /// u_other²; null when not compared or a σ is not stored).
    squareness_u: BTreeMap<String, Option<f64>>,
    /// Which check lacks each term or squareness that is not compared for that reason.
    not_identifiable_in: BTreeMap<String, Lacking>,
}

/// Which of the two checks did not identify a term.
#[derive(Serialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "snake_case")]
enum Lacking {
    Baseline,
    Other,
    Both,
}

impl Lacking {
    /// From whether each check identified the term; `None` when both did.
    fn of(in_base: bool, in_other: bool) -> Option<Self> {
        match (in_base, in_other) {
            (true, true) => None,
            (false, true) => Some(Self::Baseline),
            (true, false) => Some(Self::Other),
            (false, false) => Some(Self::Both),
        }
    }

    fn says(self) -> &'static str {
        match self {
            Self::Baseline => "not identifiable in the baseline",
            Self::Other => "not identifiable in the other check",
            Self::Both => "not identifiable in either",
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let base = read_identification(&args.baseline)?;
    let other = read_identification(&args.other)?;
    comparison::check_diff_step(&base, &other, args.step_mm)
        .map_err(|m| BadInput(format!("--{}", m.replace('_', "-"))))?;
    let (terms, squareness) = comparison::diff(&base, &other, args.step_mm);
    let squareness_u = comparison::squareness_changes(&base, &other)
        .into_iter()
        .map(|(name, c)| (name.to_string(), c.and_then(|c| c.u)))
        .collect();
    let mut not_identifiable_in = BTreeMap::new();
    for name in terms.keys() {
        let lacking = Lacking::of(
            base.coefficients(name).is_some(),
            other.coefficients(name).is_some(),
        );
        if let Some(l) = lacking {
            not_identifiable_in.insert(name.clone(), l);
        }
    }
    for name in squareness.keys() {
        let lacking = Lacking::of(
            base.squareness(name).is_some(),
            other.squareness(name).is_some(),
        );
        if let Some(l) = lacking {
            not_identifiable_in.insert(name.clone(), l);
        }
    }
    let doc = Comparison {
        drift: comparison::drift(&base, &other),
        terms,
        squareness,
        squareness_u,
        not_identifiable_in,
    };
    super::out::document(args.json, &doc, summary)?;
    Ok(ExitCode::SUCCESS)
}

use mtcal_views::plots::unit_label;

fn summary(c: &Comparison) -> String {
    let u = |u: Option<f64>| u.map_or("u not stored".into(), |u| format!("u = {u:.3}"));
    let mut s = format!(
        "drift (largest change over the travel both checks measured):\n  {:.3} µm ({}) in {}\n  {:.3} µrad ({}) in {}\n",
        c.drift.drift_um,
        u(c.drift.drift_um_u),
        c.drift.worst_term_um.as_deref().unwrap_or("-"),
        c.drift.drift_urad,
        u(c.drift.drift_urad_u),
        c.drift.worst_term_urad.as_deref().unwrap_or("-"),
    );
    s += "term   unit  common travel mm      largest |change|   at mm     u\n";
    for (name, d) in &c.terms {
        let largest = d
            .delta
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        match (d.travel_mm, largest) {
            (Some([lo, hi]), Some((i, v))) => {
                s += &format!(
                    "{name:<6} {:<5} [{lo:>8.1}, {hi:>8.1}]  {:>14.3}  {:>8.1}  {}\n",
                    unit_label(&d.unit),
                    v,
                    d.positions_mm[i],
                    d.u.get(i).map_or("-".into(), |u| format!("{u:.3}"))
                )
            }
            _ if !d.identifiable => {
                s += &format!(
                    "{name:<6} {:<5} {}\n",
                    unit_label(&d.unit),
                    c.not_identifiable_in
                        .get(name)
                        .map_or("not identifiable", |l| l.says())
                )
            }
            _ => {
                s += &format!(
                    "{name:<6} {:<5} no common measured travel\n",
                    unit_label(&d.unit)
                )
            }
        }
    }
    for (name, v) in &c.squareness {
        match v {
            Some(v) => {
                s += &format!(
                    "{name:<6} µrad  {:<20}  {v:>14.3}  {:>8}  {}\n",
                    "(a constant)",
                    "",
                    c.squareness_u
                        .get(name)
                        .copied()
                        .flatten()
                        .map_or("-".into(), |u| format!("{u:.3}"))
                )
            }
            None => {
                s += &format!(
                    "{name:<6} µrad  {}\n",
                    c.not_identifiable_in
                        .get(name)
                        .map_or("not identifiable", |l| l.says())
                )
            }
        }
    }
    if !c.drift.not_compared.is_empty() {
        s += &format!("not compared: {}\n", c.drift.not_compared.join(", "));
    }
    s
}
