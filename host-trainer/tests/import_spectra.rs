//! Spectrum files into the dataset (`import --format spectra-csv |
//! enlight-responses | pixels`) and the `peaks` table.
//!
//! Every file is synthetic, written by the test: Gaussian peaks (0.3 nm FWHM) at known,
//! off-grid wavelengths that move frame by frame, on a floor, with white noise from a fixed
//! seed (SNR in dB = 10·log₁₀(height/σ), the detector's convention). The tolerances were set on
//! seed 1 and are checked on seed 2 as well (`SEEDS`).

use crate::common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use fbg_trainer::data::import::{
    import, import_to_csv, peaks_to_csv, Format, ImportOptions, OnError, Scale, PEAKS_HEADER,
};
use fbg_trainer::data::Dataset;
use fbg_trainer::rng::{Rng, Stream};

/// Seeds of the noise: 1 tuned the tolerances, 2 checks them.
const SEEDS: [u64; 2] = [1, 2];
/// FWHM of every peak \[nm\].
const FWHM: f64 = 0.3;
/// Frames per file (one per second).
const FRAMES: usize = 12;

/// One grating of the synthetic installation: channel (1-based), wavelength at frame 0 \[nm\],
/// drift \[pm per frame\], height over the floor (linear).
#[derive(Clone, Copy)]
struct Grating {
    channel: usize,
    nm0: f64,
    pm_per_frame: f64,
    height: f64,
}

/// Two gratings on channel 1, one on channel 2; the wavelengths off any grid used here.
const GRATINGS: [Grating; 3] = [
    Grating { channel: 1, nm0: 1535.01234, pm_per_frame: 3.1, height: 1.0 },
    Grating { channel: 1, nm0: 1545.03711, pm_per_frame: -2.3, height: 0.8 },
    Grating { channel: 2, nm0: 1550.00493, pm_per_frame: 5.7, height: 0.9 },
];

impl Grating {
    /// True wavelength at frame `j` \[nm\].
    fn nm(&self, j: usize) -> f64 {
        self.nm0 + 1e-3 * self.pm_per_frame * j as f64
    }
}

/// A synthetic spectrum: floor + the gratings of `channel` at frame `j` (plus `extra` peaks
/// (nm, height)), white noise of σ = 10^(−snr_db/10) (relative to a height of 1).
fn spectrum(
    wavelengths: &[f64],
    channel: usize,
    j: usize,
    floor: f64,
    snr_db: f64,
    extra: &[(f64, f64)],
    rng: &mut Rng,
) -> Vec<f64> {
    let s = FWHM / 2.354_820_045_030_949;
    let sigma = 10f64.powf(-snr_db / 10.0);
    let mut peaks: Vec<(f64, f64)> =
        GRATINGS.iter().filter(|g| g.channel == channel).map(|g| (g.nm(j), g.height)).collect();
    peaks.extend_from_slice(extra);
    wavelengths
        .iter()
        .map(|&l| {
            let p: f64 = peaks.iter().map(|&(c, h)| h * (-0.5 * ((l - c) / s).powi(2)).exp()).sum();
            floor + p + sigma * rng.normal()
        })
        .collect()
}

