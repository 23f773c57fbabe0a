//! The memory bank over whole streams: the memory vector against an independent
//! reference, start, gaps and repeated time stamps, saved and resumed state, unused slots, and
//! f32 against f64 over a 14-day record.

use fbg_shared::layout::paper::{MEM_AMBIENT, MEM_GRATING, MEM_OBSERVER, MEM_STOP, N_GRATINGS, N_MEMORY};
use fbg_shared::layout::{pad, Dims, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS};

const D: Dims = Dims::PAPER;
use fbg_shared::{MemoryBank, MemoryGroup, MemorySpec, MemoryState, Real};
use fbg_testkit::models::full_memory_spec;
use fbg_testkit::Rng;

/// One input sample of the bank: Δλ [pm], T_amb [°C], t [s].
#[derive(Clone, Copy, Debug)]
struct In {
    dl: [f64; 3],
    t_amb: f64,
    t: f64,
}

impl In {
    /// The same sample rounded to f32 (and back): what both precisions are fed.
    fn f32_exact(self) -> In {
        let r = |v: f64| f64::from(v as f32);
        In { dl: self.dl.map(r), t_amb: r(self.t_amb), t: r(self.t) }
    }
}

fn update<F: Real>(b: &mut MemoryBank<F>, s: &In) -> [F; N_MEMORY] {
    let m = b.update(&pad(&s.dl.map(F::from_f64)), F::from_f64(s.t_amb), F::from_f64(s.t));
    assert!(m[N_MEMORY..].iter().all(|&v| v == F::ZERO), "no term beyond the paper layout");
    pad(&m)
}

/// A random-walk stream on an irregular clock: Δt from {1, 7, 60, 300} s, with a long gap
/// (1e5 s), a repeated time stamp and a backward one now and then.
fn irregular_stream(seed: u64, n: usize) -> Vec<In> {
    let mut r = Rng(seed);
    let mut dl = [r.uniform(-50.0, 50.0), r.uniform(-50.0, 50.0), r.uniform(-50.0, 50.0)];
    let mut t = 1000.0;
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d += r.uniform(-3.0, 3.0);
            }
            t += match k % 397 {
                100 => 1e5,
                200 => 0.0,
                300 => -30.0,
                _ => [1.0, 7.0, 60.0, 300.0][(r.next_u64() % 4) as usize],
            };
            In { dl, t_amb: 20.0 + 3.0 * (t / 86_400.0 * std::f64::consts::TAU).sin() + r.uniform(-0.1, 0.1), t }
        })
        .map(In::f32_exact)
        .collect()
}

// ---------------------------------------------------------------------------------------------
// An independent reference: every operator written out from its definition, f64, libm's expm1.

#[derive(Clone, Copy)]
struct Reference {
    spec: MemorySpec<f64>,
    grating: [[f64; N_GRATINGS]; N_GRATING_TAUS],
    ambient: [f64; N_AMBIENT_TAUS],
    play: [[f64; N_GRATINGS]; N_PLAYS],
    lagged: f64,
    out: f64,
    t_prev: Option<f64>,
}

impl Reference {
    fn new(spec: MemorySpec<f64>) -> Self {
        Reference {
            spec,
            grating: Default::default(),
            ambient: Default::default(),
            play: Default::default(),
            lagged: 0.0,
            out: 0.0,
            t_prev: None,
        }
    }

