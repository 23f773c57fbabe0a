//! Every importer's rows brought to one form ([`Merged`]): times, wavelengths per grating,
//! the ambient reading and the references — for ENLIGHT peaks and the spectrum formats, the
//! references of a `--refs` CSV joined onto the peak times.

use super::enlight;
use super::logger_csv::{self, LoggerTable};
use super::mapping::Map;
use super::problems::FileSkips;
use super::spectra;
use super::summary::{EnlightInfo, JoinInfo, SpectraInfo};
use super::time_axis::TimeKind;
use super::{join, ImportOptions};
use crate::data::timestamp::format_timestamp;
use crate::data::{Measurand, T_AMB_COLUMN};
use crate::error::TrainerError;

/// The rows of either importer before the common steps.
pub(super) struct Merged {
    pub(super) input: String,
    pub(super) lines: Vec<u64>,
    pub(super) t: Vec<f64>,
    pub(super) kind: TimeKind,
    pub(super) absolute: bool,
    pub(super) time_column: String,
    /// The ambient thermometer (source column, values), if the record has one.
    pub(super) ambient: Option<(String, Vec<f64>)>,
    /// The references (measurand, source column, values), in canonical order.
    pub(super) refs: Vec<(Measurand, String, Vec<f64>)>,
    /// Absolute nm, or shift pm where `is_shift`; one per grating.
    pub(super) wl: Vec<Vec<f64>>,
    pub(super) is_shift: Vec<bool>,
    pub(super) ref_nm: Vec<Option<f64>>,
    pub(super) sources: Vec<String>,
    pub(super) rows_read: usize,
    pub(super) skips: Vec<FileSkips>,
    pub(super) enlight: Option<EnlightInfo>,
    pub(super) join: Option<JoinInfo>,
    pub(super) spectra: Option<SpectraInfo>,
    /// Error when no row has an ambient temperature.
    pub(super) empty_hint: String,
    pub(super) n_before_drop: usize,
}

impl Merged {
    /// A logger CSV, which carries its ambient reading and references in its own columns.
    pub(super) fn from_logger_csv(opts: &ImportOptions, m: &Map, input_name: &str) -> Result<Merged, TrainerError> {
        if opts.refs.is_some() {
            return Err(TrainerError::Config {
                origin: input_name.to_string(),
                key: "--refs".into(),
                message: "--refs is for --format enlight; a logger CSV carries its ambient temperature and references in its own columns (name them in the map)".into(),
            });
        }
        let gratings = m.csv_gratings();
        let tab = logger_csv::read(&opts.input, m, Some(&gratings), opts.on_error)?;
        let n = tab.t.len();
        let skips = vec![tab.problems.summary()];
        let specs = &tab.grating_specs;
        Ok(Merged {
            input: input_name.to_string(),
            lines: tab.lines,
            t: tab.t,
            kind: tab.time_kind,
            absolute: tab.absolute,
            time_column: tab.time_column,
            empty_hint: format!(
                "{input_name}: every row lacks an ambient temperature (column `{}`)",
                tab.ambient.as_ref().map_or(T_AMB_COLUMN, |a| a.name.as_str())
            ),
            ambient: tab.ambient.map(|a| (a.name, a.values)),
            refs: tab.refs.into_iter().map(|(m, c)| (m, c.name, c.values)).collect(),
            is_shift: specs.iter().map(|g| g.unit.is_shift()).collect(),
            ref_nm: specs.iter().map(|g| g.ref_nm).collect(),
            sources: tab
                .gratings
                .iter()
                .zip(specs)
                .map(|(c, g)| format!("column `{}` ({})", c.name, g.unit.name()))
                .collect(),
            wl: tab.gratings.into_iter().map(|c| c.values).collect(),
            rows_read: skips[0].rows_read,
            skips,
            enlight: None,
            join: None,
            spectra: None,
            n_before_drop: n,
        })
    }

    /// An ENLIGHT peaks export, with the references of `--refs` joined onto its times when
    /// given (the export itself carries neither an ambient reading nor references).
    pub(super) fn from_enlight(
        opts: &ImportOptions,
        map: Option<&Map>,
        map_origin: Option<&str>,
        m: &Map,
        input_name: &str,
    ) -> Result<Merged, TrainerError> {
        let peaks = enlight::read(&opts.input, map, map_origin.unwrap_or("map"), opts.on_error)?;
        let window_map = map.is_some_and(|m| !m.grating.is_empty());
        let n_g = peaks.nm.len();
        let mut merged = Merged {
            input: input_name.to_string(),
            lines: peaks.lines.clone(),
            t: peaks.t.clone(),
            kind: peaks.time_kind,
            absolute: peaks.absolute,
            time_column: "1 (time)".into(),
            ambient: None,
            refs: Vec::new(),
            wl: peaks.nm.clone(),
            is_shift: vec![false; n_g],
            ref_nm: (0..n_g).map(|g| if window_map { m.grating[g].ref_nm } else { None }).collect(),
            sources: peaks.layout.clone(),
            rows_read: peaks.problems.rows_read,
            skips: vec![peaks.problems.summary()],
            enlight: Some(EnlightInfo {
                channels: peaks.channels,
                delimiter: if peaks.delimiter == '\t' { "tab".into() } else { peaks.delimiter.to_string() },
                metadata_lines: peaks.metadata_lines,
                unassigned_rows: peaks.unassigned_rows,
                culture: peaks.culture.clone(),
                date_order: peaks.date_order.as_ref().map(|d| d.0),
                date_order_from: peaks.date_order.as_ref().map(|d| d.1.clone()),
            }),
            join: None,
            spectra: None,
            empty_hint: String::new(),
            n_before_drop: peaks.t.len(),
        };
        merged.join_refs_file(opts, m)?;
        Ok(merged)
    }

