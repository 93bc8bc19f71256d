//! Byte encoding of bundles. Every read is bounds-checked; counts are checked
//! against the bytes left before anything is allocated.

use super::*;
use crate::expr::BinOp;

struct W(Vec<u8>);

impl W {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u16(&mut self, v: u16) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    // The decoder rejects non-finite numbers, but constants the compiler folds can
    // overflow (`z 1e308` is infinite as f32): they are written saturated to the
    // largest finite value (NaN as 0), so every encoded bundle loads.
    fn f32(&mut self, v: f32) {
        let v = if v.is_nan() { 0.0 } else { v.clamp(f32::MIN, f32::MAX) };
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        let v = if v.is_nan() { 0.0 } else { v.clamp(f64::MIN, f64::MAX) };
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.f32(*x);
        }
    }
    fn len(&mut self, n: usize) {
        self.u32(n as u32);
    }
    fn str(&mut self, s: &str) {
        self.len(s.len());
        self.0.extend_from_slice(s.as_bytes());
    }
}

struct R<'a> {
    b: &'a [u8],
    at: usize,
    section: &'static str,
}

impl<'a> R<'a> {
    fn err(&self, what: &str) -> LoadError {
        LoadError(format!("{what} in section `{}` at byte {}", self.section, self.at))
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], LoadError> {
        let end = self.at.checked_add(n).filter(|e| *e <= self.b.len()).ok_or_else(|| self.err("truncated data"))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn arr<const N: usize>(&mut self) -> Result<[u8; N], LoadError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, LoadError> {
        Ok(self.arr::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, LoadError> {
        Ok(u16::from_le_bytes(self.arr()?))
    }
    fn u32(&mut self) -> Result<u32, LoadError> {
        Ok(u32::from_le_bytes(self.arr()?))
    }
    fn u64(&mut self) -> Result<u64, LoadError> {
        Ok(u64::from_le_bytes(self.arr()?))
    }
    fn f32(&mut self) -> Result<f32, LoadError> {
        let v = f32::from_le_bytes(self.arr()?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err("non-finite number"))
        }
    }
    fn f64(&mut self) -> Result<f64, LoadError> {
        let v = f64::from_le_bytes(self.arr()?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err("non-finite number"))
        }
    }
    fn f32s<const N: usize>(&mut self) -> Result<[f32; N], LoadError> {
        let mut a = [0f32; N];
        for x in &mut a {
            *x = self.f32()?;
        }
        Ok(a)
    }
    /// A count of elements each at least `min_size` bytes, checked against what is left.
    fn len(&mut self, min_size: usize) -> Result<usize, LoadError> {
        let n = self.u32()? as usize;
        if n.saturating_mul(min_size.max(1)) > self.b.len() - self.at {
            return Err(self.err(&format!("count {n} larger than the data left")));
        }
        Ok(n)
    }
    fn str(&mut self) -> Result<String, LoadError> {
        let n = self.len(1)?;
        let bytes = self.take(n)?;
        String::from_utf8(bytes.to_vec()).map_err(|_| self.err("string is not UTF-8"))
    }
}

/// An operand of an expression instruction in the bundle's bytes.
trait ExprOperand: Sized {
    fn put(self, w: &mut W);
    fn get(r: &mut R) -> Result<Self, LoadError>;
}

impl ExprOperand for f64 {
    fn put(self, w: &mut W) {
        w.f64(self)
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        r.f64()
    }
}

impl ExprOperand for u8 {
    fn put(self, w: &mut W) {
        w.u8(self)
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        r.u8()
    }
}

impl ExprOperand for i32 {
    fn put(self, w: &mut W) {
        w.u32(self as u32)
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        Ok(r.u32()? as i32)
    }
}

impl ExprOperand for u16 {
    fn put(self, w: &mut W) {
        w.u16(self)
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        r.u16()
    }
}

impl ExprOperand for u32 {
    fn put(self, w: &mut W) {
        w.u32(self)
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        r.u32()
    }
}

/// A binary operator is stored as its id (its position in `BINOPS`).
impl ExprOperand for BinOp {
    fn put(self, w: &mut W) {
        w.u8(self.id())
    }
    fn get(r: &mut R) -> Result<Self, LoadError> {
        let id = r.u8()?;
        BinOp::from_id(id).ok_or_else(|| r.err(&format!("unknown operator {id}")))
    }
}

/// The expression instructions' tags and operand types, written once: the encoder
/// ([`encode_expr_op`]) and the decoder ([`decode_expr_op`]) are generated from it.
macro_rules! expr_ops {
    ($( $tag:literal => $v:ident $(($t:ty))? ),* $(,)?) => {
        /// Appends expression instruction `op`: its tag, then its operand.
        fn encode_expr_op(w: &mut W, op: ExprOp) {
            // (Exhaustive: every instruction has a tag.)
            match op {
                $( ExprOp::$v { .. } => w.u8($tag), )*
            }
            $( expr_ops!(@put w, op, $v $(, $t)?); )*
        }

        /// Reads one expression instruction.
        fn decode_expr_op(r: &mut R) -> Result<ExprOp, LoadError> {
            Ok(match r.u8()? {
                $( $tag => expr_ops!(@get r, $v $(, $t)?), )*
                t => return Err(r.err(&format!("unknown expression op {t}"))),
            })
        }
    };
    (@put $w:ident, $op:ident, $v:ident) => {};
    (@put $w:ident, $op:ident, $v:ident, $t:ty) => {
        if let ExprOp::$v(x) = $op {
            ExprOperand::put(x, $w);
        }
    };
    (@get $r:ident, $v:ident) => { ExprOp::$v };
    (@get $r:ident, $v:ident, $t:ty) => { ExprOp::$v(<$t as ExprOperand>::get($r)?) };
}

expr_ops! {
    0 => Push(f64),
    1 => Var(u8),
    2 => Neg,
    3 => Bin(BinOp),
    4 => Call(u8),
    5 => Slot(u16),
    6 => Skip(u32),
    7 => SkipUnless(u32),
    8 => Pick(u32),
    9 => Slide(u32),
    10 => Funcs(u32),
    11 => Enter(u32),
    12 => Fn(i32),
    13 => Ret,
}

fn encode_composite(w: &mut W, c: &Composite) {
    w.f32s(&c.q);
    w.f32s(&c.qh);
    w.f32s(&c.u);
    w.f32s(&c.color);
    w.f32s(&c.weight);
    w.f32(c.fps);
    // Flags: 1 = non-uniform factor follows, 2 = HSB adjustments follow, 4 = a set colour follows.
    w.u8(u8::from(c.n.is_some()) | (u8::from(c.hsb.is_some()) << 1) | (u8::from(c.set.is_some()) << 2));
    if let Some(n) = &c.n {
        w.f32s(n);
    }
    if let Some(h) = &c.hsb {
        w.f32s(h);
    }
    if let Some(s) = &c.set {
        w.f32s(s);
    }
}

fn decode_composite(r: &mut R) -> Result<Composite, LoadError> {
    let (q, qh, u, color, weight, fps) = (r.f32s()?, r.f32s()?, r.f32s()?, r.f32s()?, r.f32s()?, r.f32()?);
    let flags = r.u8()?;
    if flags > 7 {
        return Err(r.err("unknown composite flags"));
    }
    let n = if flags & 1 != 0 { Some(r.f32s()?) } else { None };
    let hsb = if flags & 2 != 0 { Some(r.f32s()?) } else { None };
    let set = if flags & 4 != 0 { Some(r.f32s()?) } else { None };
    Ok(Composite { q, qh, u, color, weight, fps, n, hsb, set })
}

/// The settings section.
fn encode_settings(w: &mut W, s: &Settings) {
    w.u32(s.startshape);
    w.u32(s.maxdepth);
    w.f32(s.minsize);
    w.u64(s.maxiter);
    w.u32(s.stacksize);
    w.u64(s.randseed);
    w.f32s(&s.normal);
    w.f32s(&s.background);
    w.f32(s.fps);
    w.f32(s.duration);
    w.f32(s.camerafov);
    w.f32(s.near);
    w.f32(s.far);
    w.u32(s.linerule);
    w.u32(s.camerarule);
    w.u8(u8::from(s.flat));
    w.u8(u8::from(s.breadth));
    w.u64(s.maxobjects);
    w.len(s.namespaces.len());
    for n in &s.namespaces {
        w.u32(*n);
    }
}

/// The transforms section.
fn encode_transforms(w: &mut W, transforms: &[Transform]) {
    w.len(transforms.len());
    for t in transforms {
        match t {
            Transform::Const(c) => {
                w.u8(0);
                encode_composite(w, c);
            }
            Transform::Dynamic { adjs, divisor } => {
                w.u8(1);
                w.f32(*divisor);
                w.len(adjs.len());
                for a in adjs {
                    w.u8(a.kind as u8);
                    w.u8(a.axis);
                    w.len(a.args.len());
                    for arg in &a.args {
                        match arg {
                            Arg::Const(v) => {
                                w.u8(0);
                                w.f32(*v);
                            }
                            Arg::Expr(e) => {
                                w.u8(1);
                                w.u32(*e);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The rules section.
fn encode_rules(w: &mut W, rules: &[Rule]) {
    w.len(rules.len());
    for r in rules {
        w.u32(r.name);
        match r.selector {
            Selector::Random => w.u8(0),
            Selector::Depth => w.u8(1),
            Selector::Scale => w.u8(2),
            Selector::Sequential => w.u8(3),
            Selector::Pattern => w.u8(4),
            Selector::Function(e) => {
                w.u8(5);
                w.u32(e);
            }
        }
        w.len(r.defs.len());
        for d in &r.defs {
            w.f32(d.weight);
            w.u32(d.weight_expr);
            w.u32(d.start);
            w.u32(d.retire_depth);
            w.u32(d.retire_to);
        }
        w.len(r.transforms.len());
        for t in &r.transforms {
            w.u32(*t);
        }
        w.u32(r.iter);
        // Parameters: a default flag, then the default.
        w.len(r.params.len());
        for p in &r.params {
            match p {
                None => w.u8(0),
                Some(v) => {
                    w.u8(1);
                    w.f64(*v);
                }
            }
        }
        w.u16(r.frame);
    }
}

/// The shaders, program and uniforms sections.
fn encode_graphics(w: &mut W, b: &Bundle) {
    w.len(b.shaders.len());
    for s in &b.shaders {
        w.u8(s.vertex as u8);
        w.u32(s.name);
        w.u32(s.source);
        w.len(s.spirv.len());
        for word in &s.spirv {
            w.u32(*word);
        }
    }
    // Program.
    match &b.program {
        None => w.u8(0),
        Some(p) => {
            w.u8(1);
            w.u32(p.vertex);
            w.u32(p.fragment);
        }
    }
    // Uniforms.
    w.len(b.uniforms.len());
    for u in &b.uniforms {
        w.u32(u.name);
        match u.source {
            UniformSource::Const(v) => {
                w.u8(0);
                w.f32s(&v);
            }
            UniformSource::Frame { rule, prop } => {
                w.u8(1);
                w.u32(rule);
                w.u8(prop);
            }
        }
    }
}

/// Encodes a bundle to bytes (deterministic).
pub fn encode(b: &Bundle) -> Vec<u8> {
    let mut w = W(Vec::new());
    // Strings.
    w.len(b.strings.len());
    for s in &b.strings {
        w.str(s);
    }
    encode_settings(&mut w, &b.settings);
    encode_transforms(&mut w, &b.transforms);
    // Expressions.
    w.len(b.exprs.len());
    for e in &b.exprs {
        w.len(e.len());
        for op in e {
            encode_expr_op(&mut w, *op);
        }
    }
    encode_rules(&mut w, &b.rules);
    // Code.
    let mut code = Vec::new();
    for op in &b.code {
        op.encode(&mut code);
    }
    w.len(b.code.len());
    w.len(code.len());
    w.0.extend_from_slice(&code);
    // Isosurfaces.
    w.len(b.isosurfaces.len());
    for i in &b.isosurfaces {
        w.u32(i.name);
        w.f32s(&i.min);
        w.f32s(&i.max);
        for r in i.res {
            w.u32(r);
        }
        w.u32(i.function);
    }
    encode_graphics(&mut w, b);
    // Params.
    w.len(b.params.len());
    for p in &b.params {
        w.u32(p.name);
        w.u8(p.ty);
        w.f64(p.value);
        w.f64(p.min);
        w.f64(p.max);
    }
    // Source map.
    w.len(b.source_map.len());
    for l in &b.source_map {
        w.u32(l.op);
        w.u32(l.file);
        w.u32(l.line);
    }
    // Extensions: empty string when there are none.
    w.str(&b.extensions.encode());
    let payload = w.0;
    let mut out = W(Vec::with_capacity(payload.len() + 24));
    out.0.extend_from_slice(&MAGIC);
    out.u16(VERSION);
    out.u16(0);
    out.u64(fnv1a(&payload));
    out.u64(payload.len() as u64);
    out.0.extend_from_slice(&payload);
    out.0
}

/// The settings section.
fn decode_settings(r: &mut R) -> Result<Settings, LoadError> {
    r.section = "settings";
    let startshape = r.u32()?;
    let maxdepth = r.u32()?;
    let minsize = r.f32()?;
    let maxiter = r.u64()?;
    let stacksize = r.u32()?;
    let randseed = r.u64()?;
    let normal = r.f32s()?;
    let background = r.f32s()?;
    let fps = r.f32()?;
    let duration = r.f32()?;
    let camerafov = r.f32()?;
    let near = r.f32()?;
    let far = r.f32()?;
    let linerule = r.u32()?;
    let camerarule = r.u32()?;
    let flat = match r.u8()? {
        0 => false,
        1 => true,
        _ => return Err(r.err("the flat setting is neither 0 nor 1")),
    };
    let breadth = match r.u8()? {
        0 => false,
        1 => true,
        _ => return Err(r.err("the order setting is neither 0 (depth) nor 1 (breadth)")),
    };
    let maxobjects = r.u64()?;
    let n = r.len(4)?;
    let mut namespaces = Vec::with_capacity(n);
    for _ in 0..n {
        namespaces.push(r.u32()?);
    }
    Ok(Settings {
        startshape,
        maxdepth,
        minsize,
        maxiter,
        stacksize,
        randseed,
        normal,
        background,
        fps,
        duration,
        camerafov,
        near,
        far,
        linerule,
        camerarule,
        namespaces,
        flat,
        breadth,
        maxobjects,
    })
}

/// The transforms section.
fn decode_transforms(r: &mut R) -> Result<Vec<Transform>, LoadError> {
    r.section = "transforms";
    let n = r.len(5)?;
    let mut transforms = Vec::with_capacity(n);
    for _ in 0..n {
        transforms.push(match r.u8()? {
            0 => Transform::Const(decode_composite(r)?),
            1 => {
                let divisor = r.f32()?;
                let n = r.len(6)?;
                let mut adjs = Vec::with_capacity(n);
                for _ in 0..n {
                    let k = r.u8()?;
                    let kind = AdjOp::from_byte(k).ok_or_else(|| r.err(&format!("unknown adjustment kind {k}")))?;
                    let axis = r.u8()?;
                    let n = r.len(5)?;
                    let mut args = Vec::with_capacity(n);
                    for _ in 0..n {
                        args.push(match r.u8()? {
                            0 => Arg::Const(r.f32()?),
                            1 => Arg::Expr(r.u32()?),
                            t => return Err(r.err(&format!("unknown argument tag {t}"))),
                        });
                    }
                    adjs.push(PrimAdj { kind, axis, args });
                }
                Transform::Dynamic { adjs, divisor }
            }
            t => return Err(r.err(&format!("unknown transform tag {t}"))),
        });
    }
    Ok(transforms)
}

/// The rules section.
fn decode_rules(r: &mut R) -> Result<Vec<Rule>, LoadError> {
    r.section = "rules";
    let n = r.len(23)?;
    let mut rules = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.u32()?;
        let selector = match r.u8()? {
            0 => Selector::Random,
            1 => Selector::Depth,
            2 => Selector::Scale,
            3 => Selector::Sequential,
            4 => Selector::Pattern,
            5 => Selector::Function(r.u32()?),
            t => return Err(r.err(&format!("unknown selector {t}"))),
        };
        let m = r.len(12)?;
        let mut defs = Vec::with_capacity(m);
        for _ in 0..m {
            defs.push(Def {
                weight: r.f32()?,
                weight_expr: r.u32()?,
                start: r.u32()?,
                retire_depth: r.u32()?,
                retire_to: r.u32()?,
            });
        }
        let m = r.len(4)?;
        let mut tr = Vec::with_capacity(m);
        for _ in 0..m {
            tr.push(r.u32()?);
        }
        let iter = r.u32()?;
        let m = r.len(1)?;
        let mut params = Vec::with_capacity(m);
        for _ in 0..m {
            params.push(match r.u8()? {
                0 => None,
                1 => Some(r.f64()?),
                t => return Err(r.err(&format!("unknown parameter flag {t}"))),
            });
        }
        let frame = r.u16()?;
        rules.push(Rule { name, selector, defs, transforms: tr, iter, params, frame });
    }
    Ok(rules)
}

/// What the shaders, program and uniforms sections hold.
type Graphics = (Vec<Shader>, Option<Program>, Vec<Uniform>);

/// The shaders, program and uniforms sections.
fn decode_graphics(r: &mut R) -> Result<Graphics, LoadError> {
    r.section = "shaders";
    let n = r.len(13)?;
    let mut shaders = Vec::with_capacity(n);
    for _ in 0..n {
        let vertex = r.u8()? != 0;
        let name = r.u32()?;
        let source = r.u32()?;
        let m = r.len(4)?;
        let mut spirv = Vec::with_capacity(m);
        for _ in 0..m {
            spirv.push(r.u32()?);
        }
        shaders.push(Shader { vertex, name, source, spirv });
    }
    r.section = "program";
    let program = match r.u8()? {
        0 => None,
        1 => Some(Program { vertex: r.u32()?, fragment: r.u32()? }),
        t => return Err(r.err(&format!("unknown program tag {t}"))),
    };
    r.section = "uniforms";
    let n = r.len(9)?;
    let mut uniforms = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.u32()?;
        let source = match r.u8()? {
            0 => UniformSource::Const(r.f32s()?),
            1 => UniformSource::Frame { rule: r.u32()?, prop: r.u8()? },
            t => return Err(r.err(&format!("unknown uniform tag {t}"))),
        };
        uniforms.push(Uniform { name, source });
    }
    Ok((shaders, program, uniforms))
}

/// Decodes bytes into a bundle, checking the header, check value and every length.
/// Indices are checked by [`verify`].
pub fn decode(bytes: &[u8]) -> Result<Bundle, LoadError> {
    if bytes.len() < 24 || bytes[..4] != MAGIC {
        return Err(LoadError("not an MDG bundle (bad magic)".into()));
    }
    let mut h = R { b: bytes, at: 4, section: "header" };
    let version = h.u16()?;
    if version != VERSION {
        return Err(LoadError(format!(
            "format version {version}, this VM reads version {VERSION}: rebuild the bundle"
        )));
    }
    let _flags = h.u16()?;
    let check = h.u64()?;
    let len = h.u64()?;
    let payload = &bytes[24..];
    if len != payload.len() as u64 {
        return Err(LoadError(format!("payload is {} bytes, header says {len}", payload.len())));
    }
    if fnv1a(payload) != check {
        return Err(LoadError("check value mismatch: the bundle is corrupt".into()));
    }
    let mut r = R { b: payload, at: 0, section: "strings" };
    let n = r.len(4)?;
    let mut strings = Vec::with_capacity(n);
    for _ in 0..n {
        strings.push(r.str()?);
    }
    let settings = decode_settings(&mut r)?;
    let transforms = decode_transforms(&mut r)?;
    r.section = "expressions";
    let n = r.len(4)?;
    let mut exprs = Vec::with_capacity(n);
    for _ in 0..n {
        let m = r.len(1)?;
        let mut e = Vec::with_capacity(m);
        for _ in 0..m {
            e.push(decode_expr_op(&mut r)?);
        }
        exprs.push(e);
    }
    let rules = decode_rules(&mut r)?;
    r.section = "code";
    let n_ops = r.len(1)?;
    let n_bytes = r.len(1)?;
    let code_bytes = r.take(n_bytes)?;
    let mut code = Vec::with_capacity(n_ops);
    let mut at = 0;
    while at < code_bytes.len() {
        let (op, len) = Op::decode(code_bytes, at).map_err(|e| LoadError(e.to_string()))?;
        code.push(op);
        at += len;
    }
    if code.len() != n_ops {
        return Err(LoadError(format!("code holds {} ops, header says {n_ops}", code.len())));
    }
    r.section = "isosurfaces";
    let n = r.len(40)?;
    let mut isosurfaces = Vec::with_capacity(n);
    for _ in 0..n {
        isosurfaces.push(Isosurface {
            name: r.u32()?,
            min: r.f32s()?,
            max: r.f32s()?,
            res: [r.u32()?, r.u32()?, r.u32()?],
            function: r.u32()?,
        });
    }
    let (shaders, program, uniforms) = decode_graphics(&mut r)?;
    r.section = "params";
    let n = r.len(29)?;
    let mut params = Vec::with_capacity(n);
    for _ in 0..n {
        params.push(Param { name: r.u32()?, ty: r.u8()?, value: r.f64()?, min: r.f64()?, max: r.f64()? });
    }
    r.section = "source map";
    let n = r.len(12)?;
    let mut source_map = Vec::with_capacity(n);
    for _ in 0..n {
        source_map.push(SourceLoc { op: r.u32()?, file: r.u32()?, line: r.u32()? });
    }
    r.section = "extensions";
    let text = r.str()?;
    let extensions = Extensions::decode(&text).map_err(|e| r.err(&e))?;
    if r.at != payload.len() {
        return Err(LoadError(format!("{} trailing bytes after the last section", payload.len() - r.at)));
    }
    Ok(Bundle {
        strings,
        settings,
        transforms,
        exprs,
        rules,
        code,
        isosurfaces,
        shaders,
        program,
        uniforms,
        params,
        source_map,
        extensions,
    })
}