    fn update(&mut self, s: &In) -> [f64; N_MEMORY] {
        let sp = self.spec;
        let row = sp.observer_row;
        let t_g = row[0] * s.dl[0] + row[1] * s.dl[1] + row[2] * s.dl[2] + row[3] * s.t_amb + row[4];
        let observer_on = sp.observer_lag_s > 0.0;
        let mut m = [0.0; N_MEMORY];
        let Some(t_prev) = self.t_prev else {
            // First sample: every operator at its own input, high-pass and stop terms 0.
            self.grating = [s.dl; N_GRATING_TAUS];
            self.play = [s.dl; N_PLAYS];
            self.ambient = [s.t_amb; N_AMBIENT_TAUS];
            self.lagged = t_g;
            self.out = t_g - s.t_amb;
            self.t_prev = Some(s.t);
            if observer_on {
                m[MEM_OBSERVER] = self.out;
            }
            return m;
        };
        let dt = s.t - t_prev;
        self.t_prev = Some(s.t);
        let alpha = |tau: f64| if dt > 0.0 { -(-dt / tau).exp_m1() } else { 0.0 };
        for (j, &tau) in sp.grating_tau_s.iter().enumerate() {
            for i in 0..N_GRATINGS {
                if tau > 0.0 {
                    let e = &mut self.grating[j][i];
                    *e += alpha(tau) * (s.dl[i] - *e);
                    m[MEM_GRATING + N_GRATINGS * j + i] = s.dl[i] - *e;
                }
            }
        }
        for (j, &tau) in sp.ambient_tau_s.iter().enumerate() {
            if tau > 0.0 {
                let e = &mut self.ambient[j];
                *e += alpha(tau) * (s.t_amb - *e);
                m[MEM_AMBIENT + j] = s.t_amb - *e;
            }
        }
        for (j, &r) in sp.play_half_width_pm.iter().enumerate() {
            for i in 0..N_GRATINGS {
                if r > 0.0 {
                    let p = &mut self.play[j][i];
                    *p = p.clamp(s.dl[i] - r, s.dl[i] + r);
                    m[MEM_STOP + N_GRATINGS * j + i] = s.dl[i] - *p;
                }
            }
        }
        if observer_on {
            self.lagged += alpha(sp.observer_lag_s) * (t_g - self.lagged);
            self.out += alpha(sp.observer_smooth_s) * (self.lagged - s.t_amb - self.out);
            m[MEM_OBSERVER] = self.out;
        }
        m
    }
}

#[test]
fn the_bank_computes_each_term_as_defined() {
    let spec = full_memory_spec();
    for seed in 0..3 {
        let mut bank = MemoryBank::<f64>::new(&spec, &D);
        let mut reference = Reference::new(spec.convert());
        let mut worst = 0.0f64;
        for s in irregular_stream(seed, 5000) {
            let (m, want) = (update(&mut bank, &s), reference.update(&s));
            for k in 0..N_MEMORY {
                // Relative to the inputs' scale (terms are differences of O(100) pm values).
                let err = (m[k] - want[k]).abs() / (1.0 + s.dl.iter().fold(s.t_amb.abs(), |a, v| a.max(v.abs())));
                worst = worst.max(err);
                assert!(
                    err < 1e-13,
                    "seed {seed} t {} term {k} ({:?}): {} vs {}",
                    s.t,
                    spec.term(&D, k),
                    m[k],
                    want[k]
                );
            }
        }
        eprintln!("bank against its definition, seed {seed}: worst scaled difference {worst:.1e}");
    }
}

#[test]
fn the_layout_names_every_term() {
    let spec = full_memory_spec();
    let mut seen = [0usize; 4];
    for k in 0..N_MEMORY {
        let t = spec.term(&D, k).expect("every slot is a term");
        assert!(spec.term_active(&D, k), "the full spec uses slot {k}");
        seen[MemoryGroup::ALL.iter().position(|&g| g == t.group).unwrap()] += 1;
        match t.group {
            MemoryGroup::GratingHighPass => {
                assert_eq!((t.grating, t.parameter), (k % 3, spec.grating_tau_s[k / 3]), "{k}")
            }
            MemoryGroup::AmbientHighPass => assert_eq!(t.parameter, spec.ambient_tau_s[k - MEM_AMBIENT]),
            MemoryGroup::Stop => {
                assert_eq!((t.grating, t.parameter), ((k - MEM_STOP) % 3, spec.play_half_width_pm[(k - MEM_STOP) / 3]))
            }
            MemoryGroup::DriftObserver => assert_eq!((k, t.parameter), (MEM_OBSERVER, spec.observer_smooth_s)),
        }
    }
    assert_eq!(seen, [N_GRATINGS * N_GRATING_TAUS, N_AMBIENT_TAUS, N_GRATINGS * N_PLAYS, 1]);
    assert_eq!(spec.term(&D, N_MEMORY), None);
    assert_eq!(MemorySpec::<f32>::off().term(&D, 3).map(|t| t.parameter), Some(0.0));
    assert!(!MemorySpec::<f32>::off().any());
    assert_eq!(
        MemoryGroup::ALL.map(|g| (g.name(), g.unit())),
        [("grating-high-pass", "pm"), ("ambient-high-pass", "°C"), ("stop", "pm"), ("drift-observer", "°C")]
    );
}

