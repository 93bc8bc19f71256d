//! The guide editor's session without a window (no GPU): the std guided tree
//! compiled by the CLI's toolchain, searched in the background as the window does —
//! the newest answer wins, a cancelled search answers nothing, a reload keeps edited
//! guides and takes the grammar's new ones otherwise, a guide file's change replaces
//! them, the seed and the saved file — and `mdg-view --png` searching too.

mod common;

use common::*;
use mdg_cli::toolchain::Toolchain;
use mdg_guided::{Guide, GuidedTable};
use mdg_viewer::guided::search::NS_BONES;
use mdg_viewer::guided::session::{Accepted, Outcome, Session, SessionOptions};
use mdg_viewer::guided::worker::Preempt;
use mdg_viewer::model::{LoadOptions, Loader as _, Model};
use mdg_vm::bundle::Section;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn guided_tree(source: Option<&str>) -> Model {
    let path = match source {
        Some(text) => {
            let p = out_dir().join("session_tree.mdg");
            std::fs::write(&p, text).expect("write");
            p
        }
        None => root().join("std/examples/guided_tree.mdg"),
    };
    let opts = LoadOptions { guided_search: true, ..load_options() };
    match Toolchain.load(&path, &opts) {
        Ok((m, _)) => m,
        Err(f) => panic!("{}", f.error),
    }
}

fn session(model: &Model, save_to: &str) -> (Session, mpsc::Receiver<(u64, Outcome)>) {
    let (tx, rx) = mpsc::channel();
    let tx = Mutex::new(tx);
    let opts = SessionOptions { seed: 3, eval: Default::default(), guides: None, save_to: out_dir().join(save_to) };
    let s = Session::start(Arc::new(model.bundle.clone()), opts, move |id, out| {
        if let Ok(t) = tx.lock() {
            let _ = t.send((id, out));
        }
    })
    .expect("a session");
    (s, rx)
}

/// Hands answers to the session until it is idle; returns what it showed, last first.
fn settle(s: &mut Session, rx: &mpsc::Receiver<(u64, Outcome)>) -> Vec<(u64, Model2)> {
    let mut shown = Vec::new();
    while !s.is_idle() {
        let (id, out) = rx.recv_timeout(Duration::from_secs(60)).expect("an answer within a minute");
        match s.accept(id, out) {
            Accepted::Show(found) => {
                let (bones, cost, stop) = (bones_of(&found.output), found.summary.cost.total(), found.summary.stop);
                shown.insert(0, (id, Model2 { bones, cost, stop }))
            }
            Accepted::Failed(e) => panic!("search failed: {e}"),
            Accepted::Nothing => {}
        }
    }
    shown
}

struct Model2 {
    bones: Vec<[[f32; 3]; 2]>,
    cost: f64,
    stop: mdg_guided::Stop,
}

fn bones_of(out: &mdg_vm::output::Output) -> Vec<[[f32; 3]; 2]> {
    out.lines.iter().filter(|l| l.namespace == NS_BONES).map(|l| [l.points[0], l.points[1]]).collect()
}

#[test]
fn searches_answer_newest_first_and_cancelled_ones_show_nothing() {
    let m = guided_tree(None);
    let (mut s, rx) = session(&m, "session1.json");
    let first = s.search_now().expect("the first search");
    assert!(!bones_of(&first.output).is_empty());
    let reference =
        Model2 { bones: bones_of(&first.output), cost: first.summary.cost.total(), stop: first.summary.stop };

    // Three edits in a row, each cancelling the one before: only the newest is
    // shown, and it is what a search of the final guides gives (the search is
    // deterministic at a fixed number of generations).
    let mut guides: Vec<Guide> = s.editor.guides().to_vec();
    for k in 0..3 {
        guides[2].points[3][0] += 0.3 * (k + 1) as f64;
        assert!(s.editor.replace(guides.clone()));
        s.request(Preempt::Cancel);
    }
    let shown = settle(&mut s, &rx);
    assert!(!shown.is_empty(), "the newest search is shown");
    let (newest_id, newest) = &shown[0];
    assert_eq!(*newest_id, 3, "the third request's model is on screen");
    let mut again = Session::start(
        Arc::new(m.bundle.clone()),
        SessionOptions {
            seed: 3,
            eval: Default::default(),
            guides: Some((out_dir().join("unused.json"), guides.clone())),
            save_to: out_dir().join("unused.json"),
        },
        |_, _| {},
    )
    .expect("session");
    let direct = again.search_now().expect("search");
    // The section's 200 ms budget can cut a debug-build search on a busy machine; the
    // model then depends on where (the default model may be the final generation's).
    let all = mdg_guided::Stop::Generations;
    if newest.stop == all && direct.summary.stop == all {
        assert_eq!(newest.bones, bones_of(&direct.output), "same guides and seed, same model");
    } else {
        eprintln!("a search was cut by the time budget: the models are not compared");
    }
    assert!((newest.cost - reference.cost).abs() > 1e-9, "moving the guide changed the model");

    // Waiting requests (a drag): the running one finishes, the waiting one is
    // replaced by the newer; answers never go back to an older model.
    for k in 0..5 {
        guides[2].points[3][2] += 0.05 * (k + 1) as f64;
        s.editor.replace(guides.clone());
        s.request(Preempt::Wait);
    }
    let shown = settle(&mut s, &rx);
    let ids: Vec<u64> = shown.iter().map(|(id, _)| *id).collect();
    assert!(ids.windows(2).all(|w| w[0] > w[1]), "shown newest last: {ids:?}");
    assert_eq!(ids.first(), Some(&8), "the last request is shown");
    assert!(s.summary.is_some());
    assert!(!s.request_if_changed(Preempt::Cancel), "nothing changed since");

    // Reseeding changes the model.
    assert_eq!(s.reseed(), 4);
    s.request(Preempt::Cancel);
    let shown = settle(&mut s, &rx);
    assert_eq!(shown.len(), 1);
}

