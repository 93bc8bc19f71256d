//! `mdg-run` on a grammar with `guide` / `search` sections: the SOSMC search, then
//! the geometry phase (docs/guided.md).

use super::Common;
use crate::failure::Failure;
use mdg_guided::measure::{beyond_reach, coverage, covered_runs};
use mdg_guided::{
    guides_from_json, GuidedTable, Prepared, Progress, Resampling, SearchOptions, Stop, Utilisation, REACH_SAMPLES,
};
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::eval::EvalOptions;
use mdg_vm::output::Output;
use std::path::PathBuf;
use std::time::Duration;

/// Guided-search options of `mdg-run`.
#[derive(clap::Args, Debug, Default)]
pub struct GuidedArgs {
    /// Guided search: guiding curves from a JSON file, replacing the program's
    /// `guide` sections (format in docs/guided.md).
    #[arg(long, value_name = "FILE.json")]
    pub guides: Option<PathBuf>,
    /// Guided search: time budget with its unit, e.g. `200ms`, `0.5s`, or `none`
    /// (a bare number is refused; the default: every generation runs, so the model is the same on any
    /// machine; the `search` section's `budget` is for interactive use, `mdg-view`).
    #[arg(long, value_name = "TIME")]
    pub budget: Option<String>,
    /// Guided search: particles in the first and the last generation, `N` or `FIRST:LAST`.
    #[arg(long, value_name = "N[:M]")]
    pub particles: Option<String>,
    /// Guided search: number of generations (`--generations` is the creature
    /// grammar's).
    #[arg(id = "search_generations", long = "search-generations", value_name = "N")]
    pub generations: Option<u32>,
    /// Guided search: starting heuristic scale (ramped to 0 over the first part of the search).
    #[arg(long, value_name = "X")]
    pub heuristic_scale: Option<f64>,
    /// Guided search: no heuristic cost (same as --heuristic-scale 0).
    #[arg(long)]
    pub no_heuristic: bool,
    /// Guided search: resampling scheme, `systematic` or `multinomial`.
    #[arg(long, value_name = "SCHEME")]
    pub resample: Option<String>,
    /// Guided search: the utilisation term, `paper` (eq. 7 as written: a bone credits
    /// every segment between the points of the guide closest to its base and its tip)
    /// or `local` (only the arc within the bone's own length of its base); overrides the
    /// `search` section's `utilisation` key (default: the key, else `local`).
    #[arg(long, value_name = "TERM")]
    pub utilisation: Option<String>,
    /// Guided search: worker threads (results are the same for any number).
    #[arg(long, value_name = "N")]
    pub search_threads: Option<usize>,
    /// Guided search: leave the guides and the bones out of the model (by default they
    /// are added as lines in namespaces `guides` and `bones`).
    #[arg(long)]
    pub no_skeleton_lines: bool,
}

impl GuidedArgs {
    /// The first search flag given, if any (they mean nothing without a `search`
    /// section).
    pub fn given(&self) -> Option<&'static str> {
        let flags = [
            (self.guides.is_some(), "--guides"),
            (self.budget.is_some(), "--budget"),
            (self.particles.is_some(), "--particles"),
            (self.generations.is_some(), "--search-generations"),
            (self.heuristic_scale.is_some(), "--heuristic-scale"),
            (self.no_heuristic, "--no-heuristic"),
            (self.resample.is_some(), "--resample"),
            (self.search_threads.is_some(), "--search-threads"),
            (self.utilisation.is_some(), "--utilisation"),
            (self.no_skeleton_lines, "--no-skeleton-lines"),
        ];
        flags.iter().find(|(on, _)| *on).map(|(_, f)| *f)
    }
}

/// Parses `--budget`: `200ms`, `0.5s` or `none`; a bare number is refused (it was
/// milliseconds here and seconds for `--time-budget`): [`crate::args::parse_duration`].
pub fn parse_budget(s: &str) -> Result<Option<Duration>, String> {
    crate::args::parse_duration("--budget", s)
}

