//! `mtcal identify SESSION_DIR [--method joint|stepwise] [--order N] [--basis ...]
//! [--explain] [--json]`: reads a session folder (strictly), identifies the 21 terms and
//! prints a readable summary, or the identification result document with `--json`.
//! With `--explain`, a misfit is diagnosed and, where the diagnosis explains it, the
//! result is the explained model's ([`super::explain`]).

use super::BadInput;
use mtcal_solver::basis::BasisKind;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, Method, identify};
use mtcal_solver::text::num;
use mtcal_views::plots::unit_label;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Session folder (session.json and the plane CSV files).
    pub session: PathBuf,
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Estimator: one joint least-squares problem, or the seed patent's two steps.
    #[arg(long, value_enum, default_value = "joint")]
    pub method: MethodArg,
    /// Polynomial order N of the error functions (straightness uses 2..N).
    #[arg(long, default_value_t = 3)]
    pub order: usize,
    /// Basis of the error functions (same span; Legendre is better conditioned).
    #[arg(long, value_enum, default_value = "polynomial")]
    pub basis: BasisArg,
    /// Spacing of the reported value grid, mm.
    #[arg(long, default_value_t = 5.0)]
    pub grid_mm: f64,
    /// When the 21-term model does not explain the recording (the misfit gate), diagnose
    /// the session and, where the diagnosis explains the misfit, give the explained model
    /// (the 21 terms fitted jointly with the physics found), its decision and one action
    /// per finding. A session the 21-term model explains gives the plain result.
    #[arg(long)]
    pub explain: bool,
    /// Print the identification result document (JSON) instead of the summary.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::ValueEnum, Clone, Copy)]
pub enum MethodArg {
    Joint,
    Stepwise,
}

#[derive(clap::ValueEnum, Clone, Copy)]
pub enum BasisArg {
    Polynomial,
    Legendre,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let session = mtcal_formats::read_session_dir(&args.session, &args.read.limits())?;
    let opts = IdentifyOptions {
        method: match args.method {
            MethodArg::Joint => Method::Joint,
            MethodArg::Stepwise => Method::Stepwise,
        },
        basis: match args.basis {
            BasisArg::Polynomial => BasisKind::Polynomial,
            BasisArg::Legendre => BasisKind::Legendre,
        },
        order: args.order,
        grid_step_mm: args.grid_mm,
        topology: None,
    };
    let mut result = identify(&session, &opts)
        .map_err(|e| BadInput(format!("{}: {e}", args.session.display())))?;
    if args.explain {
        result = super::explain::explained(&session, &opts, result, &args.session)?;
    }
    super::out::document(args.json, &result, summary)?;
    Ok(ExitCode::SUCCESS)
}

/// The human-readable summary: fit, identifiability, each term's range and uncertainty.
pub fn summary(r: &IdentificationResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let o = &r.observability;
    let _ = writeln!(
        s,
        "machine {} measured {} — method {:?}, {} basis order {}",
        r.machine_id,
        r.measured_at,
        r.method,
        r.model.basis.name(),
        r.model.order
    );
    let _ = writeln!(
        s,
        "fit: {} samples, residual RMS {} µm, noise floor {}",
        r.fit.samples,
        num(r.fit.residual_rms_um),
        r.fit
            .noise_estimate_um
            .map_or("n/a".to_string(), |n| format!("{} µm", num(n)))
    );
    // The misfit gate's outcome, said where the fit is: a misfit's figures are not judged
    // and its compensation table is refused (docs/conventions.md, "The misfit gate").
    let check = r.model_check.clone().unwrap_or_else(|| r.model_check());
    let _ = writeln!(s, "model check: {}", check.statement);
    if check.is_misfit() {
        let next = if r.explained.is_some() {
            "not decided (what remains: under the explained model below)"
        } else {
            "`mtcal identify --explain` decides it on the explained model where the \
             diagnosis explains the misfit; `mtcal diagnose` on this session says what the \
             model leaves out"
        };
        let _ = writeln!(
            s,
            "  no verdict and no compensation table from this model; {next}"
        );
    }

    let _ = writeln!(
        s,
        "identifiability: rank {} of {} parameters, condition number {}",
        o.rank,
        o.parameters,
        num(o.condition_number)
    );
    let _ = writeln!(
        s,
        "\n{:<6} {:>5} {:>12} {:>12} {:>10}",
        "term", "unit", "min", "max", "max std"
    );
    for (name, t) in &r.terms {
        if t.identifiable {
            let min = t.values.iter().copied().fold(f64::INFINITY, f64::min);
            let max = t.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let sd = t.std.iter().copied().fold(0.0, f64::max);
            let _ = writeln!(
                s,
                "{name:<6} {:>5} {:>12} {:>12} {:>10}",
                unit_label(&t.unit),
                num(min),
                num(max),
                num(sd)
            );
        } else {
            let _ = writeln!(
                s,
                "{name:<6} {:>5} {:>36}",
                unit_label(&t.unit),
                if t.confounded_with.is_empty() {
                    "not identifiable (no effect in this plan)".to_string()
                } else {
                    format!("not identifiable (with {})", t.confounded_with.join(", "))
                }
            );
        }
    }
    for (name, q) in &r.squareness {
        match (q.value_urad, q.std_urad) {
            (Some(v), Some(sd)) => {
                let _ = writeln!(s, "{name:<6} {:>5} {:>12} ± {}", "µrad", num(v), num(sd));
            }
            _ => {
                let _ = writeln!(s, "{name:<6} {:>5} {:>36}", "µrad", "not identifiable");
            }
        }
    }
    for c in &o.confounded {
        let _ = writeln!(s, "\nconfounded: {}", c.seen_as);
    }
    for a in &o.advice {
        let _ = writeln!(s, "advice: {a}");
    }
    s.push_str(&super::standards::summary(&r.standards));
    if let Some(m) = &r.explained {
        s.push_str(&super::explain::summary(m));
    }
    s
}
