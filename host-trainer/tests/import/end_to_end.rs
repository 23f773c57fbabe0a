//! End to end: simulated installation → ENLIGHT export + refs CSV → import → read → train.

use super::*;

/// `2024-03-01 00:00:00` + `t` seconds, as ENLIGHT writes it.
fn stamp(t: f64) -> String {
    let ms = (t * 1e3).round() as u64;
    let (s, ms) = (ms / 1000, ms % 1000);
    let (day, rem) = (s / 86_400, s % 86_400);
    format!("2024-03-{:02} {:02}:{:02}:{:02}.{ms:03}", 1 + day, rem / 3600, rem % 3600 / 60, rem % 60)
}

#[test]
fn simulated_enlight_export_imports_exactly_and_trains() {
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 2.0;
    cfg.clock.dt_s = 300.0;
    let sim = simulate(&cfg, 11);
    let d = &sim.data;
    let n = d.len();
    assert_eq!(n, 576);
    let nominal = cfg.gratings.nominal_nm;
    let dropped = 100; // FBG2's peak missing on this row

    let dir = tempfile::tempdir().unwrap();
    let peaks = dir.path().join("sim_peaks.txt");
    let mut text = String::from(
        "Micron Optics ENLIGHT Sensing Analysis Software\t1.7.2\nInstrument\tsi155\nChannels\t4\nStart Time\t2024/03/01 00:00:00\n\nTimestamp\t# CH 1\t# CH 2\t# CH 3\t# CH 4\tPeaks\n",
    );
    for i in 0..n {
        let nm: Vec<f64> = (0..3).map(|g| nominal[g] + d.dl_pm[g][i] / 1000.0).collect();
        if i == dropped {
            text.push_str(&format!("{}\t1\t0\t1\t0\t{:.9}\t{:.9}\t\n", stamp(d.t_s[i]), nm[0], nm[2]));
        } else {
            text.push_str(&format!("{}\t1\t1\t1\t0\t{:.9}\t{:.9}\t{:.9}\t\n", stamp(d.t_s[i]), nm[0], nm[1], nm[2]));
        }
    }
    std::fs::write(&peaks, text).unwrap();
    let refs = dir.path().join("sim_refs.csv");
    let mut text = String::from("time,T_amb_C,T_C,strain_ue,p_kPa\n");
    for i in 0..n {
        text.push_str(&format!(
            "{},{:.9},{:.9},{:.9},{:.9}\n",
            stamp(d.t_s[i]),
            d.ambient()[i],
            d.target(0).as_slice()[i],
            d.target(1).as_slice()[i],
            d.target(2).as_slice()[i]
        ));
    }
    std::fs::write(&refs, text).unwrap();
    let map = dir.path().join("sim_map.toml");
    let mut text = String::new();
    for (g, nm) in nominal.iter().enumerate() {
        text.push_str(&format!(
            "[[grating]]\nchannel = {}\nwindow_nm = [{}, {}]\nref_nm = {nm}\n\n",
            g + 1,
            nm - 2.0,
            nm + 2.0
        ));
    }
    std::fs::write(&map, text).unwrap();

    let out = dir.path().join("data.csv");
    let o = ImportOptions {
        format: Format::Enlight,
        input: peaks,
        map: Some(map),
        refs: Some(refs),
        split: SplitChoice::Fraction(0.5),
        on_error: OnError::Fail,
        max_skipped: DEFAULT_MAX_SKIPPED,
        zero_from: None,
        start_unix_s: None,
        scale: None,
    };
    let s = import_to_csv(&o, &out).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.gaps), (n, n, vec![0, 1, 0]));
    let back = Dataset::read_csv(&out).unwrap();
    assert_eq!(back.len(), n);
    for i in 0..n {
        assert!(close(back.t_s[i], d.t_s[i], 1e-9));
        for g in 0..3 {
            if g == 1 && i == dropped {
                assert!(back.dl_pm[g][i].is_nan());
                continue;
            }
            assert!(
                close(back.dl_pm[g][i], d.dl_pm[g][i], 1e-3),
                "row {i} grating {g}: {} vs {}",
                back.dl_pm[g][i],
                d.dl_pm[g][i]
            );
        }
        assert!(close(back.ambient()[i], d.ambient()[i], 1e-6));
        assert!(
            close(back.target(0).as_slice()[i], d.target(0).as_slice()[i], 1e-6)
                && close(back.target(1).as_slice()[i], d.target(1).as_slice()[i], 1e-6)
                && close(back.target(2).as_slice()[i], d.target(2).as_slice()[i], 1e-6)
        );
    }
    // The same split as the simulator's 50 %.
    assert_eq!(back.split, d.split);

    let grid = TrainOptions::builder()
        .centres(vec![8, 16])
        .sigma_mults(vec![1.0, 2.0])
        .alpha_rels(vec![1e-5, 1e-3])
        .dead_bands_pm(vec![2.0, 4.0])
        .check()
        .unwrap();
    let t = train(&back, &grid, &Origin { scenario: "imported".into(), seed: 0 }).unwrap();
    assert_eq!(t.selection.n_cal, n / 2 - 1, "the gap row is not used for fitting");
    assert_eq!(t.model_h.fitted, [true, true, true, false]);
    assert!(t.selection.cv_rmse_h.iter().all(|r| r.is_finite()), "{:?}", t.selection.cv_rmse_h);
}
