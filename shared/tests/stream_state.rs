//! Host tests of the model apart from its stream state: the trainer's entry points (core and
//! activations, `advance`), checkpoints resumed, and which models share a stream rule.

use crate::common;

use common::{bits, irregular, memory_params, params, stream, K};
use fbg_shared::layout::{Dims, MAX_MEMORY};
use fbg_shared::{Compensator, Estimate, FeatureSet, Flags, MemorySpec, PreparedModel, Sample, StreamState};
use fbg_testkit::models::{full_memory_spec, memory_model, short_provenance};

/// The first used grating high-pass of `some_memory_spec` (τ slot 1, grating 0).
const MEM_FIRST_ACTIVE: usize = 3;

#[test]
fn core_and_activations_are_what_step_computes() {
    for fs in FeatureSet::ALL {
        let mut p = params(K, 21, fs);
        // With zero residual weights a step's values are the polynomial core's.
        for c in p.centres.iter_mut() {
            c.w = [0.0; 4];
        }
        let model = PreparedModel::<f32, K>::new(&p).unwrap();
        let (mut a, mut b) = (StreamState::new(), StreamState::new());
        let mut ss = stream(21, 300);
        ss[40].dl_pm[1] = f32::NAN;
        for s in &ss {
            let mut psi_step = [0.0f32; K];
            let e = model.step_with(&mut a, s, |j, v| psi_step[j] = v);
            let mut psi = [-1.0f32; K];
            match model.core_and_activations(&mut b, s, &mut psi) {
                Some(v) => {
                    assert_eq!(v.map(f32::to_bits), e.values.map(f32::to_bits), "{fs:?}");
                    assert_eq!(psi.map(f32::to_bits), psi_step.map(f32::to_bits), "{fs:?}");
                }
                None => {
                    assert!(e.flags.contains(Flags::NON_FINITE));
                    assert_eq!(psi, [-1.0; K], "psi untouched");
                }
            }
            assert_eq!(a.latch_values(), b.latch_values());
        }
    }
}

/// The model's step over a state is the compensator's, bit for bit, and one model serves
/// several streams at once.
#[test]
fn one_model_steps_many_streams_as_many_compensators() {
    let p = memory_params(K, 23, FeatureSet::HysteresisAware);
    let model = PreparedModel::<f32, K>::new(&p).unwrap();
    let (x, y) = (irregular(23, 300), irregular(24, 300));
    let (mut cx, mut cy) = (Compensator::<f32, K>::new(&p).unwrap(), Compensator::<f32, K>::new(&p).unwrap());
    let (mut sx, mut sy) = (StreamState::new(), StreamState::new());
    for (a, b) in x.iter().zip(&y) {
        assert_eq!(bits(&model.step(&mut sx, a)), bits(&cx.step(a)));
        assert_eq!(bits(&model.step(&mut sy, b)), bits(&cy.step(b)));
        assert_eq!((&sx, &sy), (cx.state(), cy.state()));
    }
}

#[test]
fn a_stream_resumed_from_its_state_answers_as_the_whole_stream() {
    let p = params(K, 22, FeatureSet::HysteresisAware);
    let ss = stream(22, 400);
    let mut whole = Compensator::<f32, K>::new(&p).unwrap();
    let mut state = None;
    let mut expected = Vec::new();
    for (i, s) in ss.iter().enumerate() {
        if i == 250 {
            state = Some(*whole.state());
        }
        expected.push(bits(&whole.step(s)));
    }
    // Another model of the same parameters resumes at sample 250.
    let resumed = PreparedModel::<f32, K>::new(&p).unwrap();
    assert!(resumed.same_stream(whole.model()));
    let mut state = state.unwrap();
    for (s, want) in ss[250..].iter().zip(&expected[250..]) {
        assert_eq!(&bits(&resumed.step(&mut state, s)), want);
    }
    // A model with another dead band moves its latches differently.
    let mut q = p.clone();
    q.hyper.dead_band_pm *= 2.0;
    assert!(!PreparedModel::<f32, K>::new(&q).unwrap().same_stream(whole.model()));
}

#[test]
fn core_and_activations_include_the_memory_terms() {
    for fs in FeatureSet::ALL {
        let mut p = memory_params(K, 33, fs);
        for c in p.centres.iter_mut() {
            c.w = [0.0; 4];
        }
        let model = PreparedModel::<f32, K>::new(&p).unwrap();
        let (mut a, mut b) = (StreamState::new(), StreamState::new());
        let mut ss = irregular(33, 300);
        ss[50].t_s = f32::NAN;
        for s in &ss {
            let mut psi = [0.0f32; K];
            let e = model.step(&mut a, s);
            match model.core_and_activations(&mut b, s, &mut psi) {
                Some(v) => assert_eq!(v.map(f32::to_bits), e.values.map(f32::to_bits), "{fs:?}"),
                None => assert!(e.flags.contains(Flags::NON_FINITE)),
            }
            assert_eq!(a, b);
        }
    }
}

