//! Writing a log as `arcsim-log/1` CSV.

use crate::{Field, LogSample};

/// The samples as an `arcsim-log/1` table: the header, then one row per sample; unknown optional
/// values are empty, numbers in shortest round-trip form.
pub fn to_csv(samples: &[LogSample]) -> String {
    let header: Vec<&str> = Field::ALL.iter().map(|f| f.name()).collect();
    let mut out = header.join(",");
    out.push('\n');
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for s in samples {
        out.push_str(&format!(
            "{},{},{},{},{},{}\n",
            s.t_s,
            s.gantry_angle_deg,
            u8::from(s.beam_on),
            opt(s.energy_mev),
            s.spot.map(|k| k.to_string()).unwrap_or_default(),
            opt(s.mu)
        ));
    }
    out
}
