//! `mtcal cradle`: 5-axis cradle A/C connection check from a rotary point set
//! (datasets contract section 2), or `--simulate` to write an example point set.

use super::BadInput;
use anyhow::Context;
use mtcal_solver::SolverError;
use mtcal_solver::cradle::{
    CradleOptions, CradleResult, CradleSimulation, Deflection, angle_text, check_cradle,
    simulate_cradle,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Rotary point set CSV (a_deg,c_deg,x_mm,y_mm,z_mm[,t_s]); the sidecar <stem>.json
    /// (machine_id, measured_at) is read when present.
    #[arg(value_name = "POINTS.csv", required_unless_present = "simulate")]
    points: Option<PathBuf>,
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Print the full result document (JSON) instead of the summary.
    #[arg(long)]
    json: bool,
    /// The instrument frame is not registered to the machine axes: report only the
    /// location errors intrinsic to the cradle (EY0C, EB0C).
    #[arg(long)]
    unregistered: bool,
    /// Nominal intersection of the A and C axes in the instrument frame, mm (X,Y,Z).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        num_args = 3,
        allow_hyphen_values = true
    )]
    pivot_mm: Option<Vec<f64>>,
    /// Write a simulated cradle point set (and its sidecar) to OUT.csv instead.
    #[arg(long, value_name = "OUT.csv", conflicts_with = "points")]
    simulate: Option<PathBuf>,
    /// Seed of the simulation.
    #[arg(long, default_value_t = 1, requires = "simulate")]
    seed: u64,
    /// Simulate a compliant A/C connection (the table tilts with A about the pivot);
    /// the same as `--deflection pivot`.
    #[arg(long, requires = "simulate", conflicts_with = "deflection")]
    compliant: bool,
    /// How the simulated table deflects with A: `rigid`, `pivot` (tilts about the
    /// pivot) or `mount` (the C table tilts about its own mount 150 mm below the pivot,
    /// about X and about its Y, both growing with sin A).
    #[arg(long, value_name = "KIND", requires = "simulate", value_parser = parse_deflection)]
    deflection: Option<Deflection>,
    /// Tracker noise of the simulation, µm per coordinate.
    #[arg(long, default_value_t = 2.0, requires = "simulate")]
    noise_um: f64,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(out) = &args.simulate {
        return simulate(out, &args);
    }
    let path = args
        .points
        .as_ref()
        .expect("clap requires POINTS or --simulate");
    let limits = args.read.limits();
    mtcal_formats::stat_path(path)?;
    let points = mtcal_formats::read_rotary_points_path(path, &limits)?;
    let mut opts = CradleOptions {
        registered_frame: !args.unregistered,
        ..CradleOptions::default()
    };
    if let Some(p) = &args.pivot_mm {
        if p.iter().any(|v| !v.is_finite()) {
            return Err(BadInput("--pivot-mm: three finite numbers expected".into()).into());
        }
        opts.pivot_mm = [p[0], p[1], p[2]];
    }
    let result = check_cradle(&points, &opts).map_err(|e| match e {
        SolverError::InvalidInput(m) | SolverError::Degenerate(m) => {
            anyhow::Error::new(BadInput(format!("{}: {m}", path.display())))
        }
        other => anyhow::Error::new(other),
    })?;
    super::out::document(args.json, &result, summary)?;
    Ok(ExitCode::SUCCESS)
}

fn simulate(out: &Path, args: &Args) -> anyhow::Result<ExitCode> {
    if !(args.noise_um.is_finite() && args.noise_um >= 0.0) {
        return Err(BadInput("--noise-um must be a finite number ≥ 0".into()).into());
    }
    let deflection = match (args.deflection, args.compliant) {
        (Some(d), _) => d,
        (None, true) => Deflection::Pivot,
        (None, false) => Deflection::Rigid,
    };
    let mut sim = CradleSimulation::example_with(deflection, args.seed);
    sim.noise_um = args.noise_um;
    let mut set = simulate_cradle(&sim);
    set.measured_at = Some("2026-01-01T00:00:00Z".into());
    let mut csv = Vec::new();
    mtcal_formats::write_rotary_points(&mut csv, &set)?;
    let mut json = Vec::new();
    mtcal_formats::write_rotary_sidecar(&mut json, &set)?;
    let name = out
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| format!("{}: not a file name", out.display()))?;
    let sidecar = out.with_file_name(mtcal_formats::rotary::sidecar_name(name));
    // Write both to temporaries first: nothing half-written on failure.
    let tmp_csv = out.with_extension("csv.tmp");
    let tmp_json = sidecar.with_extension("json.tmp");
    std::fs::write(&tmp_csv, &csv).with_context(|| format!("writing {}", tmp_csv.display()))?;
    std::fs::write(&tmp_json, &json).with_context(|| format!("writing {}", tmp_json.display()))?;
    std::fs::rename(&tmp_csv, out)?;
    std::fs::rename(&tmp_json, &sidecar)?;
    super::out::noteln!(
        "wrote {} ({} points, {} A poses) and {}; truth: {}",
        out.display(),
        set.points.len(),
        sim.a_deg.len(),
        sidecar.display(),
        serde_json::to_string(&sim.truth)?
    );
    Ok(ExitCode::SUCCESS)
}

