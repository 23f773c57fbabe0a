//! Bounded waits and bounded memory: a trickling device times
//! out at the answer deadline, an overlong line is refused as it is read, a huge cell is cut
//! in the message, `compensate` streams its rows to the same bytes as before, and a model
//! that cannot be loaded is named.

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::common;
#[cfg(target_os = "linux")]
use common::run_peak_rss;
use common::{bin, run, short_csv};

use fbg_trainer::compensate::{self, Precision};
use fbg_trainer::data::{quote_cell, Dataset, MAX_LINE_BYTES};
use fbg_trainer::eval::score;
use fbg_trainer::export;

/// A dataset CSV with `bad` as the last cell of its third data row (line 4).
fn csv_with(dir: &Path, bad: &[u8]) -> std::path::PathBuf {
    csv_with_repeated(dir, bad, 1)
}

/// [`csv_with`] with `piece` written `times` times as that cell (never held whole).
fn csv_with_repeated(dir: &Path, piece: &[u8], times: usize) -> std::path::PathBuf {
    let p = dir.join("bad.csv");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
    f.write_all(b"t_s,T_C,T_amb_C,dl1_pm,split\n0,20,20,1,cal\n60,20,20,1,cal\n120,20,20,").unwrap();
    for _ in 0..times {
        f.write_all(piece).unwrap();
    }
    f.write_all(b",cal\n180,20,20,1,cal\n").unwrap();
    f.flush().unwrap();
    p
}

#[cfg(target_os = "linux")]
#[test]
fn a_line_over_the_limit_is_refused_with_its_number_without_being_read_whole() {
    let d = tempfile::tempdir().unwrap();
    // 200 MB of digits in one cell (written in pieces): before, the reader took 1.3 GB and
    // then refused it.
    let csv = csv_with_repeated(d.path(), &[b'7'; 1 << 20], 200);
    let model = d.path().join("m.fbgm");
    let (ok, err, rss) = run_peak_rss(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(!ok);
    assert!(err.contains("line 4") && err.contains(&format!("longer than {MAX_LINE_BYTES} bytes")), "{err}");
    assert!(err.len() < 1000, "the line is not echoed: {} bytes of message", err.len());
    eprintln!("peak RSS {} MB", rss >> 20);
    assert!(rss < 64 << 20, "peak RSS {} MB: the line was read whole", rss >> 20);
    assert!(!model.exists());
}

/// A fake device on a local port that answers every connection by trickling one byte every
/// 200 ms (never a complete frame) until the client goes away.
fn trickling_device() -> (u16, std::thread::JoinHandle<()>) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let h = std::thread::spawn(move || {
        let (mut sock, _) = listener.accept().unwrap();
        for _ in 0..300 {
            std::thread::sleep(Duration::from_millis(200));
            if sock.write_all(&[0x42]).is_err() {
                return;
            }
        }
    });
    (port, h)
}

#[test]
fn device_status_times_out_on_a_trickling_device_at_the_deadline() {
    let (port, dev) = trickling_device();
    let t0 = Instant::now();
    let (ok, _, err) = run(bin().args(["device", "status", "--timeout", "2", "--port"]).arg(port.to_string()));
    let took = t0.elapsed();
    assert!(!ok, "{err}");
    assert!(err.contains("timed out") && err.contains("within 2.000 s"), "{err}");
    // Before: each trickled byte restarted a per-read time-out and this waited a minute; the
    // upper bound leaves room for a loaded machine running every test at once.
    assert!(took >= Duration::from_secs(2) && took < Duration::from_secs(6), "{took:?}: {err}");
    dev.join().unwrap();
}

#[test]
fn a_line_just_over_the_limit_is_refused_and_one_at_the_limit_is_read() {
    let d = tempfile::tempdir().unwrap();
    // A cell padded with leading zeros to make its line exactly the limit: still a number.
    let line_rest = "120,20,20,".len() + ",cal".len();
    let at_limit = format!("{}1", "0".repeat(MAX_LINE_BYTES - line_rest - 1));
    let csv = csv_with(d.path(), at_limit.as_bytes());
    assert_eq!(Dataset::read_csv(&csv).unwrap().len(), 4);
    let over = format!("0{at_limit}");
    let csv = csv_with(d.path(), over.as_bytes());
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    assert!(e.contains("bad.csv: line 4") && e.contains("longer than"), "{e}");
    // The comment lines before the header are bounded too.
    let p = d.path().join("comment.csv");
    std::fs::write(&p, format!("# {}\nt_s,T_C,dl1_pm\n0,1,2\n", "x".repeat(2 << 20))).unwrap();
    let e = Dataset::read_csv(&p).unwrap_err().to_string();
    assert!(e.contains("line 1") && e.contains("longer than"), "{e}");
}

