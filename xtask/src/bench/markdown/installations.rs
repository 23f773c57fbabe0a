//! The hold-out band coverage of the other installations: its target row and its section.

use super::*;
use crate::bench::installations::InstallationCoverage;

/// The target row: every installation's mean within 95 ± 3 % per channel, no seed below 85 %.
pub(super) fn target_row(s: &mut String, inst: &[InstallationCoverage]) {
    let measured: Vec<String> = inst
        .iter()
        .map(|i| {
            let nc = i.channels.len();
            let means: Vec<f64> = (0..nc).map(|c| InstallationCoverage::mean(&i.coverage_h, c)).collect();
            let mins: Vec<f64> = (0..nc).map(|c| InstallationCoverage::min(&i.coverage_h, c)).collect();
            format!(
                "`{}` ({}): mean {} %, lowest seed {} %, {} channel-seeds below 85 %",
                i.preset,
                channel_names(&i.channels),
                pcts(&means),
                pcts(&mins),
                i.below_floor().len()
            )
        })
        .collect();
    let met = !inst.is_empty() && inst.iter().all(InstallationCoverage::met);
    out!(
        s,
        "| {} presets, seeds {}–{}: Model-H hold-out band coverage, mean within 95 ± 3 % per channel, no seed below 85 % (DESIGN §4) | {} | {} | installations part (below) |",
        slash(inst.iter().map(|i| format!("`{}`", i.preset))),
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
        measured.join("; "),
        if met { "**met**" } else { "**not met**" }
    );
}

/// The section: per installation, Model-H's and Model-P's coverage per channel over the seeds.
pub(super) fn installations(s: &mut String, inst: &[InstallationCoverage]) {
    if inst.is_empty() {
        return;
    }
    out!(s, "## Hold-out band coverage of the other installations\n");
    out!(
        s,
        "The week after calibration of each seed's own record (`simulate --preset P --seed S`), the models and bands `train` \
         makes with the interrogator's statement (its stated stability and per-channel drift gains, from the record's \
         `.meta.json`). Per channel: mean over the seeds (lowest seed). Target: mean within 95 ± 3 %, no seed below 85 %.\n"
    );
    out!(s, "| installation | seeds | channels | Model-H coverage | Model-P coverage | below 85 % (seed: channel %) |\n|---|---|---|---|---|---|");
    for i in inst {
        let nc = i.channels.len();
        let cell = |v: &[Vec<f64>]| {
            slash((0..nc).map(|c| {
                format!(
                    "{:.1} ({:.1})",
                    100.0 * InstallationCoverage::mean(v, c),
                    100.0 * InstallationCoverage::min(v, c)
                )
            }))
        };
        let low: Vec<String> =
            i.below_floor().iter().map(|(seed, ch, v)| format!("{seed}: {ch} {:.1}", 100.0 * v)).collect();
        out!(
            s,
            "| `{}` | {} | {} | {} % | {} % | {} |",
            i.preset,
            i.seeds.len(),
            channel_names(&i.channels),
            cell(&i.coverage_h),
            cell(&i.coverage_p),
            if low.is_empty() { "none".to_string() } else { low.join(", ") }
        );
    }
    if let Some(first) = inst.first() {
        out!(s, "\n    {}\n", first.command);
    }
}
