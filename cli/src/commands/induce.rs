//! `mdgc induce EXAMPLE…`: induce a grid grammar from example buildings.

use crate::failure::{Exit, Failure};
use std::path::PathBuf;
use std::process::ExitCode;

/// Induce a grid grammar from example buildings (.txt, .vox, .nbt, .schem) and
/// write it as MDG source (see docs/grid.md).
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  mdgc induce house.txt -o style.mdg\n  \
                        mdgc induce a.nbt b.nbt --spec 2d --alpha 0.5 --ops merge --overlap -o style.mdg")]
pub struct Args {
    /// Example buildings (one grammar for all: a shared style).
    #[arg(required = true)]
    pub examples: Vec<PathBuf>,
    /// Shape specification: rect (filled rectangles in a plane), 2d (connected, in a plane) or 3d.
    #[arg(long, default_value = "rect", value_name = "rect|2d|3d")]
    pub spec: String,
    /// Weight of the number of shapes in the cost (≥ 0).
    #[arg(long, default_value_t = mdg_grid::infer::DEFAULT_ALPHA)]
    pub alpha: f64,
    /// Hill-climbing operations.
    #[arg(long, default_value = "both", value_name = "merge|split|both")]
    pub ops: String,
    /// Keep overlapping shapes (every block is covered either way).
    #[arg(long)]
    pub overlap: bool,
    /// Cost: `sum` = α·(1 + #S) + Σ entropy (the paper's reference implementation, which made its
    /// tables and pictures), `kinds` = α·(1 + #S) + Σ entropy·kinds (the reference's second cost),
    /// `product` = (1 + #S)^α · Σ entropy (the paper's equation 4 as printed; α has no effect).
    #[arg(long, default_value = "sum", value_name = "sum|kinds|product")]
    pub cost: String,
    /// After the search, cut shapes along the floors and walls they touch (the reference's post-split).
    #[arg(long)]
    pub post_split: bool,
    /// With several examples: cut the largest piece (at least N blocks) two shapes of different
    /// examples have in common out of both, so they match and share rules (sub-shape matching;
    /// 0 turns it off).
    #[arg(long, default_value_t = mdg_compiler::induce::DEFAULT_SHARE, value_name = "N")]
    pub share: usize,
    /// The grammar's name (default: the first example's file name).
    #[arg(long)]
    pub name: Option<String>,
    /// Write every shape in full and every match as a `match` line (by default each class of
    /// matching shapes is written once, its other members as `like` references).
    #[arg(long)]
    pub full: bool,
    /// Seeds the summary generates and measures (complete, distinct, block kinds; seeds 1 to N with the
    /// grammar's generate settings); 0 skips the summary (the large GDMC towers take seconds).
    #[arg(long, default_value_t = mdg_grid::assess::SEEDS, value_name = "N")]
    pub summary_seeds: u64,
    /// The grammar source to write.
    #[arg(short, long, value_name = "STYLE.mdg")]
    pub output: PathBuf,
}

/// The most seeds `--summary-seeds` generates.
pub const MAX_SUMMARY_SEEDS: u64 = 1000;

