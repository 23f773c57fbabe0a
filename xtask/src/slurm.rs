//! `cargo xtask slurm`: the sharded fleet on a real Slurm, end to end, on this machine.
//!
//! Installs Debian's `slurm-wlm` and `munge` when missing (as root, like the QEMU step), starts a
//! single-node cluster (munged when no munge daemon answers, slurmctld and slurmd on localhost,
//! configuration, state and logs under `target/slurm/`), submits `deploy/slurm/fleet.sbatch` as
//! a 4-task array over a generated manifest of 64 groups, cancels one array task while it runs,
//! waits for the others, checks that `fleet status` reports that shard's unfinished groups as
//! missing, resubmits only that task, and checks that it trains only the groups the cancelled
//! run had not finished. Then `fleet status` must report every group done, and every blob must
//! be byte for byte what a single-machine `fleet` run writes. The daemons it started are
//! stopped by their process ids, also on failure. Not part of `cargo xtask test`: it needs root
//! and minutes. The figures go to `target/slurm/slurm.json` and into BENCHMARKS.json/.md
//! (which `cargo xtask bench` carries over).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread::sleep;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use serde_json::{json, Value};

use crate::cmd::{describe, is_root, run, step};

/// Groups in the generated manifest.
pub const GROUPS: usize = 64;
/// Array tasks (shards).
pub const SHARDS: usize = 4;
/// The shard cancelled mid-run and resubmitted.
const KILLED_SHARD: usize = 2;
/// Distinct simulated datasets the groups draw from (round robin).
const DATASETS: usize = 8;

/// Where the figures land.
pub fn figures_path(root: &Path) -> PathBuf {
    root.join("target/slurm/slurm.json")
}

/// Processes this task started, stopped (by pid) when dropped.
struct Daemons {
    pid_files: Vec<PathBuf>,
}

impl Drop for Daemons {
    fn drop(&mut self) {
        for f in self.pid_files.iter().rev() {
            if let Some(pid) = fs::read_to_string(f).ok().and_then(|s| s.trim().parse::<u32>().ok()) {
                let _ = Command::new("kill").arg(pid.to_string()).status();
                eprintln!("xtask: stopped pid {pid} ({})", f.display());
            }
        }
    }
}

fn found(program: &str, arg: &str) -> bool {
    Command::new(program).arg(arg).stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok()
}

fn ensure_packages() -> Result<()> {
    if found("/usr/sbin/slurmctld", "-V") && found("/usr/sbin/munged", "--version") && found("sbatch", "--version") {
        return Ok(());
    }
    ensure!(
        is_root(),
        "slurm-wlm and munge are not installed; run as root (this task starts daemons), or install them with \
         `sudo apt-get install -y slurm-wlm munge`"
    );
    eprintln!("xtask: slurm-wlm / munge missing, installing them with apt-get");
    run(Command::new("apt-get").args(["update", "-qq"]))?;
    run(Command::new("apt-get")
        .args(["install", "-y", "-qq", "slurm-wlm", "munge"])
        .env("DEBIAN_FRONTEND", "noninteractive"))?;
    Ok(())
}

