//! `fbg-trainer golden`: golden vectors for the firmware tests.

use std::path::PathBuf;

use anyhow::Result;

use fbg_trainer::data::files::check_outputs;
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::export;

/// Write golden vectors (device inputs and f64 expected outputs) for the firmware tests.
#[derive(clap::Args)]
pub struct GoldenArgs {
    /// Dataset CSV whose first hold-out samples become the vectors.
    #[arg(long)]
    data: PathBuf,
    /// Model-H blob the expected outputs come from.
    #[arg(long, default_value = "model.fbgm")]
    model: PathBuf,
    /// Number of hold-out samples.
    #[arg(long, default_value_t = 1000)]
    samples: usize,
    /// Output directory (created when missing): golden_inputs.bin, golden_expected.csv,
    /// golden_meta.json.
    #[arg(long, default_value = "golden")]
    out: PathBuf,
}

impl GoldenArgs {
    pub fn run(self) -> Result<()> {
        let (data, model, out) = (&self.data, &self.model, &self.out);
        let files = export::golden_files(out);
        let side = fbg_trainer::data::record_meta::sidecar_path(data);
        check_outputs(&files.iter().map(PathBuf::as_path).collect::<Vec<_>>(), &[data, &side, model])?;
        let d = Dataset::read_csv(data)?;
        let h = export::read_blob(model)?;
        d.inputs_for(&h.dims, &data.display().to_string(), "golden")?;
        let hold = d.holdout_indices();
        let idx: Vec<usize> = hold.into_iter().take(self.samples).collect();
        let (eh, _) = evaluate_holdout(&h, &d)?;
        let rmse: Vec<f64> = eh.channels.iter().map(|c| c.rmse).collect();
        export::write_golden(out, &h, &d, &idx, &rmse)?;
        eprintln!("wrote {} golden samples into {}", idx.len(), out.display());
        Ok(())
    }
}
