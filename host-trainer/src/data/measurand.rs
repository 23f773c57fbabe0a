//! What a reference column measures: a kind (temperature, strain, pressure) and an index, which
//! give the dataset column name, the unit and a short name (DESIGN §3).
//!
//! | kind | index 1 | index k ≥ 2 | unit |
//! |---|---|---|---|
//! | temperature | `T_C` | `T{k}_C` | °C |
//! | strain | `strain_ue` | `strain{k}_ue` | µε |
//! | pressure | `p_kPa` | `p{k}_kPa` | kPa |
//!
//! The canonical order (the CSV writer's) is by kind (T, ε, p), then index, so the paper's
//! `T_C,strain_ue,p_kPa` keeps its order.

use std::fmt;

/// Largest number of gratings a dataset may carry (`dl1_pm..dl8_pm`).
pub const MAX_GRATINGS: usize = 8;
/// Largest number of measurands (reference columns) a dataset may carry.
pub const MAX_MEASURANDS: usize = 4;
/// Largest index of one kind (`strain9_ue`).
pub const MAX_INDEX: u8 = 9;

/// The physical quantity of a measurand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Temperature,
    Strain,
    Pressure,
}

impl Kind {
    /// Every kind, in canonical order.
    pub const ALL: [Kind; 3] = [Kind::Temperature, Kind::Strain, Kind::Pressure];

    /// Column prefix and suffix: `T` + `_C`, `strain` + `_ue`, `p` + `_kPa`.
    fn affixes(self) -> (&'static str, &'static str) {
        match self {
            Kind::Temperature => ("T", "_C"),
            Kind::Strain => ("strain", "_ue"),
            Kind::Pressure => ("p", "_kPa"),
        }
    }
    /// The unit, as printed.
    pub fn unit(self) -> &'static str {
        match self {
            Kind::Temperature => "°C",
            Kind::Strain => "µε",
            Kind::Pressure => "kPa",
        }
    }
    /// The quantity's name in words.
    pub(crate) fn long_name(self) -> &'static str {
        match self {
            Kind::Temperature => "temperature",
            Kind::Strain => "strain",
            Kind::Pressure => "pressure",
        }
    }
    /// The symbol used in tables (`T`, `ε`, `p`).
    pub fn symbol(self) -> &'static str {
        match self {
            Kind::Temperature => "T",
            Kind::Strain => "ε",
            Kind::Pressure => "p",
        }
    }
}

/// One measurand: a kind and its index (1 for the first of a kind).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Measurand {
    pub kind: Kind,
    /// 1-based; `T_C` is index 1, `T2_C` index 2.
    pub index: u8,
}

impl Measurand {
    /// The reference temperature `T_C`.
    pub const T: Measurand = Measurand { kind: Kind::Temperature, index: 1 };
    /// The reference strain `strain_ue`.
    pub const STRAIN: Measurand = Measurand { kind: Kind::Strain, index: 1 };
    /// The reference pressure `p_kPa`.
    pub const P: Measurand = Measurand { kind: Kind::Pressure, index: 1 };
    /// The paper's three outputs, in the order of the model's channels (T, ε, p).
    pub const PAPER: [Measurand; 3] = [Measurand::T, Measurand::STRAIN, Measurand::P];

    /// A measurand of `kind` with `index` (1..=[`MAX_INDEX`]).
    pub fn new(kind: Kind, index: u8) -> Option<Measurand> {
        (1..=MAX_INDEX).contains(&index).then_some(Measurand { kind, index })
    }