// ---------------------------------------------------------------------------------------------
// Start, gaps, repeated and backward time stamps

/// A spec with one short and one long τ on the gratings and the ambient, one play, observer.
fn gap_spec() -> MemorySpec<f64> {
    let mut s = MemorySpec::<f64>::off();
    s.grating_tau_s[0] = 60.0;
    s.grating_tau_s[3] = 86_400.0;
    s.ambient_tau_s[1] = 120.0;
    s.play_half_width_pm[2] = 5.0;
    s.observer_lag_s = 300.0;
    s.observer_smooth_s = 600.0;
    s.observer_row = pad(&[0.1, 0.0, -0.05, 0.5, 10.0]);
    s
}

fn walk(seed: u64, n: usize, t0: f64, dt: f64) -> Vec<In> {
    let mut r = Rng(seed);
    let mut dl = [10.0, -20.0, 30.0];
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d += r.uniform(-2.0, 2.0);
            }
            In { dl, t_amb: 20.0 + r.uniform(-1.0, 1.0), t: t0 + dt * k as f64 }
        })
        .collect()
}

#[test]
fn the_first_sample_primes_every_operator() {
    let spec = full_memory_spec();
    let s = In { dl: [12.0, -7.5, 300.0], t_amb: 21.5, t: 5e5 };
    let m = update(&mut MemoryBank::<f64>::new(&spec, &D), &s);
    let row = spec.observer_row.map(f64::from);
    let t_g = row[0] * s.dl[0] + row[1] * s.dl[1] + row[2] * s.dl[2] + row[3] * s.t_amb + row[4];
    for (k, &v) in m.iter().enumerate() {
        if k == MEM_OBSERVER {
            // The observer starts at the difference itself: no smoothing has happened yet.
            assert!((v - (t_g - s.t_amb)).abs() < 1e-12, "{v} vs {}", t_g - s.t_amb);
        } else {
            assert_eq!(v.to_bits(), 0, "term {k} is +0 on the first sample");
        }
    }
    // A second identical sample at the same time changes nothing.
    let mut b = MemoryBank::<f64>::new(&spec, &D);
    let first = update(&mut b, &s);
    assert_eq!(update(&mut b, &s), first);
}

#[test]
fn a_long_gap_re_primes_the_short_low_passes_only() {
    let spec = gap_spec();
    let before = walk(1, 300, 0.0, 60.0);
    let t_end = before.last().unwrap().t;
    let gap = 1e5; // ≫ 60, 120, 300, 600 s; ≈ 1.16 × 86 400 s
    let after = walk(2, 200, t_end + gap, 60.0);
    let mut bank = MemoryBank::<f64>::new(&spec, &D);
    let mut reference = Reference::new(spec);
    for s in &before {
        update(&mut bank, s);
        reference.update(s);
    }
    let s_long_before = reference.grating[3];
    let first = after[0];
    let m = update(&mut bank, &first);
    // Short τ (60 s): α = 1 − e^(−1667) = 1 exactly, so the EMA jumps to the new sample and its
    // high-pass is 0 up to the rounding of (x − s) + s. Asserted: |hp| <= 1e-13 (the Δλ are
    // O(100) pm; a non-re-primed 60-s low-pass would be off by the whole walk since then).
    for i in 0..3 {
        assert!(m[MEM_GRATING + i].abs() <= 1e-13, "grating {i}: {}", m[MEM_GRATING + i]);
    }
    assert!(m[MEM_AMBIENT + 1].abs() <= 1e-13, "ambient: {}", m[MEM_AMBIENT + 1]);
    // The observer's two low-passes (300 s, 600 s) are re-primed too: its output is the new
    // T_g − T_amb, as on a first sample.
    let row = spec.observer_row;
    let t_g = row[0] * first.dl[0] + row[1] * first.dl[1] + row[2] * first.dl[2] + row[3] * first.t_amb + row[4];
    assert!((m[MEM_OBSERVER] - (t_g - first.t_amb)).abs() < 1e-12);
    // Long τ (1 day): a gap of 1.16 τ is just a long step, hp = e^(−gap/τ)·(x − s_before).
    for i in 0..3 {
        let want = (-gap / 86_400.0).exp() * (first.dl[i] - s_long_before[i]);
        assert!((m[MEM_GRATING + 9 + i] - want).abs() < 1e-12, "grating {i}: {} vs {want}", m[MEM_GRATING + 9 + i]);
    }
    // The stop terms ignore the clock: exactly what a bank without the gap gives.
    let mut no_gap = MemoryBank::<f64>::new(&spec, &D);
    for s in &before {
        update(&mut no_gap, s);
    }
    let m_no_gap = update(&mut no_gap, &In { t: t_end + 60.0, ..first });
    assert_eq!(m[MEM_STOP + 6..MEM_STOP + 9], m_no_gap[MEM_STOP + 6..MEM_STOP + 9]);
    // After the gap the short-τ terms continue as a bank primed at the first sample after it.
    let mut fresh = MemoryBank::<f64>::new(&spec, &D);
    update(&mut fresh, &first);
    for s in &after[1..] {
        let (a, b) = (update(&mut bank, s), update(&mut fresh, s));
        for k in [0, 1, 2, MEM_AMBIENT + 1, MEM_OBSERVER] {
            assert!((a[k] - b[k]).abs() < 1e-12, "term {k} at t {}: {} vs {}", s.t, a[k], b[k]);
        }
    }
}