fn output(cmd: &mut Command) -> Result<String> {
    let o = cmd.output().with_context(|| format!("could not start `{}`", describe(cmd)))?;
    if !o.status.success() {
        bail!("`{}` failed: {}", describe(cmd), String::from_utf8_lossy(&o.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}

fn hostname() -> Result<String> {
    Ok(output(&mut Command::new("hostname"))?.trim().to_string())
}

/// Start munged unless one answers, then slurmctld and slurmd on `dir/slurm.conf`.
fn start_cluster(dir: &Path) -> Result<(Daemons, PathBuf)> {
    let mut daemons = Daemons { pid_files: Vec::new() };
    let munge_ok = || {
        Command::new("sh")
            .args(["-c", "munge -n | unmunge"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if !munge_ok() {
        let mdir = dir.join("munge");
        fs::create_dir_all(&mdir)?;
        fs::create_dir_all("/run/munge")?;
        run(Command::new("chown").args(["munge:munge", "/run/munge"]).arg(&mdir))?;
        let pid = mdir.join("munged.pid");
        run(Command::new("runuser")
            .args(["-u", "munge", "--", "/usr/sbin/munged", "--pid-file"])
            .arg(&pid)
            .arg("--log-file")
            .arg(mdir.join("munged.log")))?;
        daemons.pid_files.push(pid);
        let t = Instant::now();
        while !munge_ok() {
            ensure!(t.elapsed() < Duration::from_secs(10), "munged did not answer within 10 s");
            sleep(Duration::from_millis(200));
        }
    }
    let host = hostname()?;
    let cpus = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    for sub in ["state", "spool"] {
        fs::create_dir_all(dir.join(sub))?;
    }
    let d = dir.display();
    let conf = dir.join("slurm.conf");
    fs::write(
        &conf,
        format!(
            "# Written by `cargo xtask slurm`: a single-node cluster on this machine.\n\
             ClusterName=fbgxtask\nSlurmctldHost={host}(127.0.0.1)\nAuthType=auth/munge\n\
             SlurmUser=root\nSlurmdUser=root\nSlurmctldPort=16817\nSlurmdPort=16818\n\
             StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/slurmctld.log\nSlurmdLogFile={d}/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSwitchType=switch/none\nMpiDefault=none\n\
             SchedulerType=sched/backfill\nSelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
             ReturnToService=2\nAccountingStorageType=accounting_storage/none\nJobCompType=jobcomp/none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
             PartitionName=xtask Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n"
        ),
    )?;
    // A previous run's state would bring back its jobs.
    let _ = fs::remove_dir_all(dir.join("state"));
    fs::create_dir_all(dir.join("state"))?;
    run(Command::new("/usr/sbin/slurmctld").arg("-f").arg(&conf))?;
    daemons.pid_files.push(dir.join("slurmctld.pid"));
    run(Command::new("/usr/sbin/slurmd").arg("-f").arg(&conf))?;
    daemons.pid_files.push(dir.join("slurmd.pid"));
    let t = Instant::now();
    loop {
        let s = output(Command::new("sinfo").args(["-h", "-o", "%T"]).env("SLURM_CONF", &conf)).unwrap_or_default();
        if s.trim() == "idle" {
            break;
        }
        ensure!(
            t.elapsed() < Duration::from_secs(30),
            "the node is not idle after 30 s (sinfo: {}); see {}/slurmctld.log",
            s.trim(),
            d
        );
        sleep(Duration::from_millis(300));
    }
    Ok((daemons, conf))
}

/// A manifest of GROUPS groups over DATASETS short simulated records, its outputs under `models`.
fn make_manifest(trainer: &Path, dir: &Path) -> Result<PathBuf> {
    let cfg = dir.join("short.toml");
    fs::write(&cfg, "# 2 days at 60 s\n[clock]\ndays = 2.0\n")?;
    for k in 0..DATASETS {
        let csv = dir.join(format!("d{k}.csv"));
        if !csv.exists() {
            run(Command::new(trainer)
                .args(["simulate", "--seed", &(200 + k).to_string(), "--config"])
                .arg(&cfg)
                .arg("--out")
                .arg(&csv)
                .stderr(Stdio::null()))?;
        }
    }
    let mut m = String::from("# Written by `cargo xtask slurm`: every feature set and the memory terms per group.\n[defaults]\nfeatures = \"all\"\n");
    for g in 0..GROUPS {
        m.push_str(&format!(
            "\n[[group]]\nname = \"sensor-{g:03}\"\ndata = \"d{}.csv\"\nout = \"models/sensor-{g:03}.fbgm\"\n",
            g % DATASETS
        ));
    }
    let path = dir.join("fleet.toml");
    fs::write(&path, m)?;
    Ok(path)
}

fn sbatch(root: &Path, trainer: &Path, conf: &Path, manifest: &Path, array: &str, log_dir: &Path) -> Result<String> {
    let out = output(
        Command::new("sbatch")
            .args(["--parsable", "--cpus-per-task=1", &format!("--array={array}")])
            .arg(format!("--output={}/fleet-%A_%a.out", log_dir.display()))
            .arg(root.join("deploy/slurm/fleet.sbatch"))
            .env("SLURM_CONF", conf)
            .env("FLEET_MANIFEST", manifest)
            .env("FLEET_SHARDS", SHARDS.to_string())
            .env("FBG_TRAINER", trainer),
    )?;
    let id = out.trim().split(';').next().unwrap_or("").to_string();
    ensure!(!id.is_empty(), "sbatch printed no job id");
    eprintln!("xtask: submitted job {id} (array {array})");
    Ok(id)
}

fn job_running(conf: &Path, id: &str) -> Result<bool> {
    Ok(!output(Command::new("squeue").args(["-h", "-j", id]).env("SLURM_CONF", conf))?.trim().is_empty())
}

fn wait_job(conf: &Path, id: &str, limit: Duration) -> Result<()> {
    let t = Instant::now();
    while job_running(conf, id)? {
        ensure!(t.elapsed() < limit, "job {id} still running after {} s", limit.as_secs());
        sleep(Duration::from_millis(500));
    }
    Ok(())
}

fn fleet_status(trainer: &Path, manifest: &Path) -> Result<(bool, Value)> {
    let o = Command::new(trainer)
        .args(["fleet", "status", "--json", "--shards", &SHARDS.to_string(), "--manifest"])
        .arg(manifest)
        .output()?;
    let v: Value = serde_json::from_slice(&o.stdout)
        .with_context(|| format!("fleet status printed no JSON: {}", String::from_utf8_lossy(&o.stderr)))?;
    Ok((o.status.success(), v))
}

fn count(v: &Value, state: &str) -> usize {
    v["counts"][state].as_u64().unwrap_or(0) as usize
}

/// The shard summary of shard `i` of SHARDS.
fn shard_summary(manifest: &Path, i: usize) -> Result<Value> {
    let p = manifest.with_file_name(format!(
        "{}.shard-{i}-of-{SHARDS}.json",
        manifest.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
    ));
    serde_json::from_str(&fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?)
        .with_context(|| format!("parsing {}", p.display()))
}

pub fn run_all(root: &Path) -> Result<()> {
    step("slurm: packages, trainer");
    ensure_packages()?;
    let trainer = crate::fixtures::trainer(root)?;
    let dir = root.join("target/slurm");
    fs::create_dir_all(&dir)?;
    let work = dir.join("fleet");
    let _ = fs::remove_dir_all(work.join("models"));
    fs::create_dir_all(&work)?;
    for e in fs::read_dir(&work)? {
        let p = e?.path();
        if p.to_string_lossy().contains(".shard-") {
            fs::remove_file(p)?;
        }
    }
    let manifest = make_manifest(&trainer, &work)?;

    step("slurm: a single-node cluster (munged, slurmctld, slurmd)");
    let (_daemons, conf) = start_cluster(&dir)?;

    step("slurm: the array job, one task cancelled mid-run");
    let logs = dir.join("logs");
    fs::create_dir_all(&logs)?;
    let (_, shard_before) = fleet_status(&trainer, &manifest)?;
    let started = Instant::now();
    let job = sbatch(root, &trainer, &conf, &manifest, &format!("0-{}", SHARDS - 1), &logs)?;
    // Cancel the chosen task once it has finished at least one group but not all of them.
    let task = format!("{job}_{KILLED_SHARD}");
    let per_shard = GROUPS.div_ceil(SHARDS);
    // A group has finished when its record `<stem>.fleet.json` exists (written last), which is
    // cheap to poll; `fleet status` (which reads and digests every CSV) runs once for the list.
    let records: Vec<PathBuf> = shard_before["groups"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|g| g["shard"].as_u64() == Some(KILLED_SHARD as u64))
        .filter_map(|g| g["out"].as_str().map(|o| work.join(Path::new(o).with_extension("fleet.json"))))
        .collect();
    ensure!(!records.is_empty(), "shard {KILLED_SHARD} has no group");
    let t = Instant::now();
    let done_before_kill = loop {
        let done = records.iter().filter(|r| r.exists()).count();
        if done >= 1 {
            break done;
        }
        ensure!(t.elapsed() < Duration::from_secs(300), "shard {KILLED_SHARD} finished no group within 300 s");
        sleep(Duration::from_millis(100));
    };
    run(Command::new("scancel").arg(&task).env("SLURM_CONF", &conf))?;
    eprintln!("xtask: cancelled task {task} after {done_before_kill} of about {per_shard} groups");
    wait_job(&conf, &job, Duration::from_secs(1800))?;
    let first_wall = started.elapsed().as_secs_f64();
    let (ok, st) = fleet_status(&trainer, &manifest)?;
    ensure!(!ok, "fleet status exited 0 although task {task} was cancelled");
    let missing = count(&st, "missing");
    ensure!(missing > 0, "fleet status reports nothing missing after the cancel: {st}");
    let done_after_kill = GROUPS - missing;

    step("slurm: resubmit the cancelled shard only");
    let t2 = Instant::now();
    let job2 = sbatch(root, &trainer, &conf, &manifest, &KILLED_SHARD.to_string(), &logs)?;
    wait_job(&conf, &job2, Duration::from_secs(1800))?;
    let resubmit_wall = t2.elapsed().as_secs_f64();
    let s = shard_summary(&manifest, KILLED_SHARD)?;
    let (trained, skipped) = (s["trained"].as_u64().unwrap_or(0) as usize, s["skipped"].as_u64().unwrap_or(0) as usize);
    ensure!(
        trained == missing && trained + skipped == s["groups"].as_array().map(Vec::len).unwrap_or(0),
        "the resubmitted shard trained {trained} and skipped {skipped}; {missing} were missing: {s}"
    );
    let (ok, st) = fleet_status(&trainer, &manifest)?;
    ensure!(ok && count(&st, "done") == GROUPS, "fleet status after the resubmit: {st}");

    step("slurm: every blob equals a single-machine fleet run's");
    let single_wall = single_machine(&trainer, &dir, &work, &manifest)?;

    let shards: Vec<Value> = (0..SHARDS)
        .map(|i| {
            let s = shard_summary(&manifest, i)?;
            Ok(json!({"shard": i, "groups": s["groups"].as_array().map(Vec::len), "trained": s["trained"],
                      "skipped": s["skipped"], "seconds": s["seconds"],
                      "groups_per_s": s["trained"].as_f64().unwrap_or(0.0) / s["seconds"].as_f64().unwrap_or(f64::NAN)}))
        })
        .collect::<Result<_>>()?;
    let figures = json!({
        "command": "cargo xtask slurm",
        "groups": GROUPS, "shards": SHARDS, "cpus_per_task": 1,
        "cpus": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "first_submission_wall_seconds": first_wall,
        "killed_shard": KILLED_SHARD, "done_when_cancelled": done_before_kill, "done_after_first_submission": done_after_kill,
        "resubmitted": {"trained": trained, "skipped": skipped, "wall_seconds": resubmit_wall},
        "total_wall_seconds": first_wall + resubmit_wall,
        "single_machine_wall_seconds": single_wall,
        "per_shard_last_run": shards,
        "blobs_identical_to_single_machine": true,
    });
    fs::write(figures_path(root), serde_json::to_string_pretty(&figures)?)?;
    crate::bench::record_slurm(root, figures.clone())?;
    eprintln!("{}", serde_json::to_string_pretty(&figures)?);
    eprintln!("xtask: slurm passed; figures in {}", figures_path(root).display());
    Ok(())
}

/// A single-machine `fleet` run on copies of the records and the manifest (under
/// `dir/single`); every blob the Slurm shards wrote in `work` must equal its own. Returns its
/// wall time.
fn single_machine(trainer: &Path, dir: &Path, work: &Path, manifest: &Path) -> Result<f64> {
    let single = dir.join("single");
    let _ = fs::remove_dir_all(&single);
    fs::create_dir_all(&single)?;
    for k in 0..DATASETS {
        fs::copy(work.join(format!("d{k}.csv")), single.join(format!("d{k}.csv")))?;
        // The record's sidecars: its zero and clock (which the blob carries) and the scenario.
        for side in [format!("d{k}.record.json"), format!("d{k}.meta.json")] {
            let p = work.join(&side);
            if p.exists() {
                fs::copy(&p, single.join(&side))?;
            }
        }
    }
    fs::copy(manifest, single.join("fleet.toml"))?;
    let t3 = Instant::now();
    run(Command::new(trainer).args(["fleet", "--manifest"]).arg(single.join("fleet.toml")).stderr(Stdio::null()))?;
    let single_wall = t3.elapsed().as_secs_f64();
    for g in 0..GROUPS {
        for name in [format!("sensor-{g:03}.fbgm"), format!("sensor-{g:03}-p.fbgm")] {
            let a = fs::read(work.join("models").join(&name))?;
            let b = fs::read(single.join("models").join(&name))?;
            ensure!(a == b, "{name}: the Slurm shard wrote other bytes than the single-machine run");
            fbg_shared::blob::decode::<{ crate::targets::PRODUCT_K }>(&a)
                .map_err(|e| anyhow::anyhow!("{name} does not decode: {e}"))?;
        }
    }
    Ok(single_wall)
}
