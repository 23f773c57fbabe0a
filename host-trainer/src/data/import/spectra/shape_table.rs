//! A grating's reflection shape as a template, and the template fit of a frame's peak
//! ([`fbg_shared::spectrum::template::template_fit`]): the simulator's design tables and a
//! measured scan given in an import map ([`super::shape`]) are both a [`ShapeTable`].

use fbg_shared::spectrum::template::template_fit;
use fbg_shared::spectrum::{Region, Spectrum, Template, Threshold};

/// Template tables' step \[nm\] and half-span \[nm\]: 1 pm, a few hundredths of a 512-pixel
/// spectrometer's pixel, over the main lobe and the first side lobes of a 0.3 nm grating.
const TEMPLATE_STEP_NM: f64 = 0.001;
const TEMPLATE_HALF_SPAN_NM: f64 = 1.5;

/// A grating's reflection shape (its design, or a measured scan), tabulated at
/// [`TEMPLATE_STEP_NM`] from `first_offset_nm` about its centre (x = 0: the wavelength a fit
/// of it reports).
#[derive(Clone, Debug)]
pub(crate) struct ShapeTable {
    values: Vec<f64>,
    first_offset_nm: f64,
}

impl ShapeTable {
    /// The shape `r(x)` at offsets x \[nm\] from the centre, tabulated over ±[`TEMPLATE_HALF_SPAN_NM`].
    pub(crate) fn from_fn(r: impl Fn(f64) -> f64) -> ShapeTable {
        let n = (TEMPLATE_HALF_SPAN_NM / TEMPLATE_STEP_NM).round() as i64;
        ShapeTable {
            values: (-n..=n).map(|k| r(k as f64 * TEMPLATE_STEP_NM)).collect(),
            first_offset_nm: -(n as f64) * TEMPLATE_STEP_NM,
        }
    }

    /// The table as a template ([`fbg_shared::spectrum::Template`]); `None` with a value that
    /// is not finite.
    pub(crate) fn template(&self) -> Option<Template<'_, f64>> {
        Template::new(&self.values, self.first_offset_nm, TEMPLATE_STEP_NM)
    }

    /// A measured shape (a swept-laser scan of the grating: wavelengths \[nm\], increasing,
    /// and reflectance, linear) tabulated like a design, at the same step about `centre_nm`
    /// (the wavelength the fit reports), over the same half-span or the scan's own range where
    /// that is shorter (0 beyond, as a template reads). `None` when that leaves fewer than two
    /// values or one that is not finite (the caller checks the scan and picks the centre:
    /// [`super::shape`]).
    pub(crate) fn from_scan(wavelength_nm: &[f64], reflectance: &[f64], centre_nm: f64) -> Option<ShapeTable> {
        if wavelength_nm.len() < 2 || wavelength_nm.len() != reflectance.len() {
            return None;
        }
        let (&first, &last) = (wavelength_nm.first()?, wavelength_nm.last()?);
        let steps = |x: f64| (x / TEMPLATE_STEP_NM).floor() as i64;
        let lo = (-steps(TEMPLATE_HALF_SPAN_NM)).max(-steps(centre_nm - first));
        let hi = steps(TEMPLATE_HALF_SPAN_NM).min(steps(last - centre_nm));
        let values: Vec<f64> = (lo..=hi)
            .map(|k| {
                let x = centre_nm + k as f64 * TEMPLATE_STEP_NM;
                let j = wavelength_nm.partition_point(|&w| w <= x).clamp(1, wavelength_nm.len() - 1);
                let (w0, w1, r0, r1) = (wavelength_nm[j - 1], wavelength_nm[j], reflectance[j - 1], reflectance[j]);
                r0 + (r1 - r0) * (x - w0) / (w1 - w0)
            })
            .collect();
        let table = ShapeTable { values, first_offset_nm: lo as f64 * TEMPLATE_STEP_NM };
        (table.values.len() >= 2 && table.template().is_some()).then_some(table)
    }
}

/// The template fit in window `w` from the method's peak at `pixel` (of the whole frame);
/// `None` where the window or the fit fails.
pub(crate) fn refine(
    spectrum: &Spectrum<'_, f64>,
    w: &fbg_shared::spectrum::Window<f64>,
    t: &Template<'_, f64>,
    pixel: f64,
) -> Option<f64> {
    let span = w.span(spectrum)?;
    let samples = spectrum.samples().get(span.first..=span.last)?;
    let region = Region::new(samples, Threshold::default());
    let e = template_fit(&region, spectrum.grid(), span.first, t, pixel - span.first as f64)?;
    Some(spectrum.grid().wavelength(span.first as f64 + e.pixel))
}
