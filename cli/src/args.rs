//! Command-line options shared by `mdgc`, `mdg-run` and `mdg-view`: the ones that
//! change what a grammar compiles to (`--param`, `--preset`, `--std`).

use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use std::path::PathBuf;

/// `--param NAME=VALUE…`, `--preset P…`, `--std DIR`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CompileArgs {
    /// Override a `@param`: NAME=VALUE (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Choose a preset (defines its name for `@ifdef`).
    #[arg(long = "preset")]
    pub presets: Vec<String>,
    /// Where `@import NAME` looks (default: $MDG_STD or the bundled std/).
    #[arg(long)]
    pub std: Option<PathBuf>,
    /// Not a flag: colours are written in the grammar. Accepted (hidden) only to
    /// answer a `--colour`/`--color` with how to change a colour, instead of clap's
    /// suggestion of an unrelated flag.
    #[arg(long = "colour", alias = "color", hide = true, num_args = 0..=1, value_name = "C")]
    pub colour: Option<Option<String>>,
}

/// The answer to `--colour`: how colours are chosen.
pub const NO_COLOUR_FLAG: &str = "there is no --colour flag: colours are written in the grammar, as adjustments \
     (`{hue 120 sat 1}`, `{R -1}`: docs/reference.md §5, Colour and weight). To choose one from the command line, \
     declare it with `@param float hue 120` and write `{hue hue sat 1}`, then pass --param hue=200";

impl CompileArgs {
    /// The preprocessor options these arguments ask for; an error names a malformed `--param`.
    pub fn options(&self) -> Result<Options, String> {
        if self.colour.is_some() {
            return Err(NO_COLOUR_FLAG.to_string());
        }
        let mut params = Vec::new();
        for p in &self.params {
            let (n, v) = p.split_once('=').ok_or_else(|| format!("--param {p}: expected NAME=VALUE"))?;
            params.push((n.to_string(), v.to_string()));
        }
        Ok(Options {
            defines: self.presets.clone(),
            params,
            std_dir: self.std.clone().or_else(driver::default_std_dir),
        })
    }
}

