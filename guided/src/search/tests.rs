//! Tests of the search's schedules, store compaction and helpers.

use super::*;

#[test]
fn schedules_ramp_like_the_paper() {
    let o = SearchOptions {
        particles: (100, 15),
        generations: 100,
        heuristic_scale: 2.0,
        heuristic_fraction: 0.4,
        budget: None,
        resampling: Resampling::Systematic,
        seed: 0,
        threads: None,
        parallel_min: PARALLEL_MIN_PARTICLES,
        clock: None,
        cancel: None,
        choice: ModelChoice::default(),
    };
    assert_eq!(o.particles_at(0), 100);
    assert_eq!(o.particles_at(99), 15);
    assert_eq!(o.scheduled_steps(), 5750);
    assert_eq!(o.heuristic_at(0), 2.0);
    assert!((o.heuristic_at(20) - 1.0).abs() < 1e-12);
    assert_eq!(o.heuristic_at(40), 0.0);
    assert_eq!(o.heuristic_at(99), 0.0);
}

#[test]
fn compaction_keeps_each_referenced_call_once_and_rewrites_the_references() {
    use mdg_vm::eval::State;
    let call = |rule: u32| Pending {
        call: Call { rule, state: State { color: [1.0; 4], ..State::start(0.0) }, depth: rule },
        near: None,
    };
    // Segment 0 holds calls 0..4, segment 1 calls 10..13.
    let frozen = vec![(0..4).map(call).collect::<Vec<_>>(), (10..13).map(call).collect()];
    let at = |seg: u64, i: u64| (seg << 32) | i;
    let particle = |refs: &[(u64, f64)]| Particle {
        history: None,
        pending: refs.iter().map(|&(at, h)| PRef { at, h }).collect(),
        counts: Vec::new(),
        cost: Cost::default(),
        score: 0.0,
    };
    // Two particles sharing call (1, 2); calls (0, 0), (0, 2), (1, 0) unreferenced.
    let mut ps = vec![particle(&[(at(1, 2), 0.5), (at(0, 1), 0.25)]), particle(&[(at(0, 3), 1.0), (at(1, 2), 0.5)])];
    let seg = compact(&frozen, &mut ps);
    let rules: Vec<u32> = seg.iter().map(|p| p.call.rule).collect();
    assert_eq!(rules, vec![12, 1, 3]);
    let refs: Vec<Vec<(u64, f64)>> = ps.iter().map(|p| p.pending.iter().map(|r| (r.at, r.h)).collect()).collect();
    assert_eq!(refs, vec![vec![(0, 0.5), (1, 0.25)], vec![(2, 1.0), (0, 0.5)]]);
    // Read back through a store whose only frozen segment is the new one.
    let store = Store { frozen: std::slice::from_ref(&seg), id: u32::MAX, local: &mut Vec::new() };
    assert_eq!(store.get(ps[1].pending[0].at).call.rule, 3);
}

#[test]
fn argmin_takes_the_first_minimum() {
    assert_eq!(argmin(&[3.0, 1.0, 1.0, 2.0]), 1);
    assert_eq!(argmin(&[f64::NAN, 5.0]), 1);
    assert_eq!(argmin(&[-1.0]), 0);
}
