//! `mdgc import FILE.cfdg|FILE.es [-o OUT.mdg] [--report R.json] [--size PX]`:
//! translate a Context Free or Structure Synth program into an MDG grammar
//! ([`mdg_compiler::importer`]), print the report of what was approximated or left
//! out on stderr, and check that the grammar compiles.

use crate::failure::Failure;
use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze_text;
use mdg_compiler::importer::{self, Dialect};
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

/// Translate a Context Free (.cfdg) or Structure Synth (.es) program into MDG.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The program: FILE.cfdg (Context Free 2 or 3) or FILE.es (Structure Synth).
    pub file: PathBuf,
    /// Where to write the MDG grammar (default: standard output).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The side in pixels of the picture whose minimum size (0.3 px, or
    /// `CF::MinimumSize`) becomes `minsize`, as `cfdg -s PX` (Context Free only).
    #[arg(long, default_value_t = 500)]
    pub size: u32,
    /// The size of one pixel in model units, instead of finding it by evaluating
    /// the grammar (Context Free programs without `CF::Size`).
    #[arg(long)]
    pub pixel: Option<f64>,
    /// At most this many rule calls in each evaluation that sizes the picture.
    #[arg(long, default_value_t = 2_000_000)]
    pub calibration_calls: u64,
    #[command(flatten)]
    pub compile: crate::args::CompileArgs,
}

pub fn run(args: Args) -> ExitCode {
    let Some(dialect) = Dialect::of_path(&args.file) else {
        return Failure::usage(format!(
            "{}: expected a .cfdg (Context Free) or .es (Structure Synth) file",
            args.file.display()
        ))
        .report("mdgc import");
    };
    if args.size == 0 {
        return Failure::usage("--size must be at least 1 pixel").report("mdgc import");
    }
    if let Some(p) = args.pixel {
        if !(p.is_finite() && p > 0.0) {
            return Failure::usage(format!("--pixel {p}: expected a positive size in model units"))
                .report("mdgc import");
        }
    }
    let text = match std::fs::read(&args.file) {
        Ok(b) => String::from_utf8_lossy(&b).into_owned(),
        Err(e) => return Failure::usage(format!("cannot read {}: {e}", args.file.display())).report("mdgc import"),
    };
    let compile = match args.compile.options() {
        Ok(o) => o,
        Err(e) => return Failure::usage(e).report("mdgc import"),
    };
    let dir = args.file.parent().map(|p| p.to_path_buf()).unwrap_or_default();
    let read_dir = dir.clone();
    let read = move |name: &str| -> Option<String> {
        let p = read_dir.join(name);
        std::fs::read(&p).ok().map(|b| String::from_utf8_lossy(&b).into_owned())
    };
    let file = args.file.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let opts = importer::Options { pixels: f64::from(args.size), pixel: args.pixel };
    // The grammar is evaluated where the output will be, so its imports resolve.
    let out_dir = args.output.as_ref().and_then(|o| o.parent().map(|p| p.to_path_buf())).unwrap_or(dir);
    let out_dir = if out_dir.as_os_str().is_empty() { PathBuf::from(".") } else { out_dir };
    let measure = |mdg: &str| crate::importing::measure(mdg, &out_dir, &compile, args.calibration_calls);
    let imp = importer::calibrate(&file, &text, dialect, &opts, &read, &measure);
    eprint!("{}", mdg_compiler::diag::escape_text(&imp.report.to_text()));
    let n = imp.report.notes.len();
    eprintln!("mdgc import: {n} construct{} approximated or left out", if n == 1 { "" } else { "s" });
    if let Some(r) = &args.report {
        if let Err(e) = mdg_export::write_atomic(r, imp.report.to_json().as_bytes()) {
            return Failure::usage(format!("cannot write {}: {e}", r.display())).report("mdgc import");
        }
    }
    match &args.output {
        Some(o) => {
            if let Err(e) = mdg_export::write_atomic(o, imp.mdg.as_bytes()) {
                return Failure::usage(format!("cannot write {}: {e}", o.display())).report("mdgc import");
            }
            eprintln!("wrote {}", o.display());
        }
        None => print!("{}", imp.mdg),
    }
    // The translation is only useful if it compiles: say so when it does not.
    let path = out_dir.join("imported.mdg");
    let a = analyze_text(&FsLoader, &path, &imp.mdg, &compile, CheckOptions { require_start: true });
    if a.has_errors() {
        eprint!("{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
        return Failure::input("the imported grammar does not compile (errors above)").report("mdgc import");
    }
    ExitCode::SUCCESS
}
