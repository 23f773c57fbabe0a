//! `fbg-trainer fleet` and `fleet status`: many sensor groups from one manifest.

use std::path::PathBuf;

use anyhow::{bail, Result};

use fbg_trainer::fleet::{self, FleetOptions};

use crate::args::SignArgs;

/// `fbg-trainer fleet`: calibrate the sensor groups of a manifest in parallel.
#[derive(clap::Args, Clone, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct FleetArgs {
    #[command(subcommand)]
    command: Option<FleetCommand>,
    /// Manifest (TOML): `[[group]]` tables with name, data, out and optional features /
    /// max_centres / drift_spec_pm_per_sqrt_day / drift_gains; `[defaults]` for the options
    /// groups leave out.
    #[arg(long, required = true)]
    manifest: Option<PathBuf>,
    /// Groups calibrated at once (threads of the pool; 0: one per core).
    #[arg(long, default_value_t = 0)]
    jobs: usize,
    /// Run only the groups of shard I of N (I from 0; a group's shard is CRC-64/XZ of its name
    /// mod N). Without it, a Slurm array task or Kubernetes Indexed Job index is used when set.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// The shard count N for an index taken from the batch engine (Slurm's
    /// SLURM_ARRAY_TASK_ID, Kubernetes' JOB_COMPLETION_INDEX); needed for Kubernetes and for a
    /// resubmitted subset of a Slurm array.
    #[arg(long, value_name = "N")]
    shards: Option<usize>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Let groups write outside the manifest's directory (`../x`, absolute paths elsewhere);
    /// refused by default, and said on stderr when allowed.
    #[arg(long)]
    allow_outside: bool,
    #[command(flatten)]
    sign: SignArgs,
}

/// `fleet` subcommands.
#[derive(clap::Subcommand, Clone, Debug)]
enum FleetCommand {
    /// Every group's state from the files on disk (done, failed with the reason, stale because
    /// its inputs changed, missing); exits non-zero unless all are done. Trains nothing.
    Status(StatusArgs),
}

/// `fbg-trainer fleet status`.
#[derive(clap::Args, Clone, Debug)]
struct StatusArgs {
    /// The manifest the groups come from.
    #[arg(long)]
    manifest: PathBuf,
    /// Also show each group's shard of N.
    #[arg(long, value_name = "N")]
    shards: Option<usize>,
    /// List every group, done ones included.
    #[arg(long)]
    all: bool,
    /// Print the status as JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl FleetArgs {
    /// Run the fleet (or its status) and fail when a group failed (is not done).
    pub fn run(self) -> Result<()> {
        if let Some(FleetCommand::Status(s)) = self.command {
            return s.run();
        }
        let Some(manifest) = self.manifest else {
            bail!("fleet: manifest: --manifest is required");
        };
        let r = fleet::run_manifest(&FleetOptions {
            manifest,
            jobs: self.jobs,
            shard: self.shard,
            shards: self.shards,
            allow_outside: self.allow_outside,
            sign: self.sign.options(),
            progress: !self.json,
        })?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            eprintln!("{}", r.text());
        }
        if r.failed > 0 {
            bail!("{} of {} groups failed (the others were calibrated)", r.failed, r.groups.len());
        }
        Ok(())
    }
}

impl StatusArgs {
    fn run(self) -> Result<()> {
        // Before the manifest is read, naming the flag (the library's own check names a key).
        if self.shards == Some(0) {
            anyhow::bail!("--shards must be at least 1 (got 0)");
        }
        let r = fleet::status_from_file(&self.manifest, self.shards)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            eprintln!("{}", r.text(self.all));
        }
        if !r.all_done {
            bail!(
                "{} of {} groups are not done",
                r.groups.len() - r.counts.get("done").copied().unwrap_or(0),
                r.groups.len()
            );
        }
        Ok(())
    }
}