#[test]
fn repeated_and_backward_time_stamps_hold_the_low_passes() {
    let spec = gap_spec();
    let ss = walk(3, 100, 0.0, 60.0);
    let mut bank = MemoryBank::<f64>::new(&spec, &D);
    let mut reference = Reference::new(spec);
    let mut m_last = [0.0; N_MEMORY];
    for s in &ss {
        m_last = update(&mut bank, s);
        reference.update(s);
    }
    let last = *ss.last().unwrap();
    let moved = In { dl: [last.dl[0] + 40.0, last.dl[1] - 40.0, last.dl[2]], t_amb: last.t_amb + 2.0, t: last.t };
    let low_pass_terms = [0, 1, 2, 9, 10, 11, MEM_AMBIENT + 1, MEM_OBSERVER];
    for t in [last.t, last.t - 30.0] {
        // Δt <= 0: α = 0, so every EMA and the observer stay exactly where they were: the same
        // inputs again give bit-identical low-pass terms, ...
        let mut b = bank;
        let m = update(&mut b, &In { t, ..last });
        for k in low_pass_terms {
            assert_eq!(m[k].to_bits(), m_last[k].to_bits(), "t {t}: term {k}");
        }
        // ... and moved inputs give the new x minus the held EMA (observer output unchanged).
        let mut b = bank;
        let mut r = reference;
        let m = update(&mut b, &In { t, ..moved });
        let want = r.update(&In { t, ..moved });
        for i in 0..3 {
            let held = reference.grating[0][i];
            assert!((m[MEM_GRATING + i] - (moved.dl[i] - held)).abs() < 1e-12, "t {t}");
            assert!((want[MEM_GRATING + i] - (moved.dl[i] - held)).abs() == 0.0);
        }
        assert!((m[MEM_AMBIENT + 1] - (moved.t_amb - reference.ambient[1])).abs() < 1e-12);
        assert_eq!(m[MEM_OBSERVER].to_bits(), m_last[MEM_OBSERVER].to_bits());
        // The plays still move: grating 1 went up by 40 pm ≫ 2r, so its stop term is +r,
        // grating 2 went down by as much.
        assert_eq!(m[MEM_STOP + 6], 5.0);
        assert_eq!(m[MEM_STOP + 7], -5.0);
    }
    // After a backward stamp the clock restarts from it: the next Δt is measured from the
    // backward stamp (here 60 s), not from the latest time seen.
    let mut b = bank;
    let mut r = reference;
    let back = In { t: last.t - 30.0, ..moved };
    update(&mut b, &back);
    r.update(&back);
    let next = In { t: last.t + 30.0, ..moved };
    let (m, want) = (update(&mut b, &next), r.update(&next));
    for k in 0..N_MEMORY {
        assert!((m[k] - want[k]).abs() < 1e-12, "term {k}");
    }
}

// ---------------------------------------------------------------------------------------------
// Saved and resumed state

