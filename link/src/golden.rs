//! The golden-vector files: what the trainer writes (`fbg-trainer golden`) and the firmware's
//! tests read and write (`cargo xtask`).
//!
//! - inputs (`golden_inputs.bin`): samples as [`fbg_shared::golden`] lays them out (grating
//!   count, eight shifts, T_amb, t);
//! - expected answers (`golden_expected.csv`): the header ([`expected_header`]: `value1..M`,
//!   `band1..M`, `flags`), then per sample the model's M values, M band half-widths (f64,
//!   shortest exact form: they read back bit for bit) and the flag bits;
//! - packs: models with their samples, as a test image embeds them ([`pack_bytes`]; the device
//!   reads them with [`fbg_shared::golden::records`]).
//!
//! ```
//! use fbg_link::golden::{expected_csv, inputs_bytes, parse_expected, parse_inputs};
//! use fbg_shared::{Estimate, Flags, Sample};
//!
//! let s = [Sample::new([1.0f32, 2.0, 3.0], 20.0, 0.0)];
//! assert_eq!(parse_inputs(&inputs_bytes(&s)).unwrap(), s);
//! let e = [Estimate {
//!     values: [0.1, f64::NAN, 3.0, 0.0],
//!     band95: [f64::INFINITY, 1.0, 2.0, 0.0],
//!     outputs: 3,
//!     flags: Flags::WEAK_SUPPORT,
//! }];
//! let back = parse_expected(&expected_csv(&e)).unwrap();
//! assert_eq!(back[0].values[0], 0.1);
//! assert!(back[0].values[1].is_nan() && back[0].band95[0] == f64::INFINITY);
//! assert_eq!(back[0].flags, Flags::WEAK_SUPPORT);
//! ```

use std::fmt::Write as _;

use fbg_shared::golden::{record_lengths, sample_bytes, samples, SAMPLE_BYTES};
use fbg_shared::layout::MAX_OUTPUTS;
use fbg_shared::{Estimate, Flags, Sample};

/// Header line of the expected-answers CSV of a model with `m` outputs:
/// `value1,…,valueM,band1,…,bandM,flags`.
pub fn expected_header(m: usize) -> String {
    let mut h: Vec<String> = (1..=m).map(|i| format!("value{i}")).collect();
    h.extend((1..=m).map(|i| format!("band{i}")));
    h.push("flags".into());
    h.join(",")
}

/// What is wrong with a golden file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FormatError {
    /// 1-based line of a CSV (0 for binary inputs).
    pub line: usize,
    /// What is wrong there.
    pub message: String,
}

impl core::fmt::Display for FormatError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.message)
        } else {
            f.write_str(&self.message)
        }
    }
}

impl std::error::Error for FormatError {}

/// Golden inputs as bytes.
pub fn inputs_bytes(samples: &[Sample<f32>]) -> Vec<u8> {
    samples.iter().flat_map(sample_bytes).collect()
}

/// Golden inputs from bytes (a whole number of samples).
pub fn parse_inputs(bytes: &[u8]) -> Result<Vec<Sample<f32>>, FormatError> {
    if !bytes.len().is_multiple_of(SAMPLE_BYTES) {
        return Err(FormatError {
            line: 0,
            message: format!("{} bytes is not a whole number of {SAMPLE_BYTES}-byte samples", bytes.len()),
        });
    }
    Ok(samples(bytes).collect())
}

/// The expected-answers CSV of `rows` (all of one model: the first row's output count names
/// the columns).
pub fn expected_csv(rows: &[Estimate<f64>]) -> String {
    let m = rows.first().map_or(0, |e| usize::from(e.outputs));
    let mut s = String::with_capacity(64 + rows.len() * 100);
    s.push_str(&expected_header(m));
    s.push('\n');
    for e in rows {
        for v in e.values().iter().chain(e.band()) {
            let _ = write!(s, "{v:e},");
        }
        let _ = writeln!(s, "{}", e.flags.0);
    }
    s
}

