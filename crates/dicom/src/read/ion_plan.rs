//! The plain structs an RT Ion Plan is read into, with inherited attributes already filled in; the
//! input of `convert`.

/// GantryRotationDirection (300A,011F) as written in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rotation {
    Cw,
    Cc,
    None,
}

/// BeamType (300A,00C4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BeamKind {
    Static,
    Dynamic,
}

/// The parts of an RT Ion Plan that the conversion needs.
#[derive(Debug, Clone)]
pub(crate) struct IonPlan {
    pub label: Option<String>,
    pub plan_name: Option<String>,
    pub sop_instance_uid: Option<String>,
    /// Treatment beams ordered by BeamNumber.
    pub beams: Vec<IonBeam>,
    /// Beams left out (setup beams, beams without spots), for the plan description.
    pub skipped: Vec<String>,
}

/// One ion beam, with control-point attributes already inherited.
#[derive(Debug, Clone)]
pub(crate) struct IonBeam {
    /// Index of the beam's item in IonBeamSequence (the file's order, not BeamNumber's).
    pub item: usize,
    pub number: i64,
    pub name: Option<String>,
    pub kind: BeamKind,
    /// BeamMeterset / FinalCumulativeMetersetWeight: the MU of one unit of meterset weight.
    pub mu_per_weight: f64,
    pub control_points: Vec<IonControlPoint>,
}

/// One item of IonControlPointSequence, with the gantry angle and direction inherited from earlier
/// control points of the same beam when absent.
#[derive(Debug, Clone)]
pub(crate) struct IonControlPoint {
    pub angle_deg: f64,
    /// Direction of the rotation from this control point to the next one.
    pub rotation: Rotation,
    /// The energy layer this control point starts, when it carries spot weights above 0.
    pub layer: Option<IonLayer>,
}

/// The spots a control point delivers (energy and paintings inherited when absent).
#[derive(Debug, Clone)]
pub(crate) struct IonLayer {
    pub energy_mev: f64,
    /// ScanSpotMetersetWeights, one per spot; the total over all paintings.
    pub weights: Vec<f64>,
    /// ScanSpotPositionMap as `[x, y]` in mm, one per spot in the file's order; None when the control
    /// point has no map.
    pub positions_mm: Option<Vec<[f64; 2]>>,
    /// NumberOfPaintings: how many times the spot list is delivered.
    pub paintings: u32,
}
