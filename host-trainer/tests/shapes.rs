//! Installations of 1–8 gratings and 1–4 measurands, with or without an
//! ambient thermometer. Every preset simulates deterministically (pinned CSV checksums; the
//! `paper` and `harsh` pins are the bytes the 3-grating simulator wrote before it was
//! generalised), round-trips through the dataset CSV, `--no-ambient` drops the `T_amb_C`
//! column and nothing else, and the commands that fit the paper's model refuse every other
//! shape with a message naming the file and what it has — never a panic.

use crate::common;

use common::{bin, run};
use fbg_trainer::data::{Dataset, Kind, Measurand};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;
use fbg_trainer::stats::std_dev;

/// CRC-32/ISCSI of the CSV of `preset` at seed 7 (14 days at 60 s).
const PINNED_CRC: [(Preset, u32); 5] = [
    (Preset::Paper, 0x7C1F_1811),
    (Preset::Harsh, 0x1C25_D9B1),
    (Preset::Temperature1, 0x9A03_BE38),
    (Preset::StrainPair, 0x1D69_F78C),
    (Preset::Array8, 0x4DB4_5FBD),
];

fn csv_bytes(preset: Preset, seed: u64, thermometer: bool) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    let mut cfg = preset.config();
    cfg.ambient.thermometer = thermometer;
    simulate(&cfg, seed).data.write_csv(&p).unwrap();
    // The data rows and header (λ_ref and the start time are in the sidecar, pinned apart).
    let text = std::fs::read_to_string(&p).unwrap();
    let side = std::fs::read_to_string(fbg_trainer::data::record_meta::sidecar_path(&p)).unwrap();
    assert!(side.contains("\"simulated\"") && side.contains("\"t0_utc\": \"2026-01-05T00:00:00.000Z\""), "{side}");
    assert!(text.starts_with("t_s,"), "{text:.100}");
    common::csv_body(&text).as_bytes().to_vec()
}

fn crc(b: &[u8]) -> u32 {
    crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(b)
}

#[test]
fn every_preset_simulates_the_pinned_bytes() {
    let mut got = Vec::new();
    for (preset, _) in PINNED_CRC {
        let a = csv_bytes(preset, 7, true);
        assert_eq!(a, csv_bytes(preset, 7, true), "{} is not deterministic", preset.name());
        got.push((preset.name(), crc(&a)));
    }
    let want: Vec<(&str, u32)> = PINNED_CRC.iter().map(|(p, c)| (p.name(), *c)).collect();
    assert_eq!(got, want, "CSV checksums (seed 7) changed");
}

#[test]
fn each_preset_has_its_shape_and_round_trips_through_the_csv() {
    let e2 = Measurand { kind: Kind::Strain, index: 2 };
    let shapes: [(Preset, usize, Vec<Measurand>, &str); 5] = [
        (Preset::Paper, 3, Measurand::PAPER.to_vec(), "t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split"),
        (Preset::Harsh, 3, Measurand::PAPER.to_vec(), "t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split"),
        (Preset::Temperature1, 1, vec![Measurand::T], "t_s,T_C,T_amb_C,dl1_pm,split"),
        (Preset::StrainPair, 2, vec![Measurand::T, Measurand::STRAIN], "t_s,T_C,strain_ue,T_amb_C,dl1_pm,dl2_pm,split"),
        (
            Preset::Array8,
            8,
            vec![Measurand::T, Measurand::STRAIN, e2, Measurand::P],
            "t_s,T_C,strain_ue,strain2_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,dl4_pm,dl5_pm,dl6_pm,dl7_pm,dl8_pm,split",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (preset, gratings, measurands, header) in shapes {
        let s = simulate(&preset.config(), 7);
        let d = &s.data;
        assert_eq!((d.n_gratings(), d.measurands(), d.t_amb_c.is_some()), (gratings, measurands.clone(), true));
        let dims = d.dims(preset.name()).unwrap();
        assert_eq!((dims.gratings(), dims.ambient(), Measurand::of_dims(&dims)), (gratings, true, measurands.clone()));
        let p = dir.path().join(format!("{}.csv", preset.name()));
        d.write_csv(&p).unwrap();
        let text = common::read_csv_body(&p);
        assert_eq!(text.lines().next().unwrap(), header);
        let back = Dataset::read_csv(&p).unwrap();
        assert_eq!(back.shape(), d.shape());
        assert_eq!(back.split, d.split);
        for (a, b) in back.dl_pm.iter().zip(&d.dl_pm) {
            assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 5e-7), "{}", preset.name());
        }
        for m in &measurands {
            let (a, b) = (back.reference(*m).unwrap(), d.reference(*m).unwrap());
            assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 5e-7), "{} {m}", preset.name());
        }
        // Writing what was read gives the same bytes: the canonical order is stable.
        let again = dir.path().join("again.csv");
        back.write_csv(&again).unwrap();
        assert_eq!(std::fs::read_to_string(&again).unwrap(), std::fs::read_to_string(&p).unwrap(), "{}", preset.name());
        // The per-sample oracle inverts every measurand to near its noise.
        let floor = s.oracle_floor();
        assert_eq!(floor.measurands, measurands);
        assert!(floor.rmse_holdout.iter().all(|v| v.is_finite() && *v > 0.0), "{}: {floor:?}", preset.name());
    }
}

