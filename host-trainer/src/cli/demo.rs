//! `fbg-trainer demo`: simulate, train, evaluate, run every study and write the whole audit
//! report into one directory.

mod spectra;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};

use fbg_shared::spectrum::Method;
use fbg_trainer::data::files::prepare_output_dir;
use fbg_trainer::data::Dataset;
use fbg_trainer::error::ShortNumber;
use fbg_trainer::eval::studies::{self, Studies};
use fbg_trainer::fit::TrainOptions;
use fbg_trainer::sim::meta::SimMeta;
use fbg_trainer::sim::spectrum::{grating, DetectorModel, PeakFinding, PixelGrid, SpectrumConfig};
use fbg_trainer::{export, report, sim};

use crate::args::ScenarioArgs;
use crate::evaluate::{print_tables, write_metrics};

/// Simulate the `paper` preset, train both models, evaluate, run every study and write the
/// whole audit report into DIR.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Output directory (created when missing) for the data, models, tables, figures and
    /// index.html.
    #[arg(long, default_value = "report")]
    out: PathBuf,
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Print metrics.json on stdout instead of the tables and progress.
    #[arg(long)]
    json: bool,
    /// The spectrum chain instead of the report: simulate the record's spectra, find the peaks
    /// in them, rebuild the record from the peaks, train and evaluate on both records and
    /// compare Model-H's hold-out RMSE (written to DIR/spectra.json; DIR/data.csv and
    /// DIR/data-spectra.csv are the two records).
    #[arg(long)]
    spectra: bool,
    /// With --spectra: the pixel grid, `spectrometer` (512 pixels over 1510–1595 nm) or `swept`
    /// (8 pm).
    #[arg(long, requires = "spectra", default_value = "spectrometer", value_parser = parse_grid)]
    grid: PixelGrid,
    /// With --spectra: the detector's SNR [dB], 10·log10(peak height/noise σ).
    #[arg(long, requires = "spectra", default_value_t = 30.0, allow_negative_numbers = true)]
    snr_db: f64,
    /// With --spectra: the gratings' peak reflectivity (0 < R < 0.9999).
    #[arg(long, requires = "spectra", default_value_t = grating::DEFAULT_PEAK_REFLECTIVITY, allow_negative_numbers = true)]
    reflectivity: f64,
    /// With --spectra: refine each peak by a fit of its grating's designed reflection shape (a
    /// template: the simulator's own, so exact, which a datasheet's is not), from the default
    /// method's estimate.
    #[arg(long, requires = "spectra")]
    template: bool,
}

fn parse_grid(s: &str) -> std::result::Result<PixelGrid, String> {
    PixelGrid::parse(s).ok_or_else(|| format!("`{s}`: `spectrometer` or `swept`"))
}

impl DemoArgs {
    /// The flags' own ranges, checked before anything is simulated: each error names its flag
    /// once (as `simulate`'s).
    fn check_flags(&self) -> Result<()> {
        crate::args::check_snr_db(self.snr_db)?;
        let r = self.reflectivity;
        if !(r > 0.0 && r < grating::PEAK_REFLECTIVITY_MAX) {
            bail!("--reflectivity: {} is out of range (0, {})", ShortNumber(r), grating::PEAK_REFLECTIVITY_MAX);
        }
        Ok(())
    }

    pub fn run(self) -> Result<()> {
        self.check_flags()?;
        if self.spectra {
            let cfg = SpectrumConfig {
                grid: self.grid,
                detector: DetectorModel { snr_db: self.snr_db, ..DetectorModel::default() },
                peak_reflectivity: self.reflectivity,
                ..SpectrumConfig::default()
            };
            let finding = if self.template {
                PeakFinding::DesignTemplate(Method::default())
            } else {
                PeakFinding::Method(Method::default())
            };
            return spectra::run(&self.out, &self.scenario, &cfg, finding, self.json);
        }
        run(&self.out, &self.scenario, self.json)
    }
}

/// `fbg-trainer demo`.
fn run(out: &Path, scenario: &ScenarioArgs, json: bool) -> Result<()> {
    let t0 = Instant::now();
    let cfg = scenario.load()?;
    let mut s = sim::simulate(&cfg, scenario.seed);
    // Refused before anything is written: a scenario without measurands has nothing to fit.
    s.data.dims(&format!("scenario `{}`", cfg.name))?;
    prepare_output_dir(out)?;
    let log = |s: &str| {
        if !json {
            eprintln!("[{:5.1} s] {s}", t0.elapsed().as_secs_f64());
        }
    };
    let data = out.join("data.csv");
    s.data.write_csv(&data)?;
    SimMeta::of(&s).write(&data)?;
    // Fit and score the record as written (6 decimals), so `train --data DIR/data.csv` rebuilds
    // DIR/model.fbgm byte for byte.
    s.data = Dataset::read_csv(&data)?;
    log(&format!(
        "simulated {} samples of scenario `{}` (seed {}) into {}",
        s.data.len(),
        cfg.name,
        s.seed,
        data.display()
    ));
    let opts = TrainOptions::default().with_progress(!json);
    let (tr, mut m) = studies::run_all(&s, &opts, Studies::ALL, &log)?;
    let model = out.join("model.fbgm");
    let files = export::ModelFiles::of(&tr, None)?;
    files.write(&model)?;
    let (nh, np) = (files.model_h.len(), files.model_p.len());
    // The warnings `train` records in coefficients.json go into metrics.json too, as `evaluate` does.
    let train_warnings = fbg_trainer::eval::warnings::from_coefficients(&export::coefficients_path(&model));
    m.warnings = fbg_trainer::eval::warnings::merge(train_warnings, std::mem::take(&mut m.warnings));
    write_metrics(&export::metrics_path(&model), &m)?;
    let hold = s.data.holdout_indices();
    let idx: Vec<usize> = hold.into_iter().take(1000).collect();
    export::write_golden(
        &out.join("golden"),
        &tr.model_h,
        &s.data,
        &idx,
        &m.table2.model_h.channels.iter().map(|c| c.rmse).collect::<Vec<_>>(),
    )?;
    log(&format!(
        "wrote model.fbgm ({nh} B), model-p.fbgm ({np} B), {}, {}, golden vectors",
        report::COEFFICIENTS_JSON,
        report::METRICS_JSON
    ));
    // The report reads back exactly what `fbg-trainer report` would, so the two never differ.
    let r = report::build(out).context("writing the report")?;
    log(&format!(
        "wrote the report (tables, {} figures as PNG and SVG, coefficient tables, index.html) in {:.1} s",
        r.files.iter().filter(|f| f.ends_with(".png")).count(),
        r.seconds
    ));
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&m)?);
    } else {
        print_tables(&m);
        eprintln!(
            "demo finished in {:.1} s; everything is in {}, open {}",
            t0.elapsed().as_secs_f64(),
            out.display(),
            out.join(report::INDEX_HTML).display()
        );
    }
    Ok(())
}
