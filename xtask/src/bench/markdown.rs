//! BENCHMARKS.md from the [`Report`]: one function per section, in the order of the file. Every
//! per-output table has a column per output of its part (`channels`).

use super::pace::{pace_targets_met, PACE_MIN_COVERAGE, SLOPE_TOL};
use super::report::{
    at_most, Accuracy, DeviceResults, EvalRun, FieldBench, FitRun, Fleet, Inference, Machine, PaceBench, PaceSummary,
    PresetRun, Report, SizeRun, StepRow, Training,
};
use super::stats::{at, fold_nan, max_rel_diff, median};
use super::verdict::f;
use super::COVERAGE_SEEDS;
use fbg_report::{GlitchRow, PaceRow};

/// The `paper` gains of the model before static fidelity, printed beside today's: an earlier
/// measurement, not one of this run.
const BEFORE_STATIC_FIDELITY: &str =
    "*earlier measurement, not this run:* before static fidelity (BENCHMARKS at 2f716d4): mean gain 47.9 / 32.2 / 41.9 %";

/// The per-seed coverage target: at least this many coverage seeds within 95 ± 2 %.
const SEEDS_WITHIN_2: usize = 16;

mod accuracy;
mod device;
mod host;
mod installations;
mod pace;
mod targets;

use accuracy::accuracy;
use device::device;
use host::{fleet, inference, slurm, training};
use pace::{pace_section, pace_targets};
use targets::targets;

/// Seconds with three significant figures.
fn secs(x: f64) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let d = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else if x >= 1.0 {
        2
    } else {
        3
    };
    format!("{x:.d$} s")
}

/// A verdict in bold.
fn yes(b: bool) -> &'static str {
    if b {
        "**met**"
    } else {
        "**not met**"
    }
}

/// Per-round values, "1.23, 4.56".
fn list2(v: &[f64]) -> String {
    v.iter().filter(|x| !x.is_nan()).map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ")
}

/// A fit's median time, NaN when it did not run (no peer).
fn median_of(run: Option<&FitRun>) -> f64 {
    run.map_or(f64::NAN, |r| r.median)
}

/// Items joined by " / " (one per output).
fn slash(v: impl IntoIterator<Item = impl std::fmt::Display>) -> String {
    v.into_iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" / ")
}

/// Values joined by " / ", `digits` decimals each.
fn join(v: &[f64], digits: usize) -> String {
    slash(v.iter().map(|x| f(*x, digits)))
}

/// Fractions as percentages with `digits` decimals joined by " / ".
fn pct(v: &[f64], digits: usize) -> String {
    slash(v.iter().map(|x| f(100.0 * x, digits)))
}

/// Fractions as percentages joined by " / ".
fn pcts(v: &[f64]) -> String {
    pct(v, 1)
}

/// `a[c] / b[c]` per output, joined by " / ".
fn ratios(a: &[f64], b: &[f64], digits: usize) -> String {
    slash((0..a.len()).map(|c| f(at(a, c) / at(b, c), digits)))
}

/// An RMSE of the output `name`: three decimals for temperature, two for the others.
fn rmse(x: f64, name: &str) -> String {
    f(x, if name == "T" { 3 } else { 2 })
}

/// RMSE per output joined by " / ".
fn rmses(v: &[f64], channels: &[String]) -> String {
    slash(v.iter().enumerate().map(|(c, x)| rmse(*x, channels.get(c).map_or("", |n| n))))
}

/// Gains of Model-H over Model-P [%] per output.
fn gains(p: &[f64], h: &[f64]) -> String {
    slash((0..p.len()).map(|c| f(fbg_report::gain_pct(p, h, c), 1)))
}

/// Table cells, each " x |".
fn cells(v: impl IntoIterator<Item = impl std::fmt::Display>) -> String {
    v.into_iter().map(|x| format!(" {x} |")).collect()
}

/// `n` empty table cells.
fn blank(n: usize) -> String {
    " |".repeat(n)
}

/// The rule under a table header of `n` columns.
fn rule(n: usize) -> String {
    format!("|{}", "---|".repeat(n))
}

/// An output's short name with its unit (`T [°C]`, `ε [µε]`, `p [kPa]`).
fn channel_unit(name: &str) -> String {
    match name {
        "T" => "T [°C]".into(),
        "strain" => "ε [µε]".into(),
        "strain2" => "ε₂ [µε]".into(),
        "p" => "p [kPa]".into(),
        other => other.into(),
    }
}

/// The outputs with their units, `T [°C] / ε [µε] / p [kPa]`.
fn channel_units(channels: &[String]) -> String {
    slash(channels.iter().map(|c| channel_unit(c)))
}

