//! `fbg-trainer stream`: the arguments and the exit status around `fbg_trainer::stream::run`.

use std::path::PathBuf;

use anyhow::{bail, Result};

use fbg_trainer::error::ShortNumber;
use fbg_trainer::stream::{run, StreamOptions};

/// `fbg-trainer stream`: check a running device against the host, sample by sample.
#[derive(clap::Args, Clone, Debug)]
pub struct StreamArgs {
    /// The model the device runs (sent first with --update-first).
    #[arg(long)]
    pub model: PathBuf,
    /// Dataset CSV whose hold-out samples are streamed.
    #[arg(long)]
    pub data: PathBuf,
    /// TCP port of the device's serial link.
    #[arg(long)]
    pub port: u16,
    /// Host of the device's serial link.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Send the model to the device over the link before streaming.
    #[arg(long)]
    pub update_first: bool,
    /// Stream only the first N hold-out samples.
    #[arg(long)]
    pub max_samples: Option<usize>,
    /// Seconds to wait for the connection, and for each answer whole (from the request sent to
    /// the answer's last byte, however the device trickles it): the stream fails when any one
    /// sample, model-transfer step or status request is not answered within it (the whole
    /// stream may take longer).
    #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
    pub timeout: f64,
    /// Print the comparison as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

impl StreamArgs {
    /// Stream, print the comparison (text on stderr, or JSON on stdout), and fail when an
    /// estimate differs from the host beyond tolerance.
    pub fn run(self) -> Result<()> {
        let timeout = timeout_arg(self.timeout)?;
        let json = self.json;
        let opts = StreamOptions {
            model: self.model,
            data: self.data,
            host: self.host,
            port: self.port,
            update_first: self.update_first,
            max_samples: self.max_samples,
            timeout,
            progress: !json,
        };
        let r = run(&opts)?;
        if json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            eprint!("{}", r.text());
        }
        if !r.ok() {
            bail!(
                "{} of {} estimates differ from the host beyond tolerance ({} in flags)",
                r.value_mismatches + r.flag_mismatches,
                r.samples,
                r.flag_mismatches
            );
        }
        Ok(())
    }
}

/// `fbg-trainer device status`: the device's audit trail and counters.
#[derive(clap::Args, Clone, Debug)]
pub struct DeviceArgs {
    #[command(subcommand)]
    pub command: DeviceCommand,
}

/// `fbg-trainer device` subcommands.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum DeviceCommand {
    /// Print the device's status: the active model (CRC digest, serial and key id of its
    /// signature), model updates accepted and refused by reason (unsigned, bad signature,
    /// unknown key, rollback, serial reused, other), link counters, stack peaks and the model
    /// store (boot source, rollback floor, event log, erases per sector). The running model,
    /// its serial, the update counters its event log holds and the rollback floor persist
    /// across resets in the model store's flash, on QEMU too (the host file `fbg-flash.bin` in QEMU's working
    /// directory); frames, samples and stack peaks count since boot (README-firmware.md, "The
    /// model store").
    Status {
        /// TCP port of the device's serial link.
        #[arg(long)]
        port: u16,
        /// Host of the device's serial link.
        #[arg(long, default_value = "127.0.0.1")]
        host: String,
        /// Seconds for the connection and the whole answer together (a device that trickles
        /// its answer byte by byte fails at this deadline like a silent one).
        #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
        timeout: f64,
        /// Print the status as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
}

impl DeviceArgs {
    /// Run the subcommand.
    pub fn run(self) -> Result<()> {
        match self.command {
            DeviceCommand::Status { port, host, timeout, json } => {
                let st = fbg_trainer::stream::device_status(&host, port, timeout_arg(timeout)?)?;
                if json {
                    println!("{}", serde_json::to_string_pretty(&st)?);
                } else {
                    print!("{}", fbg_trainer::stream::status_text(&st));
                }
                Ok(())
            }
        }
    }
}

/// Largest `--timeout` \[s\] (about 31 years): far beyond any wait, and far from where a
/// deadline `Instant::now() + timeout` would overflow (and panic).
const TIMEOUT_MAX_S: f64 = 1e9;

/// `--timeout` as a duration: a positive number of seconds up to [`TIMEOUT_MAX_S`].
fn timeout_arg(seconds: f64) -> Result<std::time::Duration> {
    if !(seconds > 0.0 && seconds <= TIMEOUT_MAX_S) {
        bail!("--timeout must be a positive number of seconds up to {TIMEOUT_MAX_S:e} (got {})", ShortNumber(seconds));
    }
    Ok(std::time::Duration::from_secs_f64(seconds))
}
