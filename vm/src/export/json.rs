//! The JSON inspection dump: VERTEX geometry, pen lines, instance placements and the
//! run's statistics, for tests and tools.

use serde::Serialize;

use super::checked_triangles;
use crate::output::{Output, Polyline, Stats};

/// The dump's top-level object.
#[derive(Serialize)]
struct Dump<'a> {
    vertices: &'a [[f32; 3]],
    triangles: Vec<[u32; 3]>,
    lines: &'a [Polyline],
    instances: Vec<DumpInstance<'a>>,
    stats: &'a Stats,
}

/// One instance: its drawable name, position (the transform's translation) and scale.
#[derive(Serialize)]
struct DumpInstance<'a> {
    name: &'a str,
    position: [f32; 3],
    scale: f32,
}

/// Appends the inspection dump of `out` as one line of JSON:
/// `{"vertices": [[x,y,z],…], "triangles": [[i,j,k],…], "lines": [{"namespace", "points", "bones"?}],
/// "instances": [{"name", "position", "scale"}], "stats": {…}}`.
/// A line's `bones` (the bone of each point) is present only when one is animated.
/// Vertices and triangles are only [`Output::mesh`] (the `VERTEX` geometry), with the
/// oriented (mirror-corrected) winding. Floats are printed as the shortest decimal that
/// reads back as the same f32; non-finite values become `null`.
pub fn write_json(out: &Output, buf: &mut Vec<u8>) -> Result<(), String> {
    let dump = Dump {
        vertices: &out.mesh.positions,
        triangles: checked_triangles(&out.mesh, "VERTEX mesh")?,
        lines: &out.lines,
        instances: out
            .instances
            .iter()
            .map(|i| DumpInstance { name: &i.name, position: i.transform.w_axis.truncate().to_array(), scale: i.scale })
            .collect(),
        stats: &out.stats,
    };
    serde_json::to_writer(&mut *buf, &dump).map_err(|e| format!("JSON dump: {e}"))?;
    buf.push(b'\n');
    Ok(())
}

#[cfg(test)]
mod tests {
    use serde_json::Value;

    use super::*;
    use crate::export::tests::sample_output;

    #[test]
    fn dump_shape() {
        let out = sample_output();
        let mut b = Vec::new();
        write_json(&out, &mut b).expect("writes");
        let v: Value = serde_json::from_slice(&b).expect("valid JSON");
        assert_eq!(v["vertices"].as_array().map(Vec::len), Some(24));
        assert_eq!(v["triangles"].as_array().map(Vec::len), Some(12));
        let t = out.mesh.triangles[0];
        assert_eq!(v["triangles"][0], serde_json::json!([t[0], t[2], t[1]]));
        assert_eq!(v["lines"][0]["points"][2], serde_json::json!([1.0, 1.0, 2.0]));
        assert_eq!(v["instances"][0], serde_json::json!({"name": "CUBE", "position": [3.0, 0.0, 0.0], "scale": 1.0}));
        assert_eq!(v["stats"]["rule_calls"], 5);
        assert_eq!(v["stats"]["warnings"][0], "maxdepth reached");
        // Shortest f32 form: 0.1 prints as 0.1, not 0.10000000149011612.
        let mut out = Output::default();
        out.mesh.push_vertex(glam::Vec3::new(0.1, 0.2, 0.3), glam::Vec3::Z, [1.0; 4], [0.0; 4], 0);
        let mut b = Vec::new();
        write_json(&out, &mut b).expect("writes");
        let text = String::from_utf8(b).expect("utf8");
        assert!(text.starts_with("{\"vertices\":[[0.1,0.2,0.3]],\"triangles\":[]"), "{text}");
    }
}
