//! Loading a sweep: the file read, its plans loaded, its axes checked into grids.

use std::path::Path;

use arcsim_plan::{ArcPlan, BeamModel, ElstModel};

use super::axes::expand_runs;
use super::plans::load_plans;
use super::*;
use crate::sweep_file::parse_sweep_file;
use crate::EvalError;

impl Sweep {
    /// Reads a sweep file and everything it names (paths relative to the file), loading plan files
    /// with [`arcsim_plan::load_plan`].
    pub fn load(path: &Path) -> Result<Sweep, EvalError> {
        Sweep::load_with(path, &|p: &Path| {
            arcsim_plan::load_plan(p).map_err(|e| e.to_string())
        })
    }

    /// As [`Sweep::load`], with a plan loader of the caller's (e.g. one that also reads DICOM).
    pub fn load_with(
        path: &Path,
        load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    ) -> Result<Sweep, EvalError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| EvalError::sweep(&file, "", format!("cannot read: {e}")))?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Sweep::from_text(&text, &file, &base_dir, load_plan)
    }

    /// Builds a sweep from a sweep file's text; `base_dir` resolves its relative paths.
    pub fn from_text(
        text: &str,
        file: &str,
        base_dir: &Path,
        load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    ) -> Result<Sweep, EvalError> {
        let spec = parse_sweep_file(text, file)?;
        let machine_path = base_dir.join(&spec.machine);
        let machine = arcsim_plan::load_machine(&machine_path).map_err(|e| EvalError::Input {
            file: file.to_string(),
            field: "machine".into(),
            message: e.to_string(),
        })?;
        let runs = expand_runs(&spec, &machine, file)?;
        let mut inputs = vec![machine_path];
        let plans = load_plans(&spec, base_dir, file, load_plan, &mut inputs)?;
        let (plans, resequenced) = match &spec.resequence {
            Some(r) => super::plans::with_resequenced(plans, &machine, r.runs(), file)?,
            None => (plans, Vec::new()),
        };
        check_combinations(file, Some(plans.len()), runs.iter().map(|r| &r.grid))?;
        Ok(Sweep {
            name: spec.name,
            description: spec.description,
            source: file.to_string(),
            plans,
            machine,
            schedule_grids: runs,
            margins: spec.margins,
            certify: spec.certify,
            target: spec.target.unwrap_or_default(),
            inputs,
            resequenced,
        })
    }

    /// The base machine's setting (its J, A, V; ELST, window and beam model as they are).
    pub fn base_setting(&self) -> Setting {
        let g = &self.machine.gantry;
        Setting {
            jerk_deg_per_s3: g.max_jerk_deg_per_s3,
            accel_deg_per_s2: g.max_accel_deg_per_s2,
            speed_deg_per_s: g.max_speed_deg_per_s,
            elst_up_s: None,
            elst_down_s: None,
            window_deg: None,
            scan_speed_mm_per_s: None,
            dose_rate_scale: None,
            burst_switching_time_s: None,
            spill_charge_mu: None,
            spill_refill_time_s: None,
            spill_max_layers: None,
        }
    }

    /// The base machine's value of an axis (ELST up: `None` for a polynomial model; scanning
    /// speed: `None` for a `per_mu` beam model or separate x and y speeds; dose-rate scale: 1).
    pub fn base_value(&self, axis: Axis) -> Option<f64> {
        match axis {
            Axis::ElstUp => match self.machine.elst {
                ElstModel::Constant { up_s, .. } => Some(up_s),
                _ => None,
            },
            Axis::ElstDown => match self.machine.elst {
                ElstModel::Constant { down_s, .. } | ElstModel::Polynomial { down_s, .. } => {
                    Some(down_s)
                }
                _ => None,
            },
            Axis::Window => Some(self.machine.default_window_deg),
            Axis::ScanSpeed => single_scan_speed(&self.machine.beam),
            Axis::DoseRateScale => Some(1.0),
            Axis::BurstSwitching => self.machine.beam.burst_switching_time_s(),
            Axis::SpillCharge => self.machine.beam.spill().map(|s| s.charge_mu),
            Axis::SpillRefill => self.machine.beam.spill().map(|s| s.refill_time_s),
            Axis::SpillMaxLayers => self
                .machine
                .beam
                .spill()
                .and_then(|s| s.max_layers_per_spill)
                .map(f64::from),
            other => self.base_setting().get(other),
        }
    }

    /// The base machine's ELST and default window ([`Defaults`]).
    pub fn defaults(&self) -> Defaults {
        Defaults {
            elst_up_s: self.base_value(Axis::ElstUp),
            elst_down_s: self.base_value(Axis::ElstDown),
            window_deg: self.machine.default_window_deg,
            scan_speed_mm_per_s: single_scan_speed(&self.machine.beam),
            dose_rate_scale: 1.0,
            burst_switching_time_s: self.machine.beam.burst_switching_time_s(),
            spill_charge_mu: self.base_value(Axis::SpillCharge),
            spill_refill_time_s: self.base_value(Axis::SpillRefill),
            spill_max_layers: self.base_value(Axis::SpillMaxLayers),
        }
    }

    /// Number of combinations per plan (the sum of the schedule entries' grid sizes; saturates at
    /// `usize::MAX`, a loaded sweep has at most [`MAX_COMBINATIONS`]).
    pub fn combinations_per_plan(&self) -> usize {
        self.schedule_grids
            .iter()
            .fold(0usize, |n, r| n.saturating_add(r.grid.len()))
    }

    /// Total number of combinations (saturates as [`Sweep::combinations_per_plan`]).
    pub fn combinations(&self) -> usize {
        self.plans
            .len()
            .saturating_mul(self.combinations_per_plan())
    }
}

/// The one scanning speed of a beam model: `None` for `per_mu` (no scanning speed) and for
/// different x and y speeds.
pub(super) fn single_scan_speed(beam: &BeamModel) -> Option<f64> {
    match beam {
        BeamModel::PerMu(_) => None,
        BeamModel::Scanning(b) => match b.speeds_mm_per_s() {
            (x, y) if x == y && x.is_finite() => Some(x),
            _ => None,
        },
    }
}