/// Parses `--particles`: `N` or `FIRST:LAST`.
pub fn parse_particles(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("--particles {s}: expected N or FIRST:LAST, whole numbers from 1 to 1000000");
    let one = |x: &str| match x.trim().parse::<u32>() {
        Ok(v) if (1..=1_000_000).contains(&v) => Ok(v),
        _ => Err(bad()),
    };
    match s.split_once(':') {
        Some((a, b)) => Ok((one(a)?, one(b)?)),
        None => {
            let v = one(s)?;
            Ok((v, v))
        }
    }
}

/// The search options: the `search` section's, overridden by the command line.
pub fn options(settings: &mdg_guided::SearchSettings, args: &GuidedArgs, seed: u64) -> Result<SearchOptions, String> {
    let mut o = SearchOptions::from_settings(settings, seed);
    // A batch run is repeatable: a time budget only when asked for.
    o.budget = match &args.budget {
        Some(b) => parse_budget(b)?,
        None => None,
    };
    if let Some(p) = &args.particles {
        o.particles = parse_particles(p)?;
    }
    if let Some(g) = args.generations {
        if g == 0 || g > 10_000_000 {
            return Err(format!("--search-generations {g}: expected a whole number from 1 to 10000000"));
        }
        o.generations = g;
    }
    if let Some(h) = args.heuristic_scale {
        if !(h.is_finite() && h >= 0.0) {
            return Err(format!("--heuristic-scale {h}: expected a number ≥ 0"));
        }
        o.heuristic_scale = h;
    }
    if args.no_heuristic {
        o.heuristic_scale = 0.0;
    }
    if let Some(r) = &args.resample {
        o.resampling = Resampling::from_name(r)
            .ok_or_else(|| format!("--resample {r}: expected `systematic` or `multinomial`"))?;
    }
    if let Some(t) = args.search_threads {
        if t == 0 || t > 1024 {
            return Err(format!("--search-threads {t}: expected 1 to 1024"));
        }
        o.threads = Some(t);
    }
    Ok(o)
}

/// `--utilisation`, if given (it overrides the `search` section's `utilisation`).
pub fn utilisation_flag(args: &GuidedArgs) -> Result<Option<Utilisation>, String> {
    args.utilisation
        .as_deref()
        .map(|u| Utilisation::from_name(u).ok_or_else(|| format!("--utilisation {u}: expected `paper` or `local`")))
        .transpose()
}

