//! [`Memo`]: the last values of a pure function of a few numbers, by their bits (the
//! flat writer's linear maps and normals, which repeat from frame to frame).

/// A direct-mapped memo of a pure function of `N` numbers' bits (the last value
/// made for each of [`MEMO_SLOTS`] hash slots): the same values as calling the
/// function, found for the price of a hash and a comparison where keys repeat (on
/// the benchmark tree, 60 % of the frames' linear maps and nearly every normal).
pub(super) struct Memo<const N: usize, V> {
    slots: Vec<Option<([u32; N], V)>>,
}

/// The slots of a [`Memo`].
const MEMO_SLOTS: usize = 4096;

impl<const N: usize, V: Copy> Memo<N, V> {
    pub(super) fn new() -> Memo<N, V> {
        Memo { slots: vec![None; MEMO_SLOTS] }
    }

    /// `make()`'s value for the key `key` (whose bits are all `make` reads).
    #[inline(always)]
    pub(super) fn get(&mut self, key: [u32; N], make: impl FnOnce() -> V) -> V {
        let h = key.iter().fold(0x9e37_79b9u32, |h, &k| (h ^ k).wrapping_mul(0x2c1b_3c6d)).rotate_left(8);
        let slot = (h as usize) % MEMO_SLOTS;
        match self.slots.get(slot) {
            Some(Some((k, v))) if *k == key => *v,
            _ => {
                let v = make();
                if let Some(s) = self.slots.get_mut(slot) {
                    *s = Some((key, v));
                }
                v
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key gets its own function's value, however many keys share a slot,
    /// and repeated keys are found without calling the function.
    #[test]
    fn a_memo_gives_each_key_its_value() {
        let f = |k: [u32; 2]| k[0].wrapping_mul(31) ^ k[1].rotate_left(7);
        let mut memo: Memo<2, u32> = Memo::new();
        let mut calls = 0;
        for round in 0..3 {
            for i in 0..3 * MEMO_SLOTS as u32 {
                // (Few distinct keys in the last round: they stay in their slots.)
                let key = if round == 2 { [i % 64, 7] } else { [i, i / 3] };
                let v = memo.get(key, || {
                    calls += 1;
                    f(key)
                });
                assert_eq!(v, f(key), "key {key:?}");
            }
        }
        assert!(calls < 6 * MEMO_SLOTS + 64 + 64, "{calls} calls");
    }
}