/// The 10 pm grid over 1530–1556 nm of the spectra CSVs.
fn csv_grid() -> Vec<f64> {
    (0..2600).map(|k| 1530.0 + 0.01 * k as f64).collect()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A spectra CSV of every frame and channel, linear or dB, with `extra` peaks per (frame,
/// channel) and a `clip` level (saturation).
fn spectra_csv(seed: u64, scale: Scale, extra: &dyn Fn(usize, usize) -> Vec<(f64, f64)>, clip: f64) -> String {
    let grid = csv_grid();
    let mut rng = Rng::new(seed, Stream::WhiteNoise);
    let mut t = String::from("t_s,channel");
    for l in &grid {
        write!(t, ",{l:.3}").unwrap();
    }
    t.push('\n');
    for j in 0..FRAMES {
        for c in 1..=2 {
            write!(t, "{}.000,{c}", j).unwrap();
            for v in spectrum(&grid, c, j, 0.01, 40.0, &extra(j, c), &mut rng) {
                let v = v.min(clip);
                match scale {
                    Scale::Linear => write!(t, ",{v:.6e}").unwrap(),
                    Scale::Db => write!(t, ",{:.5}", 10.0 * v.log10()).unwrap(),
                }
            }
            t.push('\n');
        }
    }
    t
}

fn no_extra(_: usize, _: usize) -> Vec<(f64, f64)> {
    Vec::new()
}

/// An ENLIGHT Responses export in de-DE: decimal commas, day-first dates, dB levels.
fn responses(seed: u64) -> String {
    let grid = csv_grid();
    let mut rng = Rng::new(seed, Stream::WhiteNoise);
    let mut t = String::from(
        "6\nMicron Optics ENLIGHT Responses (synthetic)\nCulture:\tde-DE\nWavelength Start\t1530,000\nWavelength Delta\t0,010\nNumber of Points\t2600\n",
    );
    for j in 0..FRAMES {
        writeln!(t, "03.01.2024 10:00:{j:02}").unwrap();
        for c in 1..=2 {
            let v: Vec<String> = spectrum(&grid, c, j, 0.01, 40.0, &[], &mut rng)
                .iter()
                .map(|v| format!("{:.5}", 10.0 * v.log10()).replace('.', ","))
                .collect();
            writeln!(t, "{}", v.join("\t")).unwrap();
        }
    }
    t
}

/// The pixel calibration of the pixels file: 512 pixels over ≈ 1510–1595 nm.
const PIXEL_TO_NM: [f64; 3] = [1510.0, 0.166, 1e-6];

/// A spectrometer's frames: 512 pixels, counts on a floor of 1000, peaks of 40 000 × height,
/// rounded to whole counts.
fn pixels(seed: u64) -> String {
    let wl: Vec<f64> = (0..512)
        .map(|p| {
            let p = p as f64;
            PIXEL_TO_NM[0] + PIXEL_TO_NM[1] * p + PIXEL_TO_NM[2] * p * p
        })
        .collect();
    let mut rng = Rng::new(seed, Stream::WhiteNoise);
    let mut t = String::from("t_s,channel");
    for p in 0..512 {
        write!(t, ",p{p}").unwrap();
    }
    t.push('\n');
    for j in 0..FRAMES {
        for c in 1..=2 {
            write!(t, "{j},{c}").unwrap();
            for v in spectrum(&wl, c, j, 0.025, 40.0, &[], &mut rng) {
                write!(t, ",{}", (40_000.0 * v).round()).unwrap();
            }
            t.push('\n');
        }
    }
    t
}

/// A map: each grating's channel and a ±2 nm window, `ref_nm` the true frame-0 wavelength;
/// `spectra` the `[spectra]` table's lines.
fn map(spectra: &str) -> String {
    let mut m = format!("[spectra]\n{spectra}\n");
    for g in GRATINGS {
        writeln!(
            m,
            "[[grating]]\nchannel = {}\nwindow_nm = [{}, {}]\nref_nm = {}",
            g.channel,
            g.nm0 - 2.0,
            g.nm0 + 2.0,
            g.nm0
        )
        .unwrap();
    }
    m
}

fn options(format: Format, input: PathBuf, map: Option<PathBuf>) -> ImportOptions {
    common::import_options(format, input, map)
}

/// Largest |imported shift − true shift| \[pm\] over every grating and frame, the shifts taken
/// from `ref_nm(g)` (the map's, or the first frame's true wavelength).
fn worst_error(d: &Dataset, reference: &dyn Fn(usize) -> f64) -> f64 {
    let mut worst = 0.0f64;
    for (g, gr) in GRATINGS.iter().enumerate() {
        for j in 0..FRAMES {
            let want = 1e3 * (gr.nm(j) - reference(g));
            let got = d.dl_pm[g][j];
            assert!(got.is_finite(), "grating {} frame {j}: a gap", g + 1);
            worst = worst.max((got - want).abs());
        }
    }
    worst
}

/// Accuracy bounds \[pm\] at 40 dB: on seed 1 the worst shift error (printed by each test with
/// `--nocapture`) came out at a sixth of `TOL_FINE_PM` on the 10 pm grid and a third of
/// `TOL_PIXELS_PM` on the 512-pixel grid; seed 2 checks they hold on noise they were not set
/// on. Both lie well inside the targets for a single reading at 30 dB (1 pm RMS on a
/// fine grid, 3 pm on the 512-pixel one), so a wrong grid, pixel offset or scale fails them by
/// orders of magnitude.
const TOL_FINE_PM: f64 = 0.1;
const TOL_PIXELS_PM: f64 = 0.5;

#[test]
fn spectra_csv_linear_with_a_map_gives_the_known_shifts() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(dir.path(), "map.toml", &map(""));
    for seed in SEEDS {
        let input = write(dir.path(), "s.csv", &spectra_csv(seed, Scale::Linear, &no_extra, f64::INFINITY));
        let (d, s) = import(&options(Format::SpectraCsv, input, Some(m.clone()))).unwrap();
        assert_eq!((s.rows_read, s.rows_written, d.n_gratings()), (2 * FRAMES, FRAMES, 3));
        assert_eq!(d.t_s, (0..FRAMES).map(|j| j as f64).collect::<Vec<_>>());
        let sp = s.spectra.as_ref().unwrap();
        assert_eq!((sp.frames, sp.channels, sp.points, sp.scale), (FRAMES, 2, 2600, Scale::Linear));
        assert!(sp.grid.starts_with("uniform, 1530 nm + 0.01 nm·p, 2600 points"), "{}", sp.grid);
        assert!(s.gratings.iter().all(|g| g.ref_source == "map"));
        let worst = worst_error(&d, &|g| GRATINGS[g].nm0);
        eprintln!("spectra-csv, seed {seed}: worst shift error {worst:.3} pm");
        assert!(worst < TOL_FINE_PM, "seed {seed}: worst error {worst:.3} pm");
    }
}

#[test]
fn without_a_map_three_gratings_are_found_in_order_and_zeroed_on_the_first_frame() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "s.csv", &spectra_csv(1, Scale::Db, &no_extra, f64::INFINITY));
    let mut o = options(Format::SpectraCsv, input, None);
    o.scale = Some(Scale::Db);
    let (d, s) = import(&o).unwrap();
    assert_eq!(d.n_gratings(), 3);
    for (g, gr) in GRATINGS.iter().enumerate() {
        let r = s.gratings[g].ref_nm.unwrap();
        // λ_ref is the first frame's detected peak: within the reading's accuracy of the truth.
        assert!((r - gr.nm0).abs() * 1e3 < TOL_FINE_PM, "grating {}: λ_ref {r}", g + 1);
        assert_eq!(s.gratings[g].ref_source, "first reading (line 2)");
        assert!(s.gratings[g].source.contains(&format!("channel {}", gr.channel)), "{}", s.gratings[g].source);
        assert!(d.dl_pm[g][0].abs() < 1e-9);
    }
    let sp = s.spectra.as_ref().unwrap();
    assert!(sp.windows_from.contains("first spectrum"), "{}", sp.windows_from);
    assert_eq!(sp.scale_from, "--scale");
    let worst = worst_error(&d, &|g| s.gratings[g].ref_nm.unwrap());
    eprintln!("spectra-csv in dB, no map: worst shift error {worst:.3} pm");
    assert!(worst < TOL_FINE_PM, "worst error {worst:.3} pm");
}

