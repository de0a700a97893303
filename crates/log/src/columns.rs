//! The log's columns, and how another CSV's column names map onto them (`--columns`).

use crate::LogError;

/// A column of `arcsim-log/1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// `t_s`: time, s (required).
    Time,
    /// `gantry_angle_deg`: gantry angle, degrees (required).
    GantryAngle,
    /// `beam_on`: 1 while the beam is on, else 0 (required).
    BeamOn,
    /// `energy_mev`: the layer's nominal energy while the beam is on (optional).
    Energy,
    /// `spot`: index of the spot being delivered in its layer (optional).
    Spot,
    /// `mu`: MU delivered since the previous row (optional).
    Mu,
}

impl Field {
    /// Every column, in the order a log is written.
    pub const ALL: [Field; 6] = [
        Field::Time,
        Field::GantryAngle,
        Field::BeamOn,
        Field::Energy,
        Field::Spot,
        Field::Mu,
    ];

    /// The column's name in `arcsim-log/1`.
    pub fn name(self) -> &'static str {
        match self {
            Field::Time => "t_s",
            Field::GantryAngle => "gantry_angle_deg",
            Field::BeamOn => "beam_on",
            Field::Energy => "energy_mev",
            Field::Spot => "spot",
            Field::Mu => "mu",
        }
    }

    /// Whether a log must have the column.
    pub fn required(self) -> bool {
        matches!(self, Field::Time | Field::GantryAngle | Field::BeamOn)
    }

    /// What the column holds, for messages.
    pub fn meaning(self) -> &'static str {
        match self {
            Field::Time => "time in s",
            Field::GantryAngle => "gantry angle in degrees",
            Field::BeamOn => "1 while the beam is on, else 0",
            Field::Energy => "the layer's energy in MeV",
            Field::Spot => "the spot's index in its layer",
            Field::Mu => "MU since the previous row",
        }
    }
}

/// Which column of a CSV file holds each field: by default the field's own name; `--columns
/// t_s=TIME,gantry_angle_deg=GantryAngle` reads another CSV's names.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ColumnMap {
    names: Vec<(Field, String)>,
}

impl ColumnMap {
    /// Parses `FIELD=NAME` pairs separated by commas; `option` names the option in errors.
    pub fn parse(text: &str, option: &str) -> Result<ColumnMap, LogError> {
        let mut map = ColumnMap::default();
        for pair in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (field, name) = pair.split_once('=').ok_or_else(|| {
                LogError::file(
                    option,
                    format!("\"{pair}\": expected FIELD=COLUMN, e.g. t_s=TIME"),
                )
            })?;
            let (field, name) = (field.trim(), name.trim());
            let f = Field::ALL
                .into_iter()
                .find(|f| f.name() == field)
                .ok_or_else(|| {
                    let known: Vec<&str> = Field::ALL.iter().map(|f| f.name()).collect();
                    LogError::file(
                        option,
                        format!(
                            "unknown field \"{field}\"; expected one of {}",
                            known.join(", ")
                        ),
                    )
                })?;
            if name.is_empty() {
                return Err(LogError::file(option, format!("{field}= names no column")));
            }
            if map.names.iter().any(|(g, _)| *g == f) {
                return Err(LogError::file(option, format!("{field} is mapped twice")));
            }
            map.names.push((f, name.to_string()));
        }
        // One column per field: `t_s=A,mu=A` (or `mu=t_s`, leaving t_s on its own name) would
        // read one column as two things.
        for (i, a) in Field::ALL.iter().enumerate() {
            if let Some(b) = Field::ALL[i + 1..]
                .iter()
                .find(|b| map.column(**b) == map.column(*a))
            {
                return Err(LogError::file(
                    option,
                    format!(
                        "{} and {} would both read column \"{}\"; expected one column per field",
                        a.name(),
                        b.name(),
                        map.column(*a)
                    ),
                ));
            }
        }
        Ok(map)
    }

    /// The name of the column that holds `field`.
    pub fn column(&self, field: Field) -> &str {
        self.names
            .iter()
            .find(|(f, _)| *f == field)
            .map_or(field.name(), |(_, n)| n.as_str())
    }
}
