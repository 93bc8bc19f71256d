//! Skins, bone nodes, animation channels and the camera of a `.glb`.

use super::*;

/// A frame's TRS as glTF arrays: translation, unit rotation (x, y, z, w) and a uniform
/// scale (see [`trs`]); non-finite values become 0 (the rotation the identity).
pub(super) fn gltf_trs(f: &Frame) -> ([f32; 3], [f32; 4], f32) {
    let (t, r, s) = trs(f);
    let r = if r.is_finite() { r.to_array() } else { [0.0, 0.0, 0.0, 1.0] };
    (finite3(t.to_array()), r, finite(s))
}

impl<'a> Builder<'a> {
    /// The skin whose joints are the bone nodes (created once), with identity inverse
    /// bind matrices: the vertices are stored at rest, where every bone is the
    /// identity (assimp, among others, needs them written out).
    pub(super) fn skin(&mut self, bone_nodes: &[u32]) -> u32 {
        if self.root.skins.is_empty() {
            let identity = Mat4::IDENTITY.to_cols_array();
            let bytes: Vec<u8> = (0..bone_nodes.len()).flat_map(|_| identity).flat_map(f32::to_le_bytes).collect();
            let view = self.view_for(&bytes, None);
            let inverse_bind_matrices = Some(self.accessor(Accessor {
                buffer_view: view,
                component_type: FLOAT,
                count: bone_nodes.len(),
                kind: "MAT4",
                min: None,
                max: None,
                ..Accessor::default()
            }));
            self.root.skins.push(Skin {
                inverse_bind_matrices,
                joints: bone_nodes.to_vec(),
                skeleton: bone_nodes.first().copied(),
            });
        }
        0
    }

    /// JOINTS_0 (u16, the bone) and WEIGHTS_0 ((1, 0, 0, 0)) for `n` vertices.
    pub(super) fn skin_attributes(
        &mut self,
        attributes: &mut BTreeMap<&'static str, u32>,
        n: usize,
        bone: impl Fn(usize) -> u32,
    ) {
        let joints: Vec<u8> = (0..n)
            .flat_map(|i| [(bone(i).min(u16::MAX as u32) as u16).to_le_bytes(), [0; 2], [0; 2], [0; 2]])
            .flatten()
            .collect();
        let view = self.view(&joints, ARRAY_BUFFER);
        let j = self.accessor(Accessor {
            buffer_view: view,
            component_type: UNSIGNED_SHORT,
            count: n,
            kind: "VEC4",
            min: None,
            max: None,
            ..Accessor::default()
        });
        attributes.insert("JOINTS_0", j);
        let weights = vec![[1.0, 0.0, 0.0, 0.0]; n];
        attributes.insert("WEIGHTS_0", self.vec4(&weights));
    }

