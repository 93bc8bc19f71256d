//! The output floor of the tree workload (issue 10): the time to fill the buffers an
//! evaluation must produce for N `VERTEX` vertices (position, normal, colour, one
//! triangle per three vertices, the mirrored flag), through [`Mesh::push_vertex`] and
//! [`Mesh::push_triangle`] exactly as the evaluator fills them, with no transform
//! work at all. No evaluator that materialises this mesh can be faster, so
//! `cfdg time / this time` bounds the ratio any such evaluator reaches.
//!
//! ```sh
//! cargo run --release -p mdg-vm --example output_floor -- [VERTICES] [RUNS]
//! ```
//! Prints the median over RUNS (default 5) runs in milliseconds on its last line.

use glam::Vec3;
use mdg_vm::output::Mesh;
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(6_291_450);
    let runs: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(5).max(1);
    let mut ms = Vec::with_capacity(runs);
    for _ in 0..runs {
        let t = Instant::now();
        let mut m = Mesh::default();
        for i in 0..n {
            let f = i as f32;
            let k = m.push_vertex(Vec3::new(f, 0.5 * f, 1.0), Vec3::Z, [1.0; 4], [0.0; 4], 0) + 1;
            if k % 3 == 0 {
                m.push_triangle([k - 3, k - 2, k - 1], false);
            }
        }
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        // Keep the work observable so it cannot be optimised away.
        assert_eq!(m.n_vertices(), n as usize);
    }
    ms.sort_by(f64::total_cmp);
    let med = if runs % 2 == 1 { ms[runs / 2] } else { (ms[runs / 2 - 1] + ms[runs / 2]) / 2.0 };
    println!("{med:.1}");
}
