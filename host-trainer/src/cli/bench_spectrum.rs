//! `fbg-trainer bench-spectrum`: the peak detector's accuracy table on simulated spectra, for
//! `cargo xtask bench`.

use anyhow::Result;

use fbg_shared::spectrum::Method;
use fbg_trainer::sim::spectrum::accuracy::{accuracy_rows, REALISATIONS, SWEEP_BRAGG_NM, SWEEP_STEPS};
use fbg_trainer::sim::spectrum::grating::{DEFAULT_FWHM_NM, DEFAULT_PEAK_REFLECTIVITY};
use fbg_trainer::sim::spectrum::{Apodisation, PixelGrid};

/// SNRs of the table \[dB\].
const SNRS_DB: [f64; 3] = [20.0, 30.0, 40.0];

/// The peak detector on simulated spectra (one 0.3 nm grating on the SLED, each method, each
/// grid, 20/30/40 dB): RMS error and peak-locking, then the default method's locking against
/// the gratings' reflectivity and apodisation. JSON on stdout.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchSpectrumArgs {
    /// Seed of the detector noise.
    #[arg(long, default_value_t = 7)]
    seed: u64,
}

impl BenchSpectrumArgs {
    pub fn run(self) -> Result<()> {
        let grids = [PixelGrid::Swept, PixelGrid::Spectrometer];
        let mut table = Vec::new();
        for grid in grids {
            table.extend(accuracy_rows(
                grid,
                Apodisation::Uniform,
                DEFAULT_PEAK_REFLECTIVITY,
                &Method::ALL,
                &SNRS_DB,
                self.seed,
                true,
            )?);
        }
        let mut shapes = Vec::new();
        for grid in grids {
            for (apod, r) in [
                (Apodisation::Uniform, 0.1),
                (Apodisation::Uniform, 0.9),
                (Apodisation::Gaussian, 0.1),
                (Apodisation::Gaussian, 0.5),
                (Apodisation::Gaussian, 0.9),
            ] {
                shapes.extend(accuracy_rows(grid, apod, r, &[Method::default()], &[30.0], self.seed, true)?);
            }
        }
        let out = serde_json::json!({
            "grating": {
                "bragg_nm": SWEEP_BRAGG_NM,
                "fwhm_nm": DEFAULT_FWHM_NM,
                "apodisation": Apodisation::Uniform,
                "peak_reflectivity": DEFAULT_PEAK_REFLECTIVITY,
            },
            "sweep_steps": SWEEP_STEPS,
            "realisations": REALISATIONS,
            "seed": self.seed,
            "default_method": Method::default().name(),
            "table": table,
            "default_method_by_grating": shapes,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        Ok(())
    }
}