#[test]
fn an_enlight_responses_export_in_de_de_gives_the_known_shifts() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(dir.path(), "map.toml", &map(""));
    for seed in SEEDS {
        let input = write(dir.path(), "r.txt", &responses(seed));
        let (d, s) = import(&options(Format::EnlightResponses, input, Some(m.clone()))).unwrap();
        assert_eq!((s.rows_read, s.rows_written), (2 * FRAMES, FRAMES));
        assert_eq!(s.time.start.as_deref(), Some("2024-01-03T10:00:00.000"));
        let sp = s.spectra.as_ref().unwrap();
        assert_eq!((sp.scale, sp.metadata_lines), (Scale::Db, 6));
        assert_eq!(sp.culture.as_deref(), Some("de-DE (line 3)"));
        let worst = worst_error(&d, &|g| GRATINGS[g].nm0);
        eprintln!("enlight-responses, seed {seed}: worst shift error {worst:.3} pm");
        assert!(worst < TOL_FINE_PM, "seed {seed}: worst error {worst:.3} pm");
    }
}

#[test]
fn a_pixels_file_with_the_maps_polynomial_gives_the_known_shifts() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(dir.path(), "map.toml", &map("pixel_to_nm = [1510.0, 0.166, 1e-6]\nfull_scale = 65535"));
    for seed in SEEDS {
        let input = write(dir.path(), "p.csv", &pixels(seed));
        let (d, s) = import(&options(Format::Pixels, input, Some(m.clone()))).unwrap();
        assert_eq!((s.rows_written, d.n_gratings()), (FRAMES, 3));
        assert!(s.spectra.as_ref().unwrap().grid.starts_with("polynomial"));
        let worst = worst_error(&d, &|g| GRATINGS[g].nm0);
        eprintln!("pixels, seed {seed}: worst shift error {worst:.3} pm");
        assert!(worst < TOL_PIXELS_PM, "seed {seed}: worst error {worst:.3} pm");
    }
}

#[test]
fn spectra_and_an_enlight_peaks_export_of_the_same_peaks_give_the_same_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let spectra = write(dir.path(), "s.csv", &spectra_csv(2, Scale::Linear, &no_extra, f64::INFINITY));
    let mut peaks = String::from("Timestamp\t# CH 1\t# CH 2\tPeaks\n");
    for j in 0..FRAMES {
        let nm: Vec<String> = GRATINGS.iter().map(|g| format!("{:.5}", g.nm(j))).collect();
        writeln!(peaks, "{j}.000\t2\t1\t{}", nm.join("\t")).unwrap();
    }
    let peaks = write(dir.path(), "peaks.txt", &peaks);
    let (a, sa) = import(&options(Format::SpectraCsv, spectra, None)).unwrap();
    let (b, sb) = import(&options(Format::Enlight, peaks, None)).unwrap();
    assert_eq!((a.len(), a.n_gratings()), (b.len(), b.n_gratings()));
    assert_eq!(a.t_s, b.t_s);
    assert_eq!(a.split, b.split);
    let mut worst = 0.0f64;
    for g in 0..3 {
        let dr = 1e3 * (sa.gratings[g].ref_nm.unwrap() - sb.gratings[g].ref_nm.unwrap());
        assert!(dr.abs() < TOL_FINE_PM, "grating {}: λ_ref differs by {dr:.3} pm", g + 1);
        for j in 0..FRAMES {
            let e = a.dl_pm[g][j] - b.dl_pm[g][j];
            worst = worst.max(e.abs());
            // Both zero on their own first reading: the difference is the detector's error on
            // two readings (and the peaks file's 0.01 pm rounding).
            assert!(
                e.abs() < TOL_FINE_PM,
                "grating {} frame {j}: {:.3} vs {:.3} pm",
                g + 1,
                a.dl_pm[g][j],
                b.dl_pm[g][j]
            );
        }
    }
    eprintln!("spectra-csv against enlight peaks: worst difference {worst:.3} pm");
}

