//! The window under Xvfb (lavapipe in CI): `mdg-view --frames 5 --screenshot`
//! opens a window, renders five frames with validation required, reads the last
//! one back from the swapchain, and closes cleanly (exit status 0; status 3 would
//! mean validation errors). The screenshot must show the model. And hot reload in
//! the window on a private Xvfb: a good edit reloads keeping the camera, a broken
//! one prints its diagnostics and keeps the model, SIGINT closes cleanly.
//! And the guide editor as a person uses it: a `--script` drags a control point of
//! the std guided tree's guide and saves the guides; the saved file, the point and
//! the bones in the screenshots are checked.
//! X11 and signals: Unix only.
#![cfg(unix)]

mod common;

use common::*;
use std::process::Command;

/// A command running `bin` on a private X server (`xvfb-run`), which keeps the test
/// off the developer's screen and works without one; a display of our own is the
/// fallback.
fn on_an_x_server(bin: &str) -> Command {
    if have("xvfb-run") {
        let mut c = Command::new("xvfb-run");
        c.args(["-a", "-s", "-screen 0 1024x768x24", bin]);
        c
    } else if std::env::var_os("DISPLAY").is_some() {
        Command::new(bin)
    } else {
        panic!(
            "no X server for the window test: run `bash .ci/run` (it installs xvfb), or set MDG_SKIP_VULKAN_TESTS=1"
        );
    }
}

/// Whether a program is on PATH.
fn have(program: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(program).is_file()))
}

#[test]
fn window_opens_renders_frames_and_closes_cleanly() {
    if skip_vulkan() {
        return;
    }
    let bin = env!("CARGO_BIN_EXE_mdg-view");
    let shot = out_dir().join("window_screenshot.png");
    let _ = std::fs::remove_file(&shot);
    let args = [
        data("red_blue_cubes.mdg").display().to_string(),
        "--frames".into(),
        "5".into(),
        "--screenshot".into(),
        shot.display().to_string(),
        "--no-watch".into(),
        "--size".into(),
        "640x480".into(),
        "--std".into(),
        root().join("std").display().to_string(),
    ];
    let mut cmd = on_an_x_server(bin);
    let out = cmd.args(&args).env("MDG_VALIDATION", "1").output().expect("run mdg-view");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "mdg-view failed ({:?}):\n{stderr}", out.status);
    assert!(stderr.contains("closed cleanly after 5 frames"), "{stderr}");
    assert!(!stderr.contains("validation error"), "{stderr}");

    let file = std::fs::File::open(&shot).expect("the screenshot was written");
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().expect("PNG header");
    let mut px = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut px).expect("PNG data");
    assert_eq!((info.width, info.height), (640, 480), "the window's size");
    let img = Image { px, w: info.width, h: info.height };
    // The model is there: red on the left half, blue on the right, white around.
    let red_left = img.count(|x, _, c| x < 320 && reddish(c));
    let blue_right = img.count(|x, _, c| x >= 320 && bluish(c));
    let wrong_side = img.count(|x, _, c| (x >= 320 && reddish(c)) || (x < 320 && bluish(c)));
    let background = img.count(|_, _, c| white(c));
    assert!(red_left > 2000 && blue_right > 2000, "red {red_left} px, blue {blue_right} px");
    assert_eq!(wrong_side, 0);
    assert!(background > 640 * 480 / 2, "white background {background} px");
}

/// An X server of our own (`Xvfb -displayfd`), killed when dropped.
struct Xvfb {
    child: std::process::Child,
    display: String,
}

