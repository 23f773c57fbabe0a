//! What a fit gives: Model-P and Model-H, how they were chosen, and what the fit found.

use super::host::HostParams;
use super::outcome::Chosen;
use super::poly_core::PolyCore;
use super::select::Selection;
use super::static_fidelity::StaticAudit;
use crate::data::outliers::Outlier;
use crate::warning::Warning;

/// A trained pair of models and how they were chosen.
#[derive(Clone, Debug)]
pub struct Trained {
    /// Model-P: the polynomial core alone.
    pub model_p: HostParams,
    /// Model-H: the core with its memory terms and the RBF residual.
    pub model_h: HostParams,
    /// Model-P's core.
    pub core: PolyCore,
    /// What cross-validation tried and chose.
    pub selection: Selection,
    /// Wall time of each phase of the fit \[s\], in order (empty when not fitted here).
    pub phase_seconds: Vec<(&'static str, f64)>,
    /// Both models' static gains and what Model-H's dynamic terms contribute, over the
    /// calibration batch.
    pub static_audit: StaticAudit,
    /// The outlying reference cells whose calibration rows were left out of the fit
    /// ([`super::TrainOptions::on_outlier`] skip; empty otherwise).
    pub skipped: Vec<Outlier>,
    /// What the fit finds worth a user's attention (`outcome::train_warnings`).
    pub warnings: Vec<Warning>,
}

impl Trained {
    /// What cross-validation chose, with σ, α and the memory terms of the final fit.
    pub fn chosen(&self) -> Chosen {
        Chosen::of(&self.selection, &self.model_h)
    }
}
