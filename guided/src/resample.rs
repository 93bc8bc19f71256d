//! Resampling: drawing the next generation's ancestors from the weighted particles.
//!
//! Both schemes can pick every particle with positive weight, the last one included:
//! the cumulative sums are compared against the positions scaled by their own final
//! value (not a separately summed total that rounding can leave above it), and an
//! index that runs off the end (impossible in exact arithmetic) is clamped to the
//! last particle with positive weight.

use super::Resampling;

/// Normalised weights from log-weights: exp(lw − max), with NaN and −∞ as weight 0.
/// When no weight is positive (all −∞ or NaN), every particle gets the same weight.
pub fn weights_from_log(lw: &[f64]) -> Vec<f64> {
    let max = lw.iter().copied().filter(|v| !v.is_nan()).fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        // All −∞ / NaN, or some +∞: +∞ particles share the weight, else uniform.
        if max == f64::INFINITY {
            return lw.iter().map(|&v| if v == f64::INFINITY { 1.0 } else { 0.0 }).collect();
        }
        return vec![1.0; lw.len()];
    }
    lw.iter().map(|&v| if v.is_nan() { 0.0 } else { (v - max).exp() }).collect()
}

/// Draws `m` ancestor indices from `weights` (non-negative; non-finite treated as 0)
/// using uniforms from `uniform` (each in [0, 1)). Returns them in ascending order.
/// With no positive weight, draws uniformly.
pub fn resample(scheme: Resampling, weights: &[f64], m: usize, uniform: &mut dyn FnMut() -> f64) -> Vec<usize> {
    let n = weights.len();
    if n == 0 || m == 0 {
        return Vec::new();
    }
    let mut cum = Vec::with_capacity(n);
    let mut acc = 0.0f64;
    let mut last_positive = None;
    for (i, &w) in weights.iter().enumerate() {
        if w.is_finite() && w > 0.0 {
            acc += w;
            last_positive = Some(i);
        }
        cum.push(acc);
    }
    let (cum, total, last) = match last_positive {
        Some(l) if acc > 0.0 && acc.is_finite() => (cum, acc, l),
        _ => ((1..=n).map(|i| i as f64).collect(), n as f64, n - 1),
    };
    // The index of the first cumulative sum above `x` (x in [0, total)).
    let find = |x: f64| -> usize { cum.partition_point(|&c| c <= x).min(last) };
    let mut out: Vec<usize> = match scheme {
        Resampling::Systematic => {
            let u0 = uniform();
            let mut out = Vec::with_capacity(m);
            let mut j = 0usize;
            for i in 0..m {
                let x = (u0 + i as f64) / m as f64 * total;
                while j < last && cum[j] <= x {
                    j += 1;
                }
                out.push(j);
            }
            out
        }
        Resampling::Multinomial => (0..m).map(|_| find(uniform() * total)).collect(),
    };
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn every_particle_can_be_drawn() {
        for scheme in [Resampling::Systematic, Resampling::Multinomial] {
            // Equal weights: every particle appears over a few draws, the last one included.
            let mut seen = [false; 10];
            let mut u = lcg(7);
            for _ in 0..50 {
                for i in resample(scheme, &[1.0; 10], 10, &mut u) {
                    seen[i] = true;
                }
            }
            assert!(seen.iter().all(|&s| s), "{scheme:?}: {seen:?}");
            // All the weight on the last particle: it is always drawn.
            let w = [0.0, 0.0, 0.0, 5.0];
            assert_eq!(resample(scheme, &w, 6, &mut u), vec![3; 6], "{scheme:?}");
            // All on the first.
            assert_eq!(resample(scheme, &[2.0, 0.0, 0.0], 4, &mut u), vec![0; 4]);
            // Tiny weights next to large ones are still reachable (last one tiny).
            let w = [1.0, 1.0, 1e-3];
            let hits = (0..20_000).flat_map(|_| resample(scheme, &w, 1, &mut u)).filter(|&i| i == 2).count();
            assert!(hits > 0, "{scheme:?}");
        }
    }

    #[test]
    fn the_uniform_extremes_reach_both_ends() {
        // u = 0 gives the first particle; u just below 1 the last, even when rounding
        // makes the summed weights differ from the exact total.
        let w = [0.1, 0.2, 0.3, 0.4, 0.1, 0.2, 0.3];
        for scheme in [Resampling::Systematic, Resampling::Multinomial] {
            let mut zero = || 0.0;
            assert_eq!(resample(scheme, &w, 1, &mut zero)[0], 0);
            let mut almost = || 1.0 - f64::EPSILON / 2.0;
            assert_eq!(resample(scheme, &w, 1, &mut almost)[0], 6, "{scheme:?}");
        }
        // Systematic with as many draws as particles and equal weights picks each once.
        let mut u = lcg(3);
        assert_eq!(resample(Resampling::Systematic, &[1.0; 5], 5, &mut u), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn proportions_follow_the_weights() {
        let w = [1.0, 3.0];
        let mut u = lcg(11);
        let picks = resample(Resampling::Multinomial, &w, 40_000, &mut u);
        let ones = picks.iter().filter(|&&i| i == 1).count() as f64 / 40_000.0;
        assert!((ones - 0.75).abs() < 0.01, "{ones}");
        let picks = resample(Resampling::Systematic, &w, 400, &mut u);
        assert_eq!(picks.iter().filter(|&&i| i == 1).count(), 300);
    }

    #[test]
    fn degenerate_weights() {
        let mut u = lcg(5);
        assert_eq!(resample(Resampling::Systematic, &[0.0, 0.0], 2, &mut u), vec![0, 1]);
        assert_eq!(resample(Resampling::Multinomial, &[f64::NAN, 1.0], 3, &mut u), vec![1, 1, 1]);
        assert!(resample(Resampling::Systematic, &[], 3, &mut u).is_empty());
        let w = weights_from_log(&[-1000.0, -1001.0, f64::NAN, f64::NEG_INFINITY]);
        assert_eq!(w[0], 1.0);
        assert!((w[1] - (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!((w[2], w[3]), (0.0, 0.0));
        assert_eq!(weights_from_log(&[f64::NEG_INFINITY; 3]), vec![1.0; 3]);
    }
}
