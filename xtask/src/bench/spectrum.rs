//! Peak detection in spectra (DESIGN §8): the host throughput of `fbg-shared`'s detector
//! (criterion, `shared/benches/spectrum.rs`), its accuracy table on simulated grating spectra
//! (`fbg-trainer bench-spectrum`: every method × grid × SNR, RMS error and peak-locking) and
//! the chain spectrum → peaks → compensation against the peak chain (`fbg-trainer demo
//! --spectra --json`, per grid).
//!
//! Alone: `cargo xtask bench --spectrum-only` measures only this part and puts it into
//! the BENCHMARKS.json already there (BENCHMARKS.md rendered again); the rest of the file is
//! kept as it was.

use std::path::Path;

use anyhow::{Context, Result};
use fbg_report::AccuracyRow;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::runner::{criterion, criterion_median, Runner};
use super::verdict::{f, met};
use super::{Opts, TRAINER};

/// Spectra per criterion iteration (`shared/benches/spectrum.rs`).
const SPECTRUM_BATCH: f64 = 64.0;
/// The methods of the criterion bench, in `Method::ALL` order; the last is the default.
const METHODS: [&str; 5] = ["maximum", "centroid", "gaussian3", "gaussian-fit", "cross-correlation"];
/// The default method.
const DEFAULT_METHOD: &str = "cross-correlation";
/// The targets.
const TARGET_SPECTRA_PER_S: f64 = 1e5;
const TARGET_RMS_SWEPT_PM: f64 = 1.0;
const TARGET_RMS_SPECTROMETER_PM: f64 = 3.0;
const TARGET_LOCKING_PM: f64 = 0.5;
const TARGET_CHAIN_RATIO: f64 = 1.10;

/// One throughput figure.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ThroughputRow {
    /// `f64` or `f32`.
    pub precision: String,
    pub method: String,
    pub ns_per_spectrum: f64,
    pub spectra_per_second: f64,
    pub ci95_ns_per_spectrum: [f64; 2],
}

/// One chain comparison (what `demo --spectra --json` prints, the keys read here).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ChainRun {
    pub command: String,
    pub grid: String,
    /// How the peaks were found (`Method(..)` or `DesignTemplate(..)`; absent before it was
    /// recorded).
    #[serde(default)]
    pub finding: String,
    pub samples: usize,
    pub outputs: Vec<String>,
    pub units: Vec<String>,
    pub rmse_holdout_peak_chain: Vec<f64>,
    pub rmse_holdout_spectrum_chain: Vec<f64>,
    pub ratio_spectrum_over_peak: Vec<f64>,
    pub peak_error_rms_pm: Vec<f64>,
    pub peak_error_bias_pm: Vec<f64>,
}

/// The whole part.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpectrumBench {
    pub throughput_command: String,
    pub throughput: Vec<ThroughputRow>,
    pub accuracy_command: String,
    /// The sweep's grating and settings (`bench-spectrum`'s header, as printed).
    pub accuracy_setup: Value,
    pub accuracy: Vec<AccuracyRow>,
    /// The default method on other gratings (reflectivity, apodisation), 30 dB.
    pub accuracy_by_grating: Vec<AccuracyRow>,
    pub chains: Vec<ChainRun>,
}

/// Measure the part.
pub fn part(root: &Path, r: &Runner, opts: &Opts) -> Result<SpectrumBench> {
    let throughput_command = criterion(root, opts.quick, "spectrum")?;
    let mut throughput = Vec::new();
    let runs = METHODS.iter().map(|m| ("f64", *m)).chain([("f32", DEFAULT_METHOD)]);
    for (prec, method) in runs {
        let (ns, ci95_ns_per_spectrum) = criterion_median(root, &format!("spectrum_{prec}/{method}"), SPECTRUM_BATCH)?;
        throughput.push(ThroughputRow {
            precision: prec.into(),
            method: method.into(),
            ns_per_spectrum: ns,
            spectra_per_second: 1e9 / ns,
            ci95_ns_per_spectrum,
        });
    }
    let (acc, accuracy_command) = r.json(TRAINER, &["bench-spectrum", "--seed", "7"])?;
    let rows = |key: &str| -> Result<Vec<AccuracyRow>> {
        serde_json::from_value(acc.get(key).cloned().unwrap_or(Value::Null))
            .with_context(|| format!("bench-spectrum: `{key}` is not the rows expected"))
    };
    let accuracy = rows("table")?;
    let accuracy_by_grating = rows("default_method_by_grating")?;
    let mut setup = acc.clone();
    if let Some(o) = setup.as_object_mut() {
        o.remove("table");
        o.remove("default_method_by_grating");
    }
    let mut chains = Vec::new();
    for (grid, template) in [("spectrometer", false), ("spectrometer", true), ("swept", false)] {
        let out = format!("target/bench/spectra-{grid}{}", if template { "-template" } else { "" });
        let mut args = vec!["demo", "--spectra", "--grid", grid, "--seed", "7", "--json", "--out", &out];
        if template {
            args.push("--template");
        }
        let (v, command) = r.json(TRAINER, &args)?;
        let mut v = v;
        if let Some(o) = v.as_object_mut() {
            o.insert("command".into(), Value::String(command));
        }
        chains.push(serde_json::from_value(v).context("demo --spectra --json: not the keys expected")?);
    }
    Ok(SpectrumBench {
        throughput_command,
        throughput,
        accuracy_command,
        accuracy_setup: setup,
        accuracy,
        accuracy_by_grating,
        chains,
    })
}

