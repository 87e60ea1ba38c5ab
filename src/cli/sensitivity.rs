//! `mtcal sensitivity`: rank a machine's geometric errors by their effect on the
//! volumetric error (Cheng et al. 2012), locally and, with `--global N`, by Sobol indices.
//! Method and formats: docs/sensitivity.md.

use super::{BadInput, read_json};
use mtcal_solver::SolverError;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::sensitivity::{
    GlobalOptions, GridAxis, MachineDescription, MachineRef, SensitivityRequest, SensitivityResult,
    Weighting, analyse,
};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Machine description file (JSON, docs/sensitivity.md); or use --template.
    #[arg(required_unless_present = "template", conflicts_with = "template")]
    pub machine: Option<PathBuf>,
    /// Built-in machine: vmc3, hmc4-b, cradle5-ac.
    #[arg(long)]
    pub template: Option<String>,
    /// Evaluation point, axis positions in the order X,Y,Z,A,B,C (those the machine has;
    /// mm, degrees). Repeat for a tool path.
    #[arg(long = "point", value_name = "X,Y,Z,...", allow_hyphen_values = true)]
    pub points: Vec<String>,
    /// Evaluation grid, one `min:max:n` per axis, comma separated.
    #[arg(
        long,
        value_name = "xmin:xmax:n,...",
        allow_hyphen_values = true,
        conflicts_with = "points"
    )]
    pub grid: Option<String>,
    /// Share of each component the key error set must cover.
    #[arg(long, default_value_t = 0.9)]
    pub share: f64,
    /// Run the global (Sobol) analysis with N base samples.
    #[arg(long = "global", value_name = "N")]
    pub global: Option<usize>,
    /// Normalise the paper's raw sensitivities instead of sensitivity × magnitude.
    #[arg(long)]
    pub paper: bool,
    /// Tool offset x,y,z in mm (replaces the machine's).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub tool_offset: Option<String>,
    /// Identification result (JSON) of the same machine: its terms become the magnitudes.
    #[arg(long, value_name = "RESULT.json")]
    pub identification: Option<PathBuf>,
    /// Take the Jacobian at the machine's error state (given values and functions, e.g.
    /// from --identification) instead of at zero error.
    #[arg(long)]
    pub at_error_state: bool,
    /// Machine id to put in the result.
    #[arg(long, default_value = "")]
    pub machine_id: String,
    /// Rows per ranking table beyond the key errors.
    #[arg(long, default_value_t = 3)]
    pub extra_rows: usize,
    /// Print the result document (JSON) instead of the tables.
    #[arg(long)]
    pub json: bool,
}

fn bad(msg: String) -> anyhow::Error {
    anyhow::Error::new(BadInput(msg))
}

fn numbers(what: &str, s: &str) -> anyhow::Result<Vec<f64>> {
    s.split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("{what} `{s}`: `{v}` is not a number")))
        })
        .collect()
}

fn parse_grid(s: &str) -> anyhow::Result<Vec<GridAxis>> {
    s.split(',')
        .map(|part| {
            let f: Vec<&str> = part.split(':').collect();
            let err = || bad(format!("--grid `{s}`: `{part}` is not min:max:n"));
            if f.len() != 3 {
                return Err(err());
            }
            let min = f[0].trim().parse::<f64>().map_err(|_| err())?;
            let max = f[1].trim().parse::<f64>().map_err(|_| err())?;
            let n = f[2].trim().parse::<usize>().map_err(|_| err())?;
            Ok(GridAxis { min, max, n })
        })
        .collect()
}

