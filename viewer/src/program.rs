//! Which SPIR-V draws a model: the bundle's `program` (reference §13), with std's
//! Phong program (`std/shaders.mdg`) for any stage it leaves out or when there is
//! none; plus the viewer's own unlit shaders for pen lines.
//!
//! The viewer compiles no shader itself: the fallback [`Programs`] come from its
//! caller (the CLI compiles std's `shaders.mdg` and the line shaders once per
//! process).

use crate::Error;
use mdg_vm::bundle::{Bundle, NONE};

/// Vertex and fragment SPIR-V, and where they came from (for messages).
#[derive(Clone, Debug, PartialEq)]
pub struct ProgramSpirv {
    pub vertex: Vec<u32>,
    pub fragment: Vec<u32>,
    /// e.g. `flat_vs + flat_fs` or `std phong_vs + phong_fs`.
    pub label: String,
}

/// The programs the viewer falls back on, compiled by whoever drives it (the CLI
/// compiles them with the MDG compiler; the viewer itself compiles nothing):
/// std's Phong program for any stage a bundle's `program` leaves out, and the
/// unlit program for pen lines ([`LINE_VS`], [`LINE_FS`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Programs {
    pub phong: ProgramSpirv,
    /// std's `phong_instanced_vs` with `phong_fs`: instances drawn with GPU
    /// instancing where a model's vertex shader is std's (`None`: they are expanded).
    pub instanced: Option<ProgramSpirv>,
    pub lines: ProgramSpirv,
    /// The point sprites that stand in for small instances ([`POINT_VS`] with
    /// [`LINE_FS`]; `None`: small instances are drawn as meshes).
    pub points: Option<ProgramSpirv>,
}

/// The program for `bundle`: its `program` directive's shaders, std Phong for the
/// rest.
pub fn for_bundle(bundle: &Bundle, programs: &Programs) -> Result<ProgramSpirv, Error> {
    let (v, f) = match &bundle.program {
        Some(p) => (p.vertex, p.fragment),
        None => (NONE, NONE),
    };
    let shader = |i: u32| -> Result<Option<(String, Vec<u32>)>, Error> {
        if i == NONE {
            return Ok(None);
        }
        let sh = bundle
            .shaders
            .get(i as usize)
            .ok_or_else(|| Error::Other(format!("program names shader {i}, which is missing")))?;
        let name = bundle.string(sh.name).to_string();
        if sh.spirv.is_empty() {
            return Err(Error::Compile(format!(
                "shader `{name}` has no SPIR-V (the bundle was built without the shader stage)"
            )));
        }
        Ok(Some((name, sh.spirv.clone())))
    };
    let (vs, fs) = (shader(v)?, shader(f)?);
    if let (Some((vn, vertex)), Some((fname, fragment))) = (&vs, &fs) {
        return Ok(ProgramSpirv {
            vertex: vertex.clone(),
            fragment: fragment.clone(),
            label: format!("{vn} + {fname}"),
        });
    }
    let std = &programs.phong;
    let label = format!(
        "{} + {}",
        vs.as_ref().map(|(n, _)| n.clone()).unwrap_or_else(|| "std phong_vs".into()),
        fs.as_ref().map(|(n, _)| n.clone()).unwrap_or_else(|| "std phong_fs".into())
    );
    Ok(ProgramSpirv {
        vertex: vs.map(|(_, s)| s).unwrap_or_else(|| std.vertex.clone()),
        fragment: fs.map(|(_, s)| s).unwrap_or_else(|| std.fragment.clone()),
        label,
    })
}

/// The program that draws `bundle`'s instances with GPU instancing: std's instanced
/// vertex shader with the bundle's fragment shader (or std's), when the bundle's
/// vertex shader is std's `phong_vs` (none of its own); `None` when it has its own
/// (which reads world-space vertices: its instances are expanded on the CPU) or
/// std has no instanced shader.
pub fn instanced_for_bundle(bundle: &Bundle, programs: &Programs) -> Result<Option<ProgramSpirv>, Error> {
    let Some(inst) = &programs.instanced else { return Ok(None) };
    if bundle.program.as_ref().is_some_and(|p| p.vertex != NONE) {
        return Ok(None);
    }
    let mut p = for_bundle(bundle, programs)?;
    p.vertex = inst.vertex.clone();
    p.label = p.label.replacen("std phong_vs", "std phong_instanced_vs", 1);
    Ok(Some(p))
}

/// The unlit vertex shaders' uniform block and colour output ([`LINE_VS`],
/// [`POINT_VS`]).
macro_rules! unlit_globals {
    () => {
        "layout(set = 0, binding = 0) uniform Globals {
    mat4 projection;
    mat4 view;
    vec4 camera_pos;
    vec4 light_pos;
    vec4 spec_color_power;
} globals;
layout(location = 0) out vec4 v_color;
"
    };
}

/// Unlit vertex shader for pen lines: position and colour, nothing else.
pub const LINE_VS: &str = concat!(
    "#version 450
layout(location = 0) in vec3 in_position;
layout(location = 2) in vec4 in_color;
",
    unlit_globals!(),
    "void main() {
    v_color = in_color;
    gl_Position = globals.projection * globals.view * vec4(in_position, 1.0);
}
"
);

/// Vertex shader for the point sprites standing in for small instances
/// ([`crate::points`]): a world position, a size in pixels and a colour already
/// shaded (drawn unlit by [`LINE_FS`]).
pub const POINT_VS: &str = concat!(
    "#version 450
layout(location = 0) in vec3 in_position;
layout(location = 1) in float in_size;
layout(location = 2) in vec4 in_color;
",
    unlit_globals!(),
    "void main() {
    v_color = in_color;
    gl_Position = globals.projection * globals.view * vec4(in_position, 1.0);
    gl_PointSize = in_size;
}
"
);

/// Unlit fragment shader for pen lines.
pub const LINE_FS: &str = "#version 450
layout(location = 0) in vec4 v_color;
layout(location = 0) out vec4 out_color;
void main() {
    out_color = v_color;
}
";
