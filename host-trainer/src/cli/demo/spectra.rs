//! `fbg-trainer demo --spectra`: the chain spectrum → peaks → compensation next to the peak
//! chain, on one simulated record.

use std::path::Path;
use std::time::Instant;

use anyhow::Result;

use fbg_trainer::data::files::{prepare_output_dir, write_bytes_atomically};
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::studies::{self, Studies};
use fbg_trainer::fit::TrainOptions;
use fbg_trainer::sim::meta::SimMeta;
use fbg_trainer::sim::spectrum::{find_peaks, FrameSimulator, PeakFinding, SpectrumConfig};
use fbg_trainer::sim::{self, Simulation};

use crate::args::ScenarioArgs;

/// The file of the comparison in the output directory.
const SPECTRA_JSON: &str = "spectra.json";

/// Simulate the scenario; the peak chain trains on its record as written (`data.csv`), the
/// spectrum chain on the record rebuilt from the peaks of its simulated spectra
/// (`data-spectra.csv`, shifts from the same λ_ref); both train and evaluate as `demo` does
/// (`studies::run_all`, default options, without the studies). Prints and writes Model-H's
/// hold-out RMSE of both, their ratio and the peaks' errors against the rendered wavelengths.
pub fn run(
    out: &Path,
    scenario: &ScenarioArgs,
    spectrum: &SpectrumConfig,
    finding: PeakFinding,
    json: bool,
) -> Result<()> {
    let t0 = Instant::now();
    let cfg = scenario.load()?;
    let mut s = sim::simulate(&cfg, scenario.seed);
    s.data.dims(&format!("scenario `{}`", cfg.name))?;
    let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
    let frames = FrameSimulator::new(spectrum, &nominal)?;
    prepare_output_dir(out)?;
    let log = |m: &str| {
        if !json {
            eprintln!("[{:5.1} s] {m}", t0.elapsed().as_secs_f64());
        }
    };
    // Both records as written (6 decimals) and read back, as `demo` fits them.
    let data = out.join("data.csv");
    s.data.write_csv(&data)?;
    SimMeta::of(&s).write(&data)?;
    s.data = Dataset::read_csv(&data)?;
    let t = Instant::now();
    let chain = find_peaks(&s.data, &frames, finding, scenario.seed)?;
    log(&format!(
        "{} frames of {} pixels ({} channel(s)), peaks by {} in {:.1} s",
        s.data.len() * frames.channels(),
        frames.wavelengths_nm().len(),
        frames.channels(),
        chain.method,
        t.elapsed().as_secs_f64()
    ));
    let mut from_spectra: Simulation = s.clone();
    from_spectra.data = chain.data.clone();
    let data_spectra = out.join("data-spectra.csv");
    from_spectra.data.write_csv(&data_spectra)?;
    SimMeta::of(&from_spectra).write(&data_spectra)?;
    from_spectra.data = Dataset::read_csv(&data_spectra)?;
    let opts = TrainOptions::default().with_progress(!json);
    let (_, peak) = studies::run_all(&s, &opts, Studies::NONE, &log)?;
    log("peak chain trained and evaluated");
    let (_, spec) = studies::run_all(&from_spectra, &opts, Studies::NONE, &log)?;
    log("spectrum chain trained and evaluated");
    let rmse = |m: &fbg_trainer::eval::metrics::Metrics| -> Vec<f64> {
        m.table2.model_h.channels.iter().map(|c| c.rmse).collect()
    };
    let (p, q) = (rmse(&peak), rmse(&spec));
    let ratio: Vec<f64> = p.iter().zip(&q).map(|(a, b)| b / a).collect();
    let errors = chain.rms_error_pm();
    let bias: Vec<f64> = chain
        .errors_pm
        .iter()
        .map(|e| {
            let f: Vec<f64> = e.iter().copied().filter(|v| v.is_finite()).collect();
            f.iter().sum::<f64>() / f.len().max(1) as f64
        })
        .collect();
    let summary = serde_json::json!({
        "scenario": cfg.name,
        "seed": scenario.seed,
        "samples": s.data.len(),
        "spectrum": spectrum,
        "grid": spectrum.grid.name(),
        "pixels": frames.wavelengths_nm().len(),
        "channels": frames.channels(),
        "method": chain.method.name(),
        "finding": format!("{finding:?}"),
        "outputs": peak.channels,
        "units": peak.units,
        "rmse_holdout_peak_chain": p,
        "rmse_holdout_spectrum_chain": q,
        "ratio_spectrum_over_peak": ratio,
        "peak_error_rms_pm": errors,
        "peak_error_bias_pm": bias,
        "peak_faults": chain.faults,
        "seconds": t0.elapsed().as_secs_f64(),
    });
    let text = serde_json::to_string_pretty(&summary)?;
    write_bytes_atomically(&out.join(SPECTRA_JSON), text.as_bytes())?;
    if json {
        println!("{text}");
    } else {
        eprintln!(
            "spectrum chain ({} grid, {} dB, R {}, {}{}) against the peak chain, Model-H hold-out RMSE:",
            spectrum.grid.name(),
            spectrum.detector.snr_db,
            spectrum.peak_reflectivity,
            chain.method,
            match finding {
                PeakFinding::Method(_) => "",
                PeakFinding::DesignTemplate(_) => " + design template",
            }
        );
        eprintln!("{:>12} {:>12} {:>14} {:>8}", "output", "peak chain", "spectrum chain", "ratio");
        for (k, name) in peak.channels.iter().enumerate() {
            let get = |v: &[f64]| v.get(k).copied().unwrap_or(f64::NAN);
            let unit = peak.units.get(k).map(String::as_str).unwrap_or("");
            eprintln!("{name:>12} {:>9.4} {unit:<3} {:>10.4} {unit:<3} {:>8.3}", get(&p), get(&q), get(&ratio));
        }
        let per: Vec<String> = errors.iter().zip(&bias).map(|(r, b)| format!("{r:.3} (bias {b:+.3})")).collect();
        eprintln!("peak error, detected − rendered, RMS per grating [pm]: {}", per.join(", "));
        eprintln!("wrote {} in {:.1} s", out.join(SPECTRA_JSON).display(), t0.elapsed().as_secs_f64());
    }
    Ok(())
}
