//! A small figure model on top of `plotters`: a figure is a titled grid of panels, a panel is
//! bands, lines, dots and notes in data coordinates. One drawing routine serves the PNG
//! (bitmap, text by `ab_glyph` with the bundled font) and the SVG backend, so both files of a
//! figure always show the same thing.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::fonts::{self, FAMILY};
use crate::data::files::write_bytes_atomically;
use crate::error::TrainerError;

/// Okabe–Ito colours (distinguishable with the common colour-vision deficiencies).
pub(crate) const C_TRUTH: RGBColor = RGBColor(20, 20, 20);
pub(crate) const C_P: RGBColor = RGBColor(213, 94, 0);
pub(crate) const C_H: RGBColor = RGBColor(0, 114, 178);
pub(crate) const C_MEAS: RGBColor = RGBColor(230, 159, 0);
pub(crate) const C_GREY: RGBColor = RGBColor(110, 110, 110);
/// The tint of a zoom window (Okabe–Ito yellow), distinct from the grey of the hold-out shade.
pub const C_ZOOM: RGBColor = RGBColor(240, 228, 66);

/// Where a panel's legend goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Legend {
    None,
    UpperLeft,
    UpperRight,
    LowerLeft,
    LowerRight,
}

/// A polyline.
#[derive(Clone, Debug)]
pub struct Line {
    pub label: Option<String>,
    pub color: RGBColor,
    pub width: u32,
    pub dashed: bool,
    pub pts: Vec<(f64, f64)>,
}

impl Line {
    pub fn new(color: RGBColor, width: u32, pts: Vec<(f64, f64)>) -> Self {
        Line { label: None, color, width, dashed: false, pts }
    }
    pub fn label(mut self, s: impl Into<String>) -> Self {
        self.label = Some(s.into());
        self
    }
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

/// A filled polygon (a band: upper edge forward, lower edge back).
#[derive(Clone, Debug)]
pub struct Band {
    pub label: Option<String>,
    pub color: RGBColor,
    pub alpha: f64,
    pub poly: Vec<(f64, f64)>,
    /// Drawn as vertical hatch lines at every `period`-th point of the upper edge, starting at
    /// `offset`, instead of a fill: two bands hatched with different offsets interleave where
    /// they overlap, so no blended colour appears that the legend does not show. Only for
    /// bands built by [`Band::between`].
    pub hatch: Option<(usize, usize)>,
}

impl Band {
    /// The band between `lo` and `hi` over `x`.
    pub fn between(color: RGBColor, alpha: f64, x: &[f64], lo: &[f64], hi: &[f64]) -> Self {
        let mut poly: Vec<(f64, f64)> = x.iter().copied().zip(hi.iter().copied()).collect();
        poly.extend(x.iter().copied().zip(lo.iter().copied()).rev());
        Band { label: None, color, alpha, poly, hatch: None }
    }
    pub fn label(mut self, s: impl Into<String>) -> Self {
        self.label = Some(s.into());
        self
    }
    /// Hatch instead of fill (see [`Band::hatch`]).
    pub fn hatched(mut self, period: usize, offset: usize) -> Self {
        self.hatch = Some((period.max(1), offset));
        self
    }
    /// The hatch segments: (x, hi) to (x, lo) at every `period`-th x from `offset`.
    fn hatch_segments(&self, period: usize, offset: usize) -> Vec<[(f64, f64); 2]> {
        let n = self.poly.len() / 2;
        (offset..n).step_by(period).map(|i| [self.poly[i], self.poly[2 * n - 1 - i]]).collect()
    }
}

/// Scatter points.
#[derive(Clone, Debug)]
pub struct Dots {
    pub label: Option<String>,
    pub color: RGBColor,
    pub alpha: f64,
    pub radius: u32,
    pub filled: bool,
    pub pts: Vec<(f64, f64)>,
}

/// Text at a position given as fractions of the panel's data ranges (0,0 = lower left),
/// anchored at its top-left corner.
#[derive(Clone, Debug)]
pub struct Note {
    pub text: String,
    pub at: (f64, f64),
    pub color: RGBColor,
}

/// One chart.
#[derive(Clone, Debug)]
pub struct Panel {
    pub caption: String,
    pub xlabel: String,
    pub ylabel: String,
    /// Ranges; computed from the content when absent.
    pub xr: Option<(f64, f64)>,
    pub yr: Option<(f64, f64)>,
    /// Fraction of the span added on each side of an automatic range.
    pub x_pad: f64,
    pub y_pad: f64,
    /// Extra room above the content (fraction of its span) so that an upper legend does not
    /// cover data.
    pub legend_room: f64,
    /// Shaded x intervals (e.g. the hold-out) with their grey level (alpha of black).
    pub shade: Vec<(f64, f64, f64)>,
    /// Zoom windows shown elsewhere in the figure, tinted [`C_ZOOM`] (not grey).
    pub zoom: Vec<(f64, f64)>,
    /// Vertical dashed lines.
    pub vlines: Vec<f64>,
    pub bands: Vec<Band>,
    pub lines: Vec<Line>,
    pub dots: Vec<Dots>,
    pub notes: Vec<Note>,
    pub legend: Legend,
}

impl Panel {
    pub fn new(caption: impl Into<String>, xlabel: impl Into<String>, ylabel: impl Into<String>) -> Self {
        Panel {
            caption: caption.into(),
            xlabel: xlabel.into(),
            ylabel: ylabel.into(),
            xr: None,
            yr: None,
            x_pad: 0.0,
            y_pad: 0.05,
            legend_room: 0.0,
            shade: vec![],
            zoom: vec![],
            vlines: vec![],
            bands: vec![],
            lines: vec![],
            dots: vec![],
            notes: vec![],
            legend: Legend::UpperRight,
        }
    }
    pub fn note(&mut self, text: impl Into<String>, at: (f64, f64)) {
        self.notes.push(Note { text: text.into(), at, color: RGBColor(30, 30, 30) });
    }

