//! [`Memo`]: the last values of a pure function of a few numbers, by their bits (the
//! flat writer's linear maps and normals, which repeat from frame to frame).

/// A direct-mapped memo of a pure function of `N` words (the last value made for
/// each of [`MEMO_SLOTS`] hash slots): the same values as calling the function,
/// found for the price of a hash and a comparison where keys repeat. Keys are
/// 64-bit words (two `f32`s' bits each, see [`pair`]): half the words to hash and
/// compare.
pub(super) struct Memo<const N: usize, V> {
    slots: Vec<Slot<N, V>>,
    /// The slot is the hash's top `64 - shift` bits.
    shift: u32,
    /// Misses since the slots last grew: a memo starts with [`FIRST_SLOTS`] and
    /// grows four-fold (emptied: it is a cache) each time it misses twice as often
    /// as it has slots, up to [`MEMO_SLOTS`]. A file of a few instances then costs
    /// a few kilobytes, not the ~600 KB of the full table zeroed.
    misses: usize,
}

/// A slot of a [`Memo`]: a key and its value, once `full`.
#[derive(Clone, Copy)]
struct Slot<const N: usize, V> {
    full: bool,
    key: [u64; N],
    value: V,
}

/// Two `f32`s' bits as one key word.
#[inline(always)]
pub(super) fn pair(a: f32, b: f32) -> u64 {
    u64::from(a.to_bits()) | u64::from(b.to_bits()) << 32
}

/// The most slots of a [`Memo`].
const MEMO_SLOTS: usize = 4096;
/// The slots a [`Memo`] starts with.
const FIRST_SLOTS: usize = 64;

impl<const N: usize, V: Copy + Default> Memo<N, V> {
    pub(super) fn new() -> Memo<N, V> {
        Memo::with_slots(FIRST_SLOTS)
    }

    fn with_slots(n: usize) -> Memo<N, V> {
        Memo {
            slots: vec![Slot { full: false, key: [0; N], value: V::default() }; n],
            shift: 64 - n.trailing_zeros(),
            misses: 0,
        }
    }

    /// Four times the slots, empty.
    #[cold]
    #[inline(never)]
    fn grow(&mut self) {
        *self = Memo::with_slots((self.slots.len() * 4).min(MEMO_SLOTS));
    }

    /// `make()`'s value for the key `key` (whose bits are all `make` reads).
    #[inline(always)]
    pub(super) fn get(&mut self, key: [u64; N], make: impl FnOnce() -> V) -> V {
        *self.get_ref(key, make)
    }

    /// [`Memo::get`] without copying the value out.
    #[inline(always)]
    pub(super) fn get_ref(&mut self, key: [u64; N], make: impl FnOnce() -> V) -> &V {
        // (A 64-bit multiplicative hash whose high bits mix every word's bits. The
        // slot is taken from them: the low bits of the old 32-bit hash, taken
        // modulo the slots, sent the tree's frames to few slots.)
        let h = key.iter().fold(0x9e37_79b9_7f4a_7c15u64, |h, &k| (h ^ k).wrapping_mul(0x2c1b_3c6d_d1b5_4a33));
        let slot = (h >> self.shift) as usize;
        // (The top bits index the slots: in range. The keys are compared word by
        // word, without branches: no call to `bcmp`.)
        let s = &self.slots[slot];
        let same = s.key.iter().zip(&key).fold(0, |d, (a, b)| d | (a ^ b)) == 0;
        if !(s.full && same) {
            self.misses += 1;
            if self.misses > 2 * self.slots.len() && self.slots.len() < MEMO_SLOTS {
                self.grow();
                return self.get_ref(key, make);
            }
            // (The value made where it is kept: no copy of the slot.)
            let s = &mut self.slots[slot];
            s.value = missed(make);
            (s.full, s.key) = (true, key);
        }
        &self.slots[slot].value
    }
}

/// A memo's miss, out of the hit's way.
#[cold]
#[inline(never)]
fn missed<V>(make: impl FnOnce() -> V) -> V {
    make()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key gets its own function's value, however many keys share a slot,
    /// and repeated keys are found without calling the function.
    #[test]
    fn a_memo_gives_each_key_its_value() {
        let f = |k: [u64; 2]| k[0].wrapping_mul(31) ^ k[1].rotate_left(7);
        let mut memo: Memo<2, u64> = Memo::new();
        let mut calls = 0;
        for round in 0..3 {
            for i in 0..3 * MEMO_SLOTS as u64 {
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
        // It grew to its most slots on the way (and started small).
        assert_eq!(memo.slots.len(), MEMO_SLOTS);
        assert_eq!(Memo::<2, u64>::new().slots.len(), FIRST_SLOTS);
        // An empty slot holds no key, not even the zero key (its value is the
        // default, not the function's).
        let mut fresh: Memo<2, u64> = Memo::new();
        assert_eq!(fresh.get([0, 0], || 7), 7);
    }
}