/// Frame 3 saturates grating 1 (clipped at the map's full scale), frame 5 has a second peak in
/// grating 2's window.
fn flagged_file(dir: &Path) -> (PathBuf, PathBuf) {
    let extra = |j: usize, c: usize| if j == 5 && c == 1 { vec![(GRATINGS[1].nm(j) + 1.0, 0.6)] } else { Vec::new() };
    let mut text = spectra_csv(1, Scale::Linear, &extra, f64::INFINITY);
    // Frame 3, channel 1 (line 8): grating 1 at twice its height, clipped at 1.2.
    let grid = csv_grid();
    let mut rng = Rng::new(9, Stream::WhiteNoise);
    let row: Vec<String> = spectrum(&grid, 1, 3, 0.01, 40.0, &[(GRATINGS[0].nm(3), 1.0)], &mut rng)
        .iter()
        .map(|v| format!("{:.6e}", v.min(1.2)))
        .collect();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    assert!(lines[7].starts_with("3.000,1,"));
    lines[7] = format!("3.000,1,{}", row.join(","));
    text = lines.join("\n") + "\n";
    let input = write(dir, "flagged.csv", &text);
    let m = write(dir, "map.toml", &map("full_scale = 1.2"));
    (input, m)
}

#[test]
fn peaks_writes_each_frames_peaks_with_quality_and_flags() {
    let dir = tempfile::tempdir().unwrap();
    let (input, m) = flagged_file(dir.path());
    let out = dir.path().join("peaks.csv");
    let s = peaks_to_csv(&options(Format::SpectraCsv, input, Some(m)), &out).unwrap();
    assert_eq!(s.rows_written, 3 * FRAMES);
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(PEAKS_HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == PEAKS_HEADER.split(',').count()));
    let row = |j: usize, g: usize| &rows[3 * j + g];
    // t_s, timestamp (empty: plain seconds), line, grating, channel, wavelength_nm, snr_db, ...
    assert_eq!(&row(0, 0)[..5], &["0.000000", "", "2", "1", "1"]);
    assert_eq!(&row(0, 2)[2..5], &["3", "3", "2"]);
    let nm: f64 = row(4, 1)[5].parse().unwrap();
    assert!((nm - GRATINGS[1].nm(4)).abs() * 1e3 < TOL_FINE_PM, "{nm}");
    let snr: f64 = row(0, 0)[6].parse().unwrap();
    assert!((35.0..45.0).contains(&snr), "SNR {snr} dB of a 40 dB peak");
    let fwhm: f64 = row(0, 0)[7].parse().unwrap();
    assert!((fwhm - FWHM).abs() < 0.01, "FWHM {fwhm}");
    assert_eq!(row(0, 0)[10], "ok");
    assert_eq!(row(0, 0)[11], "cross-correlation");
    assert!(row(3, 0)[10].contains("saturated"), "{:?}", row(3, 0));
    assert!(row(5, 1)[10].contains("second-peak"), "{:?}", row(5, 1));
    let flagged: Vec<(usize, usize)> =
        (0..FRAMES).flat_map(|j| (0..3).map(move |g| (j, g))).filter(|&(j, g)| row(j, g)[10] != "ok").collect();
    assert_eq!(flagged, [(3, 0), (5, 1)]);
    let f = &s.spectra.flagged;
    assert_eq!((f[0].flagged, f[0].by_flag.get("saturated")), (1, Some(&1)));
    assert_eq!((f[1].flagged, f[1].by_flag.get("second-peak")), (1, Some(&1)));
}

#[test]
fn import_makes_faulty_frames_gaps_and_counts_them() {
    let dir = tempfile::tempdir().unwrap();
    let (input, m) = flagged_file(dir.path());
    let (d, s) = import(&options(Format::SpectraCsv, input, Some(m))).unwrap();
    assert!(d.dl_pm[0][3].is_nan() && d.dl_pm[1][5].is_nan());
    assert_eq!(s.gaps, [1, 1, 0]);
    let sp = s.spectra.as_ref().unwrap();
    assert_eq!(sp.gap_on, ["no-peak", "saturated", "second-peak", "at-edge"]);
    assert_eq!((sp.flagged[0].gaps, sp.flagged[1].gaps, sp.flagged[2].flagged), (1, 1, 0));
    let json = serde_json::to_value(&s).unwrap();
    assert_eq!(json["spectra"]["flagged"][0]["by_flag"]["saturated"], 1);
    assert_eq!(json["spectra"]["flagged"][1]["gaps"], 1);
    assert!(s.text().contains("dl2_pm: 1 of 12 frames flagged (second-peak 1), 1 gaps"), "{}", s.text());
}