/// `mdgc induce`: infer shapes, induce the grammar, write it, and check that the
/// written source compiles back to the same grammar.
pub fn run(args: Args) -> ExitCode {
    let Args { examples, spec, alpha, ops, overlap, cost, post_split, share, name, full, summary_seeds, output } = args;
    let (examples, spec, ops, cost, name, output) =
        (&examples[..], spec.as_str(), ops.as_str(), cost.as_str(), name.as_deref(), output.as_path());
    use mdg_grid::infer::{Cost, InferOptions, Ops, Spec};
    let usage = |m: String| Failure::usage(m).report("mdgc induce");
    let Some(spec) = Spec::parse(spec) else { return usage(format!("--spec {spec}: expected rect, 2d or 3d")) };
    let Some(ops) = Ops::parse(ops) else { return usage(format!("--ops {ops}: expected merge, split or both")) };
    let Some(cost) = Cost::parse(cost) else { return usage(format!("--cost {cost}: expected sum, kinds or product")) };
    if summary_seeds > MAX_SUMMARY_SEEDS {
        return usage(format!("--summary-seeds {summary_seeds}: at most {MAX_SUMMARY_SEEDS}"));
    }
    if !(alpha.is_finite() && alpha >= 0.0) {
        return usage(format!("--alpha {alpha}: expected a number ≥ 0"));
    }
    let opts = InferOptions { spec, alpha, ops, overlap, cost, post_split };
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
    let mut progress = |i: usize, p: mdg_grid::infer::Progress| {
        if i != last {
            bar.set_position(i as u64);
            last = i;
        }
        let file =
            files.get(i).and_then(|f| f.file_name()).map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
        bar.set_message(format!("{file}: pass {}, {} shapes, cost {:.2}", p.pass, p.shapes, p.cost));
    };
    let result = mdg_compiler::induce::read_examples(&files).and_then(|(models, notes)| {
        for n in notes {
            bar.suspend(|| eprintln!("warning: {n}"));
        }
        mdg_compiler::induce::induce_models(&models, &opts, share, &name, &mut progress)
    });
    bar.finish_and_clear();
    let (grammar, reports) = match result {
        Ok(r) => r,
        Err(e) => return Failure::from(e).report("mdgc induce"),
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
        if r.shared_cuts > 0 {
            eprintln!("  {} of its shapes cut to share a piece with another example", r.shared_cuts);
        }
    }
    // --spec 3d whose solid shapes match nothing makes a grammar that can only rebuild
    // the example: refused, saying why and what to use.
    if spec == Spec::Solid && grammar.matches.is_empty() {
        eprintln!(
            "mdgc induce: --spec 3d found {} solid shape{} and none matches another (a connected solid shape spans \
             whole walls, rooms or the whole building, so no two are alike): the grammar could only rebuild the \
             example{} and is not written; use --spec rect (the default: walls, floors and roofs as rectangles that \
             repeat) or --spec 2d",
            grammar.shapes.len(),
            if grammar.shapes.len() == 1 { "" } else { "s" },
            if examples.len() > 1 { "s" } else { "" }
        );
        return Exit::Input.into();
    }
    // What the grammar does: moves, shapes, matches, and what ten seeds generate.
    use mdg_grid::{assess, build};
    let moves: usize = reports.iter().map(|r| r.merges + r.splits).sum();
    let gen_opts =
        mdg_grid::generate::GenerateOptions { seed: 0, ..mdg_grid::generate::GenerateOptions::for_grammar(&grammar) };
    let variety = (summary_seeds > 0).then(|| build::variety(&grammar, &gen_opts, summary_seeds));
    match &variety {
        Some(Ok(v)) => eprintln!(
            "summary: {moves} moves, {} shapes, {} matches, {} rules; seeds 1–{} (the grammar's generate settings) give {} distinct \
             buildings, {} complete (enclosed where the example is, one piece, ≥ {:.0}% of its blocks), {} with all \
             its block kinds",
            grammar.shapes.len(),
            grammar.matches.len(),
            grammar.rules.len(),
            v.seeds,
            v.distinct,
            v.complete,
            assess::COMPLETE_FRACTION * 100.0,
            v.all_kinds
        ),
        Some(Err(e)) => eprintln!("warning: the grammar could not be generated to measure it: {e}"),
        None => eprintln!(
            "summary: {moves} moves, {} shapes, {} matches, {} rules; no seeds generated (--summary-seeds 0)",
            grammar.shapes.len(),
            grammar.matches.len(),
            grammar.rules.len()
        ),
    }
    for r in &reports {
        if r.merges + r.splits == 0 {
            eprintln!(
                "warning[{}]: {}: no move made: the shapes are the initial segmentation; try --alpha below 1 or \
                 --cost kinds",
                assess::W_NO_MOVE,
                r.name
            );
        }
    }
    if grammar.matches.is_empty() {
        eprintln!(
            "warning[{}]: no match: no shape matches another, so this grammar only rebuilds the example{} (parts \
             of it); try --alpha below 1, --ops merge, --cost kinds or another --spec",
            assess::W_NO_MATCH,
            if examples.len() > 1 { "s" } else { "" },
        );
    }
    if let Some(Ok(v)) = &variety {
        if v.distinct <= 1 && v.seeds > 1 {
            eprintln!(
                "warning[{}]: seeds give identical outputs: all {} seeds generate the same building",
                assess::W_SAME_OUTPUT,
                v.seeds
            );
        }
    }
    if examples.len() > 1 {
        let shared = mdg_grid::induce::shared_shapes(&grammar);
        eprintln!("shared style: {shared} of {} shapes match a shape of another example", grammar.shapes.len());
        if shared == 0 {
            eprintln!(
                "warning: no shape of one example matches a shape of another, so the grammar is the examples' \
                 grammars side by side (no shared style); try a smaller --share, --overlap, another --alpha or --spec"
            );
        }
    }
    let args: Vec<String> = examples.iter().map(|p| p.display().to_string()).collect();
    let comment = vec![
        format!(
            "Induced by `mdgc induce {} --spec {} --alpha {alpha} --ops {} --cost {}{}{}{}`.",
            args.join(" "),
            spec.name(),
            ops.name(),
            cost.name(),
            if overlap { " --overlap" } else { "" },
            if post_split { " --post-split" } else { "" },
            if share != mdg_compiler::induce::DEFAULT_SHARE { format!(" --share {share}") } else { String::new() }
        ),
        format!(
            "{} shapes, {} matches, {} rules. Generate: mdg-run {} --steps 50 --seed 1 -o house.vox",
            grammar.shapes.len(),
            grammar.matches.len(),
            grammar.rules.len(),
            output.display()
        ),
    ];
    // The written source must fit a source file and compile back to the same grammar.
    let text = match mdg_compiler::induce::write_checked_with(&grammar, &comment, output, !full) {
        Ok(t) => t,
        Err(e) => return Failure::from(e).report("mdgc induce"),
    };
    if let Err(e) = mdg_export::write_atomic(output, text.as_bytes()) {
        return Failure::usage(format!("cannot write {}: {e}", output.display())).report("mdgc induce");
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