    fn content_range(&self, axis: usize) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut take = |p: &(f64, f64)| {
            let v = if axis == 0 { p.0 } else { p.1 };
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        };
        self.bands.iter().flat_map(|b| b.poly.iter()).for_each(&mut take);
        self.lines.iter().flat_map(|l| l.pts.iter()).for_each(&mut take);
        self.dots.iter().flat_map(|d| d.pts.iter()).for_each(&mut take);
        (lo, hi)
    }

    fn range(&self, axis: usize) -> (f64, f64) {
        let (given, pad, room) =
            if axis == 0 { (self.xr, self.x_pad, 0.0) } else { (self.yr, self.y_pad, self.legend_room) };
        let (lo, hi) = given.unwrap_or_else(|| {
            let (lo, hi) = self.content_range(axis);
            let s = hi - lo;
            (lo - pad * s, hi + (pad + room) * s)
        });
        if !(lo.is_finite() && hi.is_finite()) {
            return (0.0, 1.0);
        }
        if hi - lo <= 1e-12 * (1.0 + lo.abs()) {
            let d = 0.5 * (1.0 + lo.abs() * 1e-3);
            return (lo - d, hi + d);
        }
        (lo, hi)
    }
}

/// A titled grid of panels.
#[derive(Clone, Debug)]
pub struct Grid {
    pub size: (u32, u32),
    pub title: String,
    /// One line under the title: what to look for.
    pub subtitle: String,
    pub rows: usize,
    pub cols: usize,
    pub panels: Vec<Panel>,
}

fn pe<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Decimals for tick labels on an axis spanning `span`.
pub(crate) fn decimals_for(span: f64) -> usize {
    if span.is_nan() || span <= 0.0 || !span.is_finite() {
        return 2;
    }
    let step = span / 6.0;
    (-step.log10()).ceil().clamp(0.0, 8.0) as usize
}

fn tick_fmt(span: f64) -> impl Fn(&f64) -> String {
    let d = decimals_for(span);
    move |v: &f64| {
        let s = format!("{v:.d$}");
        if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
            s[1..].to_string()
        } else {
            s
        }
    }
}

fn position(l: Legend) -> SeriesLabelPosition {
    match l {
        Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
        Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        Legend::LowerRight => SeriesLabelPosition::LowerRight,
        _ => SeriesLabelPosition::UpperRight,
    }
}