/// The rows of an expected-answers CSV (blank lines skipped).
pub fn parse_expected(text: &str) -> Result<Vec<Estimate<f64>>, FormatError> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    let cols = header.trim().split(',').count();
    let m = cols.saturating_sub(1) / 2;
    let want = expected_header(m);
    if header.trim() != want || !(1..=MAX_OUTPUTS).contains(&m) {
        return Err(FormatError {
            line: 1,
            message: format!(
                "header is `{header}`, expected `{}` with 1 to {MAX_OUTPUTS} outputs",
                expected_header(m.max(1))
            ),
        });
    }
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        let at = |message: String| FormatError { line: i + 2, message };
        if line.trim().is_empty() {
            continue;
        }
        let row: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some((flags, numbers)) = row.split_last().filter(|_| row.len() == cols) else {
            return Err(at(format!("expected {cols} columns, found {}", row.len())));
        };
        let mut e = Estimate { outputs: m as u8, ..Estimate::default() };
        for (k, c) in numbers.iter().enumerate() {
            let v = parse_f64(c).ok_or_else(|| at(format!("column {}: `{c}` is not a number", k + 1)))?;
            if k < m {
                e.values[k] = v;
            } else {
                e.band95[k - m] = v;
            }
        }
        e.flags = Flags(flags.parse().map_err(|_| at(format!("column {cols} (flags): `{flags}` is not a flag byte")))?);
        out.push(e);
    }
    Ok(out)
}

fn parse_f64(s: &str) -> Option<f64> {
    match s.to_ascii_lowercase().as_str() {
        "nan" => Some(f64::NAN),
        "inf" | "+inf" | "infinity" => Some(f64::INFINITY),
        "-inf" | "-infinity" => Some(f64::NEG_INFINITY),
        _ => s.parse::<f64>().ok(),
    }
}

/// Models and their samples as one pack, as a test image embeds it.
pub fn pack_bytes(records: &[(&[u8], &[Sample<f32>])]) -> Vec<u8> {
    let mut out = Vec::new();
    for (blob, samples) in records {
        let (blob_len, n_samples) = record_lengths(blob.len(), samples.len());
        out.extend_from_slice(&blob_len);
        out.extend_from_slice(blob);
        out.extend_from_slice(&n_samples);
        out.extend(inputs_bytes(samples));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_files_are_named_by_line() {
        assert_eq!(parse_inputs(&[0u8; 21]).unwrap_err().line, 0);
        assert_eq!(parse_expected("a,b\n").unwrap_err().line, 1);
        let h = expected_header(3);
        assert_eq!(h, "value1,value2,value3,band1,band2,band3,flags");
        let e = parse_expected(&format!("{h}\n\n1,2,3\n")).unwrap_err();
        assert_eq!((e.line, e.message.as_str()), (3, "expected 7 columns, found 3"));
        let e = parse_expected(&format!("{h}\n1,2,3,4,5,x,0\n")).unwrap_err();
        assert_eq!(e.to_string(), "line 2: column 6: `x` is not a number");
        let rows = parse_expected(&format!("{h}\n1.5,NaN,-inf,0,0,0,7\n")).unwrap();
        assert_eq!((rows[0].band95, rows[0].outputs), ([0.0; 4], 3));
        // Two outputs (and none beyond the capacity).
        assert!(rows[0].values[1].is_nan() && rows[0].values[2] == f64::NEG_INFINITY);
        let two = parse_expected(&format!("{}\n1,2,3,4,0\n", expected_header(2))).unwrap();
        assert_eq!((two[0].values(), two[0].band()), (&[1.0, 2.0][..], &[3.0, 4.0][..]));
        assert_eq!(parse_expected(&format!("{}\n", expected_header(5))).unwrap_err().line, 1);
    }

    #[test]
    fn a_pack_reads_back_on_the_device_side() {
        let s = [Sample::new([1.0f32, 2.0, 3.0], 4.0, 5.0); 3];
        let pack = pack_bytes(&[(&[9, 9], &s[..1]), (&[], &s)]);
        assert_eq!(pack.len(), 4 + 2 + 4 + SAMPLE_BYTES + 4 + 4 + 3 * SAMPLE_BYTES);
        let recs: Vec<_> = fbg_shared::golden::records(&pack).map(Option::unwrap).collect();
        assert_eq!((recs[0].blob, recs[0].len(), recs[1].len()), (&[9u8, 9][..], 1, 3));
        assert_eq!(recs[1].iter().collect::<Vec<_>>(), s);
    }
}
