//! The document and binary chunk under construction ([`Builder`]): buffer views
//! and accessors, materials, the shared meshes' accessors and the pen lines, the
//! streamed and spooled parts of the chunk ([`Sink`]), and the GLB container.

use super::*;

/// `m` mirrored in x: positions and normals with x negated, every triangle reversed.
pub(super) fn mirrored_copy(m: &Mesh) -> Mesh {
    let mut c = m.clone();
    for p in &mut c.positions {
        p[0] = -p[0];
    }
    for n in &mut c.normals {
        n[0] = -n[0];
    }
    c.mirrored = (0..c.triangles.len()).map(|i| !m.mirrored.get(i).copied().unwrap_or(false)).collect();
    c
}

/// Accessors of one shared mesh, written once and used by all its instances.
#[derive(Clone, Copy)]
pub(super) struct SharedAccessors {
    pub(super) position: u32,
    pub(super) normal: u32,
    pub(super) indices: u32,
    /// The mesh is not closed (see [`is_closed`]).
    pub(super) double_sided: bool,
}

/// Translation, rotation and per-axis scale of a proper transform whose axes are
/// orthogonal (a rotation times a scale along the object's own axes: a similarity, or
/// `s X Y Z` applied in the object's frame), or `None` when the matrix is mirrored,
/// degenerate, non-finite or sheared (relative tolerance 1e-3): glTF's TRS cannot hold
/// those, and their instances are baked.
pub(super) fn orthogonal_trs(m: &Mat4) -> Option<(Vec3, Quat, Vec3)> {
    if !m.is_finite() || m.row(3).truncate().length_squared() != 0.0 || m.row(3).w != 1.0 {
        return None;
    }
    let (a, b, c) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let big = la.max(lb).max(lc);
    if big.is_nan() || la.min(lb).min(lc) <= 1e-6 * big || big <= 1e-12 || a.dot(b.cross(c)) <= 0.0 {
        return None;
    }
    if a.dot(b).abs() > 1e-3 * la * lb || b.dot(c).abs() > 1e-3 * lb * lc || c.dot(a).abs() > 1e-3 * lc * la {
        return None;
    }
    let rot = Quat::from_mat3(&glam::Mat3::from_cols(a / la, b / lb, c / lc)).normalize();
    Some((m.w_axis.truncate(), rot, Vec3::new(la, lb, lc)))
}

/// Writes a streamed part of the binary chunk into a [`Sink`].
pub(super) type StreamFn<'a> = dyn FnOnce(&mut Sink) -> Result<(), ExportError> + 'a;

/// A part of the binary chunk: bytes made in advance, or `len` bytes that `write`
/// makes while the file is written.
pub(super) enum Segment<'a> {
    Bytes(Vec<u8>),
    Stream { len: usize, write: Box<StreamFn<'a>> },
}

/// How many bytes a [`Sink`] gathers before handing them on: as many as the file
/// writer's buffer holds (`write_file_with`'s `BufWriter`, 1 MiB), which then passes
/// them straight to the file instead of copying them into its own buffer.
pub(super) const SINK_BYTES: usize = 1 << 20;

/// The largest flat primitive (vertex records and indices) spooled in memory, so
/// that its vertices are placed once (see [`Builder::flat_primitive`]); a bigger
/// one is walked twice, its bounds first, and streamed into the file.
pub(super) const SPOOL_BYTES: usize = 64 << 20;

/// The writer a streamed part writes into: a fixed buffer (`buf[..len]` filled) in
/// front of the output, counting what went through; or a spool, a buffer of the
/// part's exact size that holds all of it (no output behind it).
pub(super) struct Sink<'w> {
    buf: Box<[u8]>,
    len: usize,
    w: Option<&'w mut dyn std::io::Write>,
    written: usize,
}