/// The section of BENCHMARKS.md.
pub fn markdown(s: &mut String, b: &SpectrumBench) {
    // The heading as BENCHMARKS.md publishes it.
    out!(s, "## Peak detection in spectra\n");
    out!(
        s,
        "Targets at 30 dB SNR (10·log₁₀(peak height/noise σ)), 0.3 nm FWHM gratings: RMS ≤ {TARGET_RMS_SWEPT_PM} pm on the 8 pm grid, ≤ {TARGET_RMS_SPECTROMETER_PM} pm on the 512-pixel grid, peak-locking ≤ {TARGET_LOCKING_PM} pm p-p for the default method (`{DEFAULT_METHOD}`); host ≥ 10⁵ spectra of 512 pixels per second on one core; the spectrum chain's compensated RMSE within 10 % of the peak chain's on `paper`.\n"
    );
    let default_row = |grid: &str| b.accuracy.iter().find(|r| r.method == DEFAULT_METHOD && r.grid == grid);
    out!(s, "| target | measured | verdict |");
    out!(s, "|---|---:|---|");
    for (grid, target) in [("swept", TARGET_RMS_SWEPT_PM), ("spectrometer", TARGET_RMS_SPECTROMETER_PM)] {
        if let Some(r) = default_row(grid) {
            let rms = r.rms_at(30.0);
            out!(s, "| RMS at 30 dB, {grid} grid ≤ {target} pm | {} pm | {} |", f(rms, 3), met(rms <= target));
            out!(
                s,
                "| peak-locking, {grid} grid ≤ {TARGET_LOCKING_PM} pm p-p | {} pm | {} |",
                f(r.locking_pp_pm, 3),
                met(r.locking_pp_pm <= TARGET_LOCKING_PM)
            );
        }
    }
    if let Some(r) = b.accuracy.iter().find(|r| r.method.ends_with("design template") && r.grid == "spectrometer") {
        let (rms, lock) = (r.rms_at(30.0), r.locking_pp_pm);
        out!(
            s,
            "| the same on the spectrometer grid with each peak refined by a fit of the grating's designed shape (`{}`) | RMS {} pm, locking {} pm | {} |",
            r.method,
            f(rms, 3),
            f(lock, 3),
            met(rms <= TARGET_RMS_SPECTROMETER_PM && lock <= TARGET_LOCKING_PM)
        );
    }
    if let Some(t) = b.throughput.iter().find(|t| t.precision == "f64" && t.method == DEFAULT_METHOD) {
        out!(
            s,
            "| host ≥ 10⁵ spectra/s (f64, one core) | {:.3e} /s | {} |",
            t.spectra_per_second,
            met(t.spectra_per_second >= TARGET_SPECTRA_PER_S)
        );
    }
    for c in &b.chains {
        let worst = c.ratio_spectrum_over_peak.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let how = if c.finding.contains("Template") { ", design template" } else { "" };
        out!(
            s,
            "| chain RMSE ≤ 1.10 × peak chain, {} grid{how} | worst ratio {} | {} |",
            c.grid,
            f(worst, 3),
            met(worst <= TARGET_CHAIN_RATIO)
        );
    }
    out!(s);
    accuracy_tables(s, b);
    throughput_table(s, b);
    chain_table(s, b);
}

