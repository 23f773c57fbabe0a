//! `index.html`: one static page (no script, no network) that shows the figures (SVG beside
//! the page, PNG linked), every table, the scenario and the provenance, and the generated
//! summary.

use crate::eval::tables::Table;

/// Escape text for HTML (element content and double-quoted attributes).
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            _ => o.push(c),
        }
    }
    o
}

fn numeric(s: &str) -> bool {
    let t = s.trim_start_matches(['−', '-', '+', '×']);
    !t.is_empty() && t.chars().all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '-' | '+' | '–'))
}

/// A [`Table`] as an HTML table, with links to its Markdown and CSV files when `stem` is given.
pub fn table(t: &Table, stem: Option<&str>) -> String {
    let mut o = String::from("<div class=\"table\"><table>\n");
    o.push_str(&format!("<caption>{}", esc(&t.title)));
    if let Some(s) = stem {
        o.push_str(&format!(
            " <span class=\"files\">(<a href=\"{s}.md\">Markdown</a> · <a href=\"{s}.csv\">CSV</a>)</span>"
        ));
    }
    o.push_str("</caption>\n<thead><tr>");
    for h in &t.header {
        o.push_str(&format!("<th>{}</th>", esc(h)));
    }
    o.push_str("</tr></thead>\n<tbody>\n");
    for r in &t.rows {
        o.push_str("<tr>");
        for c in r {
            if numeric(c) {
                o.push_str(&format!("<td class=\"n\">{}</td>", esc(c)));
            } else {
                o.push_str(&format!("<td>{}</td>", esc(c)));
            }
        }
        o.push_str("</tr>\n");
    }
    o.push_str("</tbody></table></div>\n");
    o
}

/// A figure entry of the page.
pub struct FigEntry {
    pub stem: String,
    pub title: String,
    pub caption: String,
}

/// A section of the page.
pub struct Section {
    pub id: String,
    pub title: String,
    pub body: String,
}

/// Assemble the page.
pub fn page(title: &str, header_html: &str, sections: &[Section]) -> String {
    let mut o = String::new();
    o.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    o.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    o.push_str(&format!("<title>{}</title>\n<style>\n{CSS}</style>\n</head>\n<body>\n", esc(title)));
    o.push_str(&format!("<h1>{}</h1>\n", esc(title)));
    o.push_str(header_html);
    o.push_str("<nav><strong>Contents</strong><ol>\n");
    for s in sections {
        o.push_str(&format!("<li><a href=\"#{}\">{}</a></li>\n", s.id, esc(&s.title)));
    }
    o.push_str("</ol></nav>\n");
    for s in sections {
        o.push_str(&format!("<section id=\"{}\">\n<h2>{}</h2>\n{}</section>\n", s.id, esc(&s.title), s.body));
    }
    o.push_str("</body>\n</html>\n");
    o
}

/// One figure block: the SVG inline as an image beside the page, the PNG linked.
pub fn figure(f: &FigEntry) -> String {
    format!(
        "<figure id=\"{s}\">\n<a href=\"{s}.svg\"><img src=\"{s}.svg\" alt=\"{t}\" loading=\"lazy\"></a>\n<figcaption><strong>{t}.</strong> {c} <span class=\"files\">(<a href=\"{s}.svg\">SVG</a> · <a href=\"{s}.png\">PNG</a>)</span></figcaption>\n</figure>\n",
        s = f.stem,
        t = esc(&f.title),
        c = esc(&f.caption)
    )
}

/// A definition list of (term, value) pairs.
pub fn facts(rows: &[(String, String)]) -> String {
    let mut o = String::from("<table class=\"facts\"><tbody>\n");
    for (k, v) in rows {
        o.push_str(&format!("<tr><th>{}</th><td>{}</td></tr>\n", esc(k), esc(v)));
    }
    o.push_str("</tbody></table>\n");
    o
}

const CSS: &str = r#"body { font-family: "DejaVu Sans", Verdana, Arial, sans-serif; max-width: 1180px; margin: 2em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: .2em; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
nav { background: #f6f6f6; padding: .6em 1em; border: 1px solid #e2e2e2; }
nav ol { margin: .3em 0; columns: 2; }
figure { margin: 1.5em 0; }
figure img { width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .92em; color: #333; margin-top: .4em; }
.table { overflow-x: auto; margin: 1em 0; }
table { border-collapse: collapse; font-size: .88em; }
caption { text-align: left; font-weight: bold; padding: .3em 0; caption-side: top; }
th, td { border: 1px solid #d4d4d4; padding: .25em .5em; }
th { background: #f0f0f0; text-align: left; }
td.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.facts th { width: 16em; }
.files { font-weight: normal; font-size: .9em; }
.warn { background: #fff3cd; border: 1px solid #e0c36b; padding: .6em 1em; }
.note { background: #eef4fb; border: 1px solid #b8cfe8; padding: .6em 1em; }
.summary p { margin: .6em 0; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; font-size: .85em; }
@media print { nav { display: none; } figure { page-break-inside: avoid; } }
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup() {
        assert_eq!(esc("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }

    #[test]
    fn tables_render_with_numeric_cells_right_aligned() {
        let t = Table {
            title: "T<1>".into(),
            header: vec!["a".into(), "b".into()],
            rows: vec![vec!["x".into(), "−0.12".into()]],
        };
        let h = table(&t, Some("table9"));
        assert!(h.contains("T&lt;1&gt;"));
        assert!(h.contains("<td class=\"n\">−0.12</td>"));
        assert!(h.contains("href=\"table9.csv\""));
    }
}
