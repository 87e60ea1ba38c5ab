//! `mtcal simulate --out DIR [--seed N] [--plan seed|full] [--noise-um S]
//! [--effect NAME[:k=v,...]]... [--rate-hz R]`: runs a test plan on a machine with random
//! (seeded) errors and writes the session folder (datasets contract, section 1) and
//! `truth.json` beside it.

use super::BadInput;
use anyhow::Context;
use mtcal_solver::simulate::effects::EFFECT_NAMES;
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Output folder (created; must not already hold files).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the machine's errors, the mountings, the offsets and the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Test plan: the seed patent's (one head offset) or the full plan (three offsets,
    /// mountings kept: all 21 terms identifiable).
    #[arg(long, value_enum, default_value = "seed")]
    pub plan: PlanArg,
    /// Measurement noise, standard deviation per component, µm.
    #[arg(long, default_value_t = 0.15)]
    pub noise_um: f64,
    /// Sample rate, Hz.
    #[arg(long, default_value_t = 100.0)]
    pub rate_hz: f64,
    /// An effect the rigid model lacks, with optional parameters (repeatable); the help
    /// lists the names the simulator accepts ([`effect_help`]).
    #[arg(long = "effect", value_name = "NAME[:k=v,...]", help = effect_help())]
    pub effects: Vec<String>,
    /// Machine id written into session.json.
    #[arg(long, default_value = "SIM-0001")]
    pub machine_id: String,
}

/// The help of `--effect`: the names of [`EFFECT_NAMES`], the list the simulator's own
/// refusal of an unknown name gives.
fn effect_help() -> String {
    format!(
        "An effect the rigid model lacks, with optional parameters, e.g. \
         `backlash:axis=X,lost_motion_um=4` (repeatable). Names: {}",
        EFFECT_NAMES.join(", ")
    )
}

#[derive(clap::ValueEnum, Clone, Copy)]
pub enum PlanArg {
    Seed,
    Full,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if !(args.noise_um >= 0.0 && args.noise_um.is_finite()) {
        return Err(BadInput(format!(
            "--noise-um {}: the noise is a standard deviation, a finite number ≥ 0 µm",
            args.noise_um
        ))
        .into());
    }
    if !(args.rate_hz > 0.0 && args.rate_hz.is_finite()) {
        return Err(BadInput(format!(
            "--rate-hz {}: the sample rate is a finite number > 0 Hz",
            args.rate_hz
        ))
        .into());
    }
    let effects = args
        .effects
        .iter()
        .map(|s| Effect::from_spec(s).map_err(|e| BadInput(format!("--effect {s}: {e}"))))
        .collect::<Result<Vec<_>, _>>()?;
    if let Ok(mut entries) = std::fs::read_dir(&args.out)
        && entries.next().is_some()
    {
        return Err(BadInput(format!(
            "{}: the output folder already holds files (choose an empty or new folder)",
            args.out.display()
        ))
        .into());
    }
    let opts = SimOptions {
        plan: match args.plan {
            PlanArg::Seed => Plan::Seed,
            PlanArg::Full => Plan::Full,
        },
        seed: args.seed,
        noise_um: args.noise_um,
        sample_rate_hz: args.rate_hz,
        machine_id: args.machine_id,
        effects,
        ..SimOptions::default()
    };
    let out = simulate(&random_truth(args.seed), &opts).map_err(|e| BadInput(e.to_string()))?;
    let truth = serde_json::to_string_pretty(&out.truth)?;
    mtcal_formats::write_session_dir(&args.out, &out.session)
        .with_context(|| format!("writing the session to {}", args.out.display()))?;
    let truth_path = args.out.join("truth.json");
    std::fs::write(&truth_path, truth + "\n")
        .with_context(|| format!("writing {}", truth_path.display()))?;
    super::out::outln!(
        "wrote {} ({} files, {} samples) and truth.json",
        args.out.display(),
        out.session.planes.len(),
        out.session.sample_count()
    )?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(out: PathBuf, effects: Vec<String>) -> Args {
        Args {
            out,
            seed: 3,
            plan: PlanArg::Seed,
            noise_um: 0.15,
            rate_hz: 5.0,
            effects,
            machine_id: "SIM-T".into(),
        }
    }

    /// The folder read back strictly equals the simulated session's structure, and
    /// truth.json carries the effect.
    #[test]
    fn writes_a_readable_session_and_truth() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("s");
        run(args(out.clone(), vec!["backlash:axis=Y".into()])).unwrap();
        let s = mtcal_formats::read_session_dir(&out, &Default::default()).unwrap();
        assert_eq!(s.planes.len(), 3);
        assert_eq!(s.planes[0].runs.len(), 22);
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap())
                .unwrap();
        assert_eq!(truth["effects"][0]["effect"], "backlash");
        assert_eq!(truth["effects"][0]["axis"], "Y");
        assert_eq!(truth["seed"], 3);
    }

    /// Bad effects and a used folder are the user's input errors; nothing is written.
    #[test]
    fn bad_input_is_refused_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("s");
        let e = run(args(out.clone(), vec!["wobble".into()])).unwrap_err();
        assert!(e.is::<BadInput>() && e.to_string().contains("unknown effect `wobble`"));
        assert!(!out.exists());
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("x"), "").unwrap();
        let e = run(args(out.clone(), vec![])).unwrap_err();
        assert!(e.to_string().contains("already holds files"));
    }
}