impl Xvfb {
    fn start() -> Xvfb {
        use std::io::Read;
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("start Xvfb (run `bash .ci/run` to install it)");
        // Xvfb writes the display number it chose, then a newline, when ready.
        let mut out = child.stdout.take().expect("Xvfb stdout");
        let mut number = String::new();
        let mut byte = [0u8; 1];
        while out.read(&mut byte).unwrap_or(0) == 1 && byte[0] != b'\n' {
            number.push(byte[0] as char);
        }
        assert!(!number.trim().is_empty(), "Xvfb did not report a display");
        Xvfb { child, display: format!(":{}", number.trim()) }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn window_hot_reload_keeps_the_last_good_model_and_closes_on_sigint() {
    if skip_vulkan() {
        return;
    }
    assert!(have("Xvfb"), "no Xvfb for the window test: run `bash .ci/run`, or set MDG_SKIP_VULKAN_TESTS=1");
    let x = Xvfb::start();
    let dir = out_dir().join("window-reload");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("mkdir");
    let grammar = dir.join("scene.mdg");
    let original = std::fs::read_to_string(data("red_blue_cubes.mdg")).expect("read");
    std::fs::write(&grammar, &original).expect("write");
    let shot = dir.join("after_reload.png");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mdg-view"))
        .arg(&grammar)
        .args(["--size", "320x240", "--screenshot"])
        .arg(&shot)
        .arg("--std")
        .arg(root().join("std"))
        .env("DISPLAY", &x.display)
        .env("MDG_VALIDATION", "1")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run mdg-view");
    // Lines of stderr, as they come.
    let stderr = child.stderr.take().expect("stderr");
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut log = String::new();
    let wait_for = |needle: &str, log: &mut String| {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while std::time::Instant::now() < deadline {
            if let Ok(line) = rx.recv_timeout(std::time::Duration::from_millis(200)) {
                log.push_str(&line);
                log.push('\n');
                if line.contains(needle) {
                    return;
                }
            }
        }
        panic!("no `{needle}` from mdg-view within 60 s:\n{log}");
    };
    wait_for("triangles", &mut log);
    // Give the watcher a moment, then add a green cube on top (3 cubes, 36 triangles).
    std::thread::sleep(std::time::Duration::from_millis(300));
    std::fs::write(
        &grammar,
        original.replace("cube {x 1.5 R -1 G -1}", "cube {x 1.5 R -1 G -1}\n  cube {z 2 R -1 B -1}"),
    )
    .expect("edit");
    wait_for("reloaded: 36 triangles", &mut log);
    // A broken edit: the diagnostics are printed, the three cubes stay.
    std::fs::write(&grammar, original.replace("cube {x 1.5 R -1 G -1}", "nosuchrule {}")).expect("edit");
    wait_for("reload failed", &mut log);
    wait_for("E0301", &mut log);
    // Ctrl-C: a clean close that writes the screenshot first.
    // (`kill`, not libc: the CLI crate denies unsafe code like every crate but the viewer.)
    let sent = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("run kill");
    assert!(sent.success(), "kill -INT failed");
    let exit = child.wait().expect("mdg-view exits");
    let _ = reader.join();
    for line in rx.try_iter() {
        log.push_str(&line);
        log.push('\n');
    }
    assert!(exit.success(), "mdg-view exited with {exit:?}:\n{log}");
    assert!(log.contains("closed cleanly") && log.contains("(1 reloads)"), "{log}");
    assert!(!log.contains("validation error"), "{log}");
    let file = std::fs::File::open(&shot).expect("the screenshot was written");
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().expect("PNG header");
    let mut px = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut px).expect("PNG data");
    let img = Image { px, w: info.width, h: info.height };
    let green = img.count(|_, _, c| c[1] as i32 >= 2 * (c[0].max(c[2]) as i32) + 10 && c[1] >= 25);
    let (red, blue) = (img.count(|_, _, c| reddish(c)), img.count(|_, _, c| bluish(c)));
    assert!(
        green > 300 && red > 300 && blue > 300,
        "the reloaded model (red, blue and green cubes) must still show: red {red}, blue {blue}, green {green} px"
    );
    // The camera was kept, not re-framed: framed for two cubes, the view cuts the
    // new green cube at the top edge (a re-framed view would leave a margin).
    let green_on_top_row = (0..img.w)
        .filter(|&x| {
            let c = img.at(x, 0);
            c[1] as i32 >= 2 * (c[0].max(c[2]) as i32) + 10
        })
        .count();
    assert!(green_on_top_row > 0, "the camera moved on reload");
}

/// Reads a PNG written by mdg-view.
fn read_png(path: &std::path::Path) -> Image {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().expect("PNG header");
    let mut px = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut px).expect("PNG data");
    // RGB or RGBA: keep four channels.
    let channels = px.len() / (info.width as usize * info.height as usize);
    let px = if channels == 4 { px } else { px.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect() };
    Image { px, w: info.width, h: info.height }
}

/// The bones' colour (cyan, over the model) — also where it is blended into the
/// background at a line's edge.
fn cyan(c: [u8; 4]) -> bool {
    let (r, g, b) = (c[0] as i32, c[1] as i32, c[2] as i32);
    b - r > 60 && g - r > 40
}

/// The selected guide's colour (magenta).
fn magenta(c: [u8; 4]) -> bool {
    let (r, g, b) = (c[0] as i32, c[1] as i32, c[2] as i32);
    r - g > 80 && b - g > 60
}

/// The control-point markers' ink (dark grey on a light background; the wood is
/// brown, the leaves green).
fn marker(c: [u8; 4]) -> bool {
    let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
    hi < 110 && hi - lo < 16
}

