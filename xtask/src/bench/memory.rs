//! Peak memory of the commands that read a whole record: `train`, `compensate` and
//! `evaluate --quick` (on the record without and, at 10⁶ rows, with its simulation sidecar) on
//! 10⁶ and 10⁷ rows (the `paper` clock sampled finer), each the peak
//! resident set of that one process (`wait4`'s `ru_maxrss`).
//!
//! The 10⁷-row CSV is about 0.9 GB: it is simulated into `target/bench/memory`, measured, and
//! deleted at the end (also on failure) so the bench leaves no gigabyte behind.
//!
//! `import --format spectra-csv` of a spectra file of about 1 GB (the `paper` record's spectra,
//! 512 pixels, sampled finer; `--quick`: about 0.1 GB), simulated there and deleted the same
//! way (memory that does not follow the file's length). Alone:
//! `cargo xtask bench --import-memory-only [--quick]`.

use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

use super::runner::Runner;
use super::{rel, Opts, TRAINER};

/// Rows of the memory study and their sample interval over the 14 days of the `paper` clock.
const ROWS: [(usize, f64); 2] = [(1_000_000, 1.2096), (10_000_000, 0.12096)];

/// The largest record `evaluate` is measured on with the simulation's sidecar (its studies
/// re-simulate the record).
const EVALUATE_MAX_ROWS: usize = 1_000_000;

/// The spectra import's record: its sample interval over the 14 days of the `paper` clock
/// (about 1 GB of spectra at 512 pixels; ten times coarser with `--quick`).
const SPECTRA_DT_S: f64 = 2.8;
const SPECTRA_DT_S_QUICK: f64 = 28.0;

/// Target: `import` of a 1 GB spectra file within this peak resident set.
pub const TARGET_IMPORT_SPECTRA_BYTES: u64 = 100_000_000;
/// The file size the target is stated for.
pub const TARGET_IMPORT_SPECTRA_FILE_BYTES: u64 = 1_000_000_000;

/// Targets: `compensate` and `evaluate` streaming, `train` holding its columns.
pub const TARGET_STREAM_BYTES_1E7: u64 = 200_000_000;
pub const TARGET_TRAIN_BYTES_1E7: u64 = 1_200_000_000;

/// One command's peak.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MemoryRun {
    pub command: String,
    pub rows: usize,
    /// `train`, `compensate` or `evaluate`.
    pub what: String,
    /// Peak resident set of the process \[bytes\].
    pub peak_rss_bytes: u64,
    /// Its wall time \[s\].
    pub seconds: f64,
}

/// The memory study.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Memory {
    pub runs: Vec<MemoryRun>,
    /// The `simulate` commands of the records (the 10⁷-row one deleted afterwards).
    pub datasets: Vec<String>,
    /// Bytes of each record's CSV.
    pub csv_bytes: Vec<u64>,
    /// `import --format spectra-csv` of a large spectra file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectra_import: Option<SpectraImport>,
}

/// The spectra import's peak memory.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpectraImport {
    /// The `simulate` command that wrote the spectra.
    pub simulate: String,
    /// Bytes of the spectra file.
    pub spectra_bytes: u64,
    /// Its rows (one spectrum per row), header excluded.
    pub spectra_rows: u64,
    /// The import's run.
    pub run: MemoryRun,
}

#[allow(clippy::zombie_processes)] // reaped by `wait4`, which `Child::wait` cannot replace
/// Run `program args` from `root` with stdout and stderr discarded (stderr kept for a
/// failure) and return its peak RSS \[bytes\] and wall time \[s\].
///
/// Linux carries the high-water mark of the address space a process `exec`s from into its
/// peak, and `Command::spawn` execs from this process's: the figure is the child's own only
/// while this process is smaller than the child (xtask is a few MB; a test binary running
/// other tests beside may not be).
pub fn peak_rss(root: &Path, program: &str, args: &[&str]) -> Result<(u64, f64, String)> {
    let line = format!("{program} {}", args.join(" "));
    eprintln!("bench: $ {line}");
    let dir = root.join("target/bench/memory");
    fs::create_dir_all(&dir)?;
    let err = dir.join("stderr.txt");
    let t0 = Instant::now();
    let child = Command::new(root.join(program))
        .args(args)
        .current_dir(root)
        .stdout(Stdio::null())
        .stderr(Stdio::from(fs::File::create(&err)?))
        .spawn()
        .with_context(|| format!("could not start `{line}`"))?;
    let mut status = 0;
    // SAFETY: `rusage` is plain data that `wait4` fills for our own child, which `child` never
    // waits for afterwards.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut ru) };
    let seconds = t0.elapsed().as_secs_f64();
    if pid < 0 {
        bail!("wait4 on `{line}`: {}", std::io::Error::last_os_error());
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        bail!("`{line}` failed (wait status {status}): {}", fs::read_to_string(&err).unwrap_or_default());
    }
    // Linux reports kibibytes.
    Ok((ru.ru_maxrss as u64 * 1024, seconds, line))
}