/// `segmented`: draw thick lines one segment at a time. The bitmap rasteriser joins the
/// segments of a thick polyline with unbounded miters, which shoot across the figure where a
/// noisy trace reverses; separate segments have no joins.
fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel, segmented: bool) -> Result<(), String> {
    let (x0, x1) = p.range(0);
    let (y0, y1) = p.range(1);
    let mut chart = ChartBuilder::on(area)
        .caption(p.caption.as_str(), (FAMILY, 19))
        .margin(8)
        .margin_right(26)
        .x_label_area_size(50)
        .y_label_area_size(88)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(pe)?;
    let xf = tick_fmt(x1 - x0);
    let yf = tick_fmt(y1 - y0);
    chart
        .configure_mesh()
        .x_desc(p.xlabel.as_str())
        .y_desc(p.ylabel.as_str())
        .axis_desc_style((FAMILY, 17))
        .label_style((FAMILY, 14))
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .x_labels(10)
        .y_labels(7)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(pe)?;
    for &(a, b, g) in &p.shade {
        chart.draw_series(std::iter::once(Rectangle::new([(a, y0), (b, y1)], BLACK.mix(g).filled()))).map_err(pe)?;
    }
    for &(a, b) in &p.zoom {
        chart
            .draw_series(std::iter::once(Rectangle::new([(a, y0), (b, y1)], C_ZOOM.mix(0.35).filled())))
            .map_err(pe)?;
    }
    let labelled = draw_bands(&mut chart, p)? | draw_lines(&mut chart, p, segmented)? | draw_dots(&mut chart, p)?;
    for &x in &p.vlines {
        chart.draw_series(DashedLineSeries::new(vec![(x, y0), (x, y1)], 7, 5, C_GREY.stroke_width(2))).map_err(pe)?;
    }
    for n in &p.notes {
        let pos = (x0 + n.at.0 * (x1 - x0), y0 + n.at.1 * (y1 - y0));
        let style = TextStyle::from((FAMILY, 15).into_font()).color(&n.color);
        chart.draw_series(std::iter::once(Text::new(n.text.clone(), pos, style))).map_err(pe)?;
    }
    if labelled && p.legend != Legend::None {
        chart
            .configure_series_labels()
            .label_font((FAMILY, 15))
            .background_style(WHITE.mix(0.88))
            .border_style(RGBColor(160, 160, 160))
            .position(position(p.legend))
            .margin(8)
            .draw()
            .map_err(pe)?;
    }
    Ok(())
}

/// A panel's chart: data coordinates on both axes.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The bands (hatched or filled) with their legend swatches; true when one has a label.
fn draw_bands<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>, p: &Panel) -> Result<bool, String> {
    let mut labelled = false;
    for b in &p.bands {
        if let Some((period, offset)) = b.hatch {
            let st = b.color.mix(b.alpha).stroke_width(1);
            let anno = chart
                .draw_series(b.hatch_segments(period, offset).into_iter().map(|s| PathElement::new(s.to_vec(), st)))
                .map_err(pe)?;
            if let Some(l) = &b.label {
                labelled = true;
                // The swatch is hatched the same way: vertical strokes of the band's colour.
                anno.label(l.clone()).legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, -6), (0, 6)], st)
                        + PathElement::new(vec![(6, -6), (6, 6)], st)
                        + PathElement::new(vec![(12, -6), (12, 6)], st)
                        + PathElement::new(vec![(18, -6), (18, 6)], st)
                        + PathElement::new(vec![(24, -6), (24, 6)], st)
                });
            }
            continue;
        }
        let st = b.color.mix(b.alpha).filled();
        let anno = chart.draw_series(std::iter::once(Polygon::new(b.poly.clone(), st))).map_err(pe)?;
        if let Some(l) = &b.label {
            labelled = true;
            anno.label(l.clone()).legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 24, y + 6)], st));
        }
    }
    Ok(labelled)
}

/// The lines (dashed, segmented for bitmaps when thick, or plain) with their legend entries;
/// true when one has a label.
fn draw_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    segmented: bool,
) -> Result<bool, String> {
    let mut labelled = false;
    for l in &p.lines {
        let st = l.color.stroke_width(l.width);
        let anno = if l.dashed {
            chart.draw_series(DashedLineSeries::new(l.pts.iter().copied(), 9, 6, st))
        } else if segmented && l.width > 1 {
            chart.draw_series(l.pts.windows(2).map(|w| PathElement::new(vec![w[0], w[1]], st)))
        } else {
            chart.draw_series(LineSeries::new(l.pts.iter().copied(), st))
        }
        .map_err(pe)?;
        if let Some(lab) = &l.label {
            labelled = true;
            let lw = st.stroke_width.max(3);
            let c = l.color;
            if l.dashed {
                // Dashed in the legend too: three dashes with two gaps.
                anno.label(lab.clone()).legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (6, 0)], c.stroke_width(lw))
                        + PathElement::new(vec![(10, 0), (15, 0)], c.stroke_width(lw))
                        + PathElement::new(vec![(19, 0), (24, 0)], c.stroke_width(lw))
                });
            } else {
                anno.label(lab.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(lw)));
            }
        }
    }
    Ok(labelled)
}