    /// An animation sampler's input: `count` keyframe times i/fps, with bounds.
    pub(super) fn key_times(&mut self, fps: f32, count: usize) -> u32 {
        if let Some(&a) = self.times.get(&(fps.to_bits(), count)) {
            return a;
        }
        let times: Vec<f32> = (0..count).map(|i| (i as f64 / fps as f64) as f32).collect();
        let bytes: Vec<u8> = times.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view_for(&bytes, None);
        let (lo, hi) = (times.first().copied().unwrap_or(0.0), times.last().copied().unwrap_or(0.0));
        let a = self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count,
            kind: "SCALAR",
            min: Some(vec![lo]),
            max: Some(vec![hi]),
            ..Accessor::default()
        });
        self.times.insert((fps.to_bits(), count), a);
        a
    }

    /// An animation sampler's output: float vectors of `kind` ("VEC3", "VEC4").
    pub(super) fn key_values(&mut self, data: &[f32], width: usize, kind: &'static str) -> u32 {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view_for(&bytes, None);
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: data.len() / width,
            kind,
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// Adds a STEP sampler reading `input`/`output` and a channel to `node`'s `path`.
    pub(super) fn channel(&mut self, a: &mut GAnimation, input: u32, output: u32, node: u32, path: &'static str) {
        a.samplers.push(Sampler { input, output, interpolation: "STEP" });
        a.channels.push(Channel { sampler: a.samplers.len() as u32 - 1, target: Target { node, path } });
    }

    /// Translation, rotation and scale channels for `node` from one frame per keyframe.
    pub(super) fn trs_channels(
        &mut self,
        a: &mut GAnimation,
        input: u32,
        frames: &[Frame],
        node: u32,
        with_scale: bool,
    ) {
        let (mut t, mut r, mut s) = (Vec::new(), Vec::new(), Vec::new());
        let mut prev: Option<[f32; 4]> = None;
        for f in frames {
            let (ft, mut fr, fs) = gltf_trs(f);
            // q and −q are the same rotation; keep consecutive keys on one side.
            if let Some(p) = prev {
                if p[0] * fr[0] + p[1] * fr[1] + p[2] * fr[2] + p[3] * fr[3] < 0.0 {
                    fr = fr.map(|x| -x);
                }
            }
            prev = Some(fr);
            t.extend(ft);
            r.extend(fr);
            s.extend([fs; 3]);
        }
        let out_t = self.key_values(&t, 3, "VEC3");
        self.channel(a, input, out_t, node, "translation");
        let out_r = self.key_values(&r, 4, "VEC4");
        self.channel(a, input, out_r, node, "rotation");
        if with_scale {
            let out_s = self.key_values(&s, 3, "VEC3");
            self.channel(a, input, out_s, node, "scale");
        }
    }

    /// One node per bone, nested like the bones, each with its pose at t = 0 as
    /// static TRS; returns the node of every bone (index = bone).
    pub(super) fn bone_nodes(&mut self, anim: &Animation) -> Vec<u32> {
        let mut nodes = Vec::with_capacity(anim.bones.len());
        for (b, bone) in anim.bones.iter().enumerate() {
            let name = if b == 0 { "root".to_string() } else { format!("bone {b} {}", bone.rule) };
            let mut node = Node { name: Some(name), ..Node::default() };
            if b != 0 {
                let (t, r, s) = gltf_trs(&anim.local(b, 0));
                node.translation = Some(t);
                node.rotation = Some(r);
                node.scale = Some([s; 3]);
            }
            let n = self.push_node(node);
            if b != 0 {
                if let Some(&p) = nodes.get(bone.parent as usize) {
                    let parent: u32 = p;
                    self.root.nodes[parent as usize].children.push(n);
                }
            }
            nodes.push(n);
        }
        nodes
    }

    /// Channels for every bone that moves within `duration`: keyframe i at i/fps for
    /// i = 0..=⌊duration·fps⌋, the bone's local transform at frame i.
    pub(super) fn bone_channels(&mut self, anim: &Animation, bone_nodes: &[u32], a: &mut GAnimation) {
        for (b, bone) in anim.bones.iter().enumerate().skip(1) {
            let Some(&node) = bone_nodes.get(b) else { continue };
            if !(bone.fps > 0.0 && bone.fps.is_finite()) {
                continue;
            }
            let n = frames_needed(anim.duration as f64, bone.fps).min(mdg_vm::anim::MAX_TRACK_FRAMES);
            let frames: Vec<Frame> = (0..n as u64).map(|i| anim.local(b, i)).collect();
            if n < 2 || frames.iter().all(|f| *f == frames[0]) {
                continue;
            }
            let input = self.key_times(bone.fps, n);
            self.trs_channels(a, input, &frames, node, true);
        }
    }

    /// Camera 0 and its node (static pose at t = 0, animated when it moves); returns
    /// the node.
    pub(super) fn camera(&mut self, anim: &Animation, a: &mut GAnimation) -> Option<u32> {
        let cam = anim.camera.as_ref()?;
        let track = anim.tracks.get(cam.track as usize)?;
        let znear = if cam.near.is_finite() && cam.near > 0.0 { cam.near } else { 0.1 };
        let zfar = (cam.far.is_finite() && cam.far > znear).then_some(cam.far);
        let yfov = if cam.fov.is_finite() {
            cam.fov.to_radians().clamp(1e-3, std::f32::consts::PI - 1e-3)
        } else {
            40f32.to_radians()
        };
        self.root.cameras.push(GCamera { kind: "perspective", perspective: Perspective { yfov, znear, zfar } });
        let camera = Some(self.root.cameras.len() as u32 - 1);
        let (t, r, _) = gltf_trs(&track.at(0));
        let node = self.push_node(Node {
            name: Some("camera".into()),
            camera,
            translation: Some(t),
            rotation: Some(r),
            ..Node::default()
        });
        if cam.fps > 0.0 && cam.fps.is_finite() {
            let n = frames_needed(anim.duration as f64, cam.fps).min(mdg_vm::anim::MAX_TRACK_FRAMES);
            let frames: Vec<Frame> = (0..n as u64).map(|i| track.at(i)).collect();
            if n >= 2 && frames.iter().any(|f| *f != frames[0]) {
                let input = self.key_times(cam.fps, n);
                self.trs_channels(a, input, &frames, node, false);
            }
        }
        Some(node)
    }
}
