//! What the bundle checks inside a SPIR-V module: the sizes of its arrays. A
//! shader declaring `float big[100000000];` compiles, and then the Vulkan driver
//! allocates it (lavapipe took 7.8 GB); [`largest_array`] finds such a type so the
//! compiler refuses the shader (E0502) and the verifier a bundle carrying one.

/// The most elements one array type may have (its length times those of the arrays
/// it holds): 65,536, a 256 KiB `float` array, far past what shaders declare.
pub const MAX_ARRAY_ELEMENTS: u64 = 65_536;

const OP_TYPE_ARRAY: u32 = 28;
const OP_CONSTANT: u32 = 43;
const OP_SPEC_CONSTANT: u32 = 50;

/// The element count of the largest array type in the module `words` (lengths
/// multiplied through nested arrays), or 0 when it has none. Malformed modules give
/// what could be read.
pub fn largest_array(words: &[u32]) -> u64 {
    let mut constants = std::collections::HashMap::new();
    let mut arrays: std::collections::HashMap<u32, u64> = std::collections::HashMap::new();
    let mut largest = 0u64;
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let op = words[i] & 0xFFFF;
        if count == 0 || i + count > words.len() {
            break;
        }
        let w = &words[i + 1..i + count];
        match op {
            // [result type, result id, value (low word first)]
            OP_CONSTANT | OP_SPEC_CONSTANT if w.len() >= 3 => {
                let v = u64::from(w[2]) | w.get(3).map_or(0, |hi| u64::from(*hi) << 32);
                constants.insert(w[1], v);
            }
            // [result id, element type, length id]
            OP_TYPE_ARRAY if w.len() >= 3 => {
                let len = constants.get(&w[2]).copied().unwrap_or(0);
                let inner = arrays.get(&w[1]).copied().unwrap_or(1);
                let n = len.saturating_mul(inner);
                arrays.insert(w[0], n);
                largest = largest.max(n);
            }
            _ => {}
        }
        i += count;
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A module header, then `instructions`.
    fn module(instructions: &[&[u32]]) -> Vec<u32> {
        let mut v = vec![0x0723_0203, 0x0001_0000, 0, 100, 0];
        for ins in instructions {
            v.push(((ins.len() as u32) << 16) | ins[0]);
            v.extend_from_slice(&ins[1..]);
        }
        v
    }

    #[test]
    fn nested_arrays_multiply_and_malformed_modules_do_not_panic() {
        // %int = 1; %c100 = 100; %c7 = 7; %a = float[100]; %b = %a[7]
        let m = module(&[
            &[OP_CONSTANT, 1, 10, 100],
            &[OP_CONSTANT, 1, 11, 7],
            &[OP_TYPE_ARRAY, 20, 5, 10],
            &[OP_TYPE_ARRAY, 21, 20, 11],
        ]);
        assert_eq!(largest_array(&m), 700);
        assert_eq!(largest_array(&m[..7]), 0);
        assert_eq!(largest_array(&[]), 0);
        let mut bad = m.clone();
        bad[5] = 0xFFFF_0000 | OP_TYPE_ARRAY;
        assert_eq!(largest_array(&bad), 0);
    }
}
