//! The fuzzer's generator (the workspace's one, [`mdg_vm::rng::Rng`]) and the hash
//! that names inputs.

pub use mdg_vm::rng::Rng;

/// FNV-1a, 64 bits: input names and signatures.
pub fn hash(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}
