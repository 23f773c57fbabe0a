//! A fibre Bragg grating's reflection spectrum from coupled-mode theory: the closed form of a
//! uniform grating and the piecewise-uniform transfer-matrix method (Yamada & Sakuda 1987;
//! Erdogan, "Fiber grating spectra", J. Lightwave Technol. 15, 1277, 1997) for an apodised one.
//!
//! # Coupled-mode theory (Erdogan's notation)
//!
//! A grating of length L with index modulation δn(z) = Δn·g(z)·cos(2πz/Λ) (g the apodisation,
//! max 1; "pure" apodisation: the average index change is the same all along, so it only moves
//! the Bragg wavelength and is folded into it) couples the forward and backward modes with
//!
//! - the AC coupling κ(z) = π·Δn·g(z)/λ \[1/m\];
//! - the detuning σ̂ = δ = 2π·n_eff·(1/λ − 1/λ_B) \[1/m\], λ_B = 2·n_eff·Λ the Bragg wavelength
//!   (with pure apodisation, the wavelength of the peak: σ̂ = 0).
//!
//! A uniform grating (g = 1) reflects, with γ = √(κ² − σ̂²),
//!
//! R(λ) = sinh²(γL) / (cosh²(γL) − σ̂²/κ²),
//!
//! a main lobe of peak R = tanh²(κL) at λ_B, zeros where √(σ̂² − κ²)·L = mπ — the first at
//! σ̂ = ±√(κ² + (π/L)²), i.e. Δλ₀ ≈ ±λ²·√(κ² + (π/L)²)/(2π·n_eff) — and side lobes between
//! (the first ≈ 4.7 % of a weak grating's peak). The transfer matrix of a section of length Δz
//! and constant κ is
//!
//! F = [[cosh(γΔz) − i(σ̂/γ)sinh(γΔz), −i(κ/γ)sinh(γΔz)],
//!      [i(κ/γ)sinh(γΔz), cosh(γΔz) + i(σ̂/γ)sinh(γΔz)]],
//!
//! γ complex when |σ̂| > κ; the grating's is the product of its sections', F = F_M·…·F_1, and
//! its amplitude reflectivity r = F₂₁/F₁₁ (R(L/2) = 1, S(L/2) = 0 at the far end). At σ̂ = 0 and
//! any real κ(z), r = tanh(∫κ dz): the peak of an apodised grating is tanh²(∫κ dz) too.

use num_complex::Complex64;

use crate::error::TrainerError;

/// The fibre core's effective index (SMF-28 at 1550 nm).
pub const N_EFF: f64 = 1.447;

/// 4·ln 2: a Gaussian of FWHM w is exp(−4 ln2·x²/w²).
const FOUR_LN2: f64 = 4.0 * std::f64::consts::LN_2;

/// The apodisation profile g(z) of the index modulation, 0 ≤ z ≤ L, maximum 1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Apodisation {
    /// g = 1: the sinc²-like spectrum with its side lobes.
    #[default]
    Uniform,
    /// g = exp(−4 ln2·(z − L/2)²/(L/3)²): a Gaussian of FWHM L/3 (side lobes suppressed by
    /// orders of magnitude).
    Gaussian,
    /// g = sin²(πz/L) = ½(1 − cos(2πz/L)).
    RaisedCosine,
}

impl Apodisation {
    /// g at the relative position u = z/L ∈ \[0, 1\].
    pub fn at(self, u: f64) -> f64 {
        match self {
            Apodisation::Uniform => 1.0,
            Apodisation::Gaussian => {
                let x = (u - 0.5) * 3.0;
                (-FOUR_LN2 * x * x).exp()
            }
            Apodisation::RaisedCosine => {
                let s = (std::f64::consts::PI * u).sin();
                s * s
            }
        }
    }

    /// Its name (`uniform`, `gaussian`, `raised-cosine`).
    pub fn name(self) -> &'static str {
        match self {
            Apodisation::Uniform => "uniform",
            Apodisation::Gaussian => "gaussian",
            Apodisation::RaisedCosine => "raised-cosine",
        }
    }
}

/// One grating: its apodisation, length and index modulation. The Bragg wavelength is an
/// argument of [`GratingDesign::reflectivity`] (it is what the measurands move).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GratingDesign {
    /// The apodisation g(z).
    pub apodisation: Apodisation,
    /// Grating length L \[mm\].
    pub length_mm: f64,
    /// Peak amplitude Δn of the index modulation (dimensionless; κ = π·Δn·g/λ).
    pub delta_n: f64,
    /// Effective index n_eff of the guided mode.
    pub n_eff: f64,
    /// Uniform sections of the transfer-matrix method (1 is exact for a uniform grating).
    pub sections: usize,
}

/// Sections of an apodised grating's transfer matrix (Erdogan: a few tens suffice for a smooth
/// profile; more cost time only once, when the spectrum is tabulated).
pub const APODISED_SECTIONS: usize = 100;