/// One pixel a hundred times the grating's height, in its window, was taken for the
/// grating (flagged only `asymmetric`, the value kept). Such a peak breaks
/// with every other frame of the grating: a fault, its frame a gap, counted as `implausible`;
/// the `peaks` table says so. With a map and without one (discovered windows).
#[test]
fn a_spike_far_above_the_grating_is_an_implausible_fault_and_a_gap() {
    let dir = tempfile::tempdir().unwrap();
    let text = spectra_csv(1, Scale::Linear, &no_extra, f64::INFINITY);
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Frame 4, channel 1 (line 10): the pixel at 1533.51 nm (sample 351), 1.5 nm below
    // grating 1, at 100 × its height.
    assert!(lines[9].starts_with("4.000,1,"));
    let mut cells: Vec<String> = lines[9].split(',').map(str::to_string).collect();
    cells[2 + 351] = format!("{:.6e}", 100.0 * GRATINGS[0].height);
    lines[9] = cells.join(",");
    let input = write(dir.path(), "spike.csv", &(lines.join("\n") + "\n"));
    let m = write(dir.path(), "map.toml", &map(""));
    for map in [Some(m), None] {
        let (d, s) = import(&options(Format::SpectraCsv, input.clone(), map.clone())).unwrap();
        assert!(d.dl_pm[0][4].is_nan(), "{:?}", d.dl_pm[0]);
        assert!(d
            .dl_pm
            .iter()
            .enumerate()
            .all(|(g, c)| c.iter().enumerate().all(|(j, v)| v.is_finite() || (g, j) == (0, 4))));
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["spectra"]["flagged"][0]["by_flag"]["implausible"], 1, "{json}");
        assert_eq!(json["spectra"]["flagged"][0]["gaps"], 1);
    }
    let out = dir.path().join("peaks.csv");
    let (ok, _, err) =
        common::run(common::bin().args(["peaks", "--format", "spectra-csv"]).arg(&input).arg("--out").arg(&out));
    assert!(ok, "{err}");
    let table = std::fs::read_to_string(&out).unwrap();
    let row = table.lines().find(|l| l.starts_with("4.000000,,") && l.split(',').nth(3) == Some("1")).unwrap();
    assert!(row.contains("implausible"), "{row}");
    assert_eq!(table.matches("implausible").count(), 1, "{table}");
}

/// The error of a failing import; no output written and an existing one left as it was.
fn failure(o: &ImportOptions) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("data.csv");
    std::fs::write(&out, "old\n").unwrap();
    let e = import_to_csv(o, &out).expect_err("the import should fail").to_string();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old\n", "a failed import touched the output");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "temporary files left behind");
    let peaks = dir.path().join("peaks.csv");
    if o.format != Format::Enlight {
        let e2 = peaks_to_csv(o, &peaks).expect_err("peaks should fail too").to_string();
        assert_eq!(e2, e);
        assert!(!peaks.exists());
    }
    e
}

fn assert_place(e: &str, file: &str, line: u64, column: &str) {
    assert!(e.contains(file), "file `{file}` not named: {e}");
    assert!(e.contains(&format!("line {line},")), "line {line} not named: {e}");
    assert!(e.contains(&format!("column {column}")), "column `{column}` not named: {e}");
}

/// A copy of `text` with line `n` (1-based) changed by `f`.
fn edit_line(text: &str, n: usize, f: impl Fn(&str) -> String) -> String {
    text.lines().enumerate().map(|(i, l)| if i + 1 == n { f(l) } else { l.to_string() } + "\n").collect()
}

/// Cell `k` (0-based) of a comma-separated line replaced by `v`.
fn set_cell(l: &str, k: usize, v: &str) -> String {
    let mut c: Vec<&str> = l.split(',').collect();
    c[k] = v;
    c.join(",")
}

