//! `arcsim`: how long does this proton-arc plan take on this gantry, where is the time lost, and what
//! would other limits (J, A, V) buy? Each subcommand lives in a module of its own.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod calibrate;
mod calibrate_spots;
mod compare;
mod error;
mod generate;
mod import;
mod input;
mod output;
mod profile;
mod report;
mod resequence;
mod simulate;
mod sweep;
mod switching;
mod table;
mod validate;
mod viewer;

pub use error::CliError;

#[derive(Parser)]
#[command(
    name = "arcsim",
    version,
    about = "Simulate proton-arc delivery on a jerk-limited gantry"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Plan one minimum-time jerk-limited move (or a batch of moves from a CSV file).
    #[command(after_long_help = PROFILE_TERMS)]
    Profile(profile::Args),
    /// Simulate a plan's delivery: total time, where it goes, margins; JSON/CSV/Rerun outputs.
    #[command(
        after_help = "`arcsim simulate --help` explains the summary's terms.",
        after_long_help = SIMULATE_TERMS
    )]
    Simulate(simulate::Args),
    /// Check a plan (arcsim JSON or DICOM RT Ion Plan): print every problem at once (exit 1), or a
    /// short summary (exit 0).
    Validate(validate::Args),
    /// Write a deterministic synthetic example plan (prostate, head-neck, two-arc, lung).
    GeneratePlan(generate::Args),
    /// Convert a DICOM RT Ion Plan into an arcsim plan (JSON) and summarise it.
    Import(import::Args),
    /// Evaluate plans x machine variants x schedules from a sweep file, in parallel.
    #[command(
        after_help = "`arcsim sweep --help` explains the summary's columns.",
        after_long_help = SWEEP_TERMS
    )]
    Sweep(sweep::Args),
    /// Compare a delivery log with the simulation of its plan: totals, breakdowns, differences
    /// by class, the worst layers, which motion model fits, the gantry's observed limits.
    Compare(compare::Args),
    /// Fit a machine to delivery logs (ELST, beam timing, gantry limits, spreads) and write it.
    Calibrate(calibrate::Args),
    /// Fit a `scanning` beam's spot timing (time per MU, minimum spot time, scanning speed,
    /// settling, burst switching) to per-spot logs and write the machine.
    CalibrateSpots(calibrate_spots::Args),
    /// Join the CSV outputs of `sweep --shard K/N` into the single-run table.
    SweepMerge(sweep::MergeArgs),
    /// Deliver the same dose faster: the layers of each control point in the order the machine
    /// delivers fastest (every spot, MU, energy and control point kept, checked before writing).
    Resequence(resequence::Args),
}

/// `arcsim profile --help`: what the printed result means.
const PROFILE_TERMS: &str = "\
The result (docs/results.md describes the JSON and CSV outputs):
  phase                One constant-jerk phase of the move: its start and duration (s), its jerk
                       (deg/s^3) and the speed at its start (deg/s, signed).
  total time           Duration of the move (s).
  servo grid           With --period: the time the servo grid adds to the continuous move (s).
  peak speed           The largest |speed| during the move (deg/s).
  extreme speed v_m    The signed peak (or valley) speed between the two speed changes of the
                       move (speed change, cruise at v_m, speed change).
  limits used          The highest |speed|, |acceleration| and |jerk| in % of V, of the larger of
                       A and D, and of J; 100 % means the move reaches that limit.
With --batch: one line per input line: line number, status (ok, infeasible: no such move under
the chosen policy, error: a bad value), duration_s (s), peak_speed (deg/s), message.";

