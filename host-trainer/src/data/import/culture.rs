//! The locale of an ENLIGHT / Hyperion export, peaks or Responses: its `Culture:` header line
//! or the map's `[enlight] culture`, and what the culture says of the file's numbers (the
//! decimal mark: `1535,012` in de-DE) and numeric dates (the day/month order, `dates.rs`).

use super::time_axis::{decimal_comma_number, DateOrder};
use crate::error::TrainerError;

/// What a culture says about numbers and dates.
#[derive(Clone, Debug)]
pub(crate) struct Culture {
    /// As the table spells it (`de-DE`).
    pub name: &'static str,
    /// Numbers are written `1535,012`.
    pub decimal_comma: bool,
    /// Order of numeric dates; `None` where the culture writes dates year-first (or its short
    /// date has changed between Windows versions): the dates decide, as without a culture.
    pub date_order: Option<DateOrder>,
    /// Where it was found, in words (`line 3` or `map key enlight.culture`).
    pub source: String,
}

use DateOrder::{DayFirst as D, MonthFirst as M};

/// The cultures known: .NET names (as ENLIGHT writes them), decimal comma, date order.
const CULTURES: &[(&str, bool, Option<DateOrder>)] = &[
    ("en-US", false, Some(M)),
    ("en-GB", false, Some(D)),
    ("en-IE", false, Some(D)),
    ("en-AU", false, Some(D)),
    ("en-NZ", false, Some(D)),
    ("en-IN", false, Some(D)),
    ("en-CA", false, None),
    ("de-DE", true, Some(D)),
    ("de-AT", true, Some(D)),
    ("de-LU", true, Some(D)),
    ("de-CH", false, Some(D)),
    ("fr-FR", true, Some(D)),
    ("fr-BE", true, Some(D)),
    ("fr-LU", true, Some(D)),
    ("fr-CH", false, Some(D)),
    ("fr-CA", true, None),
    ("it-IT", true, Some(D)),
    ("es-ES", true, Some(D)),
    ("es-MX", false, Some(D)),
    ("nl-NL", true, Some(D)),
    ("nl-BE", true, Some(D)),
    ("pt-PT", true, Some(D)),
    ("pt-BR", true, Some(D)),
    ("pl-PL", true, Some(D)),
    ("cs-CZ", true, Some(D)),
    ("da-DK", true, Some(D)),
    ("nb-NO", true, Some(D)),
    ("fi-FI", true, Some(D)),
    ("ru-RU", true, Some(D)),
    ("tr-TR", true, Some(D)),
    ("sv-SE", true, None),
    ("ja-JP", false, None),
    ("zh-CN", false, None),
    ("zh-TW", false, None),
    ("ko-KR", false, None),
];

/// The culture named `name` (case and `_`/`-` do not matter; a bare language such as `de`
/// means its first region in the table; empty or `invariant` is .NET's invariant culture,
/// which writes like en-US).
fn culture_named(name: &str) -> Option<(&'static str, bool, Option<DateOrder>)> {
    let n = name.trim().replace('_', "-");
    if n.is_empty() || n.eq_ignore_ascii_case("invariant") || n.eq_ignore_ascii_case("iv") {
        return Some(("invariant", false, Some(M)));
    }
    CULTURES.iter().copied().find(|(c, _, _)| c.eq_ignore_ascii_case(&n)).or_else(|| {
        (!n.contains('-'))
            .then(|| {
                CULTURES
                    .iter()
                    .copied()
                    .find(|(c, _, _)| c.split('-').next().is_some_and(|l| l.eq_ignore_ascii_case(&n)))
            })
            .flatten()
    })
}

/// `Culture: de-DE`, `Culture<TAB>de-DE`, `Culture,de-DE` or `Culture = de-DE`: the value.
fn culture_line(l: &str) -> Option<&str> {
    let t = l.trim_start_matches('\u{feff}').trim();
    let key = t.get(..7)?;
    if !key.eq_ignore_ascii_case("culture") {
        return None;
    }
    let rest = t[7..].trim_start();
    let rest = rest.strip_prefix([':', '=', '\t', ',', ';']).or_else(|| (rest.len() < t.len() - 7).then_some(rest))?;
    Some(rest.trim().trim_end_matches([',', ';', '\t']).trim().trim_matches('"'))
}