/// `--param` and `--preset` names the grammar does not declare: a usage error naming
/// the flag, with the closest declared name ("did you mean") or the list of them.
/// Checked after the analysis, where the declarations are known (see
/// [`mdg_compiler::expand::unused_command_line`]).
pub fn check_declared(a: &mdg_compiler::driver::Analysis, opts: &Options) -> Result<(), String> {
    match mdg_compiler::expand::unused_command_line(&a.expanded, &a.sources, opts).into_iter().next() {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// The first `--param`/`--preset` of `opts`, as written: they change how source
/// compiles, so a compiled bundle (`.mdgb`) cannot take them.
pub fn source_only_flag(opts: &Options) -> Option<String> {
    match (opts.params.first(), opts.defines.first()) {
        (Some((n, v)), _) => Some(format!("--param {n}={v}")),
        (None, Some(p)) => Some(format!("--preset {p}")),
        (None, None) => None,
    }
}

/// [`check_declared`] over several files (`mdgc check a.mdg b.mdg`): a flag is an
/// error only when no file uses it.
pub fn check_declared_in_any(analyses: &[mdg_compiler::driver::Analysis], opts: &Options) -> Result<(), String> {
    let mut unused: Option<Vec<(String, String)>> = None;
    for a in analyses {
        let here = mdg_compiler::expand::unused_command_line(&a.expanded, &a.sources, opts);
        unused = Some(match unused {
            None => here,
            Some(before) => before.into_iter().filter(|(f, _)| here.iter().any(|(g, _)| g == f)).collect(),
        });
    }
    match unused.unwrap_or_default().into_iter().next() {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// `--max-vertices`, `--max-frames`, `--max-iso-cells`, `--time-budget`, `--max-iter`,
/// `--max-stack`, `--max-call-depth`, `--max-calls`: the limits of
/// one evaluation, the same for `mdg-run` and `mdg-view` (docs/limits.md).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct LimitArgs {
    /// Stop after this many vertices: the mesh and sweeps, every isosurface mesh (once),
    /// one per instance and every line point (default 4,000,000; docs/limits.md).
    #[arg(long, value_name = "N")]
    pub max_vertices: Option<u64>,
    /// Frames a convolution takes from one iterator rule (default 10,000,000; a
    /// terminating iterator rule contributes all its frames up to this).
    #[arg(long, value_name = "N")]
    pub max_frames: Option<u64>,
    /// Isosurface grid cells polygonised in one run, all isosurfaces together
    /// (default 16,000,000).
    #[arg(long, value_name = "N")]
    pub max_iso_cells: Option<u64>,
    /// Stop after this much evaluation time: `2s`, `1.5s`, `500ms` or `none` (at most
    /// 10000000 s; the unit is required). Checked inside isosurface polygonisation too.
    #[arg(long, value_name = "TIME", value_parser = time_budget)]
    pub time_budget: Option<TimeLimit>,
    /// The most rule calls, whatever the grammar's `maxiter` says (default
    /// 100,000,000; a grammar's `maxiter` above it is lowered with a warning).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_iter: Option<u64>,
    /// The deepest stack of rule activations, whatever the grammar's `stacksize`
    /// says (default 1,000,000, about 110 MB; lowered with a warning).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub max_stack: Option<u32>,
    /// The deepest nesting of recursive function calls in one evaluation of an
    /// expression (default 10,000); deeper, the expression's value is NaN, with a warning.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub max_call_depth: Option<u32>,
    /// The most function calls in one evaluation of an expression (default
    /// 1,000,000: `fib(40)` stays shallow and makes 300 million); more, the value is NaN.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_calls: Option<u64>,
}

/// `--time-budget`, parsed as every duration flag is.
fn time_budget(s: &str) -> Result<TimeLimit, String> {
    parse_duration("--time-budget", s).map(TimeLimit)
}

impl LimitArgs {
    /// The evaluation options these flags ask for (defaults elsewhere).
    pub fn eval_options(&self) -> mdg_vm::eval::EvalOptions {
        let d = mdg_vm::eval::EvalOptions::default();
        mdg_vm::eval::EvalOptions {
            max_vertices: self.max_vertices.unwrap_or(d.max_vertices),
            max_frames: self.max_frames.unwrap_or(d.max_frames),
            max_iso_cells: self.max_iso_cells.unwrap_or(d.max_iso_cells),
            time_budget: self.time_budget.and_then(|t| t.0),
            max_iter: self.max_iter.unwrap_or(d.max_iter),
            max_stack: self.max_stack.unwrap_or(d.max_stack),
            calls: mdg_vm::expr::CallLimits {
                depth: self.max_call_depth.unwrap_or(d.calls.depth),
                calls: self.max_calls.unwrap_or(d.calls.calls),
            },
            ..d
        }
    }
}

/// The longest duration any flag takes: 10,000,000 s (about 116 days). Beyond it
/// `Duration` arithmetic can overflow, and no run needs more.
pub const MAX_DURATION_SECS: f64 = 1e7;

/// A parsed duration flag (`None`: no limit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeLimit(pub Option<std::time::Duration>);

/// Parses a duration flag: `200ms`, `0.5s` or `none` (no limit). A bare number is
/// refused: `--budget` read it as milliseconds and `--time-budget` as seconds, so
/// the message spells out both readings (`write 2s or 2000ms`). The value must be
/// finite, positive and at most [`MAX_DURATION_SECS`]; the error names the flag and
/// what it expects.
pub fn parse_duration(flag: &str, s: &str) -> Result<Option<std::time::Duration>, String> {
    let t = s.trim();
    if t == "none" {
        return Ok(None);
    }
    let shown: String = s.chars().take(40).collect();
    let cut = if shown.len() < s.len() { "…" } else { "" };
    let expected = "expected a positive time of at most 10000000 s with its unit, such as 200ms or 0.5s, or `none`";
    let (num, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else {
        return Err(match t.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 && v <= MAX_DURATION_SECS => {
                format!("{flag} {shown}{cut}: needs a unit: write {t}s or {}ms ({expected})", v * 1000.0)
            }
            _ => format!("{flag} {shown}{cut}: {expected}"),
        });
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * scale <= MAX_DURATION_SECS => {
            Ok(Some(std::time::Duration::from_secs_f64(v * scale)))
        }
        _ => Err(format!("{flag} {shown}{cut}: {expected}")),
    }
}

/// Parses `--samples auto|N`: 0 for `auto` (the device chooses: one sample and
/// edge smoothing on a CPU driver, 4 on a GPU), else N in 1..=64.
pub fn parse_samples(s: &str) -> Result<u32, String> {
    match s.trim() {
        "auto" => Ok(0),
        t => match t.parse::<u32>() {
            Ok(n) if (1..=64).contains(&n) => Ok(n),
            _ => Err(format!("--samples {s}: expected auto or a sample count 1..64 (e.g. 1 or 4)")),
        },
    }
}

/// The warning for a sample count the device could not give (`None` when it gave
/// the one asked for).
pub fn samples_warning(choice: &mdg_viewer::image::SampleChoice, device: &str) -> Option<String> {
    choice.differs().then(|| {
        format!(
            "warning: --samples {}: {device} offers {} samples; drawing with {}",
            choice.wanted,
            choice.offered(),
            choice.count()
        )
    })
}

/// The longest picture side (`--size`).
pub const MAX_PICTURE_SIDE: u32 = 8192;
/// The most pixels in one picture: 4096 × 4096. Pictures drawn with 4×
/// multisampling (on a GPU, or `--samples 4`) take about 60 bytes a pixel in all
/// (colour and depth samples, the resolved image, its read-back copy, the PNG's
/// rows) on top of what the renderer starts with: 8192 × 8192 took 3.8 GB on
/// lavapipe, 4096 × 4096 takes 1.5 GB; one sample needs no multisampled images.
pub const MAX_PICTURE_PIXELS: u64 = 4096 * 4096;

/// Parses `--size WIDTHxHEIGHT` for a picture: each side 1..8192 and at most
/// [`MAX_PICTURE_PIXELS`] in all; the error says which bound and why.
pub fn parse_picture_size(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X'])
        .and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 && w <= MAX_PICTURE_SIDE && h <= MAX_PICTURE_SIDE => {
            let px = w as u64 * h as u64;
            if px > MAX_PICTURE_PIXELS {
                Err(format!(
                    "--size {s}: {px} pixels, more than the {MAX_PICTURE_PIXELS} (4096x4096) a picture may have: \
                     with 4x multisampling (a GPU, or --samples 4) a picture takes about 60 bytes a pixel (8192x8192 needed 3.8 GB); \
                     choose a smaller size, e.g. 4096x4096 or 8192x2048"
                ))
            } else {
                Ok((w, h))
            }
        }
        _ => Err(format!("--size {s}: expected WIDTHxHEIGHT, each 1..{MAX_PICTURE_SIDE}, e.g. 1024x768")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn samples_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_samples("auto"), Ok(0));
        assert_eq!(parse_samples("1"), Ok(1));
        assert_eq!(parse_samples("4"), Ok(4));
        for bad in ["0", "65", "-1", "four", ""] {
            let e = parse_samples(bad).expect_err("refused");
            assert!(e.starts_with("--samples ") && e.contains("expected auto or"), "{e}");
        }
    }

    #[test]
    fn durations_parse_and_bad_ones_are_refused() {
        let s = |x| time_budget(x).map(|t| t.0);
        assert_eq!(s("250ms"), Ok(Some(Duration::from_millis(250))));
        assert_eq!(s("1.5s"), Ok(Some(Duration::from_millis(1500))));
        assert_eq!(s(" 2s "), Ok(Some(Duration::from_secs(2))));
        assert_eq!(s("none"), Ok(None));
        assert_eq!(s("10000000s"), Ok(Some(Duration::from_secs(10_000_000))));
        for bad in
            ["-1s", "nans", "NaNms", "infs", "-infs", "0s", "1e23s", "10000001s", "", "soon", "1e400ms", "s", "ms"]
        {
            let e = s(bad).expect_err("refused");
            assert!(e.starts_with("--time-budget "), "{e}");
            assert!(e.contains("expected a positive time"), "{e}");
        }
        let e = s(&"9".repeat(1000)).expect_err("refused");
        assert!(e.len() < 200, "the message shows a short prefix: {e}");
    }

    /// `--budget 2` was milliseconds and `--time-budget 2` seconds: a bare number is
    /// refused by both, with the two readings spelled out.
    #[test]
    fn a_bare_number_is_refused_by_every_duration_flag() {
        let budget = crate::modes::guided::parse_budget;
        let time = |x| time_budget(x).map(|t| t.0);
        for (flag, e) in [("--budget", budget("2")), ("--time-budget", time("2"))] {
            let e = e.expect_err("a bare number is refused");
            assert!(e.starts_with(&format!("{flag} 2: ")), "{e}");
            assert!(e.contains("needs a unit: write 2s or 2000ms"), "{e}");
        }
        let e = budget("0.5").expect_err("refused");
        assert!(e.contains("write 0.5s or 500ms"), "{e}");
        assert_eq!(budget("150ms"), Ok(Some(Duration::from_millis(150))));
        assert_eq!(budget("none"), Ok(None));
    }
}