fn parse_deflection(s: &str) -> Result<Deflection, String> {
    match s {
        "rigid" => Ok(Deflection::Rigid),
        "pivot" => Ok(Deflection::Pivot),
        "mount" => Ok(Deflection::Mount),
        other => Err(format!("`{other}`: expected rigid, pivot or mount")),
    }
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("—".into(), |x| format!("{x:.prec$}"))
}

/// The human summary: per-pose table, A axis, model choice, location errors, compensation.
pub fn summary(r: &CradleResult) -> String {
    let mut s = String::new();
    write_poses(&mut s, r);
    write_model(&mut s, r);
    if let Some(sep) = &r.kinematics.separability {
        write_separability(&mut s, sep);
    }
    write_location(&mut s, r);
    s
}

/// The check's points and poses, the A axis, and the rotation vectors per A pose.
fn write_poses(s: &mut String, r: &CradleResult) {
    let _ = writeln!(
        s,
        "cradle check: {} points, {} A poses (machine {}), reference pose A = {}°",
        r.n_points,
        r.n_poses,
        r.machine_id.as_deref().unwrap_or("—"),
        r.reference_a_deg
    );
    let a = &r.a_axis;
    let _ = writeln!(
        s,
        "A axis: direction ({:.7}, {:.7}, {:.7}) ± {:.1} µrad, through ({:.4}, {:.4}, {:.4}) mm",
        a.direction[0],
        a.direction[1],
        a.direction[2],
        a.direction_std_urad[0].hypot(a.direction_std_urad[1]),
        a.point_mm[0],
        a.point_mm[1],
        a.point_mm[2]
    );
    let _ = writeln!(
        s,
        "\nrotation vectors per A pose (µrad; patent: e1 from the point at C = 0; phase: from all points)"
    );
    let _ = writeln!(
        s,
        "{:>7} {:>9} {:>8} | {:>8} {:>26} | {:>8} {:>26} | {:>6}",
        "A °", "radius mm", "rms µm", "|r| pat", "r patent", "|r| ph", "r phase", "± µrad"
    );
    for p in &r.poses {
        let v = |x: [f64; 3]| format!("({:7.1},{:7.1},{:7.1})", x[0], x[1], x[2]);
        let _ = writeln!(
            s,
            "{:7.1} {:9.4} {:8.2} | {:8.1} {:>26} | {:8.1} {:>26} | {:6.1}",
            p.a_deg,
            p.radius_mm,
            p.circle_rms_um,
            p.rotation_point.norm_urad,
            v(p.rotation_point.vector_urad),
            p.rotation_phase.norm_urad,
            v(p.rotation_phase.vector_urad),
            p.rotation_phase.std_urad
        );
    }
}

/// The instrument frame, the model chosen with its parameters, and its rivals.
fn write_model(s: &mut String, r: &CradleResult) {
    let g = &r.registration;
    let _ = writeln!(
        s,
        "\ninstrument frame: {} (best-fit registration: rotation {}, stated pivot {:.3} mm away; nominal kinematics then miss by {:.2} µm RMS)",
        if g.frame == "machine" {
            "the machine's, as stated"
        } else {
            "registered to the nominal kinematics (best fit)"
        },
        angle_text(1e-6 * g.rotation_urad[0].hypot(g.rotation_urad[1].hypot(g.rotation_urad[2]))),
        g.pivot_offset_mm[0].hypot(g.pivot_offset_mm[1].hypot(g.pivot_offset_mm[2])),
        g.residual_rms_um
    );
    let k = &r.kinematics;
    let held = |h: Option<f64>| opt(h, 3);
    let _ = writeln!(
        s,
        "\nmodel: {:?}: {} (held-out RMS, leave one A pose out: {} µm; rigid {} µm, classic compliant {} µm; each added term must lower it by {} %)",
        k.chosen,
        k.description,
        held(r.floor.as_ref().map(|f| f.held_out_rms_um)),
        held(k.rigid.held_out_rms_um),
        held(k.compliant.as_ref().and_then(|c| c.held_out_rms_um)),
        k.margin * 100.0
    );
    for p in &k.parameters {
        let _ = writeln!(
            s,
            "  {:<4} {:>9.2} ± {:<6.2} {:<4}{}",
            p.name,
            p.value,
            p.std,
            p.unit,
            if p.model_dependent {
                "  not determined: another model explains the data as well (see below)"
            } else if p.determined {
                ""
            } else {
                "  possible, undetermined (|value| < 3 std)"
            }
        );
    }
    for rival in &k.rivals {
        let _ = writeln!(s, "  {}", rival.statement);
    }
}