/// The default FWHM of a simulated grating \[nm\] (the 0.3 nm).
pub const DEFAULT_FWHM_NM: f64 = 0.3;

/// The default peak reflectivity of a simulated grating.
pub const DEFAULT_PEAK_REFLECTIVITY: f64 = 0.5;

/// Peak reflectivities a design accepts lie strictly between 0 and this: a grating that
/// reflects everything has no transmission left to read the next one through.
pub const PEAK_REFLECTIVITY_MAX: f64 = 0.9999;

impl GratingDesign {
    /// AC coupling κ = π·Δn·g/λ \[1/m\] at wavelength `lambda_nm` and apodisation value `g`.
    pub fn kappa_per_m(&self, lambda_nm: f64, g: f64) -> f64 {
        std::f64::consts::PI * self.delta_n * g / (lambda_nm * 1e-9)
    }

    /// Detuning σ̂ = 2π·n_eff·(1/λ − 1/λ_B) \[1/m\].
    pub fn detuning_per_m(&self, bragg_nm: f64, lambda_nm: f64) -> f64 {
        std::f64::consts::TAU * self.n_eff * (1.0 / (lambda_nm * 1e-9) - 1.0 / (bragg_nm * 1e-9))
    }

    /// The mean of g over the sections (the midpoint of each): ∫κ dz = κ_max·L·mean.
    fn mean_profile(&self) -> f64 {
        let g = self.section_profile();
        g.iter().sum::<f64>() / g.len() as f64
    }

    /// Power reflectivity R(λ) ∈ \[0, 1\] of the grating at Bragg wavelength `bragg_nm`, by the
    /// transfer-matrix method over [`GratingDesign::sections`] sections (module docs).
    pub fn reflectivity(&self, bragg_nm: f64, lambda_nm: f64) -> f64 {
        self.spectrum(bragg_nm)(lambda_nm)
    }