    /// A spectrum file (`--format spectra-csv|enlight-responses|pixels`): its peaks detected
    /// per grating and frame, then as an ENLIGHT peaks export (`--refs` joined the same way).
    pub(super) fn from_spectra(
        opts: &ImportOptions,
        map: Option<&Map>,
        map_origin: Option<&str>,
        m: &Map,
        input_name: &str,
    ) -> Result<Merged, TrainerError> {
        // Only what the import reads of each peak is kept (`Found`): a long file's frames.
        let read = spectra::read::<spectra::Found>(
            opts.format,
            &opts.input,
            map,
            map_origin.unwrap_or("map"),
            opts.scale,
            opts.on_error,
        )?;
        let (nm, info) = read.series(opts.format);
        let d = read.detected;
        let n_g = nm.len();
        let window_map = map.is_some_and(|m| !m.grating.is_empty());
        let mut merged = Merged {
            input: input_name.to_string(),
            n_before_drop: d.t.len(),
            lines: d.lines,
            t: d.t,
            kind: read.facts.time_kind,
            absolute: read.facts.absolute,
            time_column: read.facts.time_column.clone(),
            ambient: None,
            refs: Vec::new(),
            wl: nm,
            is_shift: vec![false; n_g],
            ref_nm: (0..n_g).map(|g| m.grating.get(g).filter(|_| window_map).and_then(|x| x.ref_nm)).collect(),
            sources: d.gratings.iter().map(|g| g.source.clone()).collect(),
            rows_read: read.facts.problems.rows_read,
            skips: vec![read.facts.problems.summary()],
            enlight: None,
            join: None,
            spectra: Some(info),
            empty_hint: String::new(),
        };
        merged.join_refs_file(opts, m)?;
        Ok(merged)
    }

    /// Peaks carry no ambient temperature and no references: they come from `--refs` when the
    /// installation has them; without, the peaks are a field record.
    fn join_refs_file(&mut self, opts: &ImportOptions, m: &Map) -> Result<(), TrainerError> {
        if let Some(refs_path) = &opts.refs {
            let refs = logger_csv::read(refs_path, m, None, opts.on_error)?;
            self.join_refs(&refs, &refs_path.display().to_string(), m)?;
        }
        Ok(())
    }

    /// Interpolate the refs file's ambient reading and references onto the peak times.
    fn join_refs(&mut self, refs: &LoggerTable, refs_name: &str, m: &Map) -> Result<(), TrainerError> {
        if refs.ambient.is_none() && refs.refs.is_empty() {
            return Err(TrainerError::data(
                refs_name,
                refs.header_line,
                T_AMB_COLUMN,
                "the refs file has neither an ambient temperature (T_amb_C, or the map's [ambient]) nor a reference column (T_C, strain_ue, p_kPa, strain2_ue, ..., or the map's [temperature], [strain], [pressure], [[measurand]]): nothing to join",
            ));
        }
        if self.absolute != refs.absolute {
            let (p, r) = (kind_words(self.absolute), kind_words(refs.absolute));
            let fix = if refs.absolute {
                "export the peaks with timestamps"
            } else {
                "set the map key time.start to the timestamp of t = 0 in the refs (or export the refs with timestamps)"
            };
            return Err(TrainerError::data(
                refs_name,
                refs.header_line,
                &refs.time_column,
                format!("the peaks file's times are {p} but the refs' time column holds {r}, so they cannot be joined: {fix}"),
            ));
        }
        let (max_gap_s, max_gap_source) = match m.max_gap_s {
            Some(g) => (g, "map".to_string()),
            None => (3.0 * join::median_spacing(&refs.t), "3 × median refs spacing".to_string()),
        };
        let peaks_t = &self.t;
        let at = |v: &[f64]| {
            let s = join::Series::new(&refs.t, v);
            peaks_t.iter().map(|&t| s.at(t, max_gap_s)).collect::<Vec<f64>>()
        };
        let absolute = self.absolute;
        let show = |t: f64| if absolute { format_timestamp(t) } else { format!("{t} s") };
        let join = JoinInfo {
            max_gap_s,
            max_gap_source,
            refs_rows: refs.t.len(),
            refs_start: show(refs.t[0]),
            refs_end: show(refs.t[refs.t.len() - 1]),
        };
        self.empty_hint = format!(
            "{}: no peak row has an ambient temperature from {refs_name}: the peaks span {} – {}, the refs {} – {} (max_gap_s = {max_gap_s})",
            self.input,
            show(peaks_t[0]),
            show(peaks_t[peaks_t.len() - 1]),
            join.refs_start,
            join.refs_end
        );
        self.ambient = refs.ambient.as_ref().map(|a| (a.name.clone(), at(&a.values)));
        self.refs = refs.refs.iter().map(|(mm, c)| (*mm, c.name.clone(), at(&c.values))).collect();
        self.skips.push(refs.problems.summary());
        self.join = Some(join);
        Ok(())
    }
}

fn kind_words(absolute: bool) -> &'static str {
    if absolute {
        "calendar timestamps"
    } else {
        "plain seconds"
    }
}
