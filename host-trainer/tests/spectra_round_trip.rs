//! The tool imports its own spectra. `simulate --spectra` writes each pixel's own
//! wavelength in the header (a tabulated grid on the 512-pixel spectrometer, which is not
//! uniform); `import --format spectra-csv` must read it back, on every preset and grid, to
//! within what the detector itself gives on the exact grid.

use crate::common;

use fbg_shared::spectrum::Method;
use fbg_trainer::data::import::{import, Format};
use fbg_trainer::sim::spectrum::csv::write_spectra_csv;
use fbg_trainer::sim::spectrum::{peaks_from_spectra, FrameSimulator, PixelGrid, SpectrumConfig};
use fbg_trainer::sim::{self, scenario::Preset};

/// Largest difference \[pm\] between the import's shift and the one the detector gives on the
/// exact grid, searching the same windows (the simulator's, given as a map): the header's
/// wavelengths are written to the pm, and the grid read back from them must place every peak
/// as the exact grid does, to a small part of that rounding.
const TOL_SAME_WINDOWS_PM: f64 = 0.1;
/// The same without a map: the windows are then the ones discovery finds in the first
/// spectrum, and the detector's estimate moves with its window by a fraction of a pm; its
/// accuracy on these grids is several times coarser (BENCHMARKS.md, `bench-spectrum`).
const TOL_DISCOVERED_PM: f64 = 1.5;

/// Write `data`'s spectra as `frames` renders them (noise seeded by `seed`) to `path`.
fn write_spectra(path: &std::path::Path, data: &fbg_trainer::data::Dataset, frames: &FrameSimulator, seed: u64) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    write_spectra_csv(&mut w, data, frames, seed).unwrap();
}

/// The map entry of grating `g`, on channel `c` (0-based) in its simulator's window, then
/// `extra` (keys, one per line).
fn map_entry(frames: &FrameSimulator, c: usize, g: usize, extra: &str) -> String {
    let w = frames.window(g);
    format!("[[grating]]\nchannel = {}\nwindow_nm = [{}, {}]\n{extra}", c + 1, w.lo_nm, w.hi_nm)
}

#[test]
fn simulated_spectra_of_every_preset_and_grid_import_as_the_detector_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    for preset in Preset::ALL {
        for grid in [PixelGrid::Spectrometer, PixelGrid::Swept] {
            let mut cfg = preset.config();
            cfg.clock.days = 2.0 / 24.0;
            let s = sim::simulate(&cfg, 7);
            let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
            let frames = FrameSimulator::new(&SpectrumConfig { grid, ..SpectrumConfig::default() }, &nominal).unwrap();
            let path = dir.path().join(format!("{}-{}.csv", preset.name(), grid.name()));
            write_spectra(&path, &s.data, &frames, 7);
            let mut map = String::new();
            for c in 0..frames.channels() {
                for &g in frames.gratings_of(c) {
                    map += &map_entry(&frames, c, g, "");
                }
            }
            let map_path = dir.path().join("map.toml");
            std::fs::write(&map_path, map).unwrap();
            // The detector on the exact grid, with the import's default method.
            let chain = peaks_from_spectra(&s.data, &frames, Method::default(), 7).unwrap();
            let case = format!("{} on the {} grid", preset.name(), grid.name());
            for (map, tol) in [(Some(map_path), TOL_SAME_WINDOWS_PM), (None, TOL_DISCOVERED_PM)] {
                let from_map = map.is_some();
                let opts = common::import_options(Format::SpectraCsv, path.clone(), map);
                let (d, summary) = import(&opts).unwrap_or_else(|e| panic!("{case}: {e}"));
                // No frame of a clean record is taken for implausible.
                let json = serde_json::to_value(&summary).unwrap();
                for f in json["spectra"]["flagged"].as_array().unwrap() {
                    assert!(f["by_flag"].get("implausible").is_none(), "{case}: {f}");
                }
                // Discovery without a map finds the simulated gratings, in wavelength order.
                assert_eq!(d.n_gratings(), s.data.n_gratings(), "{case}");
                let mut order: Vec<usize> = (0..nominal.len()).collect();
                if !from_map {
                    order.sort_by(|&a, &b| nominal[a].total_cmp(&nominal[b]));
                } else {
                    order = (0..frames.channels()).flat_map(|c| frames.gratings_of(c).to_vec()).collect();
                }
                let (mut worst, mut compared) = (0.0f64, 0usize);
                for (imported, &g) in d.dl_pm.iter().zip(&order) {
                    let exact = &chain.data.dl_pm[g];
                    for (i, &y) in imported.iter().enumerate() {
                        // Zeroed on the first frame, as the import zeroes without `ref_nm`.
                        let want = exact[i] - exact[0];
                        if y.is_finite() && want.is_finite() {
                            worst = worst.max((y - want).abs());
                            compared += 1;
                        }
                    }
                }
                let how = if from_map { "the simulator's windows" } else { "discovered windows" };
                eprintln!(
                    "{case}, {how}: worst |import − detector on the exact grid| {worst:.4} pm over {compared} peaks"
                );
                assert!(compared >= d.len() * d.n_gratings() * 9 / 10, "{case}: {compared} peaks compared");
                assert!(worst <= tol, "{case}, {how}: {worst} pm");
            }
        }
    }
}