pub fn request(args: &Args) -> anyhow::Result<SensitivityRequest> {
    let machine = match (&args.machine, &args.template) {
        (Some(p), _) => MachineRef::Description(read_json::<MachineDescription>(p, "machine")?),
        (None, Some(t)) => MachineRef::Template(t.clone()),
        (None, None) => return Err(bad("give MACHINE.json or --template NAME".into())),
    };
    let points = args
        .points
        .iter()
        .map(|p| numbers("--point", p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let grid = args.grid.as_deref().map(parse_grid).transpose()?;
    let tool_offset_mm = match &args.tool_offset {
        Some(s) => {
            let v = numbers("--tool-offset", s)?;
            Some(<[f64; 3]>::try_from(v).map_err(|_| bad("--tool-offset needs x,y,z".into()))?)
        }
        None => None,
    };
    let identification = match &args.identification {
        Some(p) => Some(Box::new(read_json::<IdentificationResult>(
            p,
            "identification",
        )?)),
        None => None,
    };
    Ok(SensitivityRequest {
        machine_id: args.machine_id.clone(),
        machine,
        points,
        grid,
        tool_offset_mm,
        share: args.share,
        weighting: if args.paper {
            Weighting::Paper
        } else {
            Weighting::Weighted
        },
        identification,
        at_error_state: args.at_error_state,
        global: args.global.map(|n| GlobalOptions {
            samples: n,
            ..Default::default()
        }),
    })
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let req = request(&args)?;
    let res = analyse(&req).map_err(|e| match e {
        SolverError::InvalidInput(m) | SolverError::Limit(m) => bad(m),
        other => anyhow::Error::new(other),
    })?;
    super::out::document(args.json, &res, |res| render(res, args.extra_rows))?;
    Ok(ExitCode::SUCCESS)
}

fn pct(v: f64) -> String {
    format!("{:.1} %", v * 100.0)
}

/// The readable report: one ranking table per component, then the global indices.
pub fn render(res: &SensitivityResult, extra_rows: usize) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let m = &res.machine;
    let axes: String = m.axes.iter().collect();
    let _ = writeln!(
        o,
        "machine {} ({} errors; workpiece [{}], tool [{}]; axes {axes}; tool offset {:?} mm)",
        m.name,
        res.errors.len(),
        m.workpiece
            .iter()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        m.tool
            .iter()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        m.tool_offset_mm
    );
    let _ = writeln!(
        o,
        "evaluated at {} {} pose(s); coefficients from {} sensitivities; key set covers {}",
        res.evaluation.poses,
        res.evaluation.kind,
        match res.weighting {
            Weighting::Weighted => "magnitude-weighted",
            Weighting::Paper => "the paper's raw",
        },
        pct(res.share)
    );
    if let Some(p) = res.evaluation.points.first()
        && res.evaluation.points.len() == 1
    {
        let _ = writeln!(o, "point {p:?}");
    }
    if let Some(v) = &res.volumetric_error_um {
        let _ = writeln!(
            o,
            "volumetric error of the given values (exact chain): {}",
            ["Ex", "Ey", "Ez", "E"]
                .iter()
                .map(|c| format!("{c} rms {:.2} max {:.2} um", v[*c].rms_um, v[*c].max_um))
                .collect::<Vec<_>>()
                .join("; ")
        );
    }
    for comp in ["Ex", "Ey", "Ez", "E"] {
        let r = &res.components[comp];
        let _ = writeln!(
            o,
            "\n{comp}: key errors {} (cover {})",
            r.key_errors.join(", "),
            pct(r.covered)
        );
        let _ = writeln!(
            o,
            "{:>4}  {:<6} {:>12} {:>12} {:>9}  {:>12} {:>9} {:>9}",
            "rank", "error", "sens mean", "sens max", "unit", "contrib µm", "coef", "cum"
        );
        let mut cum = 0.0;
        let rows = (r.key_errors.len() + extra_rows).min(r.ranking.len());
        for (i, e) in r.ranking.iter().take(rows).enumerate() {
            cum += e.coefficient;
            let unit = if e.unit == "urad" { "mm/rad" } else { "mm/mm" };
            let key = if i < r.key_errors.len() { "*" } else { " " };
            let _ = writeln!(
                o,
                "{:>3}{key}  {:<6} {:>12.3} {:>12.3} {:>9}  {:>12.3} {:>9} {:>9}",
                i + 1,
                e.error,
                e.sensitivity_mean,
                e.sensitivity_max,
                unit,
                e.contribution_mean_um,
                pct(e.coefficient),
                pct(cum)
            );
        }
    }
    if let Some(g) = &res.global {
        let _ = writeln!(
            o,
            "\nglobal (Sobol, N = {}, {:?} errors, {} poses): shares of the variance of E (Var Ex + Var Ey + Var Ez)",
            g.samples, g.distribution, g.poses
        );
        let out = &g.outputs["E"];
        let _ = writeln!(o, "rms |E| = {:.2} um", out.rms_um);
        let _ = writeln!(
            o,
            "{:>4}  {:<6} {:>16} {:>16}",
            "rank", "error", "total", "first order"
        );
        for (i, e) in out.indices.iter().take(10).enumerate() {
            let _ = writeln!(
                o,
                "{:>4}  {:<6} {:>9.3} ± {:<5.3} {:>9.3} ± {:<5.3}",
                i + 1,
                e.error,
                e.total,
                e.total_se,
                e.first_order,
                e.first_order_se
            );
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn parse(argv: &[&str]) -> Args {
        Cli::try_parse_from(std::iter::once("sensitivity").chain(argv.iter().copied()))
            .unwrap()
            .args
    }

    #[test]
    fn template_point_request_runs_and_renders() {
        let args = parse(&[
            "--template",
            "hmc4-b",
            "--point",
            "500,581.5,118,0",
            "--paper",
        ]);
        let req = request(&args).unwrap();
        assert_eq!(req.points, vec![vec![500.0, 581.5, 118.0, 0.0]]);
        assert_eq!(req.weighting, Weighting::Paper);
        let res = analyse(&req).unwrap();
        let text = render(&res, 0);
        assert!(text.contains("Ex: key errors"), "{text}");
        assert!(text.contains("581.500"), "{text}");
    }

    #[test]
    fn grid_and_numbers_are_parsed_or_rejected_as_bad_input() {
        let g = parse_grid("0:600:3,-10:10:2,-400:0:5").unwrap();
        assert_eq!(g.len(), 3);
        assert_eq!((g[1].min, g[1].max, g[1].n), (-10.0, 10.0, 2));
        for bad_grid in ["0:600", "0:600:x", "a:1:2"] {
            let e = parse_grid(bad_grid).unwrap_err();
            assert!(e.is::<BadInput>(), "{bad_grid}");
        }
        let args = parse(&["--template", "vmc3", "--point", "1,2,zz"]);
        assert!(request(&args).unwrap_err().is::<BadInput>());
    }

    #[test]
    fn a_malformed_machine_file_names_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.json");
        std::fs::write(&path, "{\n  \"name\": \"m\",\n  \"workpiece\": [oops]\n}").unwrap();
        let args = parse(&[path.to_str().unwrap()]);
        let e = request(&args).unwrap_err();
        let msg = format!("{e}");
        assert!(e.is::<BadInput>() && msg.contains("line 3"), "{msg}");
    }
}