#[test]
fn malformed_spectra_csv_names_line_and_column_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let good = spectra_csv(1, Scale::Linear, &no_extra, f64::INFINITY);
    let case = |name: &str, text: String| {
        let p = write(dir.path(), name, &text);
        failure(&options(Format::SpectraCsv, p, None))
    };
    // Cell 4 of line 5 is the 3rd wavelength, 1530.020 nm.
    let e = case("cell.csv", edit_line(&good, 5, |l| set_cell(l, 4, "x1")));
    assert_place(&e, "cell.csv", 5, "5 (1530.020)");
    assert!(e.contains("`x1` is not a number"), "{e}");
    let e = case("short.csv", edit_line(&good, 7, |l| l.rsplit_once(',').unwrap().0.to_string()));
    assert_place(&e, "short.csv", 7, "2602 (1555.990)");
    assert!(e.contains("2601 cells where the header has 2602"), "{e}");
    let e = case("long.csv", edit_line(&good, 3, |l| format!("{l},0.5")));
    assert_place(&e, "long.csv", 3, "2603");
    let e = case("order.csv", edit_line(&good, 1, |l| set_cell(l, 10, "1530.070")));
    assert_place(&e, "order.csv", 1, "11 (1530.070)");
    assert!(e.contains("must increase"), "{e}");
    let e = case("uneven.csv", edit_line(&good, 1, |l| set_cell(l, 10, "1530.085")));
    assert_place(&e, "uneven.csv", 1, "11 (1530.085)");
    assert!(e.contains("4.938 pm off the smoothest pixel polynomial"), "{e}");
    let e = case("channel.csv", edit_line(&good, 4, |l| set_cell(l, 1, "one")));
    assert_place(&e, "channel.csv", 4, "2 (channel)");
    let e = case("time.csv", edit_line(&good, 6, |l| set_cell(l, 0, "0.500")));
    assert_place(&e, "time.csv", 6, "1 (t_s)");
    assert!(e.contains("backwards"), "{e}");
    let e = case("twice.csv", edit_line(&good, 3, |l| set_cell(l, 1, "1")));
    assert_place(&e, "twice.csv", 3, "2 (channel)");
    assert!(e.contains("channel 1 twice"), "{e}");
    let e = case("header.csv", edit_line(&good, 1, |l| set_cell(l, 1, "ch")));
    assert_place(&e, "header.csv", 1, "2 (ch)");
    // A dB trace read as linear: channel 1's peak tops 0 dB (1.01 linear), channel 2's (line
    // 3) does not.
    let db = spectra_csv(1, Scale::Db, &no_extra, f64::INFINITY);
    let e = case("db.csv", db);
    assert_place(&e, "db.csv", 3, "3 (1530.000)");
    assert!(e.contains("--scale db"), "{e}");
    let e = case("cut.csv", good.trim_end().to_string());
    assert_place(&e, "cut.csv", 25, "2602 (1555.990)");
    assert!(e.contains("truncated"), "{e}");
}

#[test]
fn malformed_responses_name_line_and_column_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let good = responses(1);
    let case = |name: &str, text: String| {
        let p = write(dir.path(), name, &text);
        failure(&options(Format::EnlightResponses, p, None))
    };
    let e = case("count.txt", edit_line(&good, 1, |_| "six".into()));
    assert_place(&e, "count.txt", 1, "1 (header line count)");
    let e = case("key.txt", edit_line(&good, 5, |_| "Wavelength Step\t0,010".into()));
    assert_place(&e, "key.txt", 1, "Wavelength Delta");
    assert!(e.contains("has no `Wavelength Delta`"), "{e}");
    let e = case("culture.txt", edit_line(&good, 3, |_| "Culture:\txx-YY".into()));
    assert_place(&e, "culture.txt", 3, "Culture");
    assert!(e.contains("unknown culture `xx-YY`"), "{e}");
    // Line 9 is frame 0's channel 2; its 3rd level is at 1530.020 nm.
    let e = case(
        "level.txt",
        edit_line(&good, 9, |l| {
            l.split('\t').enumerate().map(|(k, c)| if k == 2 { "abc" } else { c }).collect::<Vec<_>>().join("\t")
        }),
    );
    assert_place(&e, "level.txt", 9, "3 (1530.020 nm)");
    let e = case("levels.txt", edit_line(&good, 8, |l| l.rsplit_once('\t').unwrap().0.to_string()));
    assert_place(&e, "levels.txt", 8, "2600 (1555.990 nm)");
    assert!(e.contains("2599 levels where the header's Number of Points is 2600"), "{e}");
    let e = case("stamp.txt", edit_line(&good, 10, |_| "03.01.2024 25:00:01".into()));
    assert_place(&e, "stamp.txt", 10, "1 (time)");
    let e = case("point.txt", edit_line(&good, 8, |l| l.replacen(',', ".", 1)));
    assert_place(&e, "point.txt", 8, "1 (1530.000 nm)");
    // Settings out of physical range, by the header line.
    let e = case("delta.txt", edit_line(&good, 5, |_| "Wavelength Delta\t1e-300".into()));
    assert_place(&e, "delta.txt", 5, "Wavelength Delta");
    assert!(e.contains("1e-300 is not a wavelength step in nm (0.0001 ≤ step < 1 nm)"), "{e}");
    let e = case("end.txt", edit_line(&good, 6, |_| "Number of Points\t1000000".into()));
    assert_place(&e, "end.txt", 6, "Number of Points");
    assert!(e.contains("end at 11529.99 nm, beyond 2000 nm"), "{e}");
    // The second block's timestamp (line 10) lost: the first block would take in its two
    // lines as channels 3 and 4. Refused at the first of them.
    let lost: String = good.lines().enumerate().filter(|&(i, _)| i != 9).map(|(_, l)| format!("{l}\n")).collect();
    let e = case("lost.txt", lost);
    assert_place(&e, "lost.txt", 10, "1 (channel line)");
    assert!(e.contains("the first block has 4 channel lines but no later block more than 2"), "{e}");
}