/// The new presets are physically sensible: about 10 pm/°C on every grating, a strain grating
/// near 1.2 pm/µε, the references nearly strain-free, the diaphragm about 1 pm/kPa; each
/// grating moves by what its sensitivities times the measurands' spreads say.
#[test]
fn the_new_presets_have_sensible_gauge_factors_and_artefacts() {
    for preset in [Preset::Temperature1, Preset::StrainPair, Preset::Array8] {
        let s = simulate(&preset.config(), 3);
        for (g, row) in s.physics.k.iter().enumerate() {
            assert!((8.5..=12.5).contains(&row[0]), "{} grating {g}: {row:?} pm/°C", preset.name());
        }
        // Every interrogator artefact is there on every grating.
        for name in fbg_trainer::sim::EFFECT_NAMES {
            let e = s.effects.by_name(name).unwrap();
            assert_eq!(e.len(), s.data.n_gratings());
            for ch in e {
                assert!(std_dev(ch.iter().copied()) > 0.0 || name == "electronics", "{} {name}", preset.name());
            }
        }
    }
    let s = simulate(&Preset::Array8.config(), 3);
    let k = &s.physics.k;
    assert!((k[0][1] - 1.2).abs() < 0.2 && (k[3][2] - 1.2).abs() < 0.2, "axial strain gratings: {k:?}");
    assert!(k[1][1] < 0.0 && k[4][2] < 0.0, "transverse gratings read −ν ε: {k:?}");
    assert!(k[2][1].abs() < 0.1 && k[5][2].abs() < 0.1 && k[7][1].abs() < 0.1, "references: {k:?}");
    assert!((k[6][3] - 1.0).abs() < 0.2, "diaphragm: {k:?}");
    let e2 = s.data.reference(Measurand { kind: Kind::Strain, index: 2 }).unwrap();
    let e1 = s.data.reference(Measurand::STRAIN).unwrap();
    assert_ne!(e1, e2, "the two strain locations draw their own loads");
    assert!((30.0..150.0).contains(&std_dev(e2.iter().copied())));
}

#[test]
fn no_ambient_drops_the_column_and_nothing_else() {
    for preset in [Preset::Paper, Preset::StrainPair, Preset::Array8] {
        let with = String::from_utf8(csv_bytes(preset, 5, true)).unwrap();
        let without = String::from_utf8(csv_bytes(preset, 5, false)).unwrap();
        let head: Vec<&str> = with.lines().next().unwrap().split(',').collect();
        let amb = head.iter().position(|h| *h == "T_amb_C").unwrap();
        assert!(!without.lines().next().unwrap().contains("T_amb_C"));
        for (a, b) in with.lines().zip(without.lines()).take(500) {
            let mut a: Vec<&str> = a.split(',').collect();
            a.remove(amb);
            assert_eq!(a.join(","), b, "{}", preset.name());
        }
    }
    // The command line and the scenario key.
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--preset", "strain-pair", "--no-ambient", "--out"]).arg(&a));
    assert!(ok && err.contains("no ambient thermometer"), "{err}");
    let cfg = dir.path().join("s.toml");
    std::fs::write(&cfg, "name = \"t1-no-amb\"\nambient = false\nmeasurands = [\"T_C\"]\n[gratings]\nnominal_nm = [1550.0]\ngauge = [[10.0]]\nc_tt = [0.012]\nc_te = []\nc_tp = []\nc_ee = []\nc_pp = []\nc_ep = []\n[scan]\nripple_phase_rad = [0.0]\n[drift]\nchannel_gain = [1.0]\n").unwrap();
    let b = dir.path().join("b.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--config"]).arg(&cfg).arg("--out").arg(&b));
    assert!(ok, "{err}");
    let text = common::read_csv_body(&b);
    assert_eq!(text.lines().next().unwrap(), "t_s,T_C,dl1_pm,split");
    let d = Dataset::read_csv(&b).unwrap();
    assert!(d.t_amb_c.is_none() && d.n_gratings() == 1);
}

