//! The JSON inspection dump: VERTEX geometry, pen lines, instance placements and the
//! run's statistics, for tests and tools.

use serde::Serialize;

use super::{finite, finite3, local_oriented, ExportError};
use mdg_vm::output::{Groups, Output};

/// One pen line, its points written as [`finite3`] writes them.
#[derive(Serialize)]
struct DumpLine<'a> {
    namespace: &'a str,
    points: Vec<[f32; 3]>,
    #[serde(skip_serializing_if = "<[u32]>::is_empty")]
    bones: &'a [u32],
}

/// One isosurface instance: its drawable name, position (the transform's
/// translation) and scale.
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
/// Vertices and triangles are the `VERTEX` geometry (prototype instances expanded
/// where they were made), with the oriented (mirror-corrected) winding; `instances`
/// are the isosurface placements. Floats are printed as the shortest decimal that
/// reads back as the same f32; a coordinate or scale that is not a finite number is
/// written as 0, as every other format writes it (the run warns about them).
pub fn write_json(out: &Output, buf: &mut Vec<u8>) -> Result<(), ExportError> {
    write_json_to(out, buf)
}

/// Writes the dump to `w`, expanding prototype instances as it goes.
pub fn write_json_to(out: &Output, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    let io = ExportError::Io;
    let js = ExportError::Json;
    // Every triangle is checked before anything is written.
    out.for_each_piece::<ExportError>(Groups::VERTEX, |piece| {
        piece.triangles.clone().try_for_each(|k| local_oriented(piece, k).map(|_| ()))
    })?;
    w.write_all(b"{\"vertices\":[").map_err(io)?;
    let mut first = true;
    out.for_each_piece::<ExportError>(Groups::VERTEX, |piece| {
        for p in &piece.mesh.positions[piece.vertices.clone()] {
            if !std::mem::take(&mut first) {
                w.write_all(b",").map_err(io)?;
            }
            serde_json::to_writer(&mut *w, &finite3(*p)).map_err(js)?;
        }
        Ok(())
    })?;
    w.write_all(b"],\"triangles\":[").map_err(io)?;
    let mut first = true;
    out.for_each_piece::<ExportError>(Groups::VERTEX, |piece| {
        for k in piece.triangles.clone() {
            let Some(t) = piece.oriented(k) else { continue };
            if !std::mem::take(&mut first) {
                w.write_all(b",").map_err(io)?;
            }
            serde_json::to_writer(&mut *w, &t).map_err(js)?;
        }
        Ok(())
    })?;
    w.write_all(b"],\"lines\":").map_err(io)?;
    let lines: Vec<DumpLine> = out
        .lines
        .iter()
        .map(|l| DumpLine {
            namespace: &l.namespace,
            points: l.points.iter().map(|p| finite3(*p)).collect(),
            bones: &l.bones,
        })
        .collect();
    serde_json::to_writer(&mut *w, &lines).map_err(js)?;
    w.write_all(b",\"instances\":").map_err(io)?;
    let instances: Vec<DumpInstance> = out
        .instances
        .iter()
        .filter_map(|i| {
            let shared = out.shared(&i).filter(|s| !s.is_prototype())?;
            Some(DumpInstance {
                name: &shared.name,
                position: finite3(out.instance_transform(&i).w_axis.truncate().to_array()),
                scale: finite(out.instance_scale(&i)),
            })
        })
        .collect();
    serde_json::to_writer(&mut *w, &instances).map_err(js)?;
    w.write_all(b",\"stats\":").map_err(io)?;
    serde_json::to_writer(&mut *w, &out.stats).map_err(js)?;
    w.write_all(b"}\n").map_err(io)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use serde_json::Value;

    use super::*;
    use crate::tests::sample_output;

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