/// An output's short name (`T`, `ε`, `p`).
fn short(name: &str) -> &str {
    match name {
        "strain" => "ε",
        "strain2" => "ε₂",
        other => other,
    }
}

/// The outputs, "T / ε / p".
fn channel_names(channels: &[String]) -> String {
    slash(channels.iter().map(|n| short(n)))
}

/// Output `c`'s short name ("?" when the run names fewer).
fn channel(channels: &[String], c: usize) -> &str {
    channels.get(c).map_or("?", |n| short(n))
}

/// The target on the mean gain of Model-H over Model-P on the `paper` preset [%] (DESIGN §8).
fn mean_gain_target(name: &str) -> f64 {
    if name.starts_with("strain") {
        30.0
    } else {
        40.0
    }
}

/// The whole file.
pub fn markdown(rep: &Report) -> String {
    let mut s = String::new();
    header(&mut s, rep);
    machine(&mut s, &rep.machine, rep.wall_seconds);
    targets(&mut s, rep);
    training(&mut s, &rep.training, &rep.datasets);
    inference(&mut s, &rep.inference_host);
    accuracy(&mut s, &rep.accuracy);
    pace_section(&mut s, rep);
    if let Some(inst) = &rep.installations {
        installations::installations(&mut s, inst);
    }
    device(&mut s, rep);
    fleet(&mut s, &rep.fleet);
    if let Some(m) = &rep.memory {
        super::memory::markdown(&mut s, m);
    }
    if let Some(v) = &rep.python {
        super::python::markdown(&mut s, v);
    }
    if let Some(sp) = &rep.spectrum {
        super::spectrum::markdown(&mut s, sp);
    }
    if let Some(v) = &rep.slurm {
        slurm(&mut s, v);
    }
    s
}

fn header(s: &mut String, rep: &Report) {
    out!(s, "# Benchmarks\n");
    out!(
        s,
        "Written by `cargo xtask bench` (xtask/src/bench/){}; the same numbers are in `BENCHMARKS.json`. \
         Every time is the median of repeated runs (counts below); every ratio compares runs taken side by side, \
         alternating, in the same invocation. Fits are timed inside the release binaries (CSV reading outside the clock).\n",
        if rep.quick { " **with --quick (one repeat: not for publishing)**" } else { "" }
    );
}

fn machine(s: &mut String, m: &Machine, wall_seconds: f64) {
    let or_q = |v: &Option<String>| v.clone().unwrap_or_else(|| "?".into());
    out!(s, "## Machine\n");
    out!(s, "| | |\n|---|---|");
    out!(s, "| CPU | {} ({} cores), {} RAM |", m.cpu, m.cores, or_q(&m.memory));
    out!(s, "| OS | {} |", m.os);
    out!(s, "| Rust | {} |", m.rustc);
    match &m.scikit_learn {
        Some(v) => out!(
            s,
            "| Python peer | Python {}, numpy {}, scikit-learn {} (venv `target/bench/venv`, `pip install scikit-learn numpy`) |",
            or_q(&m.python),
            or_q(&m.numpy),
            v
        ),
        None => out!(
            s,
            "| Python peer | **skipped**: {} |",
            m.peer_skipped_because.as_deref().unwrap_or("python3/venv/pip unavailable")
        ),
    }
    out!(s, "| QEMU | {} |", m.qemu);
    let dirty = &m.git.modified_files;
    out!(
        s,
        "| source | commit {}{} |",
        m.git.commit,
        if dirty.is_empty() { String::new() } else { format!(" with uncommitted changes to {}", dirty.join(", ")) }
    );
    out!(s, "| load average (1/5/15 min) | {} at the start, {} at the end |", m.loadavg_start, m.loadavg_end);
    out!(s, "| whole run | {:.0} s |\n", if wall_seconds.is_finite() { wall_seconds } else { 0.0 });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// BENCHMARKS.md is what this writer makes of BENCHMARKS.json: after a change to the writer,
    /// `cargo xtask bench --markdown-only` renders it again.
    #[test]
    fn committed_benchmarks_md_is_rendered_from_the_json() {
        let root = crate::cmd::root();
        let report: Report = super::super::runner::read_json(&root.join("BENCHMARKS.json")).unwrap();
        let md = std::fs::read_to_string(root.join("BENCHMARKS.md")).unwrap();
        assert!(
            markdown(&report) == md,
            "BENCHMARKS.md differs from what xtask/src/bench/markdown.rs makes of BENCHMARKS.json: run `cargo xtask bench --markdown-only`"
        );
    }
}