pub fn part(root: &Path, r: &Runner, opts: &Opts) -> Result<Memory> {
    let dir = root.join("target/bench/memory");
    fs::create_dir_all(&dir)?;
    let rows: &[(usize, f64)] = if opts.quick { &ROWS[..1] } else { &ROWS };
    let mut m = Memory::default();
    for &(n, dt) in rows {
        let csv = dir.join(format!("n{n}.csv"));
        let result = measure(root, r, &dir, &csv, n, dt, &mut m);
        // The records are big: never left behind.
        let _ = fs::remove_file(&csv);
        let _ = fs::remove_file(csv.with_extension("meta.json"));
        let _ = fs::remove_file(dir.join(format!("n{n}.out.csv")));
        let _ = fs::remove_file(dir.join(format!("n{n}-bare.csv")));
        result?;
    }
    m.spectra_import = Some(spectra_import(root, r, opts)?);
    Ok(m)
}

/// Simulate the spectra file, import it with its peak memory measured, delete both.
pub fn spectra_import(root: &Path, r: &Runner, opts: &Opts) -> Result<SpectraImport> {
    let dir = root.join("target/bench/memory");
    fs::create_dir_all(&dir)?;
    let dt = if opts.quick { SPECTRA_DT_S_QUICK } else { SPECTRA_DT_S };
    let toml = dir.join("spectra.toml");
    let (sp, rec, out) = (dir.join("spectra.csv"), dir.join("spectra-record.csv"), dir.join("spectra-import.csv"));
    let result = (|| -> Result<SpectraImport> {
        fs::write(&toml, format!("# the paper record's spectra, sampled finer\n[clock]\ndt_s = {dt}\n"))?;
        let (toml_s, sp_s, rec_s, out_s) = (rel(&toml, root), rel(&sp, root), rel(&rec, root), rel(&out, root));
        let simulate =
            r.simulate(&["--config", &toml_s, "--seed", "7", "--json", "--spectra", &sp_s, "--out", &rec_s])?;
        let spectra_bytes = fs::metadata(&sp)?.len();
        let spectra_rows = count_lines(&sp)?.saturating_sub(1);
        let (bytes, seconds, command) =
            peak_rss(root, TRAINER, &["import", "--format", "spectra-csv", &sp_s, "--out", &out_s])?;
        let run =
            MemoryRun { command, rows: spectra_rows as usize, what: "import".into(), peak_rss_bytes: bytes, seconds };
        Ok(SpectraImport { simulate, spectra_bytes, spectra_rows, run })
    })();
    for f in [&sp, &rec, &out, &rec.with_extension("meta.json")] {
        let _ = fs::remove_file(f);
    }
    result
}

/// Lines of the file at `path` (bytes `\n`), read in blocks.
fn count_lines(path: &Path) -> Result<u64> {
    use std::io::Read;
    let mut f = fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
    let mut buf = vec![0u8; 1 << 20];
    let mut n = 0u64;
    loop {
        let k = f.read(&mut buf)?;
        if k == 0 {
            return Ok(n);
        }
        n += buf.get(..k).unwrap_or_default().iter().filter(|&&b| b == b'\n').count() as u64;
    }
}

/// `cargo xtask bench --import-memory-only`: the spectra import's peak memory alone, into the
/// BENCHMARKS.json already there.
pub fn import_only(root: &Path, opts: &Opts) -> Result<()> {
    super::build_trainer(root)?;
    let part = spectra_import(root, &Runner { root: root.to_path_buf() }, opts)?;
    super::update(root, |r| {
        let memory = r.memory.get_or_insert_with(Memory::default);
        memory.spectra_import = Some(part);
        Ok(())
    })?;
    eprintln!("bench: wrote the spectra import's peak memory into BENCHMARKS.md and BENCHMARKS.json");
    Ok(())
}

