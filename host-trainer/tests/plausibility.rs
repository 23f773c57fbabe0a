//! Implausible models at the trainer's edge: `sign` refuses what the decoder
//! refuses, the trainer never writes such a blob, and `compensate` flags every row of a model
//! whose estimates leave their calibration envelope.

use std::path::Path;

use crate::common;
use common::{bin, run, short_csv};

use fbg_shared::blob;
use fbg_shared::layout::{Dims, Output, Quantity};
use fbg_shared::ModelParams;
use fbg_trainer::export;

const TINY: &[u8] = include_bytes!("../../shared/tests/golden/tiny_v7.fbgm");

type P32 = ModelParams<f32, 8>;

/// `p` as a blob with a valid CRC, whatever its numbers (what a broken or hostile tool writes).
fn unchecked(p: &P32) -> Vec<u8> {
    let mut buf = vec![0u8; blob::max_len(8)];
    let n = blob::encode_unchecked(p, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// The issue's cases on the tiny golden model, each with the field the refusal must name.
fn issue_cases() -> Vec<(&'static str, P32)> {
    let good: P32 = blob::decode(TINY).unwrap();
    let s1 = good.dims.stage1_len();
    let mut intercept = good.clone();
    intercept.stage1[0][s1 - 1] = 3.4e38; // T intercept: T = 3.4e38 °C
    let mut variance = good.clone();
    variance.centres[0].v[0] = 3.4e38;
    let mut resid = good.clone();
    resid.resid_var[0] = 3.4e38;
    let mut index = good.clone();
    let outs = [
        Output::first(Quantity::Temperature),
        Output { quantity: Quantity::Strain, index: 200 },
        Output::first(Quantity::Pressure),
    ];
    index.dims = Dims::new(good.dims.gratings(), good.dims.ambient(), &outs).unwrap();
    vec![("stage1", intercept), ("centres.v", variance), ("resid_var", resid), ("dims.outputs", index)]
}

fn assert_sign_refuses(dir: &Path, key: &Path, name: &str, bytes: &[u8], field: &str) {
    let model = dir.join(format!("{name}.fbgm"));
    std::fs::write(&model, bytes).unwrap();
    let signed = dir.join(format!("{name}-signed.fbgm"));
    let (ok, _, err) =
        run(bin().args(["sign", "--model"]).arg(&model).arg("--out").arg(&signed).arg("--sign").arg(key));
    assert!(!ok, "{name}: signed");
    assert!(
        err.contains(&format!("model parameter {field} ")) && err.contains(&format!("{name}.fbgm")),
        "{name}: {err}"
    );
    assert!(!signed.exists(), "{name}: an output was written");
}

#[test]
fn sign_refuses_an_implausible_blob_with_a_valid_crc() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    fbg_trainer::sign::keygen(&key).unwrap();
    for (field, p) in issue_cases() {
        let bytes = unchecked(&p);
        assert_eq!(blob::stored_crc(&bytes), blob::computed_crc(&bytes));
        assert_sign_refuses(d.path(), &key, &field.replace('.', "_"), &bytes, field);
        // `inspect` and every other reader refuse it the same way.
        let m = d.path().join("x.fbgm");
        std::fs::write(&m, &bytes).unwrap();
        let err = export::read_blob(&m).unwrap_err().to_string();
        assert!(err.contains(field), "{err}");
    }
    // The untouched model signs.
    let model = d.path().join("tiny.fbgm");
    std::fs::write(&model, TINY).unwrap();
    let (ok, _, err) = run(bin()
        .args(["sign", "--model"])
        .arg(&model)
        .arg("--out")
        .arg(d.path().join("s.fbgm"))
        .arg("--sign")
        .arg(&key));
    assert!(ok, "{err}");
}

#[test]
fn the_trainer_never_encodes_an_implausible_model() {
    let good: fbg_trainer::fit::HostParams = blob::decode::<8>(TINY).unwrap().convert().unwrap();
    assert!(export::blob_bytes(&good).is_ok());
    for (field, p) in issue_cases() {
        let host: fbg_trainer::fit::HostParams = p.convert().unwrap();
        let err = export::blob_bytes(&host).unwrap_err().to_string();
        assert!(err.contains(&format!("model parameter {field} ")), "{field}: {err}");
        let out = tempfile::tempdir().unwrap();
        let path = out.path().join("m.fbgm");
        assert!(export::write_blob(&path, &host).is_err());
        assert!(!path.exists());
    }
    // A value f64 holds but f32 does not (it would decode as infinity).
    let mut big = good.clone();
    big.poly[1][0] = 1e300;
    let err = export::blob_bytes(&big).unwrap_err().to_string();
    assert!(err.contains("model parameter poly "), "{err}");
}

/// A trained model made wrong with numbers that all pass the decoder (T read 500 °C high, as
/// from a wrong zero): `compensate` flags every row implausible, in f64 and in the device's f32.
#[test]
fn compensate_flags_every_row_of_a_wrong_model() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let mut p = export::read_blob(&model).unwrap();
    p.poly[0][0] += 500.0;
    let wrong = d.path().join("wrong.fbgm");
    export::write_blob(&wrong, &p).unwrap();
    for (m, implausible) in [(&model, false), (&wrong, true)] {
        for f32 in [false, true] {
            let out = d.path().join("comp.csv");
            let mut cmd = bin();
            cmd.args(["compensate", "--model"]).arg(m).arg("--data").arg(&csv).arg("--out").arg(&out);
            if f32 {
                cmd.arg("--f32");
            }
            let (ok, _, err) = run(&mut cmd);
            assert!(ok, "{err}");
            let text = std::fs::read_to_string(&out).unwrap();
            let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
            let col = head.iter().position(|h| h.starts_with("flag")).expect("a flags column");
            let rows: Vec<Vec<String>> =
                text.lines().skip(1).map(|l| l.split(',').map(str::to_string).collect()).collect();
            let flagged = rows.iter().filter(|r| r.iter().skip(col).any(|c| c.contains("implausible"))).count();
            if implausible {
                assert_eq!(flagged, rows.len(), "f32 {f32}");
            } else {
                assert_eq!(flagged, 0, "f32 {f32}");
            }
        }
    }
}