/// Whether a line may be the first of the data (a digit, then a peak count): where the metadata
/// in which [`find_culture`] looks for a `Culture:` line ends.
pub(crate) fn looks_like_data(l: &str, guess_delim: &dyn Fn(&str) -> char) -> bool {
    let mut cs = l.split(guess_delim(l)).map(str::trim);
    cs.next().is_some_and(|c| c.starts_with(|ch: char| ch.is_ascii_digit()))
        && cs.next().is_some_and(|c| c.parse::<usize>().is_ok())
}

/// The file's culture: its `Culture:` line among the metadata (the lines before the first one
/// that looks like data, or the map's `header_lines`), or the map's `enlight.culture`. Both
/// present and different, or a culture not in the table, is an error.
pub(crate) fn find_culture(
    lines: &[&str],
    header_lines: Option<usize>,
    from_map: Option<&str>,
    origin: &str,
    name: &str,
    guess_delim: &dyn Fn(&str) -> char,
) -> Result<Option<Culture>, TrainerError> {
    let end = header_lines
        .unwrap_or_else(|| lines.iter().position(|l| looks_like_data(l, guess_delim)).unwrap_or(lines.len()));
    let in_file =
        lines[..end.min(lines.len())].iter().enumerate().find_map(|(i, l)| culture_line(l).map(|v| (i as u64 + 1, v)));
    let known: Vec<&str> = CULTURES.iter().map(|c| c.0).collect();
    let lookup = |v: &str, line: Option<u64>| {
        culture_named(v).ok_or_else(|| {
            let msg = format!(
                "unknown culture `{}`: its decimal mark and date order are not known here; known: {}, invariant (or a bare language such as `de`)",
                crate::error::quote_cell(v),
                known.join(", ")
            );
            match line {
                Some(l) => TrainerError::data(name, l, "Culture", msg),
                None => TrainerError::Config { origin: origin.to_string(), key: "enlight.culture".into(), message: msg },
            }
        })
    };
    let from_file = match in_file {
        Some((line, v)) => Some((lookup(v, Some(line))?, line)),
        None => None,
    };
    let from_map = match from_map {
        Some(v) => Some(lookup(v, None)?),
        None => None,
    };
    Ok(match (from_file, from_map) {
        (Some((f, line)), Some(m)) if f.0 != m.0 => {
            return Err(TrainerError::data(
                name,
                line,
                "Culture",
                format!(
                    "the file says culture {} but the map's enlight.culture ({origin}) says {}: remove one",
                    f.0, m.0
                ),
            ))
        }
        (Some(((n, comma, order), line)), _) => {
            Some(Culture { name: n, decimal_comma: comma, date_order: order, source: format!("line {line}") })
        }
        (None, Some((n, comma, order))) => Some(Culture {
            name: n,
            decimal_comma: comma,
            date_order: order,
            source: format!("map key enlight.culture in {origin}"),
        }),
        (None, None) => None,
    })
}

/// A wavelength cell in the file's culture.
pub(crate) fn number_in(cell: &str, culture: Option<&Culture>) -> Result<Option<f64>, String> {
    match culture {
        Some(c) if c.decimal_comma => {
            let t = cell.trim();
            let place = |m: String| format!("{m} (culture {} from {})", c.name, c.source);
            if t.contains('.') {
                return decimal_comma_number(t).map(Some).map_err(place);
            }
            super::number(&t.replace(',', ".")).map_err(|_| place(format!("`{t}` is not a number")))
        }
        _ => super::number(cell).map_err(|e| {
            let comma = cell.trim().matches(',').count() == 1;
            match culture {
                Some(c) if comma => format!("{e}; the file's culture {} ({}) writes a decimal point", c.name, c.source),
                None if comma => format!("{e}; if the export is from a decimal-comma locale, add its `Culture:` line (e.g. `Culture: de-DE`) or set [enlight] culture in the map"),
                _ => e,
            }
        }),
    }
}
