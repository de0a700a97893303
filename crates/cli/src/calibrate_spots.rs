//! `arcsim calibrate-spots`: the `scanning` beam model fitted to per-spot logs — the time per MU,
//! the minimum spot time, the scanning speed(s), the settling time and the burst switching time,
//! with 95 % intervals, and each log's layers timed before and after.

use std::fmt::Write as _;
use std::path::PathBuf;

use arcsim_log::{SpotCalibration, SpotRun};

use crate::input::{input_name, load_machine, load_plan};
use crate::CliError;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The machine to start from (its beam the `scanning` model): everything but the beam's
    /// spot timing is kept from it.
    #[arg(long)]
    machine: PathBuf,
    /// Pairs of a plan and its per-spot log (the columns `simulate --spots` writes, or an
    /// IBA-style log folder): PLAN SPOTS [PLAN SPOTS ...].
    #[arg(required = true, num_args = 2.., value_names = ["PLAN", "SPOTS"])]
    inputs: Vec<PathBuf>,
    /// Where to write the fitted machine (JSON).
    #[arg(short = 'o', long = "output", value_name = "FITTED.json")]
    output: PathBuf,
    /// Write the report (every value with its interval, the residuals) as JSON.
    #[arg(long, value_name = "REPORT")]
    json: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), CliError> {
    crate::calibrate::check_pairs(
        &args.inputs,
        &args.machine,
        (&args.output, args.json.as_deref()),
        "per-spot log",
    )?;
    let base = load_machine(Some(&args.machine))?;
    let runs = args
        .inputs
        .chunks(2)
        .map(|pair| {
            let plan = load_plan(&pair[0])?;
            let log = arcsim_log::read_spots(&pair[1], &plan)
                .map_err(|e| CliError::failed(e.to_string()))?;
            Ok(SpotRun {
                plan_name: input_name(&pair[0]),
                plan,
                log,
            })
        })
        .collect::<Result<Vec<_>, CliError>>()?;
    let cal =
        arcsim_log::calibrate_spots(&base, &runs).map_err(|e| CliError::failed(e.to_string()))?;
    let machine_json =
        serde_json::to_string_pretty(&cal.machine).map_err(|e| CliError::failed(e.to_string()))?;
    // The fitted machine must read back as a machine file.
    arcsim_app::machine_from_text(&args.output.display().to_string(), &machine_json)
        .map_err(|e| CliError::failed(format!("the fitted machine is not valid: {e}")))?;
    let report = match &args.json {
        Some(_) => Some(report_json(&cal)?),
        None => None,
    };
    crate::output::print(&summary(&cal, &input_name(&args.machine), &runs));
    crate::calibrate::write_fitted(
        &args.output,
        &machine_json,
        args.json.as_deref().zip(report),
    )
}

fn report_json(cal: &SpotCalibration) -> Result<String, CliError> {
    crate::calibrate::tagged_json(cal, "arcsim-spot-calibration/1")
}

/// The readable report printed on standard output.
fn summary(cal: &SpotCalibration, base: &str, runs: &[SpotRun]) -> String {
    let mut s = String::new();
    let spots: usize = runs.iter().map(|r| r.log.spots.len()).sum();
    let _ = writeln!(
        s,
        "spot-level calibration from {base} on {} per-spot log(s), {spots} spot deliveries: {}",
        runs.len(),
        runs.iter()
            .map(|r| r.log.source.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let clock = if cal.clock_resolution_s > 0.0 {
        format!("{} s", cal.clock_resolution_s)
    } else {
        "finer than 1 µs".to_string()
    };
    let _ = writeln!(
        s,
        "clock resolution {clock}; {} move(s) or pause(s) left out as outliers",
        cal.outliers_rejected
    );
    s.push_str(&crate::calibrate::values_table(&cal.values));
    let _ = writeln!(
        s,
        "residuals (each layer's logged spots timed by the model - logged, first spot start to last spot end):"
    );
    for r in &cal.residuals {
        let _ = writeln!(
            s,
            "  {}: {} layers, logged {:.3} s; base {:.3} s ({:+.2} %); fitted {:.3} s ({:+.2} %)",
            r.log, r.layers, r.logged_s, r.base_s, r.base_error_pct, r.fitted_s, r.fitted_error_pct
        );
    }
    for w in &cal.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}
