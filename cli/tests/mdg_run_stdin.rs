//! `mdg-run FILE --stdin` evaluates the text on standard input as if it were FILE:
//! imports resolve beside FILE, FILE itself is not read (it need not exist), and
//! errors name FILE. Editors preview unsaved text this way.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdg-run-stdin-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("lib")).expect("temp dir");
    dir
}

fn run_with_stdin(args: &[&std::ffi::OsStr], input: &str) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run mdg-run");
    child.stdin.take().expect("stdin").write_all(input.as_bytes()).expect("write stdin");
    child.wait_with_output().expect("wait")
}

/// The `v …` lines of an OBJ file.
fn vertex_count(path: &std::path::Path) -> usize {
    std::fs::read_to_string(path).expect("read obj").lines().filter(|l| l.starts_with("v ")).count()
}

#[test]
fn stdin_text_is_the_file_and_imports_resolve_beside_it() {
    let dir = temp_dir("imports");
    std::fs::write(dir.join("lib/parts.mdg"), "rule petal { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("write");
    // On disk the file has one petal; the editor's text has six.
    let file = dir.join("garden.mdg");
    std::fs::write(&file, "@import lib/parts.mdg\nstartshape g\nrule g { petal {} }\n").expect("write");
    let out = dir.join("out.obj");
    let text = "@import lib/parts.mdg\nstartshape g\nrule g { 6 * {rz 60} petal {} }\n";
    let r = run_with_stdin(&[file.as_os_str(), "--stdin".as_ref(), "-o".as_ref(), out.as_os_str()], text);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(vertex_count(&out), 18);

    // A file that does not exist on disk: only its directory matters.
    let unsaved = dir.join("unsaved.mdg");
    let r = run_with_stdin(&[unsaved.as_os_str(), "--stdin".as_ref(), "-o".as_ref(), out.as_os_str()], text);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(vertex_count(&out), 18);

    // Errors are reported against FILE, with the code.
    let r = run_with_stdin(
        &[unsaved.as_os_str(), "--stdin".as_ref(), "-o".as_ref(), out.as_os_str()],
        "startshape g\nrule g { nope {} }\n",
    );
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("E0301") && err.contains("unsaved.mdg:2:10"), "{err}");
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

/// `--params-json PATH`: the compiled `@param` declarations, the values in force
/// (overrides clamped to the range), written before evaluating; not written when
/// the text does not compile (the editor keeps its sliders).
#[test]
fn params_json_lists_the_declarations_with_the_values_in_force() {
    let dir = temp_dir("params");
    let file = dir.join("p.mdg");
    let json = dir.join("p.json");
    let out = dir.join("p.obj");
    let text = "@param int count 5 1 20\n@param float spacing 1.5\n@param bool coloured true\nstartshape A\n\
                rule A { (count) * {x (spacing)} B {} }\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
    let args = |extra: &[&str]| {
        let mut a: Vec<std::ffi::OsString> =
            vec![file.clone().into(), "--stdin".into(), "-o".into(), out.clone().into(), "--params-json".into()];
        a.push(json.clone().into());
        a.extend(extra.iter().map(|s| s.into()));
        a
    };
    let run = |extra: &[&str], input: &str| {
        let a = args(extra);
        let refs: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
        run_with_stdin(&refs, input)
    };
    let r = run(&["--param", "count=40", "--param", "spacing=2.25"], text);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(
        std::fs::read_to_string(&json).expect("params json"),
        r#"[{"max":20.0,"min":1.0,"name":"count","type":"int","value":20.0},{"max":null,"min":null,"name":"spacing","type":"float","value":2.25},{"max":null,"min":null,"name":"coloured","type":"bool","value":1.0}]"#
    );
    assert_eq!(vertex_count(&out), 60);

    std::fs::remove_file(&json).expect("remove");
    let r = run(&[], "@param int count 5 1 20\nstartshape A\nrule A { nope {} }\n");
    assert_eq!(r.status.code(), Some(1));
    assert!(!json.exists(), "written for a text with errors");
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

/// `--stdin` reads at most the compiler's 16 MiB source limit: 17 MiB of text is
/// refused with a message naming standard input and the limit, after reading no
/// more than the limit (the rest is never read, so the writer sees a closed pipe).
#[test]
fn stdin_past_the_source_limit_is_refused_without_reading_it_all() {
    let dir = temp_dir("huge");
    let file = dir.join("big.mdg");
    let out = dir.join("big.obj");
    // 17 MiB of comment lines, valid grammar text were it short enough.
    let line = format!("// {}\n", "x".repeat(1020));
    let text =
        format!("startshape A\nrule A {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}} }}\n{}", line.repeat(17 * 1024));
    assert!(text.len() > 17 << 20);
    let mut child = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
        .args([file.as_os_str(), "--stdin".as_ref(), "-o".as_ref(), out.as_os_str()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run mdg-run");
    let mut stdin = child.stdin.take().expect("stdin");
    let writer = std::thread::spawn(move || stdin.write_all(text.as_bytes()).map_err(|e| e.kind()));
    let r = child.wait_with_output().expect("wait");
    let written = writer.join().expect("writer");
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(
        err.contains("standard input is larger than the 16 MiB source limit (16777216 bytes)"),
        "the message names standard input and the limit: {err}"
    );
    assert_eq!(written, Err(std::io::ErrorKind::BrokenPipe), "mdg-run read all of standard input");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).expect("cleanup");
}