/// Discovery without a map took side lobes and noise for gratings (three gratings
/// with noise at 3 % of the peak came out as eight). It must find exactly the simulated
/// gratings down to 13 dB (σ at 5 % of the reference peak, the detector's convention), for
/// uniform gratings of 90 % reflectivity (strong side lobes) and apodised ones alike, on both
/// grids, with three gratings on a channel (`paper`) and eight on a fibre (`array-8`).
#[test]
fn discovery_finds_exactly_the_simulated_gratings_down_to_13_db() {
    use fbg_trainer::sim::spectrum::{Apodisation, DetectorModel};
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for preset in [Preset::Paper, Preset::Array8] {
        let mut cfg = preset.config();
        // A few frames: discovery reads the first spectrum.
        cfg.clock.days = 1.0 / 24.0;
        cfg.clock.dt_s = 600.0;
        let s = sim::simulate(&cfg, 7);
        let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
        for grid in [PixelGrid::Spectrometer, PixelGrid::Swept] {
            for (apodisation, reflectivity) in [
                (Apodisation::Uniform, 0.9),
                (Apodisation::Uniform, 0.5),
                (Apodisation::RaisedCosine, 0.9),
                (Apodisation::Gaussian, 0.5),
            ] {
                for snr_db in [13.0, 15.0, 30.0] {
                    let spectrum = SpectrumConfig {
                        grid,
                        apodisation,
                        peak_reflectivity: reflectivity,
                        detector: DetectorModel { snr_db, ..DetectorModel::default() },
                        ..SpectrumConfig::default()
                    };
                    let frames = FrameSimulator::new(&spectrum, &nominal).unwrap();
                    let path = dir.path().join("d.csv");
                    write_spectra(&path, &s.data, &frames, 7);
                    let opts = common::import_options(Format::SpectraCsv, path, None);
                    let case = format!(
                        "{} {} {} R={reflectivity} {snr_db} dB",
                        preset.name(),
                        grid.name(),
                        apodisation.name()
                    );
                    let found = import(&opts).map(|(d, _)| d.n_gratings()).map_err(|e| e.to_string());
                    eprintln!("{case}: {found:?} of {}", nominal.len());
                    if found != Ok(nominal.len()) {
                        failures.push(case);
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// How many gratings the frames render.
fn order_len(frames: &FrameSimulator) -> usize {
    (0..frames.channels()).map(|c| frames.gratings_of(c).len()).sum()
}

/// Largest difference \[pm\] between the import with a measured shape and the simulator's
/// design-template chain: the file's header gives each pixel's wavelength to the pm, and a fit
/// over the two or three pixels a 0.3 nm grating covers moves with that rounding (the default
/// method, which weighs the whole window, by under [`TOL_SAME_WINDOWS_PM`]).
const TOL_SHAPE_PM: f64 = 1.0;

/// A grating's measured shape given to `import` (`[[grating]] shape = "scan.csv"`) refines
/// each peak by a template fit, as the simulator's design template does: on the 512-pixel
/// spectrometer, where the default method locks to the pixel grid, the imported shifts must
/// follow the design-template chain's within [`TOL_SHAPE_PM`], and their error against the
/// rendered wavelengths must be under half the default method's. Scans that cannot serve as a
/// shape, and a shape given to a logger CSV, are refused naming the file, line and column or
/// the key.
#[test]
fn a_measured_shape_in_the_map_removes_the_grid_locking() {
    use fbg_trainer::sim::spectrum::{find_peaks, PeakFinding};
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 3.0 / 24.0;
    let s = sim::simulate(&cfg, 11);
    let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
    let frames = FrameSimulator::new(&SpectrumConfig::default(), &nominal).unwrap();
    let spectra = dir.path().join("sp.csv");
    write_spectra(&spectra, &s.data, &frames, 11);
    // Each grating's "swept-laser scan": its design at 2 pm steps over ±1.2 nm.
    let mut map = String::new();
    for c in 0..frames.channels() {
        for &g in frames.gratings_of(c) {
            let (design, bragg) = (&frames.designs()[g], frames.nominal_nm()[g]);
            let scan: String = (-600..=600)
                .map(|k| {
                    let wl = bragg + 0.002 * f64::from(k);
                    format!("{wl:.4},{}\n", design.reflectivity(bragg, wl))
                })
                .collect();
            std::fs::write(dir.path().join(format!("scan{g}.csv")), format!("wavelength_nm,reflectance\n{scan}"))
                .unwrap();
            map += &map_entry(&frames, c, g, &format!("shape = \"scan{g}.csv\"\n"));
        }
    }
    let map_path = dir.path().join("map.toml");
    std::fs::write(&map_path, &map).unwrap();
    let (d, summary) =
        import(&common::import_options(Format::SpectraCsv, spectra.clone(), Some(map_path.clone()))).unwrap();
    // The summary names the refined method per grating, as the peaks table's column does; a
    // map with one grating's shape only refines that grating.
    let method_of = |m: &str| {
        std::fs::write(&map_path, m).unwrap();
        let (_, summary) =
            import(&common::import_options(Format::SpectraCsv, spectra.clone(), Some(map_path.clone()))).unwrap();
        summary.spectra.unwrap().flagged.iter().map(|f| f.method.clone()).collect::<Vec<_>>()
    };
    let all: Vec<String> = summary.spectra.unwrap().flagged.iter().map(|f| f.method.clone()).collect();
    assert!(
        all.len() == order_len(&frames) && all.iter().all(|m| *m == format!("{}+shape", Method::default().name())),
        "{all:?}"
    );
    let first_only = method_of(&map.replace("shape = \"scan", "# shape = \"scan").replacen("# shape", "shape", 1));
    assert!(first_only.iter().filter(|m| m.ends_with("+shape")).count() == 1, "{first_only:?}");
    std::fs::write(&map_path, &map).unwrap();
    let method = Method::default();
    let templated = find_peaks(&s.data, &frames, PeakFinding::DesignTemplate(method), 11).unwrap();
    let plain = find_peaks(&s.data, &frames, PeakFinding::Method(method), 11).unwrap();
    let order: Vec<usize> = (0..frames.channels()).flat_map(|c| frames.gratings_of(c).to_vec()).collect();
    for (imported, &g) in d.dl_pm.iter().zip(&order) {
        let exact = &templated.data.dl_pm[g];
        let worst = imported
            .iter()
            .zip(exact)
            .filter(|(y, e)| y.is_finite() && e.is_finite())
            .map(|(y, e)| (y - (e - exact[0])).abs())
            .fold(0.0f64, f64::max);
        // The rendered wavelength's shift: the imported one's error against it, and the
        // default method's (both zeroed on the first frame).
        let truth: Vec<f64> = exact.iter().zip(&templated.errors_pm[g]).map(|(x, e)| x - e).collect();
        let rms = |v: &[f64], zero: f64| {
            let e: Vec<f64> =
                v.iter().zip(&truth).map(|(x, t)| (x - zero) - (t - truth[0])).filter(|e| e.is_finite()).collect();
            (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt()
        };
        let (with_shape, without) = (rms(imported, 0.0), rms(&plain.data.dl_pm[g], plain.data.dl_pm[g][0]));
        eprintln!("grating {g}: |import − design-template chain| ≤ {worst:.3} pm; RMS error {with_shape:.2} pm with the shape, {without:.2} pm without");
        assert!(worst < TOL_SHAPE_PM, "grating {g}: {worst} pm");
        assert!(with_shape < 0.5 * without, "grating {g}: {with_shape} pm with the shape, {without} pm without");
    }
    // Scans that cannot be a shape: each refused naming the file, its line and column.
    let scan = |r: &[f64]| -> String {
        let rows: String =
            r.iter().enumerate().map(|(i, v)| format!("{:.3},{v}\n", 1550.0 + 0.01 * i as f64)).collect();
        format!("wavelength_nm,reflectance\n{rows}")
    };
    let cases: Vec<(String, u64, &str)> = vec![
        // One sample above half the peak: not resolved (named at the peak's line).
        (scan(&[0.1, 0.9, 0.1]), 3, "reflectance"),
        // The peak at the scan's edge: not enclosed.
        (scan(&[0.9, 0.5, 0.1]), 2, "reflectance"),
        // A second grating in the scan, named at its line.
        (scan(&[0.0, 0.6, 0.8, 1.0, 0.8, 0.6, 0.0, 0.0, 0.7, 0.0]), 10, "reflectance"),
        // dB: the peak is not above 0.
        (scan(&[-30.0, -20.0, -3.0, -20.0, -30.0]), 4, "reflectance"),
        ("wavelength_nm,reflectance\n1550.0,0.1\n1549.9,0.2\n".into(), 3, "wavelength_nm"),
        ("wavelength_nm,reflectance\n1550.0,x\n".into(), 2, "reflectance"),
        // A blank line counts: the bad cell is on line 4.
        ("wavelength_nm,reflectance\n1550.0,0.1\n\n1550.1,x\n".into(), 4, "reflectance"),
        // A missing cell.
        ("wavelength_nm,reflectance\n1550.0\n".into(), 2, "reflectance"),
        ("wl,reflectance\n1550.0,0.1\n".into(), 1, "wavelength_nm"),
    ];
    for (text, line, column) in cases {
        let scan = dir.path().join("bad.csv");
        std::fs::write(&scan, &text).unwrap();
        let bad_map = map.replacen("shape = \"scan0.csv\"", "shape = \"bad.csv\"", 1);
        let bad_map_path = dir.path().join("bad.toml");
        std::fs::write(&bad_map_path, bad_map).unwrap();
        let e = import(&common::import_options(Format::SpectraCsv, spectra.clone(), Some(bad_map_path)))
            .err()
            .unwrap_or_else(|| panic!("{text:?} accepted"))
            .to_string();
        let named = e.contains("bad.toml") && e.contains("grating[1].shape") && e.contains("bad.csv");
        assert!(named && e.contains(&format!("line {line}, column {column}")), "{text:?}: {e}");
    }
    // A shape belongs to spectra, not to a logger's table of wavelengths.
    let (log, log_map) = (dir.path().join("log.csv"), dir.path().join("log.toml"));
    std::fs::write(&log, "t_s,l1\n0,1550.0\n60,1550.001\n").unwrap();
    std::fs::write(&log_map, "[[grating]]\ncolumn = \"l1\"\nunit = \"nm\"\nshape = \"scan0.csv\"\n").unwrap();
    let e = import(&common::import_options(Format::Csv, log, Some(log_map))).err().unwrap().to_string();
    assert!(e.contains("log.toml") && e.contains("grating[1].shape"), "{e}");
}
