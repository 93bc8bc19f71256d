//! `mdgc`: check, format and build MDG grammars.
//!
//! Exit codes: 0 clean (warnings allowed), 1 errors found (or `fmt --check` found
//! unformatted files), 2 usage or IO errors.

use clap::{Parser, Subcommand, ValueEnum};
use mdg_compiler::check::CheckOptions;
use mdg_compiler::diag::{render_json, render_plain};
use mdg_compiler::driver::{self, analyze};
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "mdgc", version, about = "The MDG compiler: check, format and build shape grammars")]
#[command(
    after_help = "Examples:\n  mdgc check std/examples/tree.mdg\n  mdgc check --message-format json a.mdg b.mdg\n  mdgc fmt --check std/*.mdg"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum MessageFormat {
    Human,
    Json,
}

#[derive(clap::Args)]
struct CommonOpts {
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value = "human")]
    message_format: MessageFormat,
    #[command(flatten)]
    compile: mdg_compiler::cli::CompileArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Report every diagnostic in the given files.
    Check {
        files: Vec<PathBuf>,
        /// Check as a program: require a `startshape`.
        #[arg(long)]
        program: bool,
        #[command(flatten)]
        common: CommonOpts,
    },
    /// Compile a program to a bundle (`.mdgb`).
    Build {
        file: PathBuf,
        /// Output bundle (default: beside the input, `.mdgb`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        common: CommonOpts,
    },
    /// Print a bundle (or a program, compiled first) as readable text.
    Disasm { file: PathBuf },
    /// Induce a grid grammar from example buildings (.txt, .vox, .nbt, .schem) and
    /// write it as MDG source (see docs/grid.md).
    #[command(after_help = "Examples:\n  mdgc induce house.txt -o style.mdg\n  \
                            mdgc induce a.nbt b.nbt --spec 2d --alpha 0.5 --ops merge --overlap -o style.mdg")]
    Induce {
        /// Example buildings (one grammar for all: a shared style).
        #[arg(required = true)]
        examples: Vec<PathBuf>,
        /// Shape specification: rect (filled rectangles in a plane), 2d (connected, in a plane) or 3d.
        #[arg(long, default_value = "rect", value_name = "rect|2d|3d")]
        spec: String,
        /// Weight of the number of shapes in the cost (≥ 0).
        #[arg(long, default_value_t = 1.0)]
        alpha: f64,
        /// Hill-climbing operations.
        #[arg(long, default_value = "both", value_name = "merge|split|both")]
        ops: String,
        /// Keep overlapping shapes (every block is covered either way).
        #[arg(long)]
        overlap: bool,
        /// Cost: `product` = (1 + #S)^α · Σ entropy (the paper's equation), `sum` = α·(1 + #S) + Σ entropy
        /// (the paper's reference implementation).
        #[arg(long, default_value = "product", value_name = "product|sum")]
        cost: String,
        /// The grammar's name (default: the first example's file name).
        #[arg(long)]
        name: Option<String>,
        /// The grammar source to write.
        #[arg(short, long, value_name = "STYLE.mdg")]
        output: PathBuf,
    },
    /// Format files in place (or check that they are formatted).
    Fmt {
        files: Vec<PathBuf>,
        /// Do not write; exit 1 if any file would change.
        #[arg(long)]
        check: bool,
    },
}

