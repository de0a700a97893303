//! The default viewer layout (blueprint) of a delivery.
//!
//! Written with the blueprint archetypes rather than `rerun::blueprint::Blueprint`: the 0.36
//! Rust builder cannot set a time series view's `TimeAxis`, and without it the viewer opens every
//! plot on a 60 s window around the time cursor instead of the whole delivery.

use rerun::blueprint::components::{
    ColumnShare, ContainerKind, Corner2D, IncludedContent, PanelState, PlayState, QueryExpression,
    RootContainer, RowShare, TimelineName, ViewClass,
};
use rerun::components::Name;
use rerun::datatypes::{Float32, TimeRange, TimeRangeBoundary};
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, PanelBlueprint, PlotLegend, TimeAxis, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint,
};
use rerun::{ApplicationId, RecordingStream, RecordingStreamBuilder};

use crate::timelines::TIME;
use crate::{paths, ViewerError};

/// A view or a container of the layout.
enum Node {
    View {
        class: &'static str,
        name: String,
        origin: String,
        /// A time series' x range (timeline values); `None`: the whole timeline.
        x_range: Option<(i64, i64)>,
        /// A time series' legend corner; `None`: the viewer's default.
        legend: Option<Corner2D>,
    },
    Container {
        kind: ContainerKind,
        /// The tab title when the container is a tab.
        name: Option<String>,
        shares: Vec<f32>,
        children: Vec<Node>,
    },
}

fn view(class: &'static str, name: &str, origin: &str) -> Node {
    Node::View {
        class,
        name: name.to_owned(),
        origin: origin.to_owned(),
        x_range: None,
        legend: None,
    }
}

fn series(name: &str, origin: &str) -> Node {
    view("TimeSeries", name, origin)
}

fn container(kind: ContainerKind, shares: &[f32], children: Vec<Node>) -> Node {
    Node::Container {
        kind,
        name: None,
        shares: shares.to_vec(),
        children,
    }
}

fn named(node: Node, title: &str) -> Node {
    match node {
        Node::Container {
            kind,
            shares,
            children,
            ..
        } => Node::Container {
            kind,
            name: Some(title.to_owned()),
            shares,
            children,
        },
        Node::View {
            class,
            origin,
            x_range,
            legend,
            ..
        } => Node::View {
            class,
            name: title.to_owned(),
            origin,
            x_range,
            legend,
        },
    }
}

/// Time series stacked on the left (speed, acceleration, jerk with their limits; energy and
/// angle as tabs; the phases), the gantry (with `spots`, above the beam's-eye view of the
/// spots) and the layer log on the right.
fn delivery_layout(spots: bool) -> Node {
    let left = container(
        ContainerKind::Vertical,
        &[3.0, 3.0, 3.0, 2.5, 1.5],
        vec![
            series("Speed (°/s)", paths::SPEED),
            series("Acceleration (°/s²)", paths::ACCEL),
            series("Jerk (°/s³)", paths::JERK),
            container(
                ContainerKind::Tabs,
                &[],
                vec![
                    series("Energy (MeV)", paths::ENERGY),
                    series("Lost time (s)", paths::LOST),
                    series("Angle (°)", paths::ANGLE),
                ],
            ),
            view("StateTimeline", "Phases", paths::PHASE),
        ],
    );
    let right = if spots {
        container(
            ContainerKind::Vertical,
            &[3.0, 3.0, 2.0],
            vec![
                view("2D", "Gantry", "gantry"),
                view("2D", BEV_TITLE, paths::BEAM_EYE_VIEW),
                view("TextLog", "Layers", paths::LAYERS),
            ],
        )
    } else {
        container(
            ContainerKind::Vertical,
            &[3.0, 2.0],
            vec![
                view("2D", "Gantry", "gantry"),
                view("TextLog", "Layers", paths::LAYERS),
            ],
        )
    };
    container(ContainerKind::Horizontal, &[3.0, 2.0], vec![left, right])
}

