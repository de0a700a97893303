//! The attributes the import reads: each tag with its keyword, for reading and for error messages.

use dicom_core::Tag;
use dicom_dictionary_std::tags;

/// An attribute: its tag and its keyword, for reading and for error messages.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Attr {
    pub tag: Tag,
    pub keyword: &'static str,
}

macro_rules! attrs {
    ($($name:ident = $keyword:literal,)*) => {
        $(pub(crate) const $name: Attr = Attr { tag: tags::$name, keyword: $keyword };)*
    };
}

attrs! {
    SOP_CLASS_UID = "SOPClassUID",
    SOP_INSTANCE_UID = "SOPInstanceUID",
    RT_PLAN_LABEL = "RTPlanLabel",
    RT_PLAN_NAME = "RTPlanName",
    FRACTION_GROUP_SEQUENCE = "FractionGroupSequence",
    FRACTION_GROUP_NUMBER = "FractionGroupNumber",
    REFERENCED_BEAM_SEQUENCE = "ReferencedBeamSequence",
    REFERENCED_BEAM_NUMBER = "ReferencedBeamNumber",
    BEAM_METERSET = "BeamMeterset",
    ION_BEAM_SEQUENCE = "IonBeamSequence",
    BEAM_NUMBER = "BeamNumber",
    BEAM_NAME = "BeamName",
    BEAM_TYPE = "BeamType",
    TREATMENT_DELIVERY_TYPE = "TreatmentDeliveryType",
    FINAL_CUMULATIVE_METERSET_WEIGHT = "FinalCumulativeMetersetWeight",
    NUMBER_OF_CONTROL_POINTS = "NumberOfControlPoints",
    ION_CONTROL_POINT_SEQUENCE = "IonControlPointSequence",
    GANTRY_ANGLE = "GantryAngle",
    GANTRY_ROTATION_DIRECTION = "GantryRotationDirection",
    NOMINAL_BEAM_ENERGY = "NominalBeamEnergy",
    NUMBER_OF_SCAN_SPOT_POSITIONS = "NumberOfScanSpotPositions",
    SCAN_SPOT_POSITION_MAP = "ScanSpotPositionMap",
    SCAN_SPOT_METERSET_WEIGHTS = "ScanSpotMetersetWeights",
    NUMBER_OF_PAINTINGS = "NumberOfPaintings",
    CUMULATIVE_METERSET_WEIGHT = "CumulativeMetersetWeight",
    CUMULATIVE_DOSE_REFERENCE_COEFFICIENT = "CumulativeDoseReferenceCoefficient",
    REFERENCED_RT_PLAN_SEQUENCE = "ReferencedRTPlanSequence",
    REFERENCED_SOP_INSTANCE_UID = "ReferencedSOPInstanceUID",
    TREATMENT_SESSION_ION_BEAM_SEQUENCE = "TreatmentSessionIonBeamSequence",
    ION_CONTROL_POINT_DELIVERY_SEQUENCE = "IonControlPointDeliverySequence",
    TREATMENT_CONTROL_POINT_DATE = "TreatmentControlPointDate",
    TREATMENT_CONTROL_POINT_TIME = "TreatmentControlPointTime",
    DELIVERED_METERSET = "DeliveredMeterset",
    REFERENCED_CONTROL_POINT_INDEX = "ReferencedControlPointIndex",
    TREATMENT_TERMINATION_STATUS = "TreatmentTerminationStatus",
}