impl<'w> Sink<'w> {
    pub(super) fn new(w: &'w mut dyn std::io::Write) -> Sink<'w> {
        Sink { buf: vec![0; SINK_BYTES].into_boxed_slice(), len: 0, w: Some(w), written: 0 }
    }

    /// A spool of `bytes` bytes: [`Sink::into_spool`] hands them back.
    pub(super) fn spool(bytes: usize) -> Sink<'static> {
        Sink { buf: vec![0; bytes].into_boxed_slice(), len: 0, w: None, written: 0 }
    }

    /// The next `n` bytes (at most [`SINK_BYTES`], or what is left of a spool) to
    /// fill in.
    #[inline]
    pub(super) fn slot(&mut self, n: usize) -> Result<&mut [u8], ExportError> {
        if self.len + n > self.buf.len() {
            self.flush()?;
        }
        let at = self.len;
        self.len += n;
        match self.buf.get_mut(at..at + n) {
            Some(b) => Ok(b),
            None => Err(ExportError::Record { bytes: n }),
        }
    }

    #[inline]
    pub(super) fn put(&mut self, bytes: &[u8]) -> Result<(), ExportError> {
        self.slot(bytes.len())?.copy_from_slice(bytes);
        Ok(())
    }

    pub(super) fn flush(&mut self) -> Result<(), ExportError> {
        let Some(w) = self.w.as_mut() else {
            return Err(ExportError::StreamLength { written: self.len, laid_out: self.buf.len() });
        };
        w.write_all(&self.buf[..self.len]).map_err(ExportError::GlbIo)?;
        self.written += self.len;
        self.len = 0;
        Ok(())
    }

    /// A spool's bytes, which must fill it.
    pub(super) fn into_spool(self) -> Result<Vec<u8>, ExportError> {
        if self.len != self.buf.len() {
            return Err(ExportError::StreamLength { written: self.len, laid_out: self.buf.len() });
        }
        Ok(self.buf.into_vec())
    }
}

