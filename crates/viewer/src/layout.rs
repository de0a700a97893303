//! The default viewer layout (blueprint) of a delivery.

use rerun::blueprint::{
    Blueprint, ContainerLike, Horizontal, Spatial2DView, StateTimelineView, Tabs, TextLogView,
    TimePanel, TimeSeriesView, Vertical,
};

use crate::paths;
use crate::timelines::TIME;

fn series(name: &str, path: &str) -> ContainerLike {
    TimeSeriesView::new(name)
        .with_origin(path)
        .with_contents([format!("$origin/**")])
        .into()
}

/// Time series stacked on the left (speed, acceleration, jerk with their limits; phases;
/// energy and angle as tabs); the gantry and the layer log on the right; `time` selected.
pub fn delivery_blueprint() -> Blueprint {
    let left = Vertical::new([
        series("Speed (°/s)", paths::SPEED),
        series("Acceleration (°/s²)", paths::ACCEL),
        series("Jerk (°/s³)", paths::JERK),
        Tabs::new([
            series("Energy (MeV)", paths::ENERGY),
            series("Angle (°)", paths::ANGLE),
        ])
        .into(),
        StateTimelineView::new("Phases")
            .with_origin(paths::PHASE)
            .into(),
    ])
    .with_row_shares([3.0, 3.0, 3.0, 2.5, 1.5]);
    let right = Vertical::new([
        Spatial2DView::new("Gantry").with_origin("gantry").into(),
        TextLogView::new("Layers").with_origin(paths::LAYERS).into(),
    ])
    .with_row_shares([3.0, 2.0]);
    Blueprint::new(Horizontal::new([left.into(), right.into()]).with_column_shares([3.0, 2.0]))
        .with_time_panel(TimePanel::new().with_timeline(TIME))
}