/// The dots with their legend entries; true when one has a label.
fn draw_dots<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>, p: &Panel) -> Result<bool, String> {
    let mut labelled = false;
    for d in &p.dots {
        let st = if d.filled { d.color.mix(d.alpha).filled() } else { d.color.mix(d.alpha).stroke_width(2) };
        let r = d.radius;
        let anno = chart.draw_series(d.pts.iter().map(|&(x, y)| Circle::new((x, y), r, st))).map_err(pe)?;
        if let Some(l) = &d.label {
            labelled = true;
            let lst = if d.filled { d.color.filled() } else { d.color.stroke_width(2) };
            anno.label(l.clone()).legend(move |(x, y)| Circle::new((x + 12, y), r.max(4), lst));
        }
    }
    Ok(labelled)
}

impl Grid {
    /// Draw the figure on any backend (`segmented` for bitmaps, see `draw_panel`).
    pub fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, segmented: bool) -> Result<(), String> {
        root.fill(&WHITE).map_err(pe)?;
        let (top, body) = root.split_vertically(78);
        top.draw_text(&self.title, &TextStyle::from((FAMILY, 26).into_font()).color(&BLACK), (16, 10)).map_err(pe)?;
        top.draw_text(
            &self.subtitle,
            &TextStyle::from((FAMILY, 17).into_font()).color(&RGBColor(70, 70, 70)),
            (16, 46),
        )
        .map_err(pe)?;
        let areas = body.split_evenly((self.rows, self.cols));
        for (a, p) in areas.iter().zip(&self.panels) {
            draw_panel(a, p, segmented)?;
        }
        Ok(())
    }

    /// PNG bytes (RGB, 8 bit).
    pub fn png(&self) -> Result<Vec<u8>, String> {
        fonts::ensure_registered();
        let (w, h) = self.size;
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            self.draw(&root, true)?;
            root.present().map_err(pe)?;
        }
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
            let mut wr = enc.write_header().map_err(pe)?;
            wr.write_image_data(&buf).map_err(pe)?;
        }
        Ok(out)
    }

    /// SVG text.
    pub fn svg(&self) -> Result<String, String> {
        fonts::ensure_registered();
        let mut s = String::new();
        {
            let root = SVGBackend::with_string(&mut s, self.size).into_drawing_area();
            self.draw(&root, false)?;
            root.present().map_err(pe)?;
        }
        Ok(s)
    }

    /// Write `<stem>.png` and `<stem>.svg` into `dir`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<(), TrainerError> {
        let fail = |ext: &str, e: String| {
            let p = dir.join(format!("{stem}.{ext}"));
            TrainerError::io(&p, std::io::Error::other(format!("drawing the figure failed: {e}")))
        };
        let png = self.png().map_err(|e| fail("png", e))?;
        write_bytes_atomically(&dir.join(format!("{stem}.png")), &png)?;
        let svg = self.svg().map_err(|e| fail("svg", e))?;
        write_bytes_atomically(&dir.join(format!("{stem}.svg")), svg.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_decimals_follow_the_span() {
        assert_eq!(decimals_for(60.0), 0);
        assert_eq!(decimals_for(3.0), 1);
        assert_eq!(decimals_for(0.5), 2);
        let f = tick_fmt(1.0);
        assert_eq!(f(&-0.0001), "0.0");
        assert_eq!(f(&-0.5), "-0.5");
    }

    #[test]
    fn a_small_grid_renders_to_png_and_svg() {
        let mut p = Panel::new("a panel", "x [s]", "y [pm]");
        p.lines
            .push(Line::new(C_H, 2, (0..100).map(|i| (i as f64, (i as f64 / 10.0).sin())).collect()).label("Model-H"));
        p.note("RMSE 1.0 µε", (0.02, 0.95));
        let g = Grid { size: (400, 300), title: "T".into(), subtitle: "s".into(), rows: 1, cols: 1, panels: vec![p] };
        let png = g.png().unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let svg = g.svg().unwrap();
        assert!(svg.contains("<svg") && svg.contains("Model-H") && svg.contains("µε"));
    }
}
