//! The settings files of an IBA-style beam folder: `beam_config` (the nozzle's constants),
//! `beam` (the gantry angle, the chamber's conditions) and each layer's `map_specif`.

use std::path::Path;

use super::read::read_text;
use super::{DEFAULT_REFERENCE_PRESSURE_HPA, DEFAULT_REFERENCE_TEMPERATURE_K};
use crate::LogError;

/// The nozzle's geometry and charge calibration from `beam_config`.
#[derive(Default)]
pub(super) struct Config {
    pub(super) charge_per_mu_c: Option<f64>,
    /// [physics X, physics Y].
    pub(super) sad_mm: Option<[f64; 2]>,
    pub(super) ic_to_iso_mm: Option<[f64; 2]>,
}

pub(super) fn number(text: &str, file: &str, line: u64, what: &str) -> Result<f64, LogError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            LogError::at(
                file,
                line,
                None,
                format!("{what} `{}`; expected a finite number", text.trim()),
            )
        })
}

fn pair(text: &str, file: &str, line: u64, what: &str) -> Result<[f64; 2], LogError> {
    let f: Vec<&str> = text.split(',').collect();
    if f.len() < 2 {
        return Err(LogError::at(
            file,
            line,
            None,
            format!("{what} `{}`; expected two numbers `X,Y`", text.trim()),
        ));
    }
    Ok([
        number(f[0], file, line, what)?,
        number(f[1], file, line, what)?,
    ])
}

pub(super) fn read_config(p: &Path) -> Result<Config, LogError> {
    let (name, text) = (p.display().to_string(), read_text(p)?);
    let mut c = Config::default();
    // The SADs of a `SAD parameter` line, else of one line per axis.
    let (mut sad_pair, mut sad_by_axis): (Option<[f64; 2]>, [Option<f64>; 2]) =
        (None, [None, None]);
    for (i, l) in text.lines().enumerate() {
        let line = i as u64 + 1;
        let last = l.rsplit(';').next().unwrap_or("");
        if (l.contains("chargePerMUIC2")
            || l.contains("Charge per MU on IC2;")
            || l.contains("Charge per MU on the primary IC;"))
            && c.charge_per_mu_c.is_none()
        {
            let v = number(last, &name, line, "charge per MU")?;
            if v <= 0.0 {
                return Err(LogError::at(
                    &name,
                    line,
                    None,
                    format!("charge per MU {v}; expected coulombs > 0"),
                ));
            }
            c.charge_per_mu_c = Some(v);
        } else if l.contains("SAD parameter") && !l.contains("according scanalgo") {
            if sad_pair.is_none() {
                sad_pair = Some(pair(last, &name, line, "SAD")?);
            }
        } else if let Some(axis) = ["SAD_IC_X", "SAD_IC_Y"]
            .iter()
            .position(|k| l.contains(k) && l.contains("according scanalgo"))
        {
            // A synchrocyclotron's config: one line per axis (as REGGUI's S2C2 reader takes it),
            // a constant after the last `;`, or a formula in the deflection after a `:`.
            if l.contains(':') {
                return Err(LogError::at(
                    &name,
                    line,
                    None,
                    "a SAD formula in the spot's deflection; expected a constant SAD (mm) after the last `;`",
                ));
            }
            if sad_pair.is_none() && sad_by_axis[axis].is_none() {
                sad_by_axis[axis] = Some(number(last, &name, line, "SAD")?);
            }
        } else if l.contains("distanceFromIcToIsocenter") && c.ic_to_iso_mm.is_none() {
            c.ic_to_iso_mm = Some(pair(last, &name, line, "distanceFromIcToIsocenter")?);
        }
    }
    c.sad_mm = sad_pair.or(match sad_by_axis {
        [Some(x), Some(y)] => Some([x, y]),
        _ => None,
    });
    if let (Some(sad), Some(d)) = (c.sad_mm, c.ic_to_iso_mm) {
        if !(sad[0] > d[0] && sad[1] > d[1] && d[0] >= 0.0 && d[1] >= 0.0) {
            return Err(LogError::file(&name, format!("SAD {sad:?} mm and chamber-to-isocentre distance {d:?} mm; expected each SAD above its distance (both positive)")));
        }
    }
    Ok(c)
}

/// The beam file: the gantry angle and the chamber's correction (air density, dose factor).
pub(super) struct BeamFile {
    pub(super) gantry_angle_deg: Option<f64>,
    pub(super) correction: f64,
}