/// `activations` given the latches after a sample is `core_and_activations`' ψ bit for bit,
/// for the paper's shape (the step's specialised path) and every feature set.
fn activations_from_latches<F: fbg_shared::Real>() {
    for fs in FeatureSet::ALL {
        let p = memory_params(K, 37, fs);
        let model = PreparedModel::<F, K>::new(&p).unwrap();
        let mut live = StreamState::new();
        let mut ss: Vec<Sample<F>> = irregular(37, 300).iter().map(|s| s.cast::<F>()).collect();
        ss[40].t_s = F::from_f64(f64::NAN);
        ss[41].dl_pm[1] = F::from_f64(f64::INFINITY);
        for s in &ss {
            let (mut want, mut got) = ([F::ZERO; K], [F::ZERO; K]);
            let accepted = model.core_and_activations(&mut live, s, &mut want).is_some();
            assert_eq!(model.activations(s, &live.latch_values(), &mut got), accepted, "{fs:?}");
            if accepted {
                assert_eq!(got.map(|v| v.to_f64().to_bits()), want.map(|v| v.to_f64().to_bits()), "{fs:?}");
            }
        }
    }
}

#[test]
fn activations_from_the_latches_are_core_and_activations_psi() {
    activations_from_latches::<f32>();
    activations_from_latches::<f64>();
}

#[test]
fn advance_moves_the_memory_as_step_does() {
    let p = memory_params(K, 34, FeatureSet::HysteresisAware);
    let model = PreparedModel::<f32, K>::new(&p).unwrap();
    let (mut a, mut b) = (StreamState::new(), StreamState::new());
    let ss = irregular(34, 400);
    for s in &ss[..300] {
        model.step(&mut a, s);
        model.advance(&mut b, s);
        assert_eq!(a, b);
    }
    for s in &ss[300..] {
        assert_eq!(bits(&model.step(&mut a, s)), bits(&model.step(&mut b, s)));
    }
}

fn memory_resume<F: fbg_shared::Real>() {
    for fs in FeatureSet::ALL {
        let p = memory_model::<K>(K, 35, fs, short_provenance(), full_memory_spec());
        let ss: Vec<Sample<F>> = irregular(35, 1000).iter().map(|s| s.cast::<F>()).collect();
        let key =
            |e: &Estimate<F>| (e.values.map(|v| v.to_f64().to_bits()), e.band95.map(|v| v.to_f64().to_bits()), e.flags);
        let mut whole = Compensator::<F, K>::new(&p).unwrap();
        let mut state = None;
        let mut expected = Vec::new();
        for (i, s) in ss.iter().enumerate() {
            if i == 500 {
                state = Some(*whole.state());
            }
            expected.push(key(&whole.step(s)));
        }
        let state = state.unwrap();
        // The whole state, and its compact form put into a state that has run another stream:
        // both resume.
        let model = PreparedModel::<F, K>::new(&p).unwrap();
        assert!(model.same_stream(whole.model()));
        let mut used = StreamState::new();
        for s in ss.iter().rev().take(50) {
            model.step(&mut used, s);
        }
        let g = p.dims.gratings();
        let mut packed = vec![F::ZERO; fbg_shared::MemoryState::<F>::packed_len(g)];
        state.memory().pack(g, &mut packed).unwrap();
        model.resume_packed(&mut used, state.latches(), &packed).unwrap();
        for mut resumed in [state, used] {
            for (i, s) in ss.iter().enumerate().skip(500) {
                assert_eq!(key(&model.step(&mut resumed, s)), expected[i], "{fs:?} sample {i}");
            }
        }
    }
}

#[test]
fn a_stream_with_memory_resumed_from_its_state_answers_as_the_whole_stream() {
    memory_resume::<f32>();
    memory_resume::<f64>();
}

#[test]
fn same_stream_compares_the_memory_operators() {
    let p = memory_params(K, 36, FeatureSet::HysteresisAware);
    let c = PreparedModel::<f32, K>::new(&p).unwrap();
    let same = |q: &fbg_shared::ModelParams<f32, K>| PreparedModel::<f32, K>::new(q).unwrap().same_stream(&c);
    // Γ, B and the centres do not move the stream state.
    let mut q = p.clone();
    q.gamma[0][MEM_FIRST_ACTIVE] *= 2.0;
    q.poly[1][3] += 1.0;
    q.centres.truncate(3);
    assert!(same(&q));
    // The memory spec does.
    let changes: [fn(&mut MemorySpec<f32>); 5] = [
        |s| s.grating_tau_s[1] *= 2.0,
        |s| s.ambient_tau_s[2] = 0.0,
        |s| s.play_half_width_pm[0] = 3.0,
        |s| s.observer_lag_s = 45.0,
        |s| s.observer_row[3] = 0.5,
    ];
    for (i, f) in changes.into_iter().enumerate() {
        let mut q = p.clone();
        f(&mut q.memory);
        for (row, src) in q.gamma.iter_mut().zip(p.gamma.iter()) {
            for (k, g) in row.iter_mut().enumerate() {
                *g = if q.memory.term_active(&Dims::PAPER, k) { src[k] } else { 0.0 };
            }
        }
        assert!(!same(&q), "change {i}");
    }
    // No memory against memory (same dead band and feature set).
    let mut off = p.clone();
    off.memory = MemorySpec::off();
    off.gamma = [[0.0; MAX_MEMORY]; 4];
    assert!(!same(&off));
}

/// A packed memory state of the wrong length is refused and leaves the state as it was.
#[test]
fn resume_packed_refuses_a_wrong_length() {
    let p = memory_params(K, 41, FeatureSet::HysteresisAware);
    let model = PreparedModel::<f32, K>::new(&p).unwrap();
    let mut state = StreamState::new();
    for s in &irregular(41, 50) {
        model.step(&mut state, s);
    }
    let before = state;
    assert!(model.resume_packed(&mut state, Default::default(), &[0.0; 3]).is_err());
    assert_eq!(state, before);
}
