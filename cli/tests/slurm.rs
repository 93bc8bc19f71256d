//! The Slurm recipe of docs/batch.md, run on a real single-node Slurm that this test
//! starts by itself: `munged` with a key of its own, `slurmctld` and `slurmd` with a
//! `slurm.conf`, state, spool and logs in a temporary directory (the machine's own
//! Slurm and munge, if any, are not touched). The recipe's script is taken from
//! docs/batch.md (only the sizes changed: 4 shards of 64 seeds), submitted as an
//! array of 4 tasks; one task's `mdg-run` is killed mid-run (SIGKILL, as an
//! out-of-memory kill or a lost node would) and the task is requeued with
//! `scontrol requeue`. Then every seed is written once: each output exists, each
//! seed has exactly one line in its shard's manifest, the lines' sizes and SHA-256
//! are the files', and the requeued task says it skipped what it had finished. A
//! task resubmitted alone (`sbatch --array=2`, the recipe's other way back) finds its
//! shard done.
//!
//! Skipped, with the reason printed, only where the Slurm or munge programs are not
//! installed (Debian: `apt-get install slurm-wlm munge`; `.ci/run` installs them).
//! Every wait is bounded; the daemons are stopped at the end, also on failure.

use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const SHARDS: u64 = 4;
const SEEDS: u64 = 64;

/// A grammar that takes a moment per seed (two million rule calls), so a task is
/// still running when the test kills it.
const TREE: &str = "startshape a\nrule a {\n  VERTEX {} VERTEX {x 1} VERTEX {y rand(0, 1)}\n  1500 * {x 1} row {}\n}\n\
                    rule row { 1500 * {y 1} dot {} }\nrule dot { }\n";

/// The programs the test needs, found on PATH or in the sbin directories.
fn find(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut dirs: Vec<PathBuf> = std::env::split_paths(&path).collect();
    dirs.extend(["/usr/sbin", "/sbin", "/usr/local/sbin"].map(PathBuf::from));
    dirs.into_iter().map(|d| d.join(name)).find(|p| p.is_file())
}

