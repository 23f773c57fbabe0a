//! `fbg-trainer`: the command line (DESIGN §10). Errors end here as `anyhow` messages that name
//! the file, line, column or key. The binary uses the `fbg_trainer` library only; each
//! command has its own module here (its arguments and what it prints), the arguments several
//! share are in `args`, and the terminal's progress bars in `progress`.

mod args;
mod bench_fit;
mod bench_spectrum;
mod compensate;
mod demo;
mod evaluate;
mod fleet;
mod golden;
mod import;
mod inspect;
mod peaks;
mod progress;
mod recalibrate;
mod report;
mod sign;
mod simulate;
mod stream;
mod train;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "fbg-trainer",
    version,
    about = "Hybrid AI–polynomial compensation for FBG sensors: simulate, train, evaluate, report, export"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Simulate an installation; write its CSV and a `.meta.json` sidecar (scenario, seed,
    /// per-sample oracle).
    Simulate(simulate::SimulateArgs),
    /// Fit Model-P and Model-H on the calibration part of a CSV; write the Model-H blob, the
    /// Model-P blob beside it (`<stem>-p.fbgm`) and `<stem>.coefficients.json`.
    Train(train::TrainArgs),
    /// Evaluate models on the hold-out of a CSV: Table 2 and Table 3 (and, for simulated data
    /// with a `.meta.json`, the per-sample oracle, drift sweep and error budget); writes `<model stem>.metrics.json`.
    Evaluate(evaluate::EvaluateArgs),
    /// Field recalibration: refit the core's offset/gain and the residual weights (centres
    /// kept) of an existing model on a short batch (the calibration rows of DATA, or its first
    /// --batch-hours). Only the batch decides: each channel's update is fitted on its first
    /// 70 % and kept only if it predicts the last 30 % better than the old model (then refitted
    /// on the whole batch); otherwise the channel keeps the old coefficients (see
    /// --allow-worse). The hold-out RMSE before and after is reported separately, plays no part
    /// in the decision, and can come out worse: a warning says so.
    Recalibrate(recalibrate::RecalibrateArgs),
    /// Print a blob's header, dimensions, hyper-parameters, provenance and signature (key id,
    /// serial, and whether it verifies against --pubkey).
    Inspect(inspect::InspectArgs),
    /// Sign an existing blob (or re-sign a signed one): the blob, a trailer with the key id, a
    /// serial and flags, and the Ed25519 signature over both.
    Sign(sign::SignCmd),
    /// Make an Ed25519 signing key pair for signed model updates: the private key in OUT
    /// (PKCS#8 PEM, mode 0600, never overwritten), the public key beside it as `<stem>.pub`
    /// (raw 32 bytes: the file the firmware build trusts, `FBG_TRUSTED_KEYS`) and
    /// `<stem>.pub.hex`; prints the key id (first 8 bytes of SHA-256 of the public key).
    Keygen(sign::KeygenArgs),
    /// Write golden vectors (device inputs and f64 expected outputs) for the firmware tests.
    Golden(golden::GoldenArgs),
    /// Regenerate the audit report (figures, tables, coefficient tables, index.html) in DIR from
    /// the data.csv (+ data.meta.json), model.fbgm, model-p.fbgm and model.metrics.json there, or from
    /// the files named by --data, --model, --model-p and --metrics.
    Report(report::ReportArgs),
    /// Simulate a preset (`paper` unless --preset or --config says otherwise), train both
    /// models, evaluate, run every study and write the whole audit report into DIR.
    Demo(demo::DemoArgs),
    /// Import a real interrogator export into the dataset CSV (--format): ENLIGHT / Hyperion
    /// peaks (`enlight`, the references from --refs), any logger CSV whose columns a map names
    /// (`csv`), or spectra whose peaks are detected per grating (`spectra-csv`,
    /// `enlight-responses`, `pixels`).
    Import(import::ImportArgs),
    /// Detect the peaks of a spectrum file (spectra CSV, ENLIGHT / Hyperion Responses,
    /// spectrometer pixels) and write each frame's peak per grating with its quality (SNR,
    /// FWHM, flags, method) as a CSV.
    Peaks(peaks::PeaksArgs),
    /// Time the fit for benchmarks (`cargo xtask bench`): read a CSV once, fit it --repeats
    /// times (each fit timed alone), evaluate the last fit on the hold-out.
    BenchFit(bench_fit::BenchFitArgs),
    /// The peak detector's accuracy on simulated spectra for benchmarks (`cargo xtask bench`):
    /// every method × grid × SNR, RMS error and peak-locking, as JSON.
    BenchSpectrum(bench_spectrum::BenchSpectrumArgs),
    /// Calibrate many sensor groups in parallel from a TOML manifest (each group's data CSV and
    /// output blob); resumes without redoing finished groups; a failing group does not stop the
    /// others.
    Fleet(fleet::FleetArgs),
    /// Stream the hold-out samples of DATA to a running device (QEMU's serial port on TCP, or a
    /// board behind a serial-to-TCP bridge) and check every estimate against the host's f64
    /// compensator on the same model (1 % of the hold-out RMSE, flags identical).
    Stream(stream::StreamArgs),
    /// Compensate a logged field record with a model, as the device would: every row's
    /// measurands with their 95 % band and flags; gaps stay gaps; references are optional (when
    /// present, their errors are printed).
    Compensate(compensate::CompensateArgs),
    /// Talk to a running device: `device status` prints its audit trail (active model, its
    /// signature's serial and key id, updates accepted and refused by reason) and counters.
    Device(stream::DeviceArgs),
}

