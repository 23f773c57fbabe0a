//! Scenario names: a paced or stepped variant is named with an `@` suffix in the 24 bytes a
//! model blob's provenance holds.

/// Longest scenario name (the model blob's provenance holds 24 bytes).
pub(crate) const MAX_NAME_LEN: usize = 24;

/// `x` in few characters: `4`, `0.25`, `0.333`.
pub(super) fn short_number(x: f64) -> String {
    if x.is_finite() && x == x.round() && x.abs() < 1e9 {
        return format!("{}", x as i64);
    }
    let s = format!("{x:.3}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
    // Below the third decimal the fixed form would read 0.
    if x != 0.0 && s.parse::<f64>() == Ok(0.0) {
        format!("{x:e}")
    } else {
        s.to_string()
    }
}

/// `name` without its `@` suffixes for which `drop` holds (`paper@x4@steps` without the pace
/// is `paper@steps`).
pub(super) fn without_segments(name: &str, drop: impl Fn(&str) -> bool) -> String {
    let mut parts = name.split('@');
    let mut out = parts.next().unwrap_or("").to_string();
    for seg in parts.filter(|seg| !drop(seg)) {
        out.push('@');
        out.push_str(seg);
    }
    out
}

/// `name` + `suffix` in at most [`MAX_NAME_LEN`] bytes: the base name (before any earlier
/// `@` suffix) is shortened first, down to one character, so that the suffixes stay readable;
/// only then is the end cut.
pub(super) fn with_suffix(name: &str, suffix: &str) -> String {
    let (base, earlier) = name.split_at(name.find('@').unwrap_or(name.len()));
    let tail = format!("{earlier}{suffix}");
    let mut keep = MAX_NAME_LEN.saturating_sub(tail.len()).max(1).min(base.len());
    while !base.is_char_boundary(keep) {
        keep -= 1;
    }
    let mut out = format!("{}{tail}", &base[..keep]);
    let mut end = out.len().min(MAX_NAME_LEN);
    while !out.is_char_boundary(end) {
        end -= 1;
    }
    out.truncate(end);
    out
}