#[test]
fn reloads_keep_edited_guides_files_replace_them_and_saving_writes_a_guide_file() {
    let source = std::fs::read_to_string(root().join("std/examples/guided_tree.mdg")).expect("read");
    let m = guided_tree(Some(&source));
    let (mut s, _rx) = session(&m, "session2.json");
    assert!(!s.is_edited());
    // The grammar's trunk guide edited in its source: not edited in the window, so
    // the reload takes it.
    let moved = source.replace("points 0 0 0  0 0 1.5  0.1 0 3", "points 0 0 0  0 0 1.5  0.4 0 3");
    assert_ne!(moved, source);
    let m2 = guided_tree(Some(&moved));
    s.set_bundle(Arc::new(m2.bundle.clone()));
    assert_eq!(s.editor.guides()[0].points[2], [0.4, 0.0, 3.0]);
    assert!(!s.is_edited());
    // Edited in the window: a reload keeps the window's guides.
    s.editor.select(Some(1));
    s.editor.set_param(mdg_viewer::guided::edit::Param::DeltaA);
    s.editor.step_param(1.0).expect("stepped");
    assert!(s.is_edited());
    s.set_bundle(Arc::new(m.bundle.clone()));
    assert_eq!(s.editor.guides()[0].points[2], [0.4, 0.0, 3.0]);
    assert_eq!(s.editor.guides()[1].delta_a, 0.65);
    // A guide file's change replaces them (undoably).
    let one = vec![Guide::new("only", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]])];
    assert!(s.file_changed(one.clone()));
    assert_eq!(s.editor.guides(), &one[..]);
    assert!(!s.file_changed(one.clone()), "the same guides again change nothing");
    assert!(s.editor.undo());
    assert_eq!(s.editor.guides().len(), 3);
    // Saving writes what mdg-run --guides reads.
    let msg = s.save().expect("saved");
    assert!(msg.starts_with("saved 3 guides to "), "{msg}");
    let text = std::fs::read_to_string(out_dir().join("session2.json")).expect("the file");
    assert_eq!(mdg_guided::guides_from_json(&text).expect("valid"), s.editor.guides());
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_mdg-run"))
        .arg(root().join("std/examples/guided_tree.mdg"))
        .arg("--guides")
        .arg(out_dir().join("session2.json"))
        .args(["--format", "json", "-o"])
        .arg(out_dir().join("session2_tree.json"))
        .args(["--seed", "3", "--std"])
        .arg(root().join("std"))
        .output()
        .expect("run mdg-run");
    assert!(run.status.success(), "mdg-run --guides reads the saved file: {}", String::from_utf8_lossy(&run.stderr));
    // And grows the tree the window shows for those guides and that seed (no budget
    // cut: every generation ran).
    let shown = s.search_now().expect("search");
    assert_eq!(shown.summary.stop, mdg_guided::Stop::Generations);
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir().join("session2_tree.json")).expect("the dump"))
            .expect("JSON");
    let from_run: Vec<Vec<f64>> = dump["lines"]
        .as_array()
        .expect("lines")
        .iter()
        .filter(|l| l["namespace"] == "bones")
        .map(|l| {
            l["points"]
                .as_array()
                .expect("points")
                .iter()
                .flat_map(|p| p.as_array().expect("xyz").clone())
                .map(|v| v.as_f64().expect("number"))
                .collect()
        })
        .collect();
    let from_view: Vec<Vec<f64>> =
        bones_of(&shown.output).iter().map(|b| b.iter().flatten().map(|v| *v as f64).collect()).collect();
    assert!(!from_view.is_empty());
    assert_eq!(from_run.len(), from_view.len(), "as many bones");
    for (a, b) in from_run.iter().zip(&from_view) {
        assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5), "{a:?} vs {b:?}");
    }
}