fn options(common: &CommonOpts) -> Result<Options, String> {
    common.compile.options()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { files, program, common } => {
            if files.is_empty() {
                eprintln!("mdgc check: no files given");
                return ExitCode::from(2);
            }
            let opts = match options(&common) {
                Ok(o) => o,
                Err(e) => {
                    eprintln!("mdgc: {e}");
                    return ExitCode::from(2);
                }
            };
            let mut errors = false;
            for f in &files {
                let a = analyze(&FsLoader, f, &opts, CheckOptions { require_start: program });
                emit(&a, common.message_format);
                errors |= a.has_errors();
            }
            if errors {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            }
        }
        Command::Build { file, output, common } => {
            let opts = match options(&common) {
                Ok(o) => o,
                Err(e) => {
                    eprintln!("mdgc: {e}");
                    return ExitCode::from(2);
                }
            };
            match driver::build(&FsLoader, &file, &opts) {
                Ok((bundle, a)) => {
                    emit(&a, common.message_format);
                    let out = output.unwrap_or_else(|| file.with_extension("mdgb"));
                    let bytes = mdg_vm::bundle::encode(&bundle);
                    if let Err(e) = write_atomic(&out, &bytes) {
                        eprintln!("mdgc build: cannot write {}: {e}", out.display());
                        return ExitCode::from(2);
                    }
                    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
                    ExitCode::SUCCESS
                }
                Err(a) => {
                    emit(&a, common.message_format);
                    ExitCode::from(1)
                }
            }
        }
        Command::Disasm { file } => {
            let bundle = if file.extension().is_some_and(|e| e == "mdgb") {
                let bytes = match std::fs::read(&file) {
                    Ok(b) => b,
                    Err(e) => {
                        eprintln!("mdgc disasm: cannot read {}: {e}", file.display());
                        return ExitCode::from(2);
                    }
                };
                match mdg_vm::bundle::load(&bytes) {
                    Ok(b) => b,
                    Err(e) => {
                        eprintln!("mdgc disasm: {}: {e}", file.display());
                        return ExitCode::from(1);
                    }
                }
            } else {
                let opts = Options { std_dir: driver::default_std_dir(), ..Options::default() };
                match driver::build(&FsLoader, &file, &opts) {
                    Ok((b, _)) => b,
                    Err(a) => {
                        emit(&a, MessageFormat::Human);
                        return ExitCode::from(1);
                    }
                }
            };
            print!("{}", mdg_vm::bundle::disassemble(&bundle));
            ExitCode::SUCCESS
        }
        Command::Induce { examples, spec, alpha, ops, overlap, cost, name, output } => {
            induce(&examples, &spec, alpha, &ops, overlap, &cost, name.as_deref(), &output)
        }
        Command::Fmt { files, check } => {
            let mut changed = false;
            for f in &files {
                let text = match std::fs::read_to_string(f) {
                    Ok(t) => t,
                    Err(e) => {
                        eprintln!("mdgc fmt: cannot read {}: {e}", f.display());
                        return ExitCode::from(2);
                    }
                };
                let formatted = match mdg_compiler::fmt::format_source(&text) {
                    Ok(s) => s,
                    Err(e) => {
                        eprintln!("mdgc fmt: {}: not formatted, it has syntax errors:\n{e}", f.display());
                        return ExitCode::from(1);
                    }
                };
                if formatted != text {
                    changed = true;
                    if check {
                        println!("{} is not formatted", f.display());
                    } else if let Err(e) = write_atomic(f, formatted.as_bytes()) {
                        eprintln!("mdgc fmt: cannot write {}: {e}", f.display());
                        return ExitCode::from(2);
                    }
                }
            }
            if check && changed {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            }
        }
    }
}