/// Title of the beam's-eye view of the spots.
pub(crate) const BEV_TITLE: &str = "Beam's-eye view (spots)";

/// Deterministic view/container ids (unique within one blueprint), as hyphenated UUIDs.
fn node_id(n: u8) -> [u8; 16] {
    [
        b'a', b'r', b'c', b's', b'i', b'm', 0x40, 0, 0x80, 0, 0, 0, 0, 0, 0, n,
    ]
}

fn uuid_string(b: &[u8; 16]) -> String {
    let hex: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// Logs `node` and its children; returns its blueprint entity path.
fn log_node(bp: &RecordingStream, node: &Node, next_id: &mut u8) -> Result<String, ViewerError> {
    *next_id += 1;
    let id = node_id(*next_id);
    match node {
        Node::View {
            class,
            name,
            origin,
            x_range,
            legend,
        } => {
            let path = format!("view/{}", uuid_string(&id));
            bp.log(
                format!("{path}/ViewContents"),
                &ViewContents::new([QueryExpression("$origin/**".into())]),
            )?;
            bp.log(
                path.as_str(),
                &ViewBlueprint::new(ViewClass((*class).into()))
                    .with_display_name(Name(name.as_str().into()))
                    .with_space_origin(origin.as_str()),
            )?;
            if *class == "TimeSeries" {
                let range = match x_range {
                    Some((lo, hi)) => TimeRange {
                        start: TimeRangeBoundary::Absolute((*lo).into()),
                        end: TimeRangeBoundary::Absolute((*hi).into()),
                    },
                    None => TimeRange {
                        start: TimeRangeBoundary::Infinite,
                        end: TimeRangeBoundary::Infinite,
                    },
                };
                bp.log(
                    format!("{path}/TimeAxis"),
                    &TimeAxis::new().with_view_range(range),
                )?;
                if let Some(corner) = legend {
                    bp.log(
                        format!("{path}/PlotLegend"),
                        &PlotLegend::new().with_corner(*corner).with_visible(true),
                    )?;
                }
            }
            Ok(path)
        }
        Node::Container {
            kind,
            name,
            shares,
            children,
        } => {
            let mut contents = Vec::with_capacity(children.len());
            for child in children {
                contents.push(IncludedContent(log_node(bp, child, next_id)?.into()));
            }
            let path = format!("container/{}", uuid_string(&id));
            let mut arch = ContainerBlueprint::new(*kind).with_contents(contents);
            let shares = shares.iter().map(|&s| Float32(s));
            arch = match kind {
                ContainerKind::Horizontal => arch.with_col_shares(shares.map(ColumnShare)),
                ContainerKind::Vertical => arch.with_row_shares(shares.map(RowShare)),
                _ => arch,
            };
            if let Some(name) = name {
                arch = arch.with_display_name(Name(name.as_str().into()));
            }
            bp.log(path.as_str(), &arch)?;
            Ok(path)
        }
    }
}

/// The blueprint messages of layout `root` for application `app_id`: panels collapsed
/// (more room for the views), `timeline` selected, time in state `play`.
fn blueprint_msgs(
    app_id: ApplicationId,
    root: &Node,
    timeline: &str,
    play: PlayState,
) -> Result<Vec<LogMsg>, ViewerError> {
    let (bp, storage) = RecordingStreamBuilder::new(app_id)
        .send_properties(false)
        .blueprint()
        .memory()?;
    bp.set_time_sequence("blueprint", 0);
    let mut next_id = 0;
    log_node(&bp, root, &mut next_id)?;
    let root_id = node_id(1);
    bp.log(
        "viewport",
        &ViewportBlueprint::new().with_root_container(RootContainer(root_id.into())),
    )?;
    bp.log(
        "blueprint_panel",
        &PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    bp.log(
        "selection_panel",
        &PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    bp.log(
        "time_panel",
        &TimePanelBlueprint::new()
            .with_state(PanelState::Collapsed)
            .with_timeline(TimelineName(timeline.into()))
            .with_play_state(play),
    )?;
    Ok(storage.take())
}

/// Sends the default delivery layout into `rec` and makes it the active one; call it before
/// logging so a file starts with its layout. `with_spots` adds a 2D beam's-eye view of the
/// spots ([`paths::BEAM_EYE_VIEW`], logged by [`crate::log_spots`]) between the gantry and the
/// layer log.
pub fn send_delivery_blueprint(rec: &RecordingStream, with_spots: bool) -> Result<(), ViewerError> {
    send_blueprint(rec, &delivery_layout(with_spots), TIME)
}

/// Sends layout `root` into `rec` as the active blueprint, paused.
fn send_blueprint(rec: &RecordingStream, root: &Node, timeline: &str) -> Result<(), ViewerError> {
    send_blueprint_playing(rec, root, timeline, PlayState::Paused)
}

/// Sends layout `root` into `rec` as the active blueprint, time in state `play`.
fn send_blueprint_playing(
    rec: &RecordingStream,
    root: &Node,
    timeline: &str,
    play: PlayState,
) -> Result<(), ViewerError> {
    let app_id = rec.store_info().map_or_else(
        || ApplicationId::from(crate::DELIVERY_APP_ID),
        |i| i.application_id().clone(),
    );
    let msgs = blueprint_msgs(app_id, root, timeline, play)?;
    if let Some(blueprint_id) = msgs.first().map(|m| m.store_id().clone()) {
        rec.send_blueprint(
            msgs,
            BlueprintActivationCommand {
                blueprint_id,
                make_active: true,
                make_default: true,
            },
        );
    }
    Ok(())
}

/// One plot of a sweep: delivery time against one limit.
pub(crate) struct SweepPlot {
    pub title: String,
    pub origin: String,
    /// The x range shown (values of the sweep's plot timeline).
    pub x_range: (i64, i64),
    /// Lines in the plot (legend entries).
    pub lines: usize,
}

/// One plan of a sweep: a row of plots per schedule.
pub(crate) struct SweepTab {
    pub plan: String,
    pub rows: Vec<Vec<SweepPlot>>,
}

/// A sweep's layout: a tab per plan, in it a row of plots per schedule (legends top right,
/// where each plot's x range leaves room for them; each row as tall as its longest legend needs);
/// then a tab with the summary document and one with the row log.
pub(crate) fn send_sweep_blueprint(
    rec: &RecordingStream,
    tabs: &[SweepTab],
    summary_origin: &str,
    log_origin: &str,
) -> Result<(), ViewerError> {
    let mut children: Vec<Node> = tabs
        .iter()
        .map(|tab| {
            let rows: Vec<Node> = tab
                .rows
                .iter()
                .filter(|r| !r.is_empty())
                .map(|plots| {
                    let views: Vec<Node> = plots
                        .iter()
                        .map(|p| Node::View {
                            class: "TimeSeries",
                            name: p.title.clone(),
                            origin: p.origin.clone(),
                            x_range: Some(p.x_range),
                            legend: Some(Corner2D::RightTop),
                        })
                        .collect();
                    container(ContainerKind::Horizontal, &[], views)
                })
                .collect();
            let shares: Vec<f32> = tab
                .rows
                .iter()
                .filter(|r| !r.is_empty())
                .map(|r| r.iter().map(|p| p.lines).max().unwrap_or(1).max(3) as f32)
                .collect();
            named(container(ContainerKind::Vertical, &shares, rows), &tab.plan)
        })
        .collect();
    children.push(named(
        view("TextDocument", "Summary", summary_origin),
        "Summary",
    ));
    children.push(named(view("TextLog", "Rows", log_origin), "Rows"));
    let root = container(ContainerKind::Tabs, &[], children);
    send_blueprint_playing(rec, &root, crate::sweep::SWEEP_X, PlayState::Following)
}