#[test]
fn malformed_pixels_and_maps_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let good = pixels(1);
    let m = write(dir.path(), "map.toml", &map("pixel_to_nm = [1510.0, 0.166, 1e-6]"));
    let p = write(dir.path(), "skip.csv", &edit_line(&good, 1, |l| set_cell(l, 7, "p6")));
    let e = failure(&options(Format::Pixels, p, Some(m.clone())));
    assert_place(&e, "skip.csv", 1, "8 (p6)");
    let p = write(dir.path(), "p.csv", &good);
    let e = failure(&options(Format::Pixels, p.clone(), None));
    assert!(e.contains("spectra.pixel_to_nm"), "{e}");
    let bad = write(dir.path(), "bad.toml", &map("pixel_to_nm = [1510.0]"));
    let e = failure(&options(Format::Pixels, p.clone(), Some(bad)));
    assert!(e.contains("bad.toml") && e.contains("spectra.pixel_to_nm"), "{e}");
    let bad = write(dir.path(), "gap.toml", &map("pixel_to_nm = [1510.0, 0.166]\ngap_on = [\"wobbly\"]"));
    let e = failure(&options(Format::Pixels, p.clone(), Some(bad)));
    assert!(e.contains("spectra.gap_on") && e.contains("`wobbly` is not a peak flag"), "{e}");
    let bad = write(dir.path(), "turn.toml", &map("pixel_to_nm = [1510.0, 0.166, -1e-3]"));
    let e = failure(&options(Format::Pixels, p.clone(), Some(bad)));
    assert!(e.contains("not monotonic at pixel 83"), "{e}");
    // A calibration giving wavelengths no grating has (a sign or an exponent wrong).
    for (coefficients, pixel, says) in
        [("-1510.0, 0.166", 0, "-1510 nm"), ("1e300, 0.166", 0, "1e300 nm"), ("1510.0, 1.0", 491, "2001 nm")]
    {
        let bad = write(dir.path(), "absurd.toml", &map(&format!("pixel_to_nm = [{coefficients}]")));
        let e = failure(&options(Format::Pixels, p.clone(), Some(bad)));
        assert_place(&e, "p.csv", 1, &format!("{} (p{pixel})", pixel + 3));
        assert!(
            e.contains(&format!("pixel_to_nm gives pixel {pixel} the wavelength {says}, outside 400–2000 nm")),
            "{e}"
        );
    }
}

#[test]
fn the_cli_imports_spectra_and_writes_peaks() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "s.csv", &spectra_csv(1, Scale::Db, &no_extra, f64::INFINITY));
    let data = dir.path().join("data.csv");
    let (ok, _, err) = common::run(
        common::bin()
            .args(["import", "--format", "spectra-csv", "--scale", "db", "--json"])
            .arg(&input)
            .arg("--out")
            .arg(&data),
    );
    assert!(ok, "{err}");
    let body = common::read_csv_body(&data);
    assert!(body.starts_with("t_s,dl1_pm,dl2_pm,dl3_pm,split\n"), "{body}");
    assert_eq!(body.lines().count(), 1 + FRAMES);
    let peaks = dir.path().join("peaks.csv");
    let (ok, out, err) = common::run(
        common::bin()
            .args(["peaks", "--format", "spectra-csv", "--scale", "db", "--json"])
            .arg(&input)
            .arg("--out")
            .arg(&peaks),
    );
    assert!(ok, "{err}");
    let s: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(s["rows_written"], 3 * FRAMES);
    assert_eq!(std::fs::read_to_string(&peaks).unwrap().lines().count(), 1 + 3 * FRAMES);
    // Read as linear, the dB trace is refused with the hint; nothing written.
    let none = dir.path().join("none.csv");
    let (ok, _, err) =
        common::run(common::bin().args(["peaks", "--format", "spectra-csv"]).arg(&input).arg("--out").arg(&none));
    assert!(!ok && err.contains("--scale db") && !none.exists(), "{err}");
}

#[test]
fn references_are_joined_onto_spectrum_frames_as_onto_peaks() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "s.csv", &spectra_csv(1, Scale::Linear, &no_extra, f64::INFINITY));
    let refs = write(dir.path(), "refs.csv", "t_s,T_amb_C,T_C\n0,20.0,25.0\n5,21.0,26.0\n10,22.0,27.0\n15,23.0,28.0\n");
    let mut o = options(Format::SpectraCsv, input, None);
    o.refs = Some(refs);
    let (d, s) = import(&o).unwrap();
    assert_eq!(s.purpose, fbg_trainer::data::import::Purpose::Training);
    assert_eq!((d.len(), s.join.as_ref().unwrap().refs_rows), (FRAMES, 4));
    // 2 s: 40 % of the way from the 0 s to the 5 s reading.
    assert!((d.ambient()[2] - 20.4).abs() < 1e-9, "{}", d.ambient()[2]);
    assert!((d.target(0).as_slice()[7] - 26.4).abs() < 1e-9);
}