    /// The dataset column name: `T_C`, `strain2_ue`, `p_kPa`, ...
    pub fn column(self) -> String {
        let (pre, suf) = self.kind.affixes();
        if self.index == 1 {
            format!("{pre}{suf}")
        } else {
            format!("{pre}{}{suf}", self.index)
        }
    }
    /// The unit (°C, µε, kPa).
    pub fn unit(self) -> &'static str {
        self.kind.unit()
    }
    /// A short name for tables and plots: `T`, `ε2`, `p`.
    pub fn short_name(self) -> String {
        if self.index == 1 {
            self.kind.symbol().to_string()
        } else {
            format!("{}{}", self.kind.symbol(), self.index)
        }
    }
    /// A name in words: `temperature`, `strain 2`.
    pub(crate) fn long_name(self) -> String {
        if self.index == 1 {
            self.kind.long_name().to_string()
        } else {
            format!("{} {}", self.kind.long_name(), self.index)
        }
    }

    /// The measurand a column name stands for: `Ok(None)` when the name is no measurand
    /// column at all (`t_s`, `T_amb_C`, a logger's own column), `Err` when it looks like one
    /// but is not valid (`T1_C`, `strain0_ue`, `p12_kPa`), with the reason.
    pub fn parse(column: &str) -> Result<Option<Measurand>, String> {
        for kind in Kind::ALL {
            let (pre, suf) = kind.affixes();
            let Some(mid) = column.strip_prefix(pre).and_then(|r| r.strip_suffix(suf)) else { continue };
            if mid.is_empty() {
                return Ok(Some(Measurand { kind, index: 1 }));
            }
            if !mid.bytes().all(|b| b.is_ascii_digit()) {
                continue;
            }
            let first = Measurand { kind, index: 1 }.column();
            return match mid.parse::<u8>() {
                Ok(1) => Err(format!("the first {} is `{first}`, without an index", kind.long_name())),
                Ok(k) if (2..=MAX_INDEX).contains(&k) && !mid.starts_with('0') => {
                    Ok(Some(Measurand { kind, index: k }))
                }
                _ => Err(format!(
                    "a {} column is `{first}` or `{pre}k{suf}` with k from 2 to {MAX_INDEX}",
                    kind.long_name()
                )),
            };
        }
        Ok(None)
    }
}

impl Measurand {
    /// The model output (`fbg_shared::layout::Output`) this measurand is.
    pub fn output(self) -> fbg_shared::layout::Output {
        use fbg_shared::layout::Quantity;
        let quantity = match self.kind {
            Kind::Temperature => Quantity::Temperature,
            Kind::Strain => Quantity::Strain,
            Kind::Pressure => Quantity::Pressure,
        };
        fbg_shared::layout::Output { quantity, index: self.index }
    }
    /// The measurand a model output stands for.
    pub(crate) fn of_output(o: fbg_shared::layout::Output) -> Measurand {
        use fbg_shared::layout::Quantity;
        let kind = match o.quantity {
            Quantity::Temperature => Kind::Temperature,
            Quantity::Strain => Kind::Strain,
            Quantity::Pressure => Kind::Pressure,
        };
        Measurand { kind, index: o.index }
    }
    /// The measurands of a model's outputs, in output order.
    pub fn of_dims(dims: &fbg_shared::layout::Dims) -> Vec<Measurand> {
        dims.outputs().iter().map(|&o| Measurand::of_output(o)).collect()
    }
}

impl fmt::Display for Measurand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.column())
    }
}

impl serde::Serialize for Measurand {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.column())
    }
}

impl<'de> serde::Deserialize<'de> for Measurand {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        match Measurand::parse(&s) {
            Ok(Some(m)) => Ok(m),
            Ok(None) => Err(serde::de::Error::custom(format!(
                "`{q}` is not a measurand column (T_C, T2_C, strain_ue, strain2_ue, p_kPa, ...)",
                q = crate::error::quote_cell(&s)
            ))),
            Err(e) => Err(serde::de::Error::custom(format!("`{}`: {e}", crate::error::quote_cell(&s)))),
        }
    }
}

impl std::str::FromStr for Measurand {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match Measurand::parse(s) {
            Ok(Some(m)) => Ok(m),
            Ok(None) => Err(format!(
                "`{}` is not a measurand column (T_C, T2_C, strain_ue, strain2_ue, p_kPa, ...)",
                crate::error::quote_cell(s)
            )),
            Err(e) => Err(format!("`{}`: {e}", crate::error::quote_cell(s))),
        }
    }
}