#[test]
fn a_10_mb_cell_is_quoted_cut_to_40_characters() {
    let d = tempfile::tempdir().unwrap();
    // Under the line limit: a cell that is not a number, and a split that is not a split.
    let mut cell = "x".repeat(900_000);
    cell.insert_str(0, "abcdefghij");
    let csv = csv_with(d.path(), cell.as_bytes());
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    assert!(e.contains("line 4, column dl1_pm"), "{e}");
    assert!(e.contains(&format!("`abcdefghij{}… (900010 bytes)` is not a number", "x".repeat(30))), "{e}");
    assert!(e.len() < 200, "{e}");
    assert_eq!(quote_cell("short"), "short");
    assert_eq!(quote_cell(&"é".repeat(41)), format!("{}… (82 bytes)", "é".repeat(40)));
    // 10 MB in one cell is over the line limit: refused without the cell in the message.
    let csv = csv_with(d.path(), &vec![b'y'; 10 << 20]);
    let (ok, _, err) = run(bin().args(["compensate", "--model", "none.fbgm", "--out", "x.csv", "--data"]).arg(&csv));
    assert!(!ok && err.len() < 1000, "{} bytes: {}", err.len(), &err[..err.len().min(300)]);
    let p = d.path().join("split.csv");
    std::fs::write(&p, format!("t_s,T_C,dl1_pm,split\n0,1,2,{}\n", "s".repeat(5000))).unwrap();
    let e = Dataset::read_csv(&p).unwrap_err().to_string();
    assert!(e.contains(&format!("`{}… (5000 bytes)` is neither", "s".repeat(40))), "{e}");
}

/// The output `compensate` wrote before it streamed: every estimate of the in-memory path
/// (`compensate::estimates`, the record read whole), in the same format.
fn in_memory_output(model: &Path, csv: &Path, precision: Precision) -> String {
    fn cell(x: f64) -> String {
        if x.is_finite() {
            format!("{x}")
        } else {
            String::new()
        }
    }
    let params = export::read_blob(model).unwrap();
    let data = Dataset::read_field_csv(csv).unwrap();
    let est = compensate::estimates(&params, &data, precision).unwrap();
    let mut s = String::from("t_s");
    for c in compensate::output_columns(&params) {
        s.push_str(&format!(",{c},{c}_band95"));
    }
    s.push_str(",flags,flag_names\n");
    for (i, e) in est.iter().enumerate() {
        s.push_str(&format!("{}", data.t_s[i]));
        for c in 0..params.dims.n_outputs() {
            s.push_str(&format!(",{},{}", cell(e.values[c]), cell(e.band95[c])));
        }
        s.push_str(&format!(",{},{}\n", e.flags.0, e.flags));
    }
    s
}

#[test]
fn streamed_compensate_writes_what_the_in_memory_path_wrote() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // Gaps in the inputs and in a reference, and no split column.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut field = String::new();
    let mut n = 0;
    for l in text.lines() {
        if l.starts_with('#') || l.starts_with("t_s") {
            field.push_str(l);
        } else {
            n += 1;
            let mut cells: Vec<&str> = l.split(',').collect();
            if n % 17 == 0 {
                cells[6] = "";
            }
            if n % 23 == 0 {
                cells[1] = "";
            }
            field.push_str(&cells.join(","));
        }
        field.push('\n');
    }
    let rec = d.path().join("field.csv");
    std::fs::write(&rec, field).unwrap();
    for (precision, flag) in [(Precision::F64, None), (Precision::F32, Some("--f32"))] {
        let out = d.path().join("out.csv");
        let (ok, js, err) = run(bin()
            .args(["compensate", "--json", "--model"])
            .arg(&model)
            .args(flag)
            .arg("--data")
            .arg(&rec)
            .arg("--out")
            .arg(&out));
        assert!(ok, "{err}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), in_memory_output(&model, &rec, precision), "{precision:?}");
        // The reference errors from running sums are `score`'s on the same rows, bit for bit
        // (from the library: JSON's float parsing may move the last bit).
        let s: serde_json::Value = serde_json::from_str(&js).unwrap();
        let sum = compensate::run(&model, &rec, &d.path().join("lib.csv"), precision, Default::default(), false)
            .unwrap()
            .reference_errors
            .unwrap();
        let params = export::read_blob(&model).unwrap();
        let data = Dataset::read_field_csv(&rec).unwrap();
        let rows: Vec<usize> = (0..data.len()).filter(|&i| data.usable(i)).collect();
        let all = compensate::estimates(&params, &data, precision).unwrap();
        let at: Vec<_> = rows.iter().map(|&i| all[i]).collect();
        let ch = score::score(&params.dims, &data, &rows, &at).channels;
        assert!(s["gap_rows"].as_u64().unwrap() > 0);
        for (c, ch) in ch.iter().enumerate() {
            assert_eq!(sum.rmse[c].to_bits(), ch.rmse.to_bits());
            assert_eq!(sum.bias[c].to_bits(), ch.bias.to_bits());
            assert_eq!(sum.coverage[c].to_bits(), ch.coverage.to_bits());
            assert_eq!(sum.rows[c], rows.len());
        }
    }
}