#[test]
fn on_error_skip_leaves_a_bad_spectrum_out_as_a_gap_and_counts_it() {
    let dir = tempfile::tempdir().unwrap();
    // Line 9 is frame 3's channel 2 (grating 3).
    let text = edit_line(&spectra_csv(1, Scale::Linear, &no_extra, f64::INFINITY), 9, |l| set_cell(l, 100, "oops"));
    let input = write(dir.path(), "s.csv", &text);
    let mut o = options(Format::SpectraCsv, input, None);
    o.on_error = OnError::Skip;
    o.max_skipped = 0.1;
    let (d, s) = import(&o).unwrap();
    assert_eq!((s.rows_read, s.rows_skipped, s.rows_written), (2 * FRAMES, 1, FRAMES));
    assert_eq!(s.skipped[0].count(fbg_trainer::data::import::Reason::NonNumeric), 1);
    assert_eq!(s.skipped[0].by_reason.values().next().unwrap().first_lines, [9]);
    assert!(d.dl_pm[2][3].is_nan() && d.dl_pm[0][3].is_finite() && d.dl_pm[1][3].is_finite());
    assert_eq!(s.gaps, [0, 0, 1]);
    // Above the allowed share, nothing is imported.
    o.max_skipped = 0.01;
    let e = failure(&o);
    assert!(e.contains("--max-skipped"), "{e}");
}

#[test]
fn a_low_snr_frame_keeps_its_wavelength_and_is_counted() {
    let dir = tempfile::tempdir().unwrap();
    // Frame 6, channel 2 (line 15): grating 3 at 8 dB over the noise (height/σ) instead of 40 dB: above the no-peak SNR (7 dB) once the noise on its top is added, below the low-SNR one (10 dB).
    let grid = csv_grid();
    let mut rng = Rng::new(3, Stream::WhiteNoise);
    let weak: Vec<String> = spectrum(&grid, 3, 6, 0.01, 40.0, &[(GRATINGS[2].nm(6), 10f64.powf(-3.2))], &mut rng)
        .iter()
        .map(|v| format!("{v:.6e}"))
        .collect();
    let text = edit_line(&spectra_csv(1, Scale::Linear, &no_extra, f64::INFINITY), 15, |_| {
        format!("6.000,2,{}", weak.join(","))
    });
    let input = write(dir.path(), "s.csv", &text);
    let m = write(dir.path(), "map.toml", &map(""));
    let (d, s) = import(&options(Format::SpectraCsv, input, Some(m))).unwrap();
    let f = &s.spectra.as_ref().unwrap().flagged[2];
    assert_eq!((f.flagged, f.gaps, f.by_flag.get("low-snr")), (1, 0, Some(&1)), "{f:?}");
    assert!(d.dl_pm[2][6].is_finite());
    // Noisy, but the same grating: within a tenth of the FWHM of the truth.
    let want = 1e3 * (GRATINGS[2].nm(6) - GRATINGS[2].nm0);
    assert!((d.dl_pm[2][6] - want).abs() < 30.0, "{} vs {want}", d.dl_pm[2][6]);
}

#[test]
fn without_a_map_more_than_eight_peaks_are_refused_naming_the_channels() {
    let dir = tempfile::tempdir().unwrap();
    let extra = |_: usize, c: usize| {
        if c == 1 {
            [1531.0, 1538.0, 1540.0, 1542.0, 1548.0, 1552.0].iter().map(|&l| (l, 0.7)).collect()
        } else {
            Vec::new()
        }
    };
    let input = write(dir.path(), "nine.csv", &spectra_csv(1, Scale::Linear, &extra, f64::INFINITY));
    let e = failure(&options(Format::SpectraCsv, input, None));
    assert_place(&e, "nine.csv", 2, "2 (channel)");
    assert!(e.contains("found 9 (channel 1: 8 (line 2), channel 2: 1 (line 3))"), "{e}");
}

#[test]
fn a_responses_block_without_a_channel_is_a_gap_for_its_gratings() {
    let dir = tempfile::tempdir().unwrap();
    // Line 21 is frame 4's channel 2 (blocks of 3 lines from line 7).
    let text: String =
        responses(1).lines().enumerate().filter(|&(i, _)| i + 1 != 21).map(|(_, l)| format!("{l}\n")).collect();
    let input = write(dir.path(), "r.txt", &text);
    let (d, s) = import(&options(Format::EnlightResponses, input, None)).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.rows_skipped), (2 * FRAMES - 1, FRAMES, 0));
    assert!(d.dl_pm[2][4].is_nan() && d.dl_pm[0][4].is_finite() && d.dl_pm[1][4].is_finite());
    assert_eq!(s.gaps, [0, 0, 1]);
    assert_eq!(s.spectra.as_ref().unwrap().flagged[2].frames, FRAMES - 1);
    // A lost timestamp line would make frame 4's spectra channels 3 and 4 of frame 3: refused.
    let text: String =
        responses(1).lines().enumerate().filter(|&(i, _)| i + 1 != 19).map(|(_, l)| format!("{l}\n")).collect();
    let input = write(dir.path(), "lost.txt", &text);
    let e = failure(&options(Format::EnlightResponses, input, None));
    assert_place(&e, "lost.txt", 19, "1 (channel line)");
    assert!(e.contains("the first block has 2"), "{e}");
}
