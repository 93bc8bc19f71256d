//! The window under Xvfb (lavapipe in CI): `mdg-view --frames 5 --screenshot`
//! opens a window, renders five frames with validation required, reads the last
//! one back from the swapchain, and closes cleanly (exit status 0; status 3 would
//! mean validation errors). The screenshot must show the model.

mod common;

use common::*;
use std::process::Command;

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
    // A private X server keeps the test off the developer's screen and works
    // without one; a display of our own is the fallback.
    let mut cmd = if have("xvfb-run") {
        let mut c = Command::new("xvfb-run");
        c.args(["-a", "-s", "-screen 0 1024x768x24", bin]);
        c
    } else if std::env::var_os("DISPLAY").is_some() {
        Command::new(bin)
    } else {
        panic!("no X server for the window test: run `bash .ci/run` (it installs xvfb), or set MDG_SKIP_VULKAN_TESTS=1");
    };
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
