//! `fbg-trainer`: the command line (DESIGN §10). Errors end here as `anyhow` messages that name
//! the file, line, column or key.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

use fbg_trainer::scenario::{Preset, ScenarioConfig};
use fbg_trainer::sim;

#[derive(Parser)]
#[command(name = "fbg-trainer", version, about = "Hybrid AI–polynomial compensation for FBG sensors: simulate, train, evaluate, report, export")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

/// Where the scenario comes from.
#[derive(clap::Args, Clone)]
struct ScenarioArgs {
    /// Built-in scenario preset.
    #[arg(long, value_enum, default_value = "paper", conflicts_with = "config")]
    preset: Preset,
    /// Scenario TOML file; keys not given keep the `paper` defaults.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Random seed.
    #[arg(long, default_value_t = 7)]
    seed: u64,
}

impl ScenarioArgs {
    fn load(&self) -> Result<ScenarioConfig> {
        match &self.config {
            Some(p) => Ok(ScenarioConfig::from_toml_file(p)?),
            None => Ok(self.preset.config()),
        }
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Simulate an installation and write its CSV.
    Simulate {
        #[command(flatten)]
        scenario: ScenarioArgs,
        /// Output CSV.
        #[arg(long, default_value = "data.csv")]
        out: PathBuf,
        /// Print a JSON summary (samples, std of T/ε/p, oracle floor) on stdout.
        #[arg(long)]
        json: bool,
        /// Also write the scenario as TOML (every parameter, for audit and editing).
        #[arg(long)]
        dump_config: Option<PathBuf>,
    },
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Simulate { scenario, out, json, dump_config } => {
            let cfg = scenario.load()?;
            let s = sim::simulate(&cfg, scenario.seed);
            s.data.write_csv(&out)?;
            if let Some(p) = dump_config {
                let text = toml::to_string(&cfg).context("serialising the scenario")?;
                fbg_trainer::dataset::write_bytes_atomically(&p, text.as_bytes())?;
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&s.summary())?);
            } else {
                let o = s.oracle_floor();
                eprintln!(
                    "wrote {} ({} samples, scenario {}, seed {}); oracle floor on the hold-out: T {:.3} °C, ε {:.2} µε, p {:.2} kPa",
                    out.display(),
                    s.data.len(),
                    cfg.name,
                    scenario.seed,
                    o.rmse_holdout[0],
                    o.rmse_holdout[1],
                    o.rmse_holdout[2]
                );
            }
            Ok(())
        }
    }
}
