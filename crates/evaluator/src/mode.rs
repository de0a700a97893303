//! What a schedule entry runs: a speed schedule, a motion model, and arc ends.

use arcsim_sequencer::{ArcEnds, Motion, Schedule};
use serde::{Serialize, Serializer};

/// A schedule entry's way of moving. Named in tables and files as the schedule, then `+free`
/// for free motion and `+free-ends` for free arc ends (e.g. `optimal+free+free-ends`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RunMode {
    /// The speed schedule of each layer.
    pub schedule: Schedule,
    /// Constant speed per layer or free motion.
    pub motion: Motion,
    /// Arcs starting and ending at rest, or free.
    pub arc_ends: ArcEnds,
}

impl RunMode {
    /// Constant speed per layer under `schedule`, arcs ending at rest.
    pub fn constant(schedule: Schedule) -> Self {
        RunMode {
            schedule,
            motion: Motion::Constant,
            arc_ends: ArcEnds::Rest,
        }
    }

    /// The entry's name in tables and files, e.g. `optimal+free+free-ends`.
    pub fn name(&self) -> String {
        let mut s = self.schedule.name().to_string();
        if self.motion != Motion::Constant {
            s.push('+');
            s.push_str(self.motion.name());
        }
        if self.arc_ends == ArcEnds::Free {
            s.push_str("+free-ends");
        }
        s
    }
}

impl Serialize for RunMode {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}