fn resume_is_bit_identical<F: Real>() {
    let spec = full_memory_spec();
    for seed in 10..13 {
        let ss = irregular_stream(seed, 5000);
        let mut whole = MemoryBank::<F>::new(&spec, &D);
        let mut state = None;
        let mut expected = Vec::new();
        for (i, s) in ss.iter().enumerate() {
            if i == 2500 {
                state = Some(whole.state());
            }
            expected.push(update(&mut whole, s).map(|v| v.to_f64().to_bits()));
        }
        // A fresh bank of the same spec, and one that has already run another stream (so its
        // cached smoothing factors are for another Δt): both resume exactly.
        let fresh = MemoryBank::<F>::new(&spec, &D);
        let mut used = MemoryBank::<F>::new(&spec, &D);
        for s in irregular_stream(seed + 100, 77) {
            update(&mut used, &s);
        }
        for mut b in [fresh, used] {
            assert!(b.same_spec(&whole));
            b.set_state(state.unwrap());
            assert_eq!(b.state(), state.unwrap());
            for (i, s) in ss.iter().enumerate().skip(2500) {
                assert_eq!(update(&mut b, s).map(|v| v.to_f64().to_bits()), expected[i], "seed {seed} sample {i}");
            }
            assert_eq!(b.state(), whole.state());
        }
    }
}

fn packed_resume_is_bit_identical<F: Real>() {
    let spec = full_memory_spec();
    let n = D.gratings();
    let ss = irregular_stream(21, 3000);
    let mut whole = MemoryBank::<F>::new(&spec, &D);
    let mut packed = vec![F::ZERO; MemoryState::<F>::packed_len(n)];
    let mut expected = Vec::new();
    for (i, s) in ss.iter().enumerate() {
        if i == 1500 {
            whole.state().pack(n, &mut packed).unwrap();
        }
        expected.push(update(&mut whole, s).map(|v| v.to_f64().to_bits()));
    }
    let mut b = MemoryBank::<F>::new(&spec, &D);
    let state = MemoryState::unpack(n, &packed).unwrap();
    b.set_state(state);
    for (i, s) in ss.iter().enumerate().skip(1500) {
        assert_eq!(update(&mut b, s).map(|v| v.to_f64().to_bits()), expected[i], "sample {i}");
    }
    assert_eq!(b.state(), whole.state());
    // A packed state of the wrong length or beyond capacity is refused, not misread.
    assert!(MemoryState::<F>::unpack(n, &packed[1..]).is_err());
    assert!(MemoryState::<F>::unpack(9, &packed).is_err());
    assert!(whole.state().pack(n + 1, &mut packed).is_err());
}

#[test]
fn a_bank_resumed_from_a_packed_state_continues_bit_identically() {
    packed_resume_is_bit_identical::<f64>();
    packed_resume_is_bit_identical::<f32>();
}

#[test]
fn a_resumed_bank_continues_bit_identically_f64() {
    resume_is_bit_identical::<f64>();
}

#[test]
fn a_resumed_bank_continues_bit_identically_f32() {
    resume_is_bit_identical::<f32>();
}

#[test]
fn reset_forgets_the_stream() {
    let spec = full_memory_spec();
    let ss = irregular_stream(4, 600);
    let fresh = MemoryBank::<f32>::new(&spec, &D);
    let mut b = fresh;
    for s in &ss[..300] {
        update(&mut b, s);
    }
    assert_ne!(b.state(), fresh.state());
    b.reset();
    assert_eq!(b.state(), fresh.state());
    let mut f = fresh;
    for s in &ss[300..] {
        assert_eq!(update(&mut b, s).map(f32::to_bits), update(&mut f, s).map(f32::to_bits));
    }
}

#[test]
fn same_spec_tells_specs_apart() {
    let spec = full_memory_spec();
    let base = MemoryBank::<f32>::new(&spec, &D);
    assert!(base.same_spec(&MemoryBank::<f32>::new(&spec, &D)));
    // Built from the f64 spec: the same f32 coefficients.
    assert!(base.same_spec(&MemoryBank::<f32>::new(&spec.convert::<f64>(), &D)));
    let changes: [fn(&mut MemorySpec<f32>); 7] = [
        |s| s.grating_tau_s[2] *= 2.0,
        |s| s.grating_tau_s[5] = 0.0,
        |s| s.ambient_tau_s[0] = 1.0,
        |s| s.play_half_width_pm[1] += 1.0,
        |s| s.observer_lag_s = 0.0,
        |s| s.observer_smooth_s += 1.0,
        |s| s.observer_row[4] = 1.0,
    ];
    for (i, f) in changes.into_iter().enumerate() {
        let mut s = spec;
        f(&mut s);
        assert!(!base.same_spec(&MemoryBank::<f32>::new(&s, &D)), "change {i}");
    }
}