/// Names of a model's polynomial terms in [`fbg_shared::layout::Dims::poly_term`] order, from
/// the outputs' short names: `1`, `T`, `ε`, `p`, `T²`, …, `Tε`, … (the paper's
/// [1, T, ε, p, T², ε², p², Tε, Tp, εp] for its three outputs).
pub(crate) fn poly_term_names(dims: &fbg_shared::layout::Dims) -> Vec<String> {
    let short: Vec<String> = Measurand::of_dims(dims).iter().map(|m| m.short_name()).collect();
    (0..dims.poly_len())
        .map(|k| match dims.poly_term(k) {
            None => "1".to_string(),
            Some((i, None)) => short[i].clone(),
            Some((i, Some(j))) if i == j => format!("{}²", short[i]),
            Some((i, Some(j))) => format!("{}{}", short[i], short[j]),
        })
        .collect()
}

/// The dataset columns of a model's envelope inputs: `dl1_pm..dlN_pm`, then `T_amb_C` with
/// ambient.
pub(crate) fn input_columns(dims: &fbg_shared::layout::Dims) -> Vec<String> {
    let mut v: Vec<String> = (1..=dims.gratings()).map(grating_column).collect();
    if dims.ambient() {
        v.push("T_amb_C".into());
    }
    v
}

/// The stage-1 regressors of a model: its input columns, then `1`.
pub(crate) fn stage1_columns(dims: &fbg_shared::layout::Dims) -> Vec<String> {
    let mut v = input_columns(dims);
    v.push("1".into());
    v
}

/// The grating column `dl{g}_pm` (g 1-based).
pub(crate) fn grating_column(g: usize) -> String {
    format!("dl{g}_pm")
}

/// The grating a column name stands for (1-based): `Ok(None)` when it is no grating column,
/// `Err` when it looks like one but is out of range (`dl0_pm`, `dl9_pm`).
pub(crate) fn parse_grating_column(column: &str) -> Result<Option<usize>, String> {
    let Some(mid) = column.strip_prefix("dl").and_then(|r| r.strip_suffix("_pm")) else { return Ok(None) };
    if mid.is_empty() || !mid.bytes().all(|b| b.is_ascii_digit()) {
        return Ok(None);
    }
    match mid.parse::<usize>() {
        Ok(g) if (1..=MAX_GRATINGS).contains(&g) && !mid.starts_with('0') => Ok(Some(g)),
        _ => Err(format!("grating columns are dl1_pm to dl{MAX_GRATINGS}_pm")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_sort_canonically() {
        for name in ["T_C", "T2_C", "strain_ue", "strain2_ue", "strain9_ue", "p_kPa", "p3_kPa"] {
            let m = Measurand::parse(name).unwrap().unwrap();
            assert_eq!(m.column(), name);
        }
        for other in ["t_s", "T_amb_C", "split", "dl1_pm", "Tx_C", "pressure"] {
            assert_eq!(Measurand::parse(other).unwrap(), None, "{other}");
        }
        for bad in ["T1_C", "strain0_ue", "p12_kPa", "T02_C"] {
            assert!(Measurand::parse(bad).is_err(), "{bad}");
        }
        let mut v = [Measurand::P, Measurand::new(Kind::Strain, 2).unwrap(), Measurand::T, Measurand::STRAIN];
        v.sort();
        let names: Vec<String> = v.iter().map(|m| m.column()).collect();
        assert_eq!(names, ["T_C", "strain_ue", "strain2_ue", "p_kPa"]);
        assert_eq!(Measurand::new(Kind::Strain, 2).unwrap().short_name(), "ε2");
        assert_eq!(parse_grating_column("dl8_pm"), Ok(Some(8)));
        assert!(parse_grating_column("dl9_pm").is_err());
        assert_eq!(parse_grating_column("dlx_pm"), Ok(None));
    }
}