/// `arcsim simulate --help`: what the printed summary's terms mean.
const SIMULATE_TERMS: &str = "\
The summary, term by term (docs/results.md describes every output field):
  total delivery time  From the first beam-on (or, with free arc ends, the start of the run-up)
                       to the last beam-off, in s = beam on + energy switching + lost (gantry).
  beam on              Sum of the layers' irradiation times.
  energy switching     Sum of the energy-layer switching times (ELST): every transition between
                       two layers lasts at least its ELST, whatever the gantry does.
  lost (gantry)        Time the transitions take beyond their ELST: the time the gantry makes the
                       beam wait, sum of max(0, transition duration - ELST) (with free arc ends,
                       plus the run-up before the first beam). 0 s: the gantry never waits.
  free motion saves    Free motion (or one speed per arc: costs) against one constant speed
                       per layer, same schedule.
  transitions limited by
                       Which gantry limit, raised, would shorten each transition most: the
                       transition is re-planned exactly (same gap, boundary speeds and ELST) with
                       J alone, A and D together, or V alone doubled, and labelled with the limit
                       whose doubling saves most (ties: J, then A, then V). ELST: no doubling
                       shortens it (it lasts its energy switch; the gantry was fast enough);
                       none: no motion, zero time. A move that reaches A but spends most of its
                       time in jerk ramps is J. Doubling the limit with most lost time is a first
                       guess at the change that buys most; a whole-plan re-simulation (sweep)
                       gives the exact saving.
  tightest margins     Over the whole timeline, with when it occurs and the nearest layer:
    speed / acceleration / jerk
                       The highest use of V, of A (D while braking) and of J, in % of the limit;
                       100 % means the gantry reaches that limit somewhere.
    window slack       The smallest unused part of a layer's tolerance window, in degrees: window
                       width minus the angle swept while irradiating (with constant speed the
                       sweep is centred, half of it on each side). 0: a layer uses its whole window.
    ELST slack         The smallest time any transition lasts beyond its ELST, in s: 0 when at
                       least one transition is set by its ELST; otherwise the smallest lost time,
                       how much the gantry would have to gain on one transition before its ELST,
                       not the gantry, sets that transition's duration.
  where the time is lost
                       The lost time by cause: what limited the transitions (as above), the energy
                       switch (up, down, same energy, arc change) and how far apart their layers
                       are, with counts, seconds and the gantry angles where it happens.
  most costly transitions
                       The transitions that lose most, located (layers, or arc, control point and
                       gantry angle): start, duration, ELST and lost = duration - ELST (s), and
                       what limited it.
  prescribed speeds that cannot be delivered
                       Prescribed schedule only: each infeasible speed, the corrected one used, why.";

/// `arcsim sweep --help`: what the printed summary's columns mean.
const SWEEP_TERMS: &str = "\
The summary, per plan and schedule entry (docs/results.md describes the CSV and JSON outputs):
  base [s]             Total delivery time on the base machine (the sweep file's `machine`).
  fastest [s]          The shortest total among the grid's rows (near-equal totals tie; a tie
                       goes to the setting closest to the base machine).
  speed-up             Base total / that total (1.25: 25 % more plans per hour).
  fastest setting      The limits of that row: J (deg/s^3), A (deg/s^2), V (deg/s), and any ELST
                       (s) or window (deg) the sweep varies.
Sensitivity at the base machine
  One column per limit L (J, A, V and any other swept axis; the header gives its base value):
  the change of the total time, in s, when L alone is raised by 10 %, by central difference
  (T(1.1 L) - T(L/1.1)) / 2. Negative: raising the limit saves time. \"no effect (LO-HI)\": every
  value of the limit evaluated from LO to HI (the others at the base machine) gives the same
  total, so the limit does not bind there. The JSON output also gives s_per_ln = dT/d ln L.
Cheapest change reaching the target
  target [s]           The total to reach: the sweep's `target`, either a saving in % of the base
                       total (default 10 %) or an absolute total.
  change               Among the grid rows and the one-limit settings, the change of the base
                       machine that reaches the target with the smallest cost, the sum of
                       |ln(new/base)| over the changed limits (doubling or halving one limit
                       costs ln 2 = 0.69, doubling two costs 1.39); ties go to the shorter total.
  total [s], saves [s] Its total, and the time it saves against the base total.
Time at each value of one limit
  The total and speed-up with one swept limit at each of its values (at most 1000 of them) and
  the others at the base machine.";

/// "1 plan", "2 plans", "3 upward energy switches": `n` and the noun, plural unless `n` is 1.
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else if ["s", "x", "ch", "sh"].iter().any(|e| noun.ends_with(e)) {
        format!("{n} {noun}es")
    } else {
        format!("{n} {noun}s")
    }
}

/// A plan angle as the gantry shows it, in [0, 360): plans keep an arc's angles increasing (an
/// arc through 0° goes on past 360°), but a reader looks for 3.8°, not 363.8°.
pub fn gantry_deg(angle_deg: f64) -> f64 {
    angle_deg.rem_euclid(360.0) + 0.0
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Profile(args) => profile::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Validate(args) => validate::run(args),
        Command::GeneratePlan(args) => generate::run(args),
        Command::Import(args) => import::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::SweepMerge(args) => sweep::merge(args),
        Command::Compare(args) => compare::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::CalibrateSpots(args) => calibrate_spots::run(args),
        Command::Resequence(args) => resequence::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", output::printable(&err.to_string()));
            ExitCode::from(err.exit_code())
        }
    }
}