impl<'a> Builder<'a> {
    /// The chunk offset where the next bytes go, padded to 4 bytes.
    pub(super) fn aligned_end(&mut self) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.base + self.bin.len()
    }

    /// Reserves `len` bytes (a multiple of 4) at the current end of the chunk, to be
    /// written by `write` when the file is written; returns their offset.
    pub(super) fn stream(&mut self, len: usize, write: Box<StreamFn<'a>>) -> usize {
        let offset = self.aligned_end();
        let held = std::mem::take(&mut self.bin);
        if !held.is_empty() {
            self.segments.push(Segment::Bytes(held));
        }
        self.segments.push(Segment::Stream { len, write });
        self.base = offset + len;
        offset
    }

    /// Appends `bytes` (a multiple of 4, made in advance and held till the file is
    /// written) at the current end of the chunk; returns their offset.
    pub(super) fn held(&mut self, bytes: Vec<u8>) -> usize {
        let offset = self.aligned_end();
        let before = std::mem::take(&mut self.bin);
        if !before.is_empty() {
            self.segments.push(Segment::Bytes(before));
        }
        self.base = offset + bytes.len();
        self.segments.push(Segment::Bytes(bytes));
        offset
    }

    /// Appends `bytes` (4-byte aligned) as a buffer view and returns its index.
    pub(super) fn view(&mut self, bytes: &[u8], target: u32) -> u32 {
        self.view_for(bytes, Some(target))
    }

    /// A buffer view with an optional target (animation data has none).
    pub(super) fn view_for(&mut self, bytes: &[u8], target: Option<u32>) -> u32 {
        let offset = self.aligned_end();
        self.bin.extend_from_slice(bytes);
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length: bytes.len(),
            target,
            byte_stride: None,
        });
        self.root.buffer_views.len() as u32 - 1
    }

    pub(super) fn accessor(&mut self, a: Accessor) -> u32 {
        self.root.accessors.push(a);
        self.root.accessors.len() as u32 - 1
    }

    /// A VEC3 float vertex attribute, with min/max when `bounds`.
    pub(super) fn vec3(&mut self, data: &[[f32; 3]], bounds: bool) -> u32 {
        self.vec3_from(data.len(), |i| data[i], bounds)
    }

    /// Appends `n` items of `width` floats, `item(i)` each, straight into the binary
    /// chunk (no intermediate copy), as a vertex-attribute buffer view.
    pub(super) fn floats_view<const W: usize>(&mut self, n: usize, mut item: impl FnMut(usize) -> [f32; W]) -> u32 {
        let offset = self.aligned_end();
        self.bin.reserve(n * W * 4);
        for i in 0..n {
            for x in item(i) {
                self.bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        let byte_length = self.base + self.bin.len() - offset;
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length,
            target: Some(ARRAY_BUFFER),
            byte_stride: None,
        });
        self.root.buffer_views.len() as u32 - 1
    }

    /// Like [`Builder::vec3`], item by item.
    pub(super) fn vec3_from(&mut self, n: usize, item: impl Fn(usize) -> [f32; 3], bounds: bool) -> u32 {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let view = self.floats_view(n, |i| {
            let p = item(i);
            if bounds {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            p
        });
        let (min, max) = if bounds { (Some(lo.to_vec()), Some(hi.to_vec())) } else { (None, None) };
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: n,
            kind: "VEC3",
            min,
            max,
            ..Accessor::default()
        })
    }

    /// A VEC4 float vertex attribute.
    pub(super) fn vec4(&mut self, data: &[[f32; 4]]) -> u32 {
        self.vec4_from(data.len(), |i| data[i])
    }

    /// Like [`Builder::vec4`], item by item.
    pub(super) fn vec4_from(&mut self, n: usize, item: impl Fn(usize) -> [f32; 4]) -> u32 {
        let view = self.floats_view(n, item);
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: n,
            kind: "VEC4",
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// A u32 index list of `n` indices, written straight into the binary chunk.
    /// A u32 index list.
    pub(super) fn indices(&mut self, data: &[u32]) -> u32 {
        self.indices_of(data.len(), data.iter().copied())
    }

    pub(super) fn indices_of(&mut self, n: usize, data: impl Iterator<Item = u32>) -> u32 {
        let offset = self.aligned_end();
        self.bin.reserve(n * 4);
        for x in data {
            self.bin.extend_from_slice(&x.to_le_bytes());
        }
        let byte_length = self.base + self.bin.len() - offset;
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length,
            target: Some(ELEMENT_ARRAY_BUFFER),
            byte_stride: None,
        });
        let view = self.root.buffer_views.len() as u32 - 1;
        self.accessor(Accessor {
            buffer_view: view,
            component_type: UNSIGNED_INT,
            count: byte_length / 4,
            kind: "SCALAR",
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// The material for a base colour (display values, already clamped; written
    /// linear), double-sided for open surfaces, created on first use.
    pub(super) fn material(&mut self, color: [f32; 4], double_sided: bool) -> u32 {
        let key = (color.map(f32::to_bits), double_sided);
        if let Some(&m) = self.materials.get(&key) {
            return m;
        }
        // Dielectric: the glTF default material is fully metallic, which renders
        // vertex colours nearly black in most viewers.
        self.root.materials.push(Material {
            name: None,
            pbr_metallic_roughness: Pbr {
                base_color_factor: linear_color(color),
                metallic_factor: 0.0,
                roughness_factor: 0.6,
            },
            double_sided,
        });
        let m = self.root.materials.len() as u32 - 1;
        self.materials.insert(key, m);
        m
    }

    /// Positions, normals and indices of a shared mesh in its own space, or of its
    /// copy mirrored in x (x negated, every triangle reversed) when `mirror`.
    pub(super) fn shared_accessors(
        &mut self,
        m: &Mesh,
        name: &str,
        mirror: bool,
    ) -> Result<SharedAccessors, ExportError> {
        let tris = checked_triangles(m, &format!("shared mesh {name}"))?;
        let double_sided = !is_closed(m, &tris);
        let n = m.positions.len();
        let flip = |p: [f32; 3]| if mirror { [-p[0], p[1], p[2]] } else { p };
        let position = self.vec3_from(n, |i| flip(finite3(m.positions[i])), true);
        let normal = self.vec3_from(n, |i| flip(normal_at(m, i)), false);
        let indices = if mirror {
            self.indices_of(tris.len() * 3, tris.iter().flat_map(|t| [t[0], t[2], t[1]]))
        } else {
            self.indices_of(tris.len() * 3, tris.iter().flatten().copied())
        };
        Ok(SharedAccessors { position, normal, indices, double_sided })
    }

    /// The polylines `pick` chooses with two or more points as one `LINES` primitive.
    pub(super) fn lines_primitive(&mut self, out: &Output, pick: &dyn Fn(&Polyline) -> bool) -> Option<Primitive> {
        let mut positions = Vec::new();
        let mut bones = Vec::new();
        let mut indices = Vec::new();
        for line in out.lines.iter().filter(|l| l.points.len() >= 2 && pick(l)) {
            let base = positions.len() as u32;
            positions.extend(line.points.iter().map(|p| finite3(*p)));
            bones.extend((0..line.points.len()).map(|i| line.bone(i)));
            for k in 0..line.points.len() as u32 - 1 {
                indices.extend([base + k, base + k + 1]);
            }
        }
        if indices.is_empty() {
            return None;
        }
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3(&positions, true));
        if self.skinned {
            self.skin_attributes(&mut attributes, positions.len(), |i| bones[i]);
        }
        let indices = Some(self.indices(&indices));
        let material = Some(self.material([1.0; 4], false));
        Some(Primitive { attributes, indices, material, mode: Some(MODE_LINES), extras: None })
    }

    pub(super) fn push_mesh(&mut self, m: GMesh) -> u32 {
        self.root.meshes.push(m);
        self.root.meshes.len() as u32 - 1
    }

    pub(super) fn push_node(&mut self, n: Node) -> u32 {
        self.root.nodes.push(n);
        self.root.nodes.len() as u32 - 1
    }

    /// Serialises the document and writes the GLB container.
    pub(super) fn finish(mut self, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
        let bin_len = self.aligned_end();
        if bin_len > 0 {
            self.root.buffers.push(Buffer { byte_length: bin_len });
        }
        let mut json = serde_json::to_vec(&self.root).map_err(ExportError::GltfJson)?;
        json.resize(json.len().next_multiple_of(4), b' ');
        let bin_chunk = if bin_len == 0 { 0 } else { 8 + bin_len };
        let total = 12 + 8 + json.len() + bin_chunk;
        let total = u32::try_from(total).map_err(|_| ExportError::GlbTooLarge { bytes: total as u64 })?;
        let mut head = Vec::with_capacity(20);
        head.extend_from_slice(GLB_MAGIC);
        head.extend_from_slice(&2u32.to_le_bytes());
        head.extend_from_slice(&total.to_le_bytes());
        head.extend_from_slice(&(json.len() as u32).to_le_bytes());
        head.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        let io = ExportError::GlbIo;
        w.write_all(&head).map_err(io)?;
        w.write_all(&json).map_err(io)?;
        if bin_len > 0 {
            let mut bin_head = Vec::with_capacity(8);
            bin_head.extend_from_slice(&(bin_len as u32).to_le_bytes());
            bin_head.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            w.write_all(&bin_head).map_err(io)?;
            for seg in self.segments {
                match seg {
                    Segment::Bytes(b) => w.write_all(&b).map_err(io)?,
                    Segment::Stream { len, write } => {
                        let mut sink = Sink::new(w);
                        write(&mut sink)?;
                        sink.flush()?;
                        if sink.written != len {
                            return Err(ExportError::StreamLength { written: sink.written, laid_out: len });
                        }
                    }
                }
            }
            w.write_all(&self.bin).map_err(io)?;
        }
        Ok(())
    }
}
