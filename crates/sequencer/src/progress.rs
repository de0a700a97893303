//! How far a long simulation has got, for a user watching a terminal: free motion on a plan of
//! several hundred layers takes seconds, and silence reads as a hang.

/// One report of a simulation's progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Free motion is refining arc `arc` (0-based) of `arcs`, which has `layers` layers: `step`
    /// of at most `steps` refinement steps are done (the refinement may stop earlier).
    FreeMotion {
        /// The arc being solved (0-based, delivery order).
        arc: usize,
        /// Arcs in the plan.
        arcs: usize,
        /// Layers of this arc.
        layers: usize,
        /// Refinement steps done on this arc.
        step: usize,
        /// Most refinement steps this arc can take.
        steps: usize,
    },
}

impl Progress {
    /// The report as one line ("free motion, arc 1 of 2 (444 layers): step 12 of ≤ 120").
    pub fn line(&self) -> String {
        match *self {
            Progress::FreeMotion {
                arc,
                arcs,
                layers,
                step,
                steps,
            } => format!(
                "free motion, arc {} of {arcs} ({layers} layers): step {step} of ≤ {steps}",
                arc + 1
            ),
        }
    }
}

/// Receives progress reports (from more than one thread: `Sync`).
pub type Observer<'a> = &'a (dyn Fn(Progress) + Sync);

/// An observer that ignores every report.
pub(crate) fn ignore(_: Progress) {}