/// Pixels matching `f` within `r` pixels of (x, y).
fn count_near(img: &Image, (x, y): (f64, f64), r: f64, f: impl Fn([u8; 4]) -> bool) -> usize {
    img.count(|px, py, c| ((px as f64 - x).powi(2) + (py as f64 - y).powi(2)).sqrt() <= r && f(c))
}

/// `mdg-view: script line N: guide G point P is at pixel (X, Y)` from the log.
fn pixel_of(log: &str, guide: usize, point: usize) -> (f64, f64) {
    let needle = format!("guide {guide} point {point} is at pixel (");
    let line = log.lines().find(|l| l.contains(&needle)).unwrap_or_else(|| panic!("no `{needle}` in:\n{log}"));
    let rest = &line[line.find(&needle).expect("found") + needle.len()..];
    let (x, y) = rest.trim_end_matches(')').split_once(", ").expect("x, y");
    (x.parse().expect("x"), y.parse().expect("y"))
}

/// The guide editor, driven like a person would: under Xvfb, a script (the window's
/// own input path) presses the left button on the right arch's end point, drags it
/// 120 px right and 60 px up in 12 moves, releases, waits for the search, saves the
/// guides with `S`, and takes screenshots before and after.
///
/// Checked: the saved file is a guide file `mdg-run --guides` reads; the dragged
/// point is where the drag put it — from the front (`--camera 0,0`) the view plane
/// is y = const, and the pixel scale there comes from where two known points of the
/// guide were drawn, so the point moved by (120, 0, 60) pixels' worth within half a
/// pixel — and nothing else changed; the point's marker is drawn under the cursor's
/// end position; and the bones (cyan) moved toward the new curve: many more bone
/// pixels lie near the dragged guide (drawn magenta, selected) than before the
/// drag, and their centroid moved right, the way the point was dragged.
#[test]
fn guide_editor_drags_a_control_point_regrows_the_tree_and_saves_the_guides() {
    if skip_vulkan() {
        return;
    }
    let dir = out_dir().join("window-guides");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("mkdir");
    let original_file = root().join("std/examples/guides/arch.json");
    let guides_file = dir.join("arch.json");
    std::fs::copy(&original_file, &guides_file).expect("copy the guides");
    let original =
        mdg_guided::guides_from_json(&std::fs::read_to_string(&original_file).expect("read")).expect("valid");
    let (before, after) = (dir.join("before.png"), dir.join("after.png"));
    let (dx, dy) = (120.0, -60.0);
    let script = dir.join("drag.txt");
    std::fs::write(
        &script,
        format!(
            "idle\nscreenshot {}\npoint 3 1\npoint 3 4\npress left\nmove-by {dx} {dy} 12\nrelease left\nidle\nkey s\n\
             screenshot {}\nquit\n",
            before.display(),
            after.display()
        ),
    )
    .expect("write the script");
    let bin = env!("CARGO_BIN_EXE_mdg-view");
    let mut cmd = on_an_x_server(bin);
    let out = cmd
        .arg(root().join("std/examples/guided_tree.mdg"))
        .arg("--guides")
        .arg(&guides_file)
        .arg("--script")
        .arg(&script)
        .args(["--size", "800x600", "--camera", "0,0", "--seed", "3", "--no-watch", "--std"])
        .arg(root().join("std"))
        .env("MDG_VALIDATION", "1")
        .output()
        .expect("run mdg-view");
    let log = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "mdg-view failed ({:?}):\n{log}", out.status);
    assert!(log.contains("closed cleanly") && !log.contains("validation error"), "{log}");
    assert!(log.contains("mdg-view: guided search: cost ") && log.contains("model from generation"), "{log}");
    assert!(log.contains(&format!("saved 3 guides to {}", guides_file.display())), "{log}");

    // The saved guides: what mdg-run --guides reads; only the dragged point moved.
    let saved = mdg_guided::guides_from_json(&std::fs::read_to_string(&guides_file).expect("read the saved file"))
        .expect("the saved file is a valid guide file");
    assert_eq!(saved.len(), 3);
    for (g, (a, b)) in original.iter().zip(&saved).enumerate() {
        assert_eq!((&a.name, a.delta_a, a.segment), (&b.name, b.delta_a, b.segment));
        for (i, (pa, pb)) in a.points.iter().zip(&b.points).enumerate() {
            if (g, i) != (2, 3) {
                assert_eq!(pa, pb, "guide {} point {} moved", g + 1, i + 1);
            }
        }
    }
    // The pixel scale on the view plane y = 0, from two points of the guide.
    let (p1, p4) = (original[2].points[0], original[2].points[3]);
    let (s1, s4) = (pixel_of(&log, 3, 1), pixel_of(&log, 3, 4));
    let world = ((p4[0] - p1[0]).powi(2) + (p4[2] - p1[2]).powi(2)).sqrt();
    let pixels = ((s4.0 - s1.0).powi(2) + (s4.1 - s1.1).powi(2)).sqrt();
    let scale = world / pixels;
    // Seen from the front, +x is to the right and +z up, equally scaled.
    let world_angle = (p4[2] - p1[2]).atan2(p4[0] - p1[0]);
    let screen_angle = (-(s4.1 - s1.1)).atan2(s4.0 - s1.0);
    assert!((world_angle - screen_angle).abs() < 0.01, "world {world_angle} vs screen {screen_angle}");
    let moved = saved[2].points[3];
    let expected = [p4[0] + dx * scale, p4[1], p4[2] - dy * scale];
    let tolerance = 0.5 * scale;
    for k in 0..3 {
        assert!(
            (moved[k] - expected[k]).abs() < tolerance,
            "the dragged point is at {moved:?}, expected {expected:?} (±{tolerance:.4}, {scale:.5} per pixel)"
        );
    }

    let (img0, img1) = (read_png(&before), read_png(&after));
    assert_eq!((img1.w, img1.h), (800, 600));
    // The point's marker is under the cursor: at the start before, at the end after.
    let end = (s4.0 + dx, s4.1 + dy);
    assert!(count_near(&img0, s4, 5.0, marker) >= 4, "no marker at the point before the drag");
    assert!(count_near(&img1, end, 5.0, marker) >= 4, "no marker where the drag ended");
    // The bones followed the curve: they are nearer to it (the mean distance from
    // the dragged guide's pixels, drawn magenta as it is selected, to the nearest
    // bone pixel), and those on its side of the tree moved the way it was dragged.
    let pixels_of = |img: &Image, f: &dyn Fn([u8; 4]) -> bool| {
        let mut v = Vec::new();
        for y in 0..img.h {
            for x in 0..img.w {
                if f(img.at(x, y)) {
                    v.push((x as f64, y as f64));
                }
            }
        }
        v
    };
    let curve = pixels_of(&img1, &magenta);
    assert!(curve.len() > 200, "the selected guide is drawn in magenta: {} px", curve.len());
    // The part of the guide the drag moved: its outer half, away from its first point
    // (which stays at the fork, where the bones are near it before and after).
    let reach = (end.0 - s1.0).hypot(end.1 - s1.1);
    let curve: Vec<(f64, f64)> = curve.into_iter().filter(|c| (c.0 - s1.0).hypot(c.1 - s1.1) > 0.5 * reach).collect();
    assert!(curve.len() > 100, "the guide's outer half is drawn: {} px", curve.len());
    let (bones0, bones1) = (pixels_of(&img0, &cyan), pixels_of(&img1, &cyan));
    assert!(bones0.len() > 300 && bones1.len() > 300, "bones are drawn: {} and {} cyan px", bones0.len(), bones1.len());
    let mean_gap = |bones: &[(f64, f64)]| {
        let nearest = |p: &(f64, f64)| bones.iter().map(|b| (b.0 - p.0).hypot(b.1 - p.1)).fold(f64::MAX, f64::min);
        curve.iter().map(nearest).sum::<f64>() / curve.len() as f64
    };
    let (gap0, gap1) = (mean_gap(&bones0), mean_gap(&bones1));
    eprintln!("the dragged guide's outer half: {gap0:.1} px from the bones before, {gap1:.1} after");
    assert!(
        gap1 < 0.8 * gap0,
        "the bones did not come nearer to the dragged guide's outer half: {gap0:.1} px from it on average before, {gap1:.1} after"
    );
    let centroid_right_of = |bones: &[(f64, f64)], x0: f64| {
        let side: Vec<&(f64, f64)> = bones.iter().filter(|b| b.0 > x0).collect();
        let n = side.len().max(1) as f64;
        (side.iter().map(|b| b.0).sum::<f64>() / n, side.iter().map(|b| b.1).sum::<f64>() / n)
    };
    let (a, b) = (centroid_right_of(&bones0, s1.0), centroid_right_of(&bones1, s1.0));
    let along = ((b.0 - a.0) * dx + (b.1 - a.1) * dy) / dx.hypot(dy);
    assert!(
        along > 4.0,
        "the bones right of the guide's base moved {along:.1} px the way the point was dragged ({a:?} -> {b:?})"
    );
}