fn measure(root: &Path, r: &Runner, dir: &Path, csv: &Path, n: usize, dt: f64, m: &mut Memory) -> Result<()> {
    let toml = dir.join(format!("n{n}.toml"));
    fs::write(&toml, format!("# {n} samples over the 14 days of the paper clock\n[clock]\ndt_s = {dt}\n"))?;
    let (csv_s, toml_s) = (rel(csv, root), rel(&toml, root));
    let c = r.simulate(&["--config", &toml_s, "--seed", "7", "--json", "--out", &csv_s])?;
    m.datasets.push(c);
    m.csv_bytes.push(fs::metadata(csv)?.len());
    let model = rel(&dir.join(format!("n{n}.fbgm")), root);
    let out = rel(&dir.join(format!("n{n}.out.csv")), root);
    let metrics = rel(&dir.join(format!("n{n}.metrics.json")), root);
    // The same record under a name without a `.meta.json` beside it: what `evaluate` reads of
    // a real record (Table 2 and the pace study, no simulation studies).
    let bare = dir.join(format!("n{n}-bare.csv"));
    let _ = fs::remove_file(&bare);
    fs::hard_link(csv, &bare)?;
    let bare_s = rel(&bare, root);
    let mut runs: Vec<(&str, Vec<&str>)> = vec![
        ("train", vec!["train", "--data", &csv_s, "--out", &model]),
        ("compensate", vec!["compensate", "--model", &model, "--data", &csv_s, "--out", &out]),
        ("evaluate", vec!["evaluate", "--quick", "--model", &model, "--data", &bare_s, "--metrics", &metrics]),
    ];
    // With the simulation's sidecar `evaluate` also re-simulates the record (the per-sample
    // oracle, the pace study's runs): measured at 10⁶ rows only, it takes about ten times
    // that at 10⁷.
    if n <= EVALUATE_MAX_ROWS {
        runs.push((
            "evaluate (simulated record)",
            vec!["evaluate", "--quick", "--model", &model, "--data", &csv_s, "--metrics", &metrics],
        ));
    }
    for (what, args) in runs {
        let (bytes, seconds, command) = peak_rss(root, TRAINER, &args)?;
        m.runs.push(MemoryRun { command, rows: n, what: what.into(), peak_rss_bytes: bytes, seconds });
    }
    Ok(())
}

