//! `mtcal report RESULT.json --out check.html [--diagnosis DIAGNOSIS.json] [--tolerances
//! LIMITS.json]`: the check report, one self-contained HTML page that prints on A4
//! (docs/report.md).

use super::BadInput;
use super::export::read_identification;
use anyhow::Context;
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::tolerance::{Limits, evaluate, identification_figures};
use mtcal_views::pages::report::{CheckReport, check_report};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// An identification result (`mtcal identify --json`, or a stored result).
    pub result: PathBuf,
    /// Where to write the page (stdout without it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A diagnosis of the same check (`mtcal diagnose --json`): its findings go in the
    /// report.
    #[arg(long, value_name = "DIAGNOSIS.json")]
    pub diagnosis: Option<PathBuf>,
    /// A tolerance profile's limits (`{"terms": {"EXX": 5}, "squareness": {…},
    /// "standards": {"iso230_2.X.E_um": 8}}`, µm and µrad): the figures are decided
    /// against them (ISO 14253-1, U = 2u). Without it every figure says "no tolerance".
    #[arg(long, value_name = "LIMITS.json")]
    pub tolerances: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let doc = read_identification(&args.result)?;
    let diagnosis: Option<DiagnosisResult> = args
        .diagnosis
        .as_deref()
        .map(|p| super::read_json(p, "diagnosis"))
        .transpose()?;
    if let Some(d) = &diagnosis
        && d.machine_id != doc.machine_id
    {
        return Err(BadInput(format!(
            "the diagnosis is of machine {}, the result of {}",
            d.machine_id, doc.machine_id
        ))
        .into());
    }
    let verdict = match &args.tolerances {
        Some(p) => {
            let limits: Limits = super::read_json(p, "tolerances")?;
            limits
                .validate()
                .map_err(|m| BadInput(format!("{}: {m}", p.display())))?;
            let mut figures = identification_figures(&doc);
            let standards = doc.standards.scalar_figures();
            figures.add_standards(standards.iter().map(|f| (f.name.as_str(), f.value, f.u)));
            Some(evaluate(&limits, &figures))
        }
        None => None,
    };
    let now = mtcal_store::now_rfc3339();
    let page = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: &now,
        verdict: verdict.as_ref(),
        diagnosis: diagnosis.as_ref(),
    })
    .into_string();
    match &args.out {
        Some(p) => std::fs::write(p, page).with_context(|| format!("writing {}", p.display()))?,
        None => super::out::write(&page)?,
    }
    Ok(ExitCode::SUCCESS)
}