/// Runs the search and returns the model to export, evaluated with `eval` (the
/// limits and `--sites` of the command line; the seed is the search's).
///
/// A bad flag or an unreadable guide file is a usage error (exit 2); a guide file
/// read and refused, or guides the search cannot take, errors in the input (exit 1).
pub fn run(bundle: &Bundle, args: &GuidedArgs, common: &Common, eval: &EvalOptions) -> Result<Output, Failure> {
    let table = &GuidedTable::from_bundle(bundle)
        .map_err(Failure::input)?
        .ok_or_else(|| Failure::input("the program has no `search` section"))?;
    let guides = match &args.guides {
        Some(path) => {
            let text = mdg_vm::input::read_text_bounded(path, mdg_vm::input::MAX_DATA_BYTES)
                .map_err(|e| Failure::usage(format!("cannot read {}: {e}", path.display())))?;
            guides_from_json(&text).map_err(|e| Failure::input(format!("{}: {e}", path.display())))?
        }
        None => table.guides.clone(),
    };
    let seed = common.seed.unwrap_or(bundle.settings.randseed);
    let mut opts = options(&table.settings, args, seed).map_err(Failure::usage)?;
    // A budget covers preparing the guides too.
    let clock = std::time::Instant::now();
    opts.clock = Some(clock);
    let utilisation = utilisation_flag(args).map_err(Failure::usage)?;
    let mut prepared = Prepared::new_within(bundle, table, &guides, opts.budget.and_then(|b| clock.checked_add(b)))
        .map_err(Failure::input)?;
    if let Some(u) = utilisation {
        prepared = prepared.with_utilisation(u);
    }
    prepared.check_size(&opts).map_err(Failure::input)?;
    let bar = indicatif::ProgressBar::new(opts.generations as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} generations  {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let report = |p: &Progress| {
        bar.set_position(p.generation as u64);
        bar.set_message(format!("best cost {:.3}", p.best_cost));
    };
    let result = prepared.search(&opts, Some(&report));
    bar.finish_and_clear();
    let mut warnings = Vec::new();
    for i in 0..prepared.guides().len() {
        if prepared.guides().path(i).length() < 1e-9 {
            warnings.push(format!(
                "guided search: {} has zero length: it attracts nothing (its control points coincide)",
                prepared.guides().guide(i).label(i)
            ));
        }
    }
    // Guide parts no unguided derivation came near (docs/guided.md, "Unreachable guides").
    let reach = prepared.reach(REACH_SAMPLES, opts.generations);
    for u in beyond_reach(prepared.guides(), &reach) {
        warnings.push(format!("guided search: {}", u.message(prepared.guides(), &reach)));
    }
    if result.model.bones.is_empty() {
        warnings.push(
            "guided search: the model has no bones (no skeleton rule call was expanded: check the `skeleton` rules, \
             and --budget if one was given)"
                .to_string(),
        );
    }
    let eval_opts = EvalOptions { seed: Some(seed), ..eval.clone() };
    let mut out = prepared.geometry(&result.model, &eval_opts, !args.no_skeleton_lines);
    out.stats.warnings.extend(warnings);
    if result.stop == Stop::Budget {
        out.stats.warnings.push(format!(
            "guided search: the time budget ended the search after {} of {} generations (the result depends on the \
             machine's speed; raise --budget or lower --search-generations for a repeatable one)",
            result.generations, opts.generations
        ));
    }
    if common.stats {
        let m = &result.model;
        let stop = match result.stop {
            Stop::Generations => "all generations ran",
            Stop::Budget => "time budget",
            Stop::Complete => "no pending skeleton calls",
            Stop::Cancelled => "cancelled",
        };
        eprintln!(
            "guided search: {} generations ({stop}), the model from generation {}, {} particle-steps, {} expansions, \
             {:.1} ms (+{:.1} ms preparing)",
            result.generations,
            result.model_generation,
            result.particle_steps,
            result.expansions,
            result.elapsed.as_secs_f64() * 1e3,
            prepared.prepare_time.as_secs_f64() * 1e3
        );
        eprintln!(
            "final cost {:.4} = distance {:.4} + alignment {:.4} + utilisation {:.4}; {} bones, {} wrap-ups, {} dropped",
            m.cost.total(),
            m.cost.d,
            m.cost.a,
            m.cost.u,
            m.bones.len(),
            m.wrapped,
            m.dropped
        );
        let c = coverage(prepared.guides(), &m.bones);
        let per: Vec<String> = (0..prepared.guides().len())
            .map(|i| {
                let runs: Vec<String> =
                    covered_runs(&c.covered[i]).iter().map(|(a, b)| format!("{a:.2}–{b:.2}")).collect();
                let runs = if runs.is_empty() { "none".to_string() } else { runs.join(", ") };
                format!("{} {:.2} ({runs})", prepared.guides().guide(i).label(i), c.per_guide[i])
            })
            .collect();
        eprintln!(
            "coverage {:.2} (guide points within {} of a bone; covered stretches as fractions of each guide's length): \
             {}; utilisation {}, the grammar's reach {:.2} ({} unguided derivations)",
            c.total,
            mdg_guided::measure::COVERAGE_RADIUS,
            per.join("; "),
            prepared.guides().utilisation.name(),
            reach.radius,
            reach.samples
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budgets_and_particles_parse() {
        assert_eq!(parse_budget("200ms"), Ok(Some(Duration::from_millis(200))));
        assert_eq!(parse_budget("0.5s"), Ok(Some(Duration::from_millis(500))));
        assert!(parse_budget("150").is_err_and(|e| e.contains("write 150s or 150000ms")));
        assert_eq!(parse_budget("none"), Ok(None));
        for bad in ["", "-3ms", "0", "fast", "1e30s"] {
            assert!(parse_budget(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_particles("100:15"), Ok((100, 15)));
        assert_eq!(parse_particles("40"), Ok((40, 40)));
        for bad in ["0", "10:0", "a:b", "", "5:"] {
            assert!(parse_particles(bad).is_err(), "{bad}");
        }
    }
}