#[test]
fn compensate_f32_names_the_model_it_cannot_load() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // A weight no fit can produce (beyond f32, and beyond the decoder's plausibility bound,
    // so both paths refuse it): each error names the model file, not "fit:".
    let mut params = export::read_blob(&model).unwrap();
    params.centres[0].w[0] = 1e300;
    for (precision, what) in [(Precision::F32, "device's f32"), (Precision::F64, "host's f64")] {
        let e = compensate::load_check(&params, precision, &model).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}: cannot be loaded for the {what} arithmetic", model.display())), "{e}");
        assert!(!e.starts_with("fit:"), "{e}");
    }
}

#[test]
fn compensate_stopped_by_a_bad_row_leaves_no_output() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // A bad cell far down the record: rows before it were already compensated and written to
    // the temporary file when the reader met it.
    let mut text = std::fs::read_to_string(&csv).unwrap();
    let lines = text.lines().count();
    text.push_str("1e12,20,0,150,20,1,2,oops,holdout\n");
    let bad = d.path().join("bad.csv");
    std::fs::write(&bad, text).unwrap();
    let out = d.path().join("out.csv");
    std::fs::write(&out, "the old output\n").unwrap();
    let (ok, _, err) =
        run(bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(&bad).arg("--out").arg(&out));
    assert!(!ok);
    assert!(err.contains(&format!("line {}, column dl3_pm: `oops` is not a number", lines + 1)), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "the old output\n", "the old output is kept");
    let left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".fbg-tmp"))
        .collect();
    assert!(left.is_empty(), "no temporary left behind");
}

#[cfg(target_os = "linux")]
#[test]
fn compensate_memory_does_not_grow_with_the_record() {
    let d = tempfile::tempdir().unwrap();
    let small = d.path().join("small.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--out"]).arg(&small));
    assert!(ok, "{err}");
    // Ten times the rows: the same 14 days sampled every 6.048 s.
    let cfg = d.path().join("fine.toml");
    std::fs::write(&cfg, "[clock]\ndt_s = 6.048\n").unwrap();
    let big = d.path().join("big.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--config"]).arg(&cfg).arg("--out").arg(&big));
    assert!(ok, "{err}");
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&small).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let peak = |data: &Path| {
        let out = d.path().join("out.csv");
        let (ok, err, rss) = run_peak_rss(
            bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(data).arg("--out").arg(&out),
        );
        assert!(ok, "{err}");
        rss
    };
    let (a, b) = (peak(&small), peak(&big));
    eprintln!("compensate peak RSS: {} kB on 20 160 rows, {} kB on 201 600 rows", a >> 10, b >> 10);
    // Before it streamed, the record and every estimate were held: tens of MB more here.
    assert!(b < a + (8 << 20), "{} kB vs {} kB", b >> 10, a >> 10);
}

/// Peak RSS of `fbg-trainer import --format FORMAT --map MAP DATA --out OUT`, which must succeed.
#[cfg(target_os = "linux")]
fn import_peak_rss(format: &str, map: &Path, data: &Path, out: &Path) -> u64 {
    let (ok, err, rss) =
        run_peak_rss(bin().args(["import", "--format", format, "--map"]).arg(map).arg(data).arg("--out").arg(out));
    assert!(ok, "{err}");
    rss
}

