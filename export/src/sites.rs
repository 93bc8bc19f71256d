//! The editor's sites in a `.glb` ([`mdg_vm::output::Sites`], `mdg-run --sites`):
//! which rule and line made each triangle and instance, at which derivation depth
//! and of which node of the recorded derivation, in the glTF `extras` three.js
//! hands to the page as `userData.mdg_sites`:
//!
//! * on a triangle primitive (the `VERTEX` triangles, the sweeps, the baked
//!   instances): `{"runs": [[first triangle, site, depth, node], …], "sites": […]}`;
//! * on the primitive of an `EXT_mesh_gpu_instancing` node, the same with
//!   `"instances": true`: `first` counts the node's instances, in their order;
//! * on the node of one placed instance, one run from triangle 0.
//!
//! `sites` is `[{"rule", "file", "line"}, …]`: the whole table in each primitive's,
//! the one site in a node's.

use mdg_vm::output::{expand_isosurface, Instance, Mesh, Output, Site};

/// `{"mdg_sites": {"runs", "sites"}}` of runs over triangles, or `None` without runs.
pub(super) fn extras(runs: &[[u32; 4]], sites: &[Site]) -> Option<serde_json::Value> {
    (!runs.is_empty()).then(|| serde_json::json!({ "mdg_sites": { "runs": runs, "sites": sites } }))
}

/// The runs of a primitive made of instances `order` of `out` (by index into
/// [`Output::instances`]), one after the other, each `size(k)` items long (its
/// triangles, or 1 for an instanced node): a run wherever the site, depth or
/// node changes. Empty when the output has no instance sites.
fn runs_of(out: &Output, order: impl IntoIterator<Item = u32>, size: impl Fn(usize) -> u32) -> Vec<[u32; 4]> {
    let mut runs: Vec<[u32; 4]> = Vec::new();
    if out.sites.instance_runs.is_empty() {
        return runs;
    }
    let mut first = 0u32;
    for (k, i) in order.into_iter().enumerate() {
        if let Some(r) = out.sites.run_of_instance(i) {
            if runs.last().is_none_or(|l| l[1..] != r[1..]) {
                runs.push([first, r[1], r[2], r[3]]);
            }
        }
        first += size(k);
    }
    runs
}

/// The extras of an instanced node's primitive drawing instances `order`.
pub(super) fn instanced_extras(out: &Output, order: impl IntoIterator<Item = u32>) -> Option<serde_json::Value> {
    let runs = runs_of(out, order, |_| 1);
    let mut v = extras(&runs, &out.sites.sites)?;
    v["mdg_sites"]["instances"] = serde_json::Value::Bool(true);
    Some(v)
}

/// The extras of the node placing instance `i` alone: its one run, with a table of
/// its one site (there may be thousands of such nodes).
pub(super) fn node_extras(out: &Output, i: u32) -> Option<serde_json::Value> {
    let r = out.sites.run_of_instance(i)?;
    let site = out.sites.sites.get(r[1] as usize)?;
    extras(&[[0, 0, r[2], r[3]]], std::slice::from_ref(site))
}

/// Instances baked into one mesh, with the first triangle of each, for its runs.
#[derive(Default)]
pub(super) struct Baked {
    pub(super) mesh: Mesh,
    /// `(first triangle, instance)` per baked instance.
    from: Vec<(u32, u32)>,
}

impl Baked {
    /// Bakes instance `i` (`inst`, placing `shared`).
    pub(super) fn bake(&mut self, shared: &Mesh, out: &Output, i: u32, inst: &Instance) {
        self.from.push((self.mesh.triangles.len() as u32, i));
        expand_isosurface(&mut self.mesh, shared, out, inst);
    }

    /// The extras of the baked primitive.
    pub(super) fn extras(&self, out: &Output) -> Option<serde_json::Value> {
        let order: Vec<u32> = self.from.iter().map(|&(_, i)| i).collect();
        let end = self.mesh.triangles.len() as u32;
        let size = |k: usize| self.from.get(k + 1).map_or(end, |n| n.0) - self.from[k].0;
        extras(&runs_of(out, order.iter().copied(), size), &out.sites.sites)
    }
}

#[cfg(test)]
mod tests {
    use super::super::glb::{tests::parse_glb, write_glb, write_glb_with, GlbOptions};
    use super::super::tests::sample_output;
    use super::*;
    use serde_json::{json, Value};