/// What the ball data can separate.
fn write_separability(s: &mut String, sep: &mtcal_solver::cradle::SeparabilityReport) {
    let _ = writeln!(
        s,
        "\nwhat the ball data can separate (first-order Jacobian of the chosen model: rank {} of {}):",
        sep.rank, sep.n_params
    );
    for t in &sep.terms {
        let sets: Vec<String> = t
            .confounded_with
            .iter()
            .map(|set| {
                set.iter()
                    .map(|t| t.describe())
                    .collect::<Vec<_>>()
                    .join(" + ")
            })
            .collect();
        let verdict = match (t.in_model, t.separable, sets.is_empty()) {
            (true, true, true) => "in the model, separable".to_string(),
            (true, true, false) => format!(
                "in the model, separable; not with {}",
                sets.join(", nor with ")
            ),
            (false, true, _) => "separable if added".to_string(),
            (_, false, true) => "not separable".to_string(),
            (_, false, false) => format!("not separable from {}", sets.join(", ")),
        };
        let why = if t.why.is_empty() {
            String::new()
        } else {
            format!(" ({})", t.why)
        };
        let _ = writeln!(s, "  {}: {verdict}{why}", t.description);
    }
}

/// The location errors, the ball, the compensation and the notes.
fn write_location(s: &mut String, r: &CradleResult) {
    let k = &r.kinematics;
    let _ = writeln!(s, "\nlocation errors (ISO 230-7):");
    for e in &r.location_errors {
        let _ = writeln!(
            s,
            "  {:<10} {:>10} ± {:<8} {:<5} {:?}{}",
            e.name,
            opt(e.value, 2),
            opt(e.std, 2),
            e.unit,
            e.observability,
            e.note.as_ref().map_or(String::new(), |n| format!(": {n}"))
        );
    }
    let b = &k.ball;
    let _ = writeln!(
        s,
        "ball: radius {:.4} mm ± {:.2} µm, height {:.4} mm ± {:.2} µm, azimuth {}°",
        b.radius_mm,
        b.radius_std_um,
        b.height_mm,
        b.height_std_um,
        opt(b.azimuth_deg, 4)
    );
    let c = &r.compensation;
    let _ = writeln!(
        s,
        "\ncompensation on held-out poses: RMS {:.2} µm before → {:.2} µm after",
        c.before_rms_um, c.after_rms_um
    );
    for n in &r.notes {
        let _ = writeln!(s, "note: {n}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(points: Option<PathBuf>, simulate: Option<PathBuf>, compliant: bool) -> Args {
        Args {
            points,
            read: crate::cli::ReadArgs {
                csv_dialect: mtcal_formats::CsvDialect::Plain,
            },
            json: false,
            unregistered: false,
            pivot_mm: None,
            simulate,
            seed: 3,
            compliant,
            deflection: None,
            noise_um: 2.0,
        }
    }

    /// `--simulate` writes a point set the strict reader accepts, and the check on it
    /// chooses the model that was simulated.
    #[test]
    fn simulate_then_check() {
        let dir = tempfile::tempdir().unwrap();
        for compliant in [false, true] {
            let out = dir.path().join(format!("c{compliant}.csv"));
            run(args(None, Some(out.clone()), compliant)).unwrap();
            assert!(out.with_extension("json").is_file());
            let set = mtcal_formats::read_rotary_points_path(&out, &Default::default()).unwrap();
            assert_eq!(set.machine_id.as_deref(), Some("SIM-CRADLE"));
            let r = check_cradle(&set, &CradleOptions::default()).unwrap();
            let text = summary(&r);
            let want = if compliant {
                "model: Compliant"
            } else {
                "model: Rigid"
            };
            assert!(text.contains(want), "{text}");
            assert_eq!(
                run(args(Some(out), None, false)).unwrap(),
                ExitCode::SUCCESS
            );
        }
    }

    /// Too few A poses is the user's input being wrong (exit code 2 via `BadInput`).
    #[test]
    fn too_few_poses_is_bad_input() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.csv");
        let mut csv = String::from("a_deg,c_deg,x_mm,y_mm,z_mm\n");
        for a in [0, 30] {
            for c in [0, 90, 180, 270] {
                let (s, co) = f64::to_radians(c as f64).sin_cos();
                csv += &format!("{a},{c},{},{},0\n", 100.0 * co, 100.0 * s);
            }
        }
        std::fs::write(&path, csv).unwrap();
        let e = run(args(Some(path), None, false)).unwrap_err();
        assert!(e.chain().any(|c| c.is::<BadInput>()), "{e:#}");
        assert!(format!("{e:#}").contains("at least 3"));
    }
}