// ---------------------------------------------------------------------------------------------
// Unused slots

#[test]
fn unused_slots_give_exactly_zero() {
    let mut partial = full_memory_spec();
    partial.grating_tau_s = [0.0, 600.0, 0.0, 0.0, 86_400.0, 0.0];
    partial.ambient_tau_s = [0.0, 0.0, 3600.0, 0.0];
    partial.play_half_width_pm = [0.0, 5.0, 0.0];
    partial.observer_lag_s = 0.0; // no observer, whatever its smoothing and row say
    let off = MemorySpec::<f32>::off();
    for spec in [partial, off] {
        let mut b32 = MemoryBank::<f32>::new(&spec, &D);
        let mut b64 = MemoryBank::<f64>::new(&spec, &D);
        assert_eq!(b32.is_active(), spec.any());
        let mut nonzero = [false; N_MEMORY];
        for s in irregular_stream(5, 3000) {
            let (m32, m64) = (update(&mut b32, &s), update(&mut b64, &s));
            for k in 0..N_MEMORY {
                if !spec.term_active(&D, k) {
                    assert_eq!(m32[k].to_bits(), 0, "f32 term {k}");
                    assert_eq!(m64[k].to_bits(), 0, "f64 term {k}");
                } else {
                    nonzero[k] |= m64[k] != 0.0;
                }
            }
        }
        // ... and every used slot does move.
        for (k, moved) in nonzero.iter().enumerate() {
            assert_eq!(*moved, spec.term_active(&D, k), "term {k}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// f32 against f64 over a long record

/// Largest |m32 − m64| per term over a stream fed to both banks (f32-representable inputs, so
/// the difference is the arithmetic alone), and the largest |m64| per term.
fn f32_f64_difference(spec: &MemorySpec<f32>, ss: impl Iterator<Item = In>) -> ([f64; N_MEMORY], [f64; N_MEMORY]) {
    let mut b32 = MemoryBank::<f32>::new(spec, &D);
    let mut b64 = MemoryBank::<f64>::new(spec, &D);
    let (mut worst, mut scale) = ([0.0f64; N_MEMORY], [0.0f64; N_MEMORY]);
    for s in ss {
        let s = s.f32_exact();
        let (m32, m64) = (update(&mut b32, &s), update(&mut b64, &s));
        for k in 0..N_MEMORY {
            worst[k] = worst[k].max((f64::from(m32[k]) - m64[k]).abs());
            scale[k] = scale[k].max(m64[k].abs());
        }
    }
    (worst, scale)
}

/// 14 days at 60 s: 20 160 samples.
const FOURTEEN_DAYS: usize = 20_160;

/// Δλ random walks of O(100 pm) (±1.7 pm per sample plus a daily thermal swing of up to
/// ±100 pm), T_amb ≈ 20 °C ± 3 °C daily.
fn fourteen_days(seed: u64) -> impl Iterator<Item = In> {
    let mut r = Rng(seed);
    let mut walk = [0.0f64; 3];
    (0..FOURTEEN_DAYS).map(move |k| {
        let t = 60.0 * k as f64;
        let day = (t / 86_400.0 * std::f64::consts::TAU).sin();
        for w in walk.iter_mut() {
            *w += r.uniform(-1.7, 1.7);
        }
        In {
            dl: [walk[0] + 60.0 * day, walk[1] - 20.0 * day, walk[2] + 100.0 + 30.0 * day],
            t_amb: 20.0 + 3.0 * day + r.uniform(-0.05, 0.05),
            t,
        }
    })
}

fn by_group(worst: &[f64; N_MEMORY]) -> [f64; 4] {
    let spec = full_memory_spec();
    let mut g = [0.0f64; 4];
    for (k, &w) in worst.iter().enumerate() {
        let i = MemoryGroup::ALL.iter().position(|&x| x == spec.term(&D, k).unwrap().group).unwrap();
        g[i] = g[i].max(w);
    }
    g
}

/// The long EMAs must not drift apart in f32. Over a 14-day random walk the worst grating
/// high-pass differs by 2.7e-4 and 3.5e-4 pm for the two seeds (measured; ≈ 9–11 ulp of f32 at
/// 256 pm, where the Δλ reach 223 pm): rounding errors of the 1-week EMA (α = 9.9e-5 per sample) are forgotten over
/// 1/α samples and mostly cancel. Bound: 1e-3 pm (33 ulp at 256 pm), 0.01 % of the 10 pm per
/// °C of a temperature grating. Ambient, stop and observer terms: measured 4.2e-5 °C,
/// 1.5e-5 pm, 8.8e-6 °C; bounds 1e-4.
#[test]
fn f32_and_f64_banks_agree_over_fourteen_days() {
    let spec = full_memory_spec();
    let mut all = [0.0f64; 4];
    for seed in [2024, 7] {
        let (worst, scale) = f32_f64_difference(&spec, fourteen_days(seed));
        let g = by_group(&worst);
        eprintln!(
            "14 days at 60 s, seed {seed}, max |m32 − m64|: grating high-pass {:.2e} pm (terms up to {:.0} pm), \
             ambient {:.2e} °C, stop {:.2e} pm, observer {:.2e} °C; per grating τ slot {:?}",
            g[0],
            by_group(&scale)[0],
            g[1],
            g[2],
            g[3],
            worst[..18]
                .chunks(3)
                .map(|c| format!("{:.1e}", c.iter().fold(0.0f64, |a, &b| a.max(b))))
                .collect::<Vec<_>>()
        );
        for (a, b) in all.iter_mut().zip(g) {
            *a = a.max(b);
        }
    }
    assert!(all[0] < 1e-3, "grating high-pass: {:e} pm", all[0]);
    assert!(all[1] < 1e-4, "ambient high-pass: {:e} °C", all[1]);
    assert!(all[2] < 1e-4, "stop: {:e} pm", all[2]);
    assert!(all[3] < 1e-4, "observer: {:e} °C", all[3]);
}

/// A steady drift is the hard case for a long f32 EMA: with x − EMA settled at ramp·τ/Δt, every
/// update adds about the same increment and makes about the same rounding error, so the errors
/// add up over the 1/α samples the EMA remembers instead of cancelling. The bound is that
/// accumulation, half an ulp of the state per sample over 1/α samples: ulp(|Δλ|max)/(2α) per
/// τ slot (0.08 pm for the 1-week EMA at 250 pm, 0.011 pm for the 1-day one). Measured at 0.01 pm per sample (14 pm/day,
/// an extreme interrogator drift): 4.3e-3 pm for the 1-day EMA (bound 1.1e-2), 7.7e-4 pm for
/// the 6-hour one, 1.3e-4 pm or less for the others. A random walk on top dithers the roundings
/// and brings the difference back to the previous test's 3e-4 pm.
#[test]
fn a_steady_drift_keeps_the_f32_long_emas_within_their_rounding_bound() {
    let spec = full_memory_spec();
    // Three gratings drifting by +0.01, +0.01 and −0.01 pm per sample from 0, 50 and 0 pm, one
    // with ±0.5 pm of noise, the others noise-free (the worst case: no dithering).
    let mut r = Rng(11);
    let ss: Vec<In> = (0..FOURTEEN_DAYS)
        .map(|k| {
            let d = 0.01 * k as f64;
            In { dl: [d + r.uniform(-0.5, 0.5), 50.0 + d, -d], t_amb: 20.0, t: 60.0 * k as f64 }
        })
        .collect();
    let x_max = ss.iter().flat_map(|s| s.dl).fold(0.0f64, |a, v| a.max(v.abs()));
    let ulp = f64::from(f32::from_bits((x_max as f32).to_bits() + 1) - x_max as f32);
    let (worst, _) = f32_f64_difference(&spec, ss.into_iter());
    for (slot, &tau) in spec.grating_tau_s.iter().enumerate() {
        let alpha = -(-60.0 / f64::from(tau)).exp_m1();
        let bound = ulp / (2.0 * alpha) + 1e-4;
        let w = worst[slot * 3..slot * 3 + 3].iter().fold(0.0f64, |a, &b| a.max(b));
        eprintln!("steady drift 0.01 pm/sample: τ {tau} s: max |m32 − m64| {w:.1e} pm (bound {bound:.1e})");
        assert!(w < bound, "τ {tau}: {w:e} >= {bound:e}");
    }
    assert!(by_group(&worst)[0] < 1e-2, "grating high-pass: {:e} pm", by_group(&worst)[0]);
}
