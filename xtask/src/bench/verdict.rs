//! The words every section of BENCHMARKS.md writes a figure and a verdict with (a leaf: the
//! measuring modules and the markdown both use it, it uses neither).

/// A number with `digits` decimals, "–" when missing (NaN) or infinite.
pub fn f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

/// A verdict, bold when missed.
pub fn met(ok: bool) -> &'static str {
    if ok {
        "met"
    } else {
        "**not met**"
    }
}