/// `evaluate`, `report` and `compensate` refuse a record whose inputs are not the model's,
/// naming the file, the first missing column, what it has and what the model reads; nothing
/// is written.
#[test]
fn commands_refuse_a_record_without_the_models_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let t1 = dir.path().join("t1.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--preset", "temperature-1", "--out"]).arg(&t1));
    assert!(ok, "{err}");
    let model = dir.path().join("m.fbgm");

    // A paper-shaped model to evaluate and compensate with.
    let paper = common::short_csv(dir.path());
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&paper).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&t1).arg("--model").arg(&model));
    assert!(
        !ok && err.contains("t1.csv")
            && err.contains("`evaluate`")
            && err.contains("column dl2_pm")
            && err.contains("1 grating (dl1_pm)")
            && err.contains("3 gratings (dl1_pm..dl3_pm) and the ambient thermometer T_amb_C"),
        "{err}"
    );

    // No ambient thermometer: named as such.
    let sp = dir.path().join("sp.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--preset", "paper", "--no-ambient", "--out"]).arg(&sp));
    assert!(ok, "{err}");
    let out = dir.path().join("c.csv");
    let (ok, _, err) =
        run(bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(&sp).arg("--out").arg(&out));
    assert!(!ok && !out.exists() && err.contains("sp.csv") && err.contains("column T_amb_C"), "{err}");
    assert!(err.contains("no ambient thermometer"), "{err}");

    // `report` with data of another shape beside a paper model and its metrics.
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&paper).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let rep = dir.path().join("rep");
    let (ok, _, err) = run(bin()
        .args(["report", "--out"])
        .arg(&rep)
        .arg("--data")
        .arg(&t1)
        .arg("--model")
        .arg(&model)
        .arg("--metrics")
        .arg(dir.path().join("m.metrics.json")));
    assert!(!ok && err.contains("t1.csv") && err.contains("`report`") && !err.contains("panicked"), "{err}");
}

#[test]
fn header_mistakes_name_the_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("h.csv");
    let cases = [
        ("t_s,T_C,T_amb_C,dl1_pm,dl3_pm\n0,1,2,3,4\n", "column dl2_pm", "without holes"),
        ("t_s,T_C,dl1_pm,dl9_pm\n0,1,2,3\n", "column dl9_pm", "dl1_pm to dl8_pm"),
        ("t_s,T1_C,dl1_pm\n0,1,2\n", "column T1_C", "without an index"),
        ("t_s,T_C,T_C,dl1_pm\n0,1,2,3\n", "column T_C", "twice"),
        ("t_s,T_C,T2_C,strain_ue,strain2_ue,p_kPa,dl1_pm\n0,1,2,3,4,5,6\n", "column p_kPa", "at most 4"),
        ("t_s,T_C\n1,2\n", "column dl1_pm", "missing column `dl1_pm`"),
    ];
    for (text, column, words) in cases {
        std::fs::write(&p, text).unwrap();
        let e = Dataset::read_csv(&p).unwrap_err().to_string();
        assert!(e.contains("h.csv: line 1") && e.contains(column) && e.contains(words), "{text}: {e}");
    }
    // Order-free: columns found by name, written back in canonical order.
    std::fs::write(
        &p,
        "split,dl2_pm,p_kPa,dl1_pm,t_s,strain2_ue,note\ncal,2.5,150,1.5,0,7,x\nholdout,2.6,151,1.6,1,8,y\n",
    )
    .unwrap();
    let d = Dataset::read_csv(&p).unwrap();
    assert_eq!(d.header(), ["t_s", "strain2_ue", "p_kPa", "dl1_pm", "dl2_pm", "split"]);
    assert_eq!((d.dl_pm[1][1], d.t_amb_c.is_none()), (2.6, true));
}
