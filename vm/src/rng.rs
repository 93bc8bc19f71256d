//! The one small deterministic generator (xorshift64*) of the tests, the fuzzer and
//! the soaks: a run is reproduced by its seed. (The evaluator's random stream is
//! PCG-64, in `eval`; this one never feeds a model.)

/// xorshift64* state (never zero: `Rng(0)` stays at 0, so build one from a seed with
/// [`Rng::new`], or from a non-zero state directly).
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// A generator from a seed (any value; zero is remapped).
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15 | 1)
    }

    /// The next 64 random bits.
    pub fn bits(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.bits() % n.max(1) as u64) as usize
    }

    /// True with probability 1/n.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    /// A random element (`None` for an empty slice).
    pub fn pick<'a, T>(&mut self, v: &'a [T]) -> Option<&'a T> {
        if v.is_empty() {
            None
        } else {
            v.get(self.below(v.len()))
        }
    }

    /// A number in `lo..=hi`, biased towards small values (half the time from the
    /// low eighth of the range).
    pub fn small(&mut self, lo: u64, hi: u64) -> u64 {
        let span = hi.saturating_sub(lo).saturating_add(1);
        let span = if self.one_in(2) { (span / 8).max(1) } else { span };
        lo + self.bits() % span
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    #[test]
    fn a_seed_gives_the_same_stream_and_zero_is_remapped() {
        let (mut a, mut b) = (Rng::new(7), Rng::new(7));
        let xs: Vec<u64> = (0..8).map(|_| a.bits()).collect();
        assert_eq!(xs, (0..8).map(|_| b.bits()).collect::<Vec<_>>());
        assert!(xs.windows(2).all(|w| w[0] != w[1]));
        assert_ne!(Rng::new(0).bits(), 0);
        // The xorshift64* reference: state 1 gives 0x47E4CE4B896CDD1D first.
        assert_eq!(Rng(1).bits(), 0x47E4_CE4B_896C_DD1D);
        let mut r = Rng::new(3);
        assert!((0..100).all(|_| r.below(10) < 10) && r.below(0) == 0);
        assert_eq!(r.pick::<u8>(&[]), None);
        assert!((0..100).all(|_| (5..=9).contains(&r.small(5, 9))));
    }
}
