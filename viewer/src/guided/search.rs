//! One guided search as the viewer runs it: prepare the guides, search with the
//! `search` section's settings (its time budget included: the viewer is the
//! interactive use the budget is for), run the geometry phase, and add the bones as
//! overlay lines (namespace `bones`). The guides themselves are drawn from the
//! editor's current state ([`super::edit::Editor::overlay`]), so a dragged curve
//! follows the cursor before the search for it has finished.

use mdg_guided::cost::Cost;
use mdg_guided::measure::{beyond_reach, Reach};
use mdg_guided::{Cancel, Guide, GuidedTable, Prepared, SearchOptions, Stop, Utilisation, REACH_SAMPLES};
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::eval::EvalOptions;
use mdg_vm::output::{Output, Polyline};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// Overlay namespace of the skeleton's bones (cyan in the viewer).
pub const NS_BONES: &str = "bones";

/// Searches of at most this many scheduled particle-steps run on one thread (the
/// std tree's default search has 5,750).
pub const ONE_THREAD_STEPS: u64 = 20_000;

/// What to search.
#[derive(Clone)]
pub struct SearchRequest {
    pub bundle: Arc<Bundle>,
    pub guides: Vec<Guide>,
    /// The search's seed (and the geometry phase's).
    pub seed: u64,
    /// The geometry phase's limits (the command line's).
    pub eval: EvalOptions,
    /// The utilisation term, when not the `search` section's (`L` in the window).
    pub utilisation: Option<Utilisation>,
    /// The grammar's reach (for the unreachable-guide warning): estimated by the
    /// first search of a bundle and shared by the later ones (a new bundle gets a
    /// new cell).
    pub reach: Arc<OnceLock<Reach>>,
}

/// What a search found, in words and numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub cost: Cost,
    /// The generation the model was taken from.
    pub model_generation: u32,
    /// Generations run, of those scheduled.
    pub generations: u32,
    pub scheduled: u32,
    pub stop: Stop,
    pub n_bones: usize,
    pub seed: u64,
    /// The utilisation term searched with.
    pub utilisation: Utilisation,
    /// Guide parts beyond the grammar's reach (each also a warning of the output).
    pub unreachable: usize,
}

impl Summary {
    /// Why the search stopped, in words.
    pub fn stop_text(&self) -> &'static str {
        match self.stop {
            Stop::Generations => "all generations ran",
            Stop::Budget => "cut by the time budget",
            Stop::Complete => "nothing left to expand",
            Stop::Cancelled => "cancelled",
        }
    }

    /// One line for the title bar and the log: the final cost and its three terms,
    /// the generation of the model and why the search stopped.
    pub fn line(&self) -> String {
        let budget = if self.stop == Stop::Budget {
            format!(" after {} of {} generations", self.generations, self.scheduled)
        } else {
            String::new()
        };
        format!(
            "cost {:.2} = distance {:.2} + alignment {:.2} + utilisation {:.2}; model from generation {}; {}{budget}; \
             seed {}; utilisation {}{}",
            self.cost.total(),
            self.cost.d,
            self.cost.a,
            self.cost.u,
            self.model_generation,
            self.stop_text(),
            self.seed,
            self.utilisation.name(),
            match self.unreachable {
                0 => String::new(),
                1 => "; a guide part beyond the grammar's reach (see the log)".to_string(),
                n => format!("; {n} guide parts beyond the grammar's reach (see the log)"),
            }
        )
    }
}

/// Where a search's time went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Preparing the guides (and the EXPECTED estimate).
    pub prepare: Duration,
    pub search: Duration,
    /// The geometry phase.
    pub geometry: Duration,
}

/// A finished search: the model's output (geometry plus the bones as lines in
/// [`NS_BONES`]), what it found and how long it took.
pub struct Searched {
    pub output: Output,
    pub summary: Summary,
    pub timings: Timings,
}

/// Why a search gave no model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SearchError {
    /// The grammar has no `search` section.
    NoSection,
    /// The grammar's `search` section does not decode or verify.
    Section(mdg_vm::bundle::SectionError),
    /// The guides cannot be searched (they do not fit in memory or time): the
    /// search's message.
    Guides(String),
    /// The search panicked (a bug); the search thread goes on.
    Panicked,
}