    /// λ ↦ R(λ) ([`GratingDesign::reflectivity`]) with the apodisation of each section evaluated
    /// once for every wavelength asked: what a caller tabulating or searching the spectrum uses.
    pub fn spectrum(&self, bragg_nm: f64) -> impl Fn(f64) -> f64 + '_ {
        let g = self.section_profile();
        move |lambda_nm| self.reflectivity_over(&g, bragg_nm, lambda_nm)
    }

    /// The apodisation g at the midpoint of each section.
    fn section_profile(&self) -> Vec<f64> {
        let m = self.sections.max(1);
        (0..m).map(|i| self.apodisation.at((i as f64 + 0.5) / m as f64)).collect()
    }

    /// The transfer matrix of the sections of profile `g`. A section's γ² = κ² − σ̂² is real, so
    /// γ is real (inside the stop band: cosh, sinh) or imaginary (outside: cos, sin): each
    /// section costs two real functions, not the complex square root, cosh and sinh.
    fn reflectivity_over(&self, g: &[f64], bragg_nm: f64, lambda_nm: f64) -> f64 {
        let dz = self.length_mm * 1e-3 / g.len().max(1) as f64;
        let sigma = self.detuning_per_m(bragg_nm, lambda_nm);
        let one = Complex64::new(1.0, 0.0);
        let (mut f11, mut f12, mut f21, mut f22) = (one, Complex64::default(), Complex64::default(), one);
        for &gi in g {
            let kappa = self.kappa_per_m(lambda_nm, gi);
            let g2 = kappa * kappa - sigma * sigma;
            // cosh(γΔz) and sinh(γΔz)/γ (→ Δz as γ → 0), both real.
            let (ch, s) = if g2 >= 0.0 {
                let gamma = g2.sqrt();
                let x = gamma * dz;
                (x.cosh(), if x < 1e-8 { dz } else { x.sinh() / gamma })
            } else {
                let q = (-g2).sqrt();
                let x = q * dz;
                let (sin, cos) = x.sin_cos();
                (cos, if x < 1e-8 { dz } else { sin / q })
            };
            // A = [[ch − iσ̂s, −iκs], [iκs, ch + iσ̂s]].
            let a11 = Complex64::new(ch, -sigma * s);
            let a22 = Complex64::new(ch, sigma * s);
            let k = kappa * s;
            let minus_ik = |z: Complex64| Complex64::new(k * z.im, -k * z.re);
            let plus_ik = |z: Complex64| Complex64::new(-k * z.im, k * z.re);
            // F ← A·F (the sections from the far end, z = L, to the input, z = 0).
            (f11, f12, f21, f22) = (
                a11 * f11 + minus_ik(f21),
                a11 * f12 + minus_ik(f22),
                plus_ik(f11) + a22 * f21,
                plus_ik(f12) + a22 * f22,
            );
        }
        let r = f21 / f11;
        r.norm_sqr()
    }

    /// The closed form of a uniform grating (module docs), whatever the apodisation field says:
    /// R = sinh²(γL)/(cosh²(γL) − σ̂²/κ²), continued through |σ̂| > κ (γ imaginary).
    pub fn uniform_reflectivity(&self, bragg_nm: f64, lambda_nm: f64) -> f64 {
        let kappa = self.kappa_per_m(lambda_nm, 1.0);
        let sigma = self.detuning_per_m(bragg_nm, lambda_nm);
        let l = self.length_mm * 1e-3;
        let g2 = kappa * kappa - sigma * sigma;
        if g2 >= 0.0 {
            let s = (g2.sqrt() * l).sinh();
            let c = (g2.sqrt() * l).cosh();
            s * s / (c * c - sigma * sigma / (kappa * kappa))
        } else {
            // sinh(iqL) = i·sin(qL), cosh(iqL) = cos(qL).
            let q = (-g2).sqrt();
            let s = (q * l).sin();
            let c = (q * l).cos();
            -(s * s) / (c * c - sigma * sigma / (kappa * kappa))
        }
    }

    /// Peak reflectivity tanh²(∫κ dz) at λ_B (exact for pure apodisation).
    pub fn peak_reflectivity(&self, bragg_nm: f64) -> f64 {
        let kl = self.kappa_per_m(bragg_nm, 1.0) * self.length_mm * 1e-3 * self.mean_profile();
        kl.tanh().powi(2)
    }

    /// Full width at half maximum of the main lobe \[nm\]: the half-maximum crossings either side
    /// of λ_B, bracketed in 1 pm steps and refined by bisection. NaN when none within 20 nm.
    pub fn fwhm_nm(&self, bragg_nm: f64) -> f64 {
        let r = self.spectrum(bragg_nm);
        let half = 0.5 * r(bragg_nm);
        let crossing = |dir: f64| -> f64 {
            let step = 1e-3;
            let mut inside = 0.0;
            for k in 1..=20_000 {
                let x = k as f64 * step;
                if r(bragg_nm + dir * x) < half {
                    let (mut a, mut b) = (inside, x);
                    for _ in 0..50 {
                        let mid = 0.5 * (a + b);
                        if r(bragg_nm + dir * mid) >= half {
                            a = mid;
                        } else {
                            b = mid;
                        }
                    }
                    return 0.5 * (a + b);
                }
                inside = x;
            }
            f64::NAN
        };
        crossing(1.0) + crossing(-1.0)
    }

    /// A design of `apodisation` with peak reflectivity `peak_reflectivity` and main-lobe FWHM
    /// `fwhm_nm` at `bragg_nm`. At a fixed ∫κ dz the spectrum is a function of σ̂·L alone, so
    /// the FWHM scales as 1/L: L from a 1 mm trial, then a few fixed-point steps for the small
    /// nonlinearity of σ̂ in λ; Δn from tanh²(κ·L·mean g) = R.
    pub fn for_fwhm(
        apodisation: Apodisation,
        fwhm_nm: f64,
        peak_reflectivity: f64,
        bragg_nm: f64,
    ) -> Result<GratingDesign, TrainerError> {
        let bad = |message: String| TrainerError::Config {
            origin: "spectrum grating".into(),
            key: "grating".into(),
            message,
        };
        if !(fwhm_nm > 0.0 && fwhm_nm < 20.0) {
            return Err(bad(format!("FWHM {fwhm_nm} nm: between 0 and 20 nm")));
        }
        if !(peak_reflectivity > 0.0 && peak_reflectivity < PEAK_REFLECTIVITY_MAX) {
            return Err(bad(format!("peak reflectivity {peak_reflectivity}: between 0 and {PEAK_REFLECTIVITY_MAX}")));
        }
        if !(bragg_nm > 100.0 && bragg_nm < 10_000.0) {
            return Err(bad(format!("Bragg wavelength {bragg_nm} nm: between 100 and 10 000 nm")));
        }
        let sections = if apodisation == Apodisation::Uniform { 1 } else { APODISED_SECTIONS };
        let mut d = GratingDesign { apodisation, length_mm: 1.0, delta_n: 0.0, n_eff: N_EFF, sections };
        let kl = peak_reflectivity.sqrt().atanh();
        for _ in 0..4 {
            d.delta_n = kl * bragg_nm * 1e-9 / (std::f64::consts::PI * d.length_mm * 1e-3 * d.mean_profile());
            let w = d.fwhm_nm(bragg_nm);
            if !w.is_finite() {
                return Err(bad(format!("no half-maximum crossing at L = {} mm", d.length_mm)));
            }
            d.length_mm *= w / fwhm_nm;
        }
        d.delta_n = kl * bragg_nm * 1e-9 / (std::f64::consts::PI * d.length_mm * 1e-3 * d.mean_profile());
        Ok(d)
    }
}
