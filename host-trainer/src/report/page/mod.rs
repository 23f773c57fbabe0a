//! `index.html`, section by section in the order the page shows them: the header with the
//! recorded warnings, the findings ([`results`]), the reference material ([`reference`]), the
//! provenance ([`provenance`]) and the list of files.

mod provenance;
mod reference;
mod results;

use std::path::Path;

use super::figures::{count, num, FigSpec};
use super::html::{self, esc, FigEntry, Section};
use super::{Inputs, Outcome, COEFFICIENTS_JSON, DATA_CSV, INDEX_HTML, METRICS_JSON, MODEL_H, MODEL_P};
use crate::eval::tables::Table;

/// What the page is made from.
pub(super) struct Page<'a> {
    /// The report's directory (to list the inputs present).
    pub(super) dir: &'a Path,
    pub(super) inp: &'a Inputs,
    pub(super) specs: &'a [FigSpec],
    /// metrics.json's tables, by file stem.
    pub(super) results: &'a [(&'static str, Table)],
    /// The coefficient and sensitivity tables, by file stem.
    pub(super) coefs: &'a [(String, Table)],
    /// The files written so far, the failed checks and the notes.
    pub(super) out: &'a Outcome,
    /// The data matched their re-simulation.
    pub(super) resimulated: bool,
    /// The date the report is generated (YYYYMMDD).
    pub(super) today: u32,
}

impl Page<'_> {
    /// The figure `stem` as the page shows it (empty when it was not drawn).
    fn fig(&self, stem: &str) -> String {
        self.specs
            .iter()
            .find(|f| f.stem == stem)
            .map(|f| {
                html::figure(&FigEntry { stem: f.stem.clone(), title: f.title.clone(), caption: f.caption.clone() })
            })
            .unwrap_or_default()
    }

    /// metrics.json's table `name` with links to its files (empty when metrics.json lacks it).
    fn table_of(&self, name: &str) -> String {
        self.results.iter().find(|(n, _)| *n == name).map(|(n, t)| html::table(t, Some(n))).unwrap_or_default()
    }
}

/// The page's HTML.
pub(super) fn page(p: &Page) -> String {
    let m = &p.inp.metrics;
    let title = if m.table2.oracle_floor.is_some() {
        format!("FBG compensation audit report — scenario “{}”, seed {}", m.scenario, m.seed)
    } else {
        format!("FBG compensation audit report — “{}” (recorded data)", m.scenario)
    };
    let mut header = format!(
        "<p>Model-P (polynomial core, paper Eq. 3) and Model-H (the same core plus an RBF residual, paper Eqs. 4–7) evaluated on the hold-out of {} samples. Report generated {} by fbg-trainer {} from the files in this directory; regenerate with <code>fbg-trainer report --out &lt;this directory&gt;</code>.</p>\n",
        count(m.holdout_samples),
        date(p.today),
        env!("CARGO_PKG_VERSION")
    );
    header.push_str(&warnings_block(&m.warnings));
    let mut sections = Vec::new();
    results::summary(p, &mut sections);
    results::table2(p, &mut sections);
    results::figures(p, &mut sections);
    results::other_studies(p, &mut sections);
    reference::coefficients(p, &mut sections);
    reference::device(p, &mut sections);
    sections.push(provenance::section(p));
    sections.push(files(p));
    html::page(&title, &header, &sections)
}

/// YYYYMMDD as YYYY-MM-DD.
fn date(yyyymmdd: u32) -> String {
    format!("{:04}-{:02}-{:02}", yyyymmdd / 10_000, yyyymmdd / 100 % 100, yyyymmdd % 100)
}

/// The warnings of metrics.json (`train`'s and `evaluate`'s), the first thing on the page: each
/// message with its channel and code, and the numbers behind it.
fn warnings_block(ws: &[crate::warning::Warning]) -> String {
    if ws.is_empty() {
        return "<p class=\"note\" id=\"warnings\"><strong>Warnings:</strong> none recorded in metrics.json (by <code>train</code> or <code>evaluate</code>).</p>\n".into();
    }
    let mut o = format!(
        "<div class=\"warn\" id=\"warnings\"><strong>{} recorded by <code>train</code> and <code>evaluate</code> (metrics.json):</strong>\n<ul>\n",
        if ws.len() == 1 { "1 warning".to_string() } else { format!("{} warnings", ws.len()) }
    );
    for w in ws {
        let numbers: Vec<String> = w.numbers.iter().map(|(k, v)| format!("{k} = {}", num(*v, 4))).collect();
        o.push_str(&format!(
            "<li>{}{} <span class=\"files\">({}{})</span></li>\n",
            w.channel.as_deref().map(|c| format!("<strong>{}:</strong> ", esc(c))).unwrap_or_default(),
            esc(&w.message),
            esc(&w.code),
            if numbers.is_empty() { String::new() } else { format!("; {}", esc(&numbers.join(", "))) }
        ));
    }
    o.push_str("</ul></div>\n");
    o
}

/// Every file of the report and the inputs present beside it.
fn files(p: &Page) -> Section {
    let (dir, out) = (p.dir, p.out);
    let mut body = String::from(
        "<p>Everything in this report, beside this page (no network access is needed to view it):</p>\n<ul>\n",
    );
    for f in &out.files {
        body.push_str(&format!("<li><a href=\"{0}\">{0}</a></li>\n", esc(f)));
    }
    body.push_str(&format!("<li><a href=\"{INDEX_HTML}\">{INDEX_HTML}</a> (this page)</li>\n"));
    for f in [DATA_CSV, "data.meta.json", METRICS_JSON, MODEL_H, MODEL_P, COEFFICIENTS_JSON] {
        if dir.join(f).is_file() {
            body.push_str(&format!("<li><a href=\"{0}\">{0}</a> (input)</li>\n", f));
        }
    }
    body.push_str("</ul>\n");
    Section { id: "files".into(), title: "Files".into(), body }
}
