//! The day/month order of a file's numeric dates (`03.01.2024`: 3 January or 1 March?), from
//! its culture or its dates: for the ENLIGHT exports, peaks and Responses.

use super::culture::Culture;
use super::time_axis::{dmy_fields, DateOrder};
use crate::error::TrainerError;

/// The day/month order of a file's numeric dates, fed one data line at a time (a file read
/// line by line): [`DateProbe::see`] each data line's first cell, then [`DateProbe::finish`]:
/// the culture's order, unless some date contradicts it (an error naming the line), or without
/// a culture order the dates' own: a first field above 12 is a day, a second field above 12 is
/// a day. Dates that never settle it, or settle it both ways, are an error.
pub(crate) struct DateProbe<'a> {
    first: usize,
    culture: Option<&'a Culture>,
    name: &'a str,
    day_first: Option<(u64, String)>,
    month_first: Option<(u64, String)>,
    first_date: Option<(u64, String)>,
}

impl<'a> DateProbe<'a> {
    /// A probe of a file `name` whose data start after line `first`.
    pub(crate) fn new(first: usize, culture: Option<&'a Culture>, name: &'a str) -> Self {
        DateProbe { first, culture, name, day_first: None, month_first: None, first_date: None }
    }

    /// The first cell of data line `line`; `true` once the lines seen settle the order both
    /// ways (no later line can change the outcome).
    pub(crate) fn see(&mut self, line: u64, cell: &str) -> Result<bool, TrainerError> {
        let cell = cell.trim();
        let Some((a, b)) = dmy_fields(cell) else { return Ok(false) };
        self.first_date.get_or_insert_with(|| (line, cell.to_string()));
        if (13..=31).contains(&a) && (1..=12).contains(&b) {
            self.day_first.get_or_insert_with(|| (line, cell.to_string()));
        }
        if (13..=31).contains(&b) && (1..=12).contains(&a) {
            self.month_first.get_or_insert_with(|| (line, cell.to_string()));
        }
        if let Some(Culture { date_order: Some(o), name: c, source, .. }) = self.culture {
            let against = match o {
                DateOrder::DayFirst => &self.month_first,
                DateOrder::MonthFirst => &self.day_first,
            };
            if let Some((l, cell)) = against {
                let field = if *o == DateOrder::DayFirst { b } else { a };
                return Err(TrainerError::data(
                    self.name,
                    *l,
                    "1 (time)",
                    format!(
                        "`{}` is not a date in culture {c} ({source}), which writes dates {}: there is no month {field}; the culture does not match the dates (fix the Culture line, or the map's enlight.culture)",
                        crate::error::quote_cell(cell),
                        o.words()
                    ),
                ));
            }
        }
        Ok(self.day_first.is_some() && self.month_first.is_some())
    }

    /// The order, or the error, from the lines seen.
    pub(crate) fn finish(self) -> Result<(DateOrder, String), TrainerError> {
        let DateProbe { first, culture, name, day_first, month_first, first_date } = self;
        if let Some(Culture { date_order: Some(o), name: c, source, .. }) = culture {
            let _ = (c, source);
            return Ok((*o, "from the culture".to_string()));
        }
        match (day_first, month_first) {
            (Some((d, dc)), Some((m, mc))) => Err(TrainerError::data(
                name,
                d.max(m),
                "1 (time)",
                format!(
                    "the dates disagree on their order: `{dc}` (line {d}) can only be day-first, `{mc}` (line {m}) only month-first"
                ),
            )),
            (Some((d, dc)), None) => Ok((DateOrder::DayFirst, format!("line {d}: `{dc}` has a day above 12 first"))),
            (None, Some((m, mc))) => Ok((DateOrder::MonthFirst, format!("line {m}: `{mc}` has a day above 12 second"))),
            (None, None) => {
                let (line, cell) = first_date.unwrap_or((first as u64 + 1, String::new()));
                let why = match culture {
                    Some(c) => format!("its culture {} ({}) does not fix the day/month order", c.name, c.source),
                    None => "the file has no `Culture:` line".to_string(),
                };
                Err(TrainerError::data(
                    name,
                    line,
                    "1 (time)",
                    format!(
                        "ambiguous date `{q}`: day-first or month-first? No date in the file has a field above 12 to tell, and {why}; add the export's locale as a header line such as `Culture: de-DE` (day-first) or `Culture: en-US` (month-first), or set `culture = \"de-DE\"` (or a `time_format`) under [enlight] in the --map file",
                        q = crate::error::quote_cell(&cell)
                    ),
                ))
            }
        }
    }
}