/// The accuracy table and the default method's row per grating.
fn accuracy_tables(s: &mut String, b: &SpectrumBench) {
    out!(
        s,
        "### Accuracy on simulated spectra\n\n`{}`: one uniform grating (0.3 nm FWHM, peak reflectivity 0.5, transfer-matrix spectrum with its side lobes) at 1550 nm on the SLED, swept over one pixel in 20 steps; locking and bias noise-free (counts still rounded), RMS over 20 × 25 noisy frames per SNR; errors detected − rendered wavelength.\n",
        b.accuracy_command
    );
    out!(s, "| method | grid | locking p-p [pm] | bias [pm] | RMS 20 dB [pm] | RMS 30 dB [pm] | RMS 40 dB [pm] |");
    out!(s, "|---|---|---:|---:|---:|---:|---:|");
    for r in &b.accuracy {
        out!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.method,
            r.grid,
            f(r.locking_pp_pm, 3),
            f(r.bias_pm, 3),
            f(r.rms_at(20.0), 3),
            f(r.rms_at(30.0), 3),
            f(r.rms_at(40.0), 3)
        );
    }
    out!(s, "\nThe default method on other gratings (same command), 30 dB:\n");
    out!(s, "| method | grid | apodisation | peak reflectivity | locking p-p [pm] | RMS 30 dB [pm] |");
    out!(s, "|---|---|---|---:|---:|---:|");
    for r in &b.accuracy_by_grating {
        out!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            r.method,
            r.grid,
            r.apodisation,
            r.peak_reflectivity,
            f(r.locking_pp_pm, 3),
            f(r.rms_at(30.0), 3)
        );
    }
}

/// The criterion figures.
fn throughput_table(s: &mut String, b: &SpectrumBench) {
    out!(s, "\n### Host throughput\n\n`{}`: 512-pixel spectra with 3 sinc² peaks at 30 dB, one reused detector; criterion median of 100 samples of 64 spectra.\n", b.throughput_command);
    out!(s, "| precision | method | ns per spectrum | spectra/s | 95 % CI [ns] |");
    out!(s, "|---|---|---:|---:|---|");
    for t in &b.throughput {
        out!(
            s,
            "| {} | {} | {} | {:.3e} | {} – {} |",
            t.precision,
            t.method,
            f(t.ns_per_spectrum, 0),
            t.spectra_per_second,
            f(t.ci95_ns_per_spectrum[0], 0),
            f(t.ci95_ns_per_spectrum[1], 0)
        );
    }
}

/// The chain against the peak chain, per grid.
fn chain_table(s: &mut String, b: &SpectrumBench) {
    out!(s, "\n### Chain spectrum → peaks → compensation (`paper`, seed 7)\n");
    out!(s, "Model-H hold-out RMSE, trained and evaluated as `demo` does, on the record as simulated (peak chain) and rebuilt from the peaks of its simulated spectra (default gratings, 30 dB, the default method, and on the spectrometer grid also with each peak refined by a fit of the grating's designed shape: `--template`).\n");
    out!(s, "| grid | command | output | peak chain | spectrum chain | ratio |");
    out!(s, "|---|---|---|---:|---:|---:|");
    for c in &b.chains {
        for (k, name) in c.outputs.iter().enumerate() {
            let get = |v: &[f64]| v.get(k).copied().unwrap_or(f64::NAN);
            let unit = c.units.get(k).map(String::as_str).unwrap_or("");
            out!(
                s,
                "| {} | `{}` | {name} | {} {unit} | {} {unit} | {} |",
                c.grid,
                c.command,
                f(get(&c.rmse_holdout_peak_chain), 4),
                f(get(&c.rmse_holdout_spectrum_chain), 4),
                f(get(&c.ratio_spectrum_over_peak), 3)
            );
        }
        let per: Vec<String> = c
            .peak_error_rms_pm
            .iter()
            .zip(&c.peak_error_bias_pm)
            .map(|(r, b)| format!("{} (bias {})", f(*r, 3), f(*b, 3)))
            .collect();
        out!(s, "| {} | | peak error RMS per grating [pm] | | {} | |", c.grid, per.join(", "));
    }
    out!(s);
}

/// `cargo xtask bench --spectrum-only`: this part alone, into the BENCHMARKS.json
/// already there.
pub fn only(root: &Path, opts: &Opts) -> Result<()> {
    super::build_trainer(root)?;
    let part = part(root, &Runner { root: root.to_path_buf() }, opts)?;
    super::update(root, |r| {
        r.spectrum = Some(part);
        Ok(())
    })?;
    eprintln!("bench: wrote the spectrum part into BENCHMARKS.md and BENCHMARKS.json");
    Ok(())
}