/// A logger table is read as a stream: what grows with the file is the columns the map takes,
/// not its text. Rows with 60 columns the map does not take (≈ 700 B each), 2 000 and 40 000 of
/// them: the larger import's peak RSS stays under the smaller's plus half the larger file.
#[cfg(target_os = "linux")]
#[test]
fn logger_import_memory_grows_with_the_columns_taken_not_the_text() {
    let d = tempfile::tempdir().unwrap();
    let map = d.path().join("map.toml");
    std::fs::write(
        &map,
        "[time]\ncolumn = \"t_s\"\n[[grating]]\ncolumn = \"A\"\nunit = \"shift_pm\"\n[temperature]\ncolumn = \"TC\"\n",
    )
    .unwrap();
    let write = |name: &str, rows: usize| {
        let path = d.path().join(name);
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let extra: Vec<String> = (0..60).map(|i| format!("X{i}")).collect();
        writeln!(f, "t_s,A,TC,{}", extra.join(",")).unwrap();
        for k in 0..rows {
            let cells: Vec<String> = (0..60).map(|i| format!("{:.6}", ((k * 61 + i) % 997) as f64 / 997.0)).collect();
            writeln!(f, "{},{:.3},{:.2},{}", 60 * k, (k % 50) as f64 * 0.1, 20.0 + (k % 7) as f64, cells.join(","))
                .unwrap();
        }
        drop(f);
        path
    };
    let (small, big) = (write("small.csv", 2_000), write("big.csv", 40_000));
    let peak = |data: &Path| import_peak_rss("csv", &map, data, &d.path().join("out.csv"));
    let (a, b) = (peak(&small), peak(&big));
    let size = std::fs::metadata(&big).unwrap().len();
    eprintln!(
        "logger import peak RSS: {} kB on 2 000 rows, {} kB on 40 000 rows ({} kB of text)",
        a >> 10,
        b >> 10,
        size >> 10
    );
    // Read whole, the text alone (and its copy) was twice the file.
    assert!(b < a + size / 2, "{} kB vs {} kB, file {} kB", b >> 10, a >> 10, size >> 10);
}

/// An ENLIGHT peaks export is read as a stream too: what grows with the file is the gratings the
/// map takes, not its text. Rows of four channels with eight peaks each (≈ 340 B), the map
/// taking one of them, 2 000 and 40 000 rows: the larger import's peak RSS stays under the
/// smaller's plus half the larger file.
#[cfg(target_os = "linux")]
#[test]
fn enlight_import_memory_grows_with_the_gratings_taken_not_the_text() {
    let d = tempfile::tempdir().unwrap();
    let map = d.path().join("map.toml");
    std::fs::write(&map, "[[grating]]\nchannel = 1\nwindow_nm = [1549.0, 1551.0]\nref_nm = 1550.0\n").unwrap();
    let write = |name: &str, rows: usize| {
        let path = d.path().join(name);
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        writeln!(f, "Micron Optics ENLIGHT\t1.7.2\nTimestamp\t# CH 1\t# CH 2\t# CH 3\t# CH 4\tPeaks").unwrap();
        for k in 0..rows {
            let (h, m, sec) = (k / 3_600, (k / 60) % 60, k % 60);
            write!(f, "2024-03-01 {h:02}:{m:02}:{sec:02}.000\t8\t8\t8\t8").unwrap();
            for c in 0..4 {
                for p in 0..8 {
                    let nm = 1510.0 + 10.0 * p as f64 + 0.1 * c as f64 + ((k * 7 + p) % 13) as f64 * 1e-4;
                    write!(f, "\t{nm:.4}").unwrap();
                }
            }
            writeln!(f).unwrap();
        }
        drop(f);
        path
    };
    // At most a day of seconds: the clock stays within one date.
    let (small, big) = (write("small.txt", 2_000), write("big.txt", 40_000));
    let peak = |data: &Path| import_peak_rss("enlight", &map, data, &d.path().join("out.csv"));
    let (a, b) = (peak(&small), peak(&big));
    let size = std::fs::metadata(&big).unwrap().len();
    eprintln!(
        "ENLIGHT import peak RSS: {} kB on 2 000 rows, {} kB on 40 000 rows ({} kB of text)",
        a >> 10,
        b >> 10,
        size >> 10
    );
    // Read whole, the text alone (and its lines) was more than the file.
    assert!(b < a + size / 2, "{} kB vs {} kB, file {} kB", b >> 10, a >> 10, size >> 10);
}

#[test]
fn train_reads_the_rows_up_to_the_last_calibration_row() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("s.csv");
    std::fs::write(&p, "t_s,T_C,dl1_pm,split\n0,1,2,cal\n1,1,2,holdout\n2,1,2,cal\n3,1,2,holdout\n4,1,2,holdout\n")
        .unwrap();
    let all = Dataset::read_csv(&p).unwrap();
    let cal = Dataset::read_calibration_csv(&p).unwrap();
    assert_eq!(all.len(), 5);
    // The hold-out row between calibration rows stays (the stream runs through it).
    assert_eq!(cal, all.select(&[0, 1, 2]));
}
