//! The Slurm example run for real (issue 52, item 2): a one-node cluster (Debian's
//! `slurm-wlm` and `munge`) in a temporary folder with its own ports, key, state and logs,
//! stopped at the end even on failure; `examples/pipeline/slurm.sh` submitted as written with
//! `sbatch --wait` and command-line overrides for this machine. Its shards together build what
//! one batch builds (the same bytes, each job once, a state file per shard), a resubmission
//! builds nothing, and a second clone's array against the nginx cache computes nothing.

use super::nginx::{free_port, Nginx};
use super::project;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/pipeline/slurm.sh");
const TOKEN: &str = "slurm-t0ken";

/// munged, slurmctld and slurmd under one folder; each stopped (by the pid it wrote) when
/// this is dropped.
struct Cluster {
    dir: PathBuf,
}

/// Whether the cluster's programs are here (a failure under CI, which installs them).
fn installed() -> bool {
    let found = ["munged", "slurmctld", "slurmd", "sbatch", "sinfo"]
        .iter()
        .all(|p| {
            Command::new("sh")
                .args(["-c", &format!("command -v {p} || test -x /usr/sbin/{p}")])
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if !found {
        assert!(
            std::env::var_os("CI").is_none(),
            "Slurm is missing (Debian: slurm-wlm munge)"
        );
        eprintln!("SKIPPED: slurm-wlm or munge is not installed");
    }
    found
}

fn sh(dir: &Path, line: &str) -> std::process::Output {
    Command::new("sh")
        .args(["-c", line])
        .current_dir(dir)
        .env("PATH", "/usr/sbin:/usr/bin:/sbin:/bin")
        .output()
        .unwrap()
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        for d in ["state", "spool"] {
            std::fs::create_dir_all(dir.join(d)).unwrap();
        }
        let c = Cluster {
            dir: dir.to_path_buf(),
        };
        let host = String::from_utf8(sh(dir, "hostname -s").stdout).unwrap();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let (ctld, d) = (free_port(), free_port());
        let p = dir.display();
        let conf = format!(
            "ClusterName=cubeforge\nSlurmctldHost={host}(127.0.0.1)\nSlurmctldPort={ctld}\n\
             SlurmdPort={d}\nAuthType=auth/munge\nAuthInfo=socket={p}/munge.sock\n\
             CredType=cred/munge\nSlurmUser=root\nSlurmdUser=root\nStateSaveLocation={p}/state\n\
             SlurmdSpoolDir={p}/spool\nSlurmctldPidFile={p}/slurmctld.pid\n\
             SlurmdPidFile={p}/slurmd.pid\nSlurmctldLogFile={p}/slurmctld.log\n\
             SlurmdLogFile={p}/slurmd.log\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n\
             JobCompType=jobcomp/none\nSelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core_Memory\nMpiDefault=none\nReturnToService=2\n\
             MailProg=/bin/true\n\
             NodeName=cf1 NodeAddr=127.0.0.1 CPUs={cpus} RealMemory=1024 State=UNKNOWN\n\
             PartitionName=debug Nodes=cf1 Default=YES MaxTime=INFINITE State=UP\n",
            host = host.trim()
        );
        std::fs::write(dir.join("slurm.conf"), conf).unwrap();
        let key: Vec<u8> = (0..1024u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        std::fs::write(dir.join("munge.key"), key).unwrap();
        let start = format!(
            "chmod 400 munge.key && munged -f --socket={p}/munge.sock --key-file={p}/munge.key \
             --pid-file={p}/munged.pid --log-file={p}/munged.log --seed-file={p}/munged.seed \
             && slurmctld -f {p}/slurm.conf && slurmd -N cf1 -f {p}/slurm.conf"
        );
        let o = sh(dir, &start);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let end = Instant::now() + Duration::from_secs(30);
        while !c.sinfo().contains("idle") {
            assert!(
                Instant::now() < end,
                "the node is not idle: {}\n{}",
                c.sinfo(),
                std::fs::read_to_string(dir.join("slurmctld.log")).unwrap_or_default()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
        c
    }

    fn sinfo(&self) -> String {
        let o = self
            .command("sinfo")
            .args(["-h", "-o", "%t"])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// A Slurm command of this cluster.
    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", self.dir.join("slurm.conf"));
        c
    }

    /// Submits the example as written from `proj` as a two-task array sized for this machine,
    /// and waits for it; returns the tasks' logs, joined.
    fn bake(&self, proj: &Path, cache: Option<&str>, tag: &str) -> String {
        let log = self.dir.join(format!("bake-{tag}-%a.log"));
        let mut c = self.command("timeout");
        c.args([
            "300",
            "sbatch",
            "--wait",
            "--array=0-1",
            "--cpus-per-task=1",
        ])
        .args(["--mem=256M", "--time=5"])
        .arg(format!("--output={}", log.display()))
        .arg(EXAMPLE)
        .current_dir(proj)
        .env("CUBEFORGE", env!("CARGO_BIN_EXE_cubeforge"))
        .env("MANIFEST", "m.toml")
        .env("CUBEFORGE_CACHE", cache.unwrap_or(""))
        .env("CUBEFORGE_CACHE_TOKEN", TOKEN);
        let o = c.output().unwrap();
        let logs: String = (0..2)
            .map(|i| {
                let p = self.dir.join(format!("bake-{tag}-{i}.log"));
                std::fs::read_to_string(p).unwrap_or_default()
            })
            .collect();
        assert!(
            o.status.success(),
            "sbatch: {}{}\n{logs}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        logs
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for d in ["slurmd", "slurmctld", "munged"] {
            let pid =
                std::fs::read_to_string(self.dir.join(format!("{d}.pid"))).unwrap_or_default();
            if let Ok(pid) = pid.trim().parse::<i32>() {
                let _ = Command::new("kill").arg(pid.to_string()).status();
            }
        }
    }
}

/// Every file under `dir`, relative, with its bytes.
#[test]
fn the_slurm_example_runs_on_a_one_node_cluster() {
    if !installed() {
        return;
    }
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let Some(server) = Nginx::start(&d.join("nginx"), TOKEN) else {
        return;
    };
    let cluster = Cluster::start(&d.join("slurm"));
    for c in ["one", "array", "clone"] {
        project(&d.join(c));
    }
    // One batch of the manifest, the reference.
    let o = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["batch", "m.toml"])
        .current_dir(d.join("one/proj"))
        .env_remove("CUBEFORGE_CACHE")
        .output()
        .unwrap();
    assert!(o.status.success());
    let reference = super::contents(&d.join("one/proj/build"));
    // The array, against the cache: each job once over the two shards, the same bytes.
    let url = server.url();
    let start = Instant::now();
    let logs = cluster.bake(&d.join("array/proj"), Some(&url), "first");
    println!(
        "slurm: a 2-task array of 7 jobs in {:.2} s",
        start.elapsed().as_secs_f64()
    );
    let ran: Vec<&str> = logs.lines().filter(|l| l.starts_with("ran ")).collect();
    assert_eq!(ran.len(), 7, "{logs}");
    let mut once = ran.clone();
    once.sort();
    once.dedup();
    assert_eq!(once.len(), 7, "{logs}");
    assert!(
        super::contents(&d.join("array/proj/build")) == reference,
        "{logs}"
    );
    for i in 0..2 {
        let state = d.join(format!("array/proj/m.shard-{i}-of-2.state.json"));
        assert!(state.is_file(), "{} missing", state.display());
    }
    // Resubmitted: nothing builds.
    let again = cluster.bake(&d.join("array/proj"), Some(&url), "again");
    assert!(!again.lines().any(|l| l.starts_with("ran ")), "{again}");
    assert_eq!(
        again.matches(" 0 ran, 0 from the cache").count(),
        2,
        "{again}"
    );
    // A second clone's array: every job from the cache the first array filled.
    let puts = server.puts();
    let clone = cluster.bake(&d.join("clone/proj"), Some(&url), "clone");
    assert!(!clone.lines().any(|l| l.starts_with("ran ")), "{clone}");
    assert_eq!(clone.matches("from cache  cubeforge").count(), 7, "{clone}");
    assert!(
        super::contents(&d.join("clone/proj/build")) == reference,
        "{clone}"
    );
    assert_eq!(server.puts(), puts, "{clone}");
}