fn main() {
    quiet_on_closed_stdout();
    // The library's long operations draw their progress bars through this reporter.
    let _ = fbg_trainer::progress::set_reporter(Box::new(progress::Terminal));
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// A closed stdout (`fbg-trainer inspect m.fbgm | head -1`) ends the command as it ends `cat`:
/// by SIGPIPE, status 141 in the shell, nothing on stderr. Rust starts with SIGPIPE ignored,
/// so every `println!` into a closed pipe panicked instead ("Broken pipe", exit 101). Sockets
/// are not affected: std sends with `MSG_NOSIGNAL`, so the device link still gets EPIPE as an
/// error it reports.
fn quiet_on_closed_stdout() {
    #[cfg(unix)]
    // SAFETY: first thing in `main`, before any thread exists; SIG_DFL is a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn run() -> Result<()> {
    match Cli::parse().cmd {
        Cmd::Simulate(a) => a.run(),
        Cmd::Train(a) => a.run(),
        Cmd::Evaluate(a) => a.run(),
        Cmd::Recalibrate(a) => a.run(),
        Cmd::Inspect(a) => a.run(),
        Cmd::Sign(a) => a.run(),
        Cmd::Keygen(a) => a.run(),
        Cmd::Golden(a) => a.run(),
        Cmd::Report(a) => a.run(),
        Cmd::Demo(a) => a.run(),
        Cmd::Import(a) => a.run(),
        Cmd::Peaks(a) => a.run(),
        Cmd::BenchFit(a) => a.run(),
        Cmd::BenchSpectrum(a) => a.run(),
        Cmd::Fleet(a) => a.run(),
        Cmd::Stream(a) => a.run(),
        Cmd::Compensate(a) => a.run(),
        Cmd::Device(a) => a.run(),
    }
}

/// A UTC timestamp argument in Unix seconds.
fn utc_timestamp(s: &str, flag: &str) -> Result<f64> {
    fbg_trainer::data::timestamp::parse_timestamp(s.trim().trim_end_matches('Z'), None)
        .ok_or_else(|| anyhow::anyhow!("{flag}: `{s}` is not a UTC timestamp like 2026-01-05T00:00:00"))
}