/// `mdg-view --png` on a guided grammar runs the search first (as the window does):
/// the picture has the guides (amber) and the bones (cyan) over the tree.
#[test]
fn the_offscreen_picture_of_a_guided_grammar_is_searched() {
    if skip_vulkan() {
        return;
    }
    let png = out_dir().join("guided_view.png");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mdg-view"))
        .arg(root().join("std/examples/guided_tree.mdg"))
        .args(["--seed", "2", "--size", "400x300", "--png"])
        .arg(&png)
        .arg("--std")
        .arg(root().join("std"))
        .env("MDG_VALIDATION", "1")
        .output()
        .expect("run mdg-view");
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("mdg-view: guided search: cost ") && log.contains("seed 2"), "{log}");
    let file = std::fs::File::open(&png).expect("the picture");
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().expect("header");
    let mut px = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut px).expect("data");
    let img = Image { px, w: info.width, h: info.height };
    let cyan = img.count(|_, _, c| c[2] as i32 - c[0] as i32 > 60 && c[1] as i32 - c[0] as i32 > 40);
    let amber = img.count(|_, _, c| c[0] as i32 - c[2] as i32 > 120 && c[1] as i32 - c[2] as i32 > 60);
    assert!(cyan > 100 && amber > 100, "bones {cyan} px, guides {amber} px");
}

/// `L` in the window: the session's utilisation term cycles (the grammar's `local`
/// by default, then `paper`), the title names it, a search uses it (the same bones as
/// `mdg-run --utilisation paper` would grow: a direct search with that term), and it
/// stays through a reload. A guide beyond the grammar's reach is reported in the
/// output's warnings and the title.
#[test]
fn l_cycles_the_utilisation_term_and_far_guides_are_reported() {
    let m = guided_tree(None);
    let (mut s, _rx) = session(&m, "session_l.json");
    assert_eq!(s.utilisation(), mdg_guided::Utilisation::Local);
    let local = s.search_now().expect("a search");
    assert!(s.title().contains("; utilisation local"), "{}", s.title());
    assert_eq!(s.cycle_utilisation(), mdg_guided::Utilisation::Paper);
    let paper = s.search_now().expect("a search");
    assert!(s.title().contains("; utilisation paper"), "{}", s.title());
    assert_ne!(bones_of(&local.output), bones_of(&paper.output));
    let b = &m.bundle;
    let t = &GuidedTable::from_bundle(b).expect("a valid section").expect("table");
    let direct =
        mdg_guided::Prepared::new(b, t, &t.guides).expect("prepared").with_utilisation(mdg_guided::Utilisation::Paper);
    let mut o = mdg_guided::SearchOptions::from_settings(&t.settings, 3);
    o.budget = None;
    let r = direct.search(&o, None);
    // (Unless the section's budget cut the window's search on a busy machine.)
    if paper.summary.stop == mdg_guided::Stop::Generations {
        assert_eq!(bones_of(&paper.output).len(), r.model.bones.len());
    }
    s.set_bundle(Arc::new(m.bundle.clone()));
    assert_eq!(s.utilisation(), mdg_guided::Utilisation::Paper, "kept through a reload");
    assert!(!paper.output.stats.warnings.iter().any(|w| w.contains("reach")), "{:?}", paper.output.stats.warnings);
    // A guide up to z 12: beyond the std tree's reach.
    let tall = Guide::new("tall", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 4.0], [0.0, 0.0, 8.0], [0.0, 0.0, 12.0]]);
    s.file_changed(vec![tall]);
    let far = s.search_now().expect("a search");
    assert!(
        far.output.stats.warnings.iter().any(|w| w.starts_with("guided search: tall: ")),
        "{:?}",
        far.output.stats.warnings
    );
    assert!(s.title().contains("a guide part beyond the grammar's reach"), "{}", s.title());
}