/// Runs `cmd` to its end, at most `limit` (then kills it and fails the test).
fn run(cmd: &mut Command, limit: Duration) -> Output {
    let shown = format!("{cmd:?}");
    let mut child =
        cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn a command");
    let drain = |p: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            if let Some(mut p) = p {
                let _ = p.read_to_end(&mut v);
            }
            v
        })
    };
    let out = drain(child.stdout.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let err = drain(child.stderr.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{shown} ran past {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output { status, stdout: out.join().unwrap_or_default(), stderr: err.join().unwrap_or_default() }
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// Polls `done` every 50 ms until it holds, at most `limit`; fails the test naming
/// `what` otherwise.
fn wait_for(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < limit, "timed out after {limit:?} waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A free TCP port on the loopback interface.
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind a port");
    l.local_addr().expect("address").port()
}

/// A single-node Slurm cluster of this test's own: munged, slurmctld and slurmd in
/// the foreground as children; dropping it cancels its jobs and stops them.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<(&'static str, Child)>,
    passed: bool,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let _ = std::fs::remove_dir_all(dir);
        for d in ["munge", "state", "spool", "log", "job"] {
            std::fs::create_dir_all(dir.join(d)).expect("cluster directories");
        }
        let mut c =
            Cluster { dir: dir.to_path_buf(), conf: dir.join("slurm.conf"), daemons: Vec::new(), passed: false };
        use std::os::unix::fs::PermissionsExt;
        let munge = dir.join("munge");
        std::fs::set_permissions(&munge, std::fs::Permissions::from_mode(0o700)).expect("chmod");
        let mut key = Vec::new();
        std::fs::File::open("/dev/urandom").expect("urandom").take(1024).read_to_end(&mut key).expect("key");
        std::fs::write(munge.join("key"), key).expect("write the munge key");
        std::fs::set_permissions(munge.join("key"), std::fs::Permissions::from_mode(0o400)).expect("chmod");
        let socket = munge.join("socket");
        let log = |name: &str| std::fs::File::create(dir.join("log").join(name)).expect("log file");
        let munged = Command::new(find("munged").expect("munged"))
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--key-file={}", munge.join("key").display()))
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--pid-file={}", munge.join("pid").display()))
            .arg(format!("--log-file={}", dir.join("log/munged.log").display()))
            .arg(format!("--seed-file={}", munge.join("seed").display()))
            .stdin(Stdio::null())
            .stdout(log("munged.out"))
            .stderr(log("munged.err"))
            .spawn()
            .expect("start munged");
        c.daemons.push(("munged", munged));
        wait_for("munged's socket", Duration::from_secs(20), || socket.exists());

        let host = std::fs::read_to_string("/proc/sys/kernel/hostname").expect("hostname").trim().to_string();
        let user = String::from_utf8(run(Command::new("id").arg("-un"), Duration::from_secs(10)).stdout)
            .expect("user name")
            .trim()
            .to_string();
        let d = dir.display();
        let conf = format!(
            "ClusterName=mdgtest\nSlurmctldHost={host}(127.0.0.1)\nSlurmUser={user}\nSlurmdUser={user}\n\
             SlurmctldPort={}\nSlurmdPort={}\nAuthType=auth/munge\nCredType=cred/munge\n\
             AuthInfo=socket={}\nStateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/log/slurmctld.log\nSlurmdLogFile={d}/log/slurmd.log\n\
             ProctrackType=proctrack/pgid\nTaskPlugin=task/none\nSelectType=select/cons_tres\n\
             SelectTypeParameters=CR_CPU\nSchedulerType=sched/builtin\nJobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\nJobCompType=jobcomp/none\nMpiDefault=none\n\
             ReturnToService=2\nSlurmdParameters=config_overrides\nKillWait=5\nMinJobAge=600\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n\
             PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            free_port(),
            free_port(),
            socket.display()
        );
        std::fs::write(&c.conf, conf).expect("slurm.conf");
        for (name, bin) in [("slurmctld", "slurmctld"), ("slurmd", "slurmd")] {
            let child = Command::new(find(bin).expect("slurm daemon"))
                .arg("-D")
                .arg("-f")
                .arg(&c.conf)
                .env("SLURM_CONF", &c.conf)
                .stdin(Stdio::null())
                .stdout(log(&format!("{name}.out")))
                .stderr(log(&format!("{name}.err")))
                .spawn()
                .expect("start a slurm daemon");
            c.daemons.push((name, child));
        }
        wait_for("the node to be idle", Duration::from_secs(40), || {
            for (name, child) in &mut c.daemons {
                if let Ok(Some(s)) = child.try_wait() {
                    panic!("{name} ended ({s}); logs in {}", dir.join("log").display());
                }
            }
            let o = run(c.slurm("sinfo").args(["-h", "-N", "-o", "%T"]), Duration::from_secs(20));
            o.status.success() && String::from_utf8_lossy(&o.stdout).trim() == "idle"
        });
        c
    }

    /// A Slurm client command for this cluster.
    fn slurm(&self, name: &str) -> Command {
        let mut c = Command::new(find(name).expect("slurm command"));
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// `scontrol ARGS`, which must succeed; its output.
    fn scontrol(&self, args: &[&str]) -> String {
        let o = run(self.slurm("scontrol").args(args), Duration::from_secs(30));
        assert!(o.status.success(), "scontrol {args:?}: {}", text(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// The state of each task of array job `job`: (task id, job id, state, exit
    /// code, restarts), from `scontrol show job`.
    fn tasks(&self, job: &str) -> Vec<(u64, String, String, String, u64)> {
        let out = self.scontrol(&["show", "job", job]);
        let mut tasks = Vec::new();
        for block in out.split("\n\n").filter(|b| b.contains("JobId=")) {
            let field = |k: &str| {
                block
                    .split_whitespace()
                    .find_map(|w| w.strip_prefix(&format!("{k}=")))
                    .map(str::to_string)
                    .unwrap_or_default()
            };
            let task = field("ArrayTaskId").parse().unwrap_or(u64::MAX);
            let restarts = field("Restarts").parse().unwrap_or(0);
            tasks.push((task, field("JobId"), field("JobState"), field("ExitCode"), restarts));
        }
        tasks.sort();
        tasks
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Jobs first (their processes belong to slurmd's step daemons), then the
        // daemons, each given 10 s to end after SIGTERM.
        if let Ok(mut c) = self.slurm("scancel").arg("--user").arg(whoami()).stdin(Stdio::null()).spawn() {
            let t0 = Instant::now();
            while matches!(c.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(15) {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
        for (_, child) in self.daemons.iter_mut().rev() {
            let _ = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status();
            let t0 = Instant::now();
            while matches!(child.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(10) {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        if self.passed {
            let _ = std::fs::remove_dir_all(&self.dir);
        } else {
            eprintln!("the cluster's logs and the job's files are kept in {}", self.dir.display());
        }
    }
}

fn whoami() -> String {
    let o = Command::new("id").arg("-un").output().map(|o| o.stdout).unwrap_or_default();
    String::from_utf8_lossy(&o).trim().to_string()
}

/// The Slurm script of docs/batch.md, sized for the test: each change must apply
/// exactly once, so a recipe that changes shape fails here instead of being
/// silently not tested.
fn recipe() -> String {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/batch.md")).expect("docs/batch.md");
    let section = doc.split("## Slurm job arrays").nth(1).expect("docs/batch.md has a Slurm section");
    let script = section
        .split("```sh\n")
        .nth(1)
        .and_then(|s| s.split("```").next())
        .expect("the Slurm section starts with a ```sh block");
    let mut script = script.to_string();
    for (from, to) in [
        ("#SBATCH --array=0-63", format!("#SBATCH --array=0-{}", SHARDS - 1)),
        ("N=64 ", format!("N={SHARDS} ")),
        ("--seeds 0..100000", format!("--seeds 0..{SEEDS}")),
    ] {
        assert_eq!(
            script.matches(from).count(),
            1,
            "docs/batch.md's Slurm script should hold `{from}` once:\n{script}"
        );
        script = script.replace(from, &to);
    }
    assert!(script.starts_with("#!/bin/bash\n") && script.contains("mdg-run tree.mdg"), "{script}");
    script
}

/// The complete manifest lines of shard `k`, parsed (a line being written, without
/// its newline yet, is left out).
fn manifest(job: &Path, k: u64) -> Vec<serde_json::Value> {
    let path = job.join(format!("out/manifest-{k}-of-{SHARDS}.jsonl"));
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .split_inclusive('\n')
        .filter(|l| l.ends_with('\n'))
        .map(|l| serde_json::from_str(l).expect("a manifest line is JSON"))
        .collect()
}

#[test]
fn the_slurm_recipe_survives_a_killed_and_requeued_task() {
    let needed = ["munged", "slurmctld", "slurmd", "sbatch", "scontrol", "squeue", "sinfo", "scancel"];
    let missing: Vec<&str> = needed.iter().copied().filter(|n| find(n).is_none()).collect();
    if !missing.is_empty() {
        println!(
            "skipped: {} not installed (Debian: apt-get install slurm-wlm munge; .ci/run installs them)",
            missing.join(", ")
        );
        return;
    }
    let t0 = Instant::now();
    // Short: munge's socket path must fit a Unix socket address (108 bytes).
    let mut cluster = Cluster::start(&std::env::temp_dir().join(format!("mdg-slurm-{}", std::process::id())));
    eprintln!("cluster up in {:?}", t0.elapsed());
    let job = cluster.dir.join("job");
    std::fs::write(job.join("tree.mdg"), TREE).expect("grammar");
    std::fs::write(job.join("trees.sh"), recipe()).expect("script");
    let bin = Path::new(env!("CARGO_BIN_EXE_mdg-run")).parent().expect("bin dir").to_path_buf();
    let path = std::env::join_paths(
        std::iter::once(bin).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .expect("PATH");
    // sbatch passes its environment to the tasks (PATH finds mdg-run); appending to
    // the task logs keeps both runs of the requeued task.
    let o = run(
        cluster
            .slurm("sbatch")
            .args(["--parsable", "--open-mode=append", "trees.sh"])
            .env("PATH", &path)
            .current_dir(&job),
        Duration::from_secs(30),
    );
    assert!(o.status.success(), "sbatch: {}", text(&o));
    let id = String::from_utf8_lossy(&o.stdout).trim().split(';').next().unwrap_or_default().to_string();
    assert!(id.parse::<u64>().is_ok(), "sbatch printed {id:?}");

    // Kill task 1's mdg-run once it has finished two seeds: its pid is in the lock
    // file beside its manifest.
    let lock = job.join(format!("out/manifest-1-of-{SHARDS}.jsonl.lock"));
    let mut pid = 0u32;
    wait_for("task 1 to finish two seeds", Duration::from_secs(60), || {
        let holder = std::fs::read_to_string(&lock).unwrap_or_default();
        pid = holder.strip_prefix("pid ").and_then(|r| r.split(' ').next()).and_then(|p| p.parse().ok()).unwrap_or(0);
        pid != 0 && manifest(&job, 1).len() >= 2
    });
    let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
    assert!(String::from_utf8_lossy(&cmdline).contains("mdg-run"), "pid {pid} is not task 1's mdg-run");
    let killed = run(Command::new("kill").args(["-KILL", &pid.to_string()]), Duration::from_secs(10));
    assert!(killed.status.success(), "kill: {}", text(&killed));
    let done_when_killed = manifest(&job, 1).len();
    eprintln!("task 1 killed after {done_when_killed} seeds, at {:?}", t0.elapsed());
    assert!((done_when_killed as u64) < SEEDS / SHARDS, "task 1 had finished before it was killed");
    let task1 = format!("{id}_1");
    wait_for("task 1 to fail", Duration::from_secs(30), || {
        cluster.tasks(&task1).first().is_some_and(|t| t.2 != "RUNNING" && t.2 != "COMPLETING")
    });
    let state = cluster.tasks(&task1);
    assert_eq!(state[0].2, "FAILED", "the killed task: {state:?}");

    // Requeue it; Slurm holds a requeued job back (BeginTime): start it now.
    cluster.scontrol(&["requeue", &task1]);
    let job_id = cluster.tasks(&task1)[0].1.clone();
    cluster.scontrol(&["update", &format!("JobId={job_id}"), "StartTime=now"]);
    wait_for("the array to finish", Duration::from_secs(120), || {
        let q = run(cluster.slurm("squeue").args(["-h", "-j", &id]), Duration::from_secs(20));
        q.status.success() && q.stdout.iter().all(u8::is_ascii_whitespace)
    });

    eprintln!("the array finished at {:?}", t0.elapsed());
    let tasks = cluster.tasks(&id);
    assert_eq!(tasks.len() as u64, SHARDS, "{tasks:?}");
    for (k, _, state, exit, restarts) in &tasks {
        assert_eq!((state.as_str(), exit.as_str()), ("COMPLETED", "0:0"), "task {k}: {tasks:?}");
        assert_eq!(*restarts, u64::from(*k == 1), "task {k} restarts: {tasks:?}");
    }
    let log = std::fs::read_to_string(job.join(format!("slurm-{id}_1.out"))).expect("task 1's log");
    let resumed = format!("already done (shard 1/{SHARDS})");
    assert!(log.contains("Killed") && log.contains(&resumed), "task 1's log:\n{log}");
    let line = log.lines().find(|l| l.contains(&resumed)).unwrap_or_default();
    let skipped: usize = line.split(", ").nth(1).and_then(|s| s.split(' ').next()?.parse().ok()).unwrap_or(0);
    assert_eq!(skipped, done_when_killed, "the requeued task skips exactly what the killed one finished: {line}");

    // The recipe's other way back, a task resubmitted alone, finds its shard done.
    let o = run(
        cluster
            .slurm("sbatch")
            .args(["--parsable", "--wait", "--array=2", "trees.sh"])
            .env("PATH", &path)
            .current_dir(&job),
        Duration::from_secs(120),
    );
    let again = String::from_utf8_lossy(&o.stdout).trim().split(';').next().unwrap_or_default().to_string();
    let log = std::fs::read_to_string(job.join(format!("slurm-{again}_2.out"))).unwrap_or_default();
    assert!(o.status.success(), "task 2 resubmitted alone failed: {}\n{log}", text(&o));
    let whole = SEEDS / SHARDS;
    assert!(log.contains(&format!("0 seeds run, {whole} already done (shard 2/{SHARDS})")), "{log}");

    // Every seed written once: its file, one line in its shard's manifest, and that
    // line's size and hash are the file's.
    for k in 0..SHARDS {
        let lines = manifest(&job, k);
        let mut seeds: Vec<u64> = lines.iter().filter_map(|l| l["seed"].as_u64()).collect();
        seeds.sort();
        let want: Vec<u64> = (0..SEEDS).filter(|s| s % SHARDS == k).collect();
        assert_eq!(seeds, want, "shard {k}'s manifest: every seed of the shard once");
        for l in &lines {
            assert_eq!(l["mdg_manifest"], 2);
            let file = job.join(l["file"].as_str().expect("file"));
            let bytes = std::fs::read(&file).expect("the output of a manifest line");
            assert_eq!(l["bytes"].as_u64(), Some(bytes.len() as u64), "{}", file.display());
            let hash: String = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect();
            assert_eq!(l["sha256"].as_str(), Some(hash.as_str()), "{}", file.display());
        }
    }
    let mut names: Vec<String> = std::fs::read_dir(job.join("out"))
        .expect("out")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want: Vec<String> = (0..SEEDS).map(|s| format!("{s}.glb")).collect();
    want.extend((0..SHARDS).map(|k| format!("manifest-{k}-of-{SHARDS}.jsonl")));
    want.sort();
    assert_eq!(names, want, "out/ holds the outputs and manifests only (no lock or temporary file left)");
    eprintln!("slurm test done in {:?}", t0.elapsed());
    cluster.passed = true;
}
