//! What the tests of sweep tables share.

/// The sweep-table columns a V1 table does not have: the beam axes, the split of the beam-on
/// time and (newer still) the certificate. A table without them must still read back.
pub const COLUMNS_SINCE_V1: [&str; 13] = [
    "combinations",
    "scan_speed_mm_per_s",
    "dose_rate_scale",
    "burst_switching_time_s",
    "spill_charge_mu",
    "spill_refill_time_s",
    "spill_max_layers",
    "burst_switching_s",
    "spill_waiting_s",
    "spot_irradiation_s",
    "scanning_s",
    "lower_bound_s",
    "gap_s",
];