impl std::fmt::Display for SearchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SearchError::NoSection => write!(f, "the grammar has no `search` section"),
            SearchError::Section(e) => write!(f, "{e}"),
            SearchError::Guides(why) => write!(f, "{why}"),
            SearchError::Panicked => write!(f, "internal error: the guided search panicked"),
        }
    }
}

impl std::error::Error for SearchError {}

/// Runs one search; stops early when `cancel` is set. The error says what was
/// wrong (no `search` section, guides that do not fit in memory, …).
pub fn run_search(req: &SearchRequest, cancel: &Cancel) -> Result<Searched, SearchError> {
    let b = &*req.bundle;
    let table = &GuidedTable::from_bundle(b).map_err(SearchError::Section)?.ok_or(SearchError::NoSection)?;
    let t0 = Instant::now();
    let mut opts = SearchOptions::from_settings(&table.settings, req.seed);
    opts.clock = Some(t0);
    opts.cancel = Some(cancel.clone());
    // An interactive-size search runs on this thread: handing each of its small
    // generations to a team costs more than it saves when the cores are shared (with
    // the renderer's, on a CPU driver, or other work), and results do not depend on
    // the number of threads (docs/decisions.md, issue 19).
    if opts.scheduled_steps() <= ONE_THREAD_STEPS {
        opts.threads = Some(1);
    }
    let deadline = opts.budget.and_then(|d| t0.checked_add(d));
    let mut prepared =
        Prepared::new_within(b, table, &req.guides, deadline).map_err(|e| SearchError::Guides(e.to_string()))?;
    if let Some(u) = req.utilisation {
        prepared = prepared.with_utilisation(u);
    }
    prepared.check_size(&opts).map_err(|e| SearchError::Guides(e.to_string()))?;
    let prepare = t0.elapsed();
    let t1 = Instant::now();
    let result = prepared.search(&opts, None);
    let search = t1.elapsed();
    let t2 = Instant::now();
    let eval = EvalOptions { seed: Some(req.seed), ..req.eval.clone() };
    let mut output = prepared.geometry(&result.model, &eval, false);
    let f = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32];
    output.lines.extend(result.model.bones.iter().map(|bone| Polyline {
        namespace: NS_BONES.into(),
        points: vec![f(bone.base), f(bone.tip)],
        bones: vec![],
    }));
    let reach = req.reach.get_or_init(|| prepared.reach(REACH_SAMPLES, opts.generations));
    let unreached = beyond_reach(prepared.guides(), reach);
    output
        .stats
        .warnings
        .extend(unreached.iter().map(|u| format!("guided search: {}", u.message(prepared.guides(), reach))));
    let geometry = t2.elapsed();
    Ok(Searched {
        output,
        summary: Summary {
            cost: result.model.cost,
            model_generation: result.model_generation,
            generations: result.generations,
            scheduled: opts.generations,
            stop: result.stop,
            n_bones: result.model.bones.len(),
            seed: req.seed,
            utilisation: prepared.guides().utilisation,
            unreachable: unreached.len(),
        },
        timings: Timings { prepare, search, geometry },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_line_names_the_cost_terms_the_generation_and_the_stop() {
        let s = Summary {
            cost: Cost { d: 10.5, a: -2.25, u: -48.0 },
            model_generation: 18,
            generations: 100,
            scheduled: 100,
            stop: Stop::Generations,
            n_bones: 18,
            seed: 2,
            utilisation: Utilisation::Local,
            unreachable: 0,
        };
        assert_eq!(
            s.line(),
            "cost -39.75 = distance 10.50 + alignment -2.25 + utilisation -48.00; model from generation 18; \
             all generations ran; seed 2; utilisation local"
        );
        let cut = Summary { stop: Stop::Budget, generations: 40, ..s.clone() };
        assert!(cut.line().contains("cut by the time budget after 40 of 100 generations"), "{}", cut.line());
        let far = Summary { unreachable: 2, ..s };
        assert!(far.line().ends_with("; 2 guide parts beyond the grammar's reach (see the log)"), "{}", far.line());
    }
}