    fn site(rule: &str, line: u32) -> Site {
        Site { rule: rule.into(), file: "a.mdg".into(), line }
    }

    /// The extras of the node named `name` and of its mesh's first primitive.
    fn extras_of(json: &Value, name: &str) -> Vec<(Value, Value)> {
        let nodes = json["nodes"].as_array().expect("nodes");
        nodes
            .iter()
            .filter(|n| n["name"] == name)
            .map(|n| {
                let prim = &json["meshes"][n["mesh"].as_u64().expect("mesh") as usize]["primitives"][0];
                (n.get("extras").cloned().unwrap_or(Value::Null), prim.get("extras").cloned().unwrap_or(Value::Null))
            })
            .collect()
    }

    #[test]
    fn sites_go_in_the_extras_of_the_geometry_sweeps_and_instances() {
        let mut out = sample_output();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        // No sites unless recorded.
        assert!(!parse_glb(&b).0.to_string().contains("mdg_sites"));

        out.sites = mdg_vm::output::Sites {
            runs: vec![[0, 0, 1, 0], [4, 1, 2, 3]],
            sweep_runs: vec![[0, 1, 2, 3]],
            instance_runs: vec![[0, 0, 1, 0], [2, 1, 5, 4]],
            sites: vec![site("A", 3), site("ns.B", 7)],
        };
        let table = json!([{"rule": "A", "file": "a.mdg", "line": 3}, {"rule": "ns.B", "file": "a.mdg", "line": 7}]);
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        let geometry = json["nodes"].as_array().expect("nodes").iter().find(|n| n["name"] == "geometry").cloned();
        let prims = &json["meshes"][geometry.expect("geometry")["mesh"].as_u64().expect("mesh") as usize]["primitives"];
        // The VERTEX triangles, then the sweeps.
        assert_eq!(prims[0]["extras"], json!({"mdg_sites": {"runs": [[0, 0, 1, 0], [4, 1, 2, 3]], "sites": table}}));
        assert_eq!(prims[1]["extras"], json!({"mdg_sites": {"runs": [[0, 1, 2, 3]], "sites": table}}));
        assert_eq!(out.sites.of(3).map(|s| s.line), Some(3));
        assert_eq!(out.sites.of(4).map(|s| s.rule.as_str()), Some("ns.B"));
        // One node per instance, each with its own site (the mesh is shared).
        let nodes = extras_of(&json, "CUBE");
        assert_eq!(nodes.len(), 3);
        // (Each with its one site.)
        let one = |k: usize| json!([table[k]]);
        assert_eq!(nodes[0].0, json!({"mdg_sites": {"runs": [[0, 0, 1, 0]], "sites": one(0)}}));
        assert_eq!(nodes[0].1, Value::Null);
        assert_eq!(nodes[1].0, nodes[0].0);
        // (The third is mirrored: a mesh of its own, a node like the others.)
        assert_eq!(nodes[2].0, json!({"mdg_sites": {"runs": [[0, 0, 5, 4]], "sites": one(1)}}));

        // GPU instancing: runs over the node's instances.
        let mut b = Vec::new();
        write_glb_with(&out, &GlbOptions { instances: true }, &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        let plain = extras_of(&json, "CUBE");
        assert_eq!(plain.len(), 1, "{json}");
        assert_eq!(plain[0].1, json!({"mdg_sites": {"runs": [[0, 0, 1, 0]], "sites": table, "instances": true}}));
    }

    #[test]
    fn baked_instances_get_runs_over_their_triangles() {
        let mut out = sample_output();
        out.sites.instance_runs = vec![[0, 0, 1, 0], [1, 1, 2, 0], [2, 1, 2, 0]];
        out.sites.sites = vec![site("A", 3), site("B", 4)];
        let shared = out.shared_meshes[0].mesh.clone();
        let mut baked = Baked::default();
        for i in [0u32, 1, 2] {
            let inst = out.instances.get(i as usize).expect("an instance");
            baked.bake(&shared, &out, i, &inst);
        }
        let n = shared.triangles.len() as u32;
        assert_eq!(baked.mesh.triangles.len() as u32, 3 * n);
        let v = baked.extras(&out).expect("extras");
        // Instances 1 and 2 have one site and depth: one run.
        assert_eq!(v["mdg_sites"]["runs"], json!([[0, 0, 1, 0], [n, 1, 2, 0]]));
        out.sites.instance_runs.clear();
        assert!(baked.extras(&out).is_none());
    }
}