pub(super) fn read_beam_file(p: &Path, notes: &mut Vec<String>) -> Result<BeamFile, LogError> {
    let (name, text) = (p.display().to_string(), read_text(p)?);
    let mut angle = None;
    let (mut t, mut t_ref, mut pr, mut pr_ref, mut dose_cf) = (None, None, None, None, None);
    for (i, l) in text.lines().enumerate() {
        let line = i as u64 + 1;
        // `<mGantryAngle>…</mGantryAngle>` (the tag REGGUI reads; OncoRay's reader takes any
        // tag holding GantryAngle), or `<GantryAngle>…`.
        if let Some(a) = l.find("GantryAngle>").filter(|&a| !l[..a].ends_with('/')) {
            let value = &l[a + 12..];
            let value = &value[..value.find('<').unwrap_or(value.len())];
            angle = Some(number(value, &name, line, "GantryAngle")?);
            continue;
        }
        let f: Vec<&str> = l.split(',').map(str::trim).collect();
        if f.len() < 3 {
            continue;
        }
        let value = || number(f[f.len() - 1], &name, line, f[0]);
        let kelvin = |v: f64| {
            if f[1].starts_with("Celsius") {
                v + 273.15
            } else {
                v
            }
        };
        match f[0] {
            "temperature" => t = Some(kelvin(value()?)),
            "referenceTemperature" => t_ref = Some(kelvin(value()?)),
            "pressure" => pr = Some(value()?),
            "referencePressure" => pr_ref = Some(value()?),
            "doseCorrectionFactor" => dose_cf = Some(value()?),
            _ => {}
        }
    }
    let mut correction = dose_cf.unwrap_or(1.0);
    match (t, pr) {
        (Some(t), Some(p)) if t > 0.0 && p > 0.0 => {
            let t_ref = t_ref.unwrap_or(DEFAULT_REFERENCE_TEMPERATURE_K);
            let p_ref = pr_ref.unwrap_or(DEFAULT_REFERENCE_PRESSURE_HPA);
            // The chamber collects less charge in thinner air: charge ∝ p / T.
            correction *= (p * t_ref) / (t * p_ref);
        }
        _ => notes.push(format!(
            "{name}: no temperature and pressure: the chamber's charge is not corrected for air density"
        )),
    }
    if !(correction.is_finite() && correction > 0.0) {
        return Err(LogError::file(&name, format!("the chamber's correction factor is {correction}; expected a positive number (temperature, pressure, doseCorrectionFactor)")));
    }
    Ok(BeamFile {
        gantry_angle_deg: angle,
        correction,
    })
}

/// `map_specif`: the range (line after `…,RANGE,…`) and the chamber's offsets [physics X, Y].
pub(super) fn read_specif(p: &Path) -> Result<(Option<f64>, [f64; 2]), LogError> {
    let (name, text) = (p.display().to_string(), read_text(p)?);
    let lines: Vec<&str> = text.lines().collect();
    let mut range = None;
    let mut offset = [0.0, 0.0];
    for (i, l) in lines.iter().enumerate() {
        let next = lines.get(i + 1).copied().unwrap_or("");
        let line = i as u64 + 2;
        let fields: Vec<&str> = next.split(',').collect();
        if l.contains(",RANGE,") && range.is_none() {
            range = Some(number(
                fields.get(1).copied().unwrap_or(""),
                &name,
                line,
                "RANGE",
            )?);
        } else if l.contains("[ICX_OFFSET]") || l.contains(",ICX_OFFSET,") {
            let head: Vec<&str> = l
                .split(',')
                .map(|h| h.trim().trim_matches(['[', ']']))
                .collect();
            let col = |h: &str| head.iter().position(|x| *x == h);
            let (cx, cy) = (col("ICX_OFFSET"), col("ICY_OFFSET"));
            let (Some(cx), Some(cy)) = (cx, cy) else {
                return Err(LogError::at(
                    &name,
                    line - 1,
                    None,
                    "ICX_OFFSET without ICY_OFFSET; expected both",
                ));
            };
            offset = [
                number(
                    fields.get(cx).copied().unwrap_or(""),
                    &name,
                    line,
                    "ICX_OFFSET",
                )?,
                number(
                    fields.get(cy).copied().unwrap_or(""),
                    &name,
                    line,
                    "ICY_OFFSET",
                )?,
            ];
        }
    }
    Ok((range, offset))
}