/// `mdgc induce`: infer shapes, induce the grammar, write it, and check that the
/// written source compiles back to the same grammar.
#[allow(clippy::too_many_arguments)]
fn induce(
    examples: &[PathBuf],
    spec: &str,
    alpha: f64,
    ops: &str,
    overlap: bool,
    cost: &str,
    name: Option<&str>,
    output: &std::path::Path,
) -> ExitCode {
    use mdg_vm::grid::infer::{Cost, InferOptions, Ops, Spec};
    let usage = |m: String| {
        eprintln!("mdgc induce: {m}");
        ExitCode::from(2)
    };
    let Some(spec) = Spec::parse(spec) else { return usage(format!("--spec {spec}: expected rect, 2d or 3d")) };
    let Some(ops) = Ops::parse(ops) else { return usage(format!("--ops {ops}: expected merge, split or both")) };
    let Some(cost) = Cost::parse(cost) else { return usage(format!("--cost {cost}: expected product or sum")) };
    if !(alpha.is_finite() && alpha >= 0.0) {
        return usage(format!("--alpha {alpha}: expected a number ≥ 0"));
    }
    let opts = InferOptions { spec, alpha, ops, overlap, cost };
    let name = name.map(str::to_string).unwrap_or_else(|| {
        examples[0].file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "style".into())
    });
    let bar = indicatif::ProgressBar::new(examples.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} inferring shapes [{bar:24}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let files: Vec<&std::path::Path> = examples.iter().map(|p| p.as_path()).collect();
    let mut last = usize::MAX;
    let mut progress = |i: usize, p: mdg_vm::grid::infer::Progress| {
        if i != last {
            bar.set_position(i as u64);
            last = i;
        }
        let file =
            files.get(i).and_then(|f| f.file_name()).map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
        bar.set_message(format!("{file}: pass {}, {} shapes, cost {:.2}", p.pass, p.shapes, p.cost));
    };
    let result = mdg_compiler::induce::induce_files(&files, &opts, &name, &mut progress);
    bar.finish_and_clear();
    let (grammar, reports) = match result {
        Ok(r) => r,
        Err(e) => {
            eprintln!("mdgc induce: {e}");
            return ExitCode::from(1);
        }
    };
    for r in &reports {
        let m = &r.measures;
        eprintln!(
            "{}: {} blocks → {} shapes ({:.1}% matching, mean size {:.1}, C {:.2}); {} merges, {} splits, {:.1} ms",
            r.name,
            r.blocks,
            m.shapes,
            m.matching,
            m.size,
            m.complexity,
            r.merges,
            r.splits,
            r.seconds * 1e3
        );
    }
    let args: Vec<String> = examples.iter().map(|p| p.display().to_string()).collect();
    let comment = vec![
        format!(
            "Induced by `mdgc induce {} --spec {} --alpha {alpha} --ops {} --cost {}{}`.",
            args.join(" "),
            spec.name(),
            ops.name(),
            cost.name(),
            if overlap { " --overlap" } else { "" }
        ),
        format!(
            "{} shapes, {} matches, {} rules. Generate: mdg-run {} --steps 50 --seed 1 -o house.vox",
            grammar.shapes.len(),
            grammar.matches.len(),
            grammar.rules.len(),
            output.display()
        ),
    ];
    let text = mdg_compiler::induce::write_source(&grammar, &comment);
    // The written source must compile back to the same grammar.
    let opts = Options { std_dir: driver::default_std_dir(), ..Options::default() };
    let a = driver::analyze_text(&FsLoader, output, &text, &opts, CheckOptions { require_start: true });
    let back = if a.has_errors() {
        None
    } else {
        mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).ok().and_then(|b| b.extensions.grid)
    };
    if back.as_ref() != Some(&grammar) {
        eprint!("{}", render_plain(&a.diagnostics, &a.sources));
        eprintln!("mdgc induce: internal error: the written grammar does not compile back to the induced one");
        return ExitCode::from(1);
    }
    if let Err(e) = write_atomic(output, text.as_bytes()) {
        eprintln!("mdgc induce: cannot write {}: {e}", output.display());
        return ExitCode::from(2);
    }
    eprintln!(
        "wrote {} ({} palette entries, {} shapes, {} matches, {} rules)",
        output.display(),
        grammar.palette.len(),
        grammar.shapes.len(),
        grammar.matches.len(),
        grammar.rules.len()
    );
    ExitCode::SUCCESS
}

fn emit(a: &driver::Analysis, format: MessageFormat) {
    match format {
        MessageFormat::Human => eprint!("{}", render_plain(&a.diagnostics, &a.sources)),
        MessageFormat::Json => print!("{}", render_json(&a.diagnostics, &a.sources)),
    }
}

fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    mdg_vm::export::write_atomic(path, bytes)
}