/// The BENCHMARKS.md section.
pub fn markdown(s: &mut String, mem: &Memory) {
    out!(s, "## Memory (peak resident set per command)\n");
    out!(
        s,
        "Each command alone, its peak resident set from `wait4` (`ru_maxrss`); records of the `paper` preset sampled finer over its 14 days (seed 7). Targets at 10⁷ rows: `compensate` and `evaluate` ≤ {} MB (streaming rows), `train` ≤ {} MB (it holds the rows' columns as f64).\n",
        TARGET_STREAM_BYTES_1E7 / 1_000_000,
        TARGET_TRAIN_BYTES_1E7 / 1_000_000
    );
    out!(s, "| rows | CSV | command | peak RSS | wall time | target |");
    out!(s, "|---:|---:|---|---:|---:|---|");
    for r in &mem.runs {
        let csv = ROWS
            .iter()
            .position(|&(n, _)| n == r.rows)
            .and_then(|i| mem.csv_bytes.get(i))
            .map_or("–".to_string(), |b| format!("{:.0} MB", *b as f64 / 1e6));
        let target = match (r.rows, r.what.as_str()) {
            (10_000_000, "train") => Some(TARGET_TRAIN_BYTES_1E7),
            (10_000_000, "compensate" | "evaluate") => Some(TARGET_STREAM_BYTES_1E7),
            _ => None,
        };
        let verdict = target.map_or("–".to_string(), |t| {
            format!("≤ {} MB: {}", t / 1_000_000, if r.peak_rss_bytes <= t { "met" } else { "**not met**" })
        });
        out!(
            s,
            "| {} | {csv} | `{}` | {:.0} MB | {:.1} s | {verdict} |",
            r.rows,
            r.what,
            r.peak_rss_bytes as f64 / 1e6,
            r.seconds
        );
    }
    out!(
        s,
        "\n`evaluate` is `evaluate --quick` on the record without its simulation sidecar (a real record: Table 2 and the static audit), which streams its rows in two passes and reads only the calibration prefix the static audit needs. `evaluate (simulated record)` is the same beside its `.meta.json`, which adds the per-sample oracle and re-simulates the record: measured on {} rows only.",
        EVALUATE_MAX_ROWS
    );
    if let Some(sp) = &mem.spectra_import {
        let ok = sp.run.peak_rss_bytes <= TARGET_IMPORT_SPECTRA_BYTES;
        let size_ok = sp.spectra_bytes >= TARGET_IMPORT_SPECTRA_FILE_BYTES;
        let verdict = match (size_ok, ok) {
            (true, true) => "met",
            (true, false) => "**not met**",
            (false, _) => "not measured at that size (`--quick`)",
        };
        out!(
            s,
            "\n`import --format spectra-csv` of a {:.2} GB spectra file ({} spectra of 512 pixels, no map: discovery): peak RSS **{:.0} MB**, {:.1} s. Target: a {} GB file within {} MB: {verdict}.",
            sp.spectra_bytes as f64 / 1e9,
            sp.spectra_rows,
            sp.run.peak_rss_bytes as f64 / 1e6,
            sp.run.seconds,
            TARGET_IMPORT_SPECTRA_FILE_BYTES / 1_000_000_000,
            TARGET_IMPORT_SPECTRA_BYTES / 1_000_000
        );
    }
    out!(s, "\nCommands:\n");
    let spectra = mem.spectra_import.iter().flat_map(|sp| [&sp.simulate, &sp.run.command]);
    for c in mem.datasets.iter().chain(mem.runs.iter().map(|r| &r.command)).chain(spectra) {
        out!(s, "- `{c}`");
    }
    out!(s);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Set to a file path: [`peak_rss_probe`] measures there (in a process of its own).
    const PROBE: &str = "XTASK_PEAK_RSS_PROBE";

    /// Not a check on its own: run by [`peak_rss_is_the_childs_own`] in a fresh test process
    /// (small, as xtask is when the bench calls [`peak_rss`]), it writes the peaks of a child
    /// that touches 64 MiB and of one that touches nothing.
    #[test]
    fn peak_rss_probe() {
        let Some(out) = std::env::var_os(PROBE) else { return };
        let root = crate::cmd::root();
        let (big, _, _) = peak_rss(&root, "/usr/bin/env", &["python3", "-c", "b = bytearray(64 << 20)"]).unwrap();
        let (small, _, _) = peak_rss(&root, "/bin/sh", &["-c", "true"]).unwrap();
        fs::write(out, format!("{big} {small}")).unwrap();
    }

    #[test]
    fn peak_rss_is_the_childs_own() {
        let dir = crate::cmd::root().join("target/bench/memory");
        fs::create_dir_all(&dir).unwrap();
        let out = dir.join(format!("peaks-{}", std::process::id()));
        let probe = Command::new(std::env::current_exe().unwrap())
            .args(["--exact", "bench::memory::tests::peak_rss_probe", "--test-threads", "1", "-q"])
            .env(PROBE, &out)
            .output()
            .unwrap();
        assert!(probe.status.success(), "{}", String::from_utf8_lossy(&probe.stderr));
        let text = fs::read_to_string(&out).unwrap();
        fs::remove_file(&out).unwrap();
        let (big, small) = text.split_once(' ').unwrap();
        let (big, small): (u64, u64) = (big.parse().unwrap(), small.parse().unwrap());
        assert!(big > 64 << 20 && small < 32 << 20, "{big} {small}");
        assert!(peak_rss(&crate::cmd::root(), "/bin/sh", &["-c", "exit 3"]).is_err());
    }

    #[test]
    fn the_section_says_which_target_is_met() {
        let run = |rows, what: &str, mb: u64| MemoryRun {
            command: format!("target/release/fbg-trainer {what}"),
            rows,
            what: what.into(),
            peak_rss_bytes: mb * 1_000_000,
            seconds: 1.0,
        };
        let m = Memory {
            runs: vec![
                run(1_000_000, "evaluate", 900),
                run(10_000_000, "train", 1_100),
                run(10_000_000, "compensate", 300),
            ],
            datasets: vec!["target/release/fbg-trainer simulate".into()],
            csv_bytes: vec![93_000_000, 954_000_000],
            spectra_import: Some(SpectraImport {
                simulate: "target/release/fbg-trainer simulate --spectra s.csv".into(),
                spectra_bytes: 1_020_000_000,
                spectra_rows: 432_000,
                run: run(432_000, "import", 150),
            }),
        };
        let mut s = String::new();
        markdown(&mut s, &m);
        assert!(s.contains("| 10000000 | 954 MB | `train` | 1100 MB | 1.0 s | ≤ 1200 MB: met |"), "{s}");
        assert!(s.contains("| 10000000 | 954 MB | `compensate` | 300 MB | 1.0 s | ≤ 200 MB: **not met** |"), "{s}");
        assert!(s.contains("| 1000000 | 93 MB | `evaluate` | 900 MB | 1.0 s | – |"), "{s}");
        assert!(s.contains("peak RSS **150 MB**, 1.0 s. Target: a 1 GB file within 100 MB: **not met**."), "{s}");
        assert!(s.contains("- `target/release/fbg-trainer simulate --spectra s.csv`"), "{s}");
    }

    /// The whole part on 10⁶ rows (`--quick`); about two minutes, so run by hand:
    /// `cargo test -p xtask -- --ignored memory_part_on_a_million_rows` (after
    /// `cargo build --release -p fbg-trainer`).
    #[test]
    #[ignore]
    fn memory_part_on_a_million_rows() {
        let root = crate::cmd::root();
        let r = Runner { root: root.clone() };
        let opts = Opts {
            quick: true,
            no_device: true,
            markdown_only: false,
            spectrum_only: false,
            import_memory_only: false,
            footprint_only: false,
            installations_only: false,
        };
        let m = part(&root, &r, &opts).unwrap();
        let mut s = String::new();
        markdown(&mut s, &m);
        eprintln!("{s}");
        assert_eq!(m.runs.len(), 4);
        assert!(!root.join("target/bench/memory/n1000000.csv").exists(), "the record is deleted");
    }
}
