//! Which groups of a fleet manifest one batch task runs: `fleet --shard I/N`, or the batch
//! engine's own variables.
//!
//! A group belongs to shard `CRC-64/XZ(name) mod N` (the group's `name` as UTF-8 bytes). The
//! partition depends on nothing but the name and N: reordering the manifest, adding or removing
//! other groups, or rerunning never moves a group to another shard, and every group is in
//! exactly one shard. Shards are numbered from 0.
//!
//! Without `--shard`, the task's index and the shard count come from the engine:
//! - Slurm array jobs: `SLURM_ARRAY_TASK_ID`; the count from `--shards N` when given, else
//!   `SLURM_ARRAY_TASK_COUNT`, else `SLURM_ARRAY_TASK_MAX − SLURM_ARRAY_TASK_MIN + 1` (the index
//!   then counts from `SLURM_ARRAY_TASK_MIN`). A resubmitted subset of the array
//!   (`sbatch --array=2`) has a smaller count, so job files pass `--shards N` (ours do).
//! - Kubernetes Indexed Jobs: `JOB_COMPLETION_INDEX`, with `--shards N` (the Job's
//!   `completions`), which Kubernetes does not export.

use std::fmt;

use super::records::CRC64;
use crate::error::TrainerError;

/// Shard `index` of `count` (0 ≤ index < count).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

/// Where the shard came from (for the summary).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShardSource {
    /// `--shard I/N`.
    Option,
    /// Slurm's array variables.
    Slurm,
    /// Kubernetes' `JOB_COMPLETION_INDEX`.
    Kubernetes,
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The shard of the group named `name` among `count` shards.
pub fn shard_of(name: &str, count: usize) -> usize {
    (CRC64.checksum(name.as_bytes()) % count.max(1) as u64) as usize
}

impl Shard {
    /// Build a shard, checking 1 ≤ count and index < count (the error follows where the
    /// numbers came from: `--shard 5/2: the index 5 is not below the count 2 …`).
    pub fn new(index: usize, count: usize) -> Result<Shard, String> {
        if count == 0 {
            return Err("the count must be at least 1".into());
        }
        if index >= count {
            return Err(format!("the index {index} is not below the count {count} (shards count from 0)"));
        }
        Ok(Shard { index, count })
    }

    /// Parse `I/N` (e.g. `0/4`). The error says what is wrong with `s` without quoting it: the
    /// caller names the option and its value first (`--shard 5/2: …`).
    pub fn parse(s: &str) -> Result<Shard, String> {
        let (i, n) = s.split_once('/').ok_or_else(|| "not I/N (e.g. 0/4)".to_string())?;
        let num = |x: &str, what: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("the {what} `{}` is not a whole number", crate::error::quote_cell(x)))
        };
        Shard::new(num(i, "index")?, num(n, "count")?)
    }

    /// Whether the group named `name` is in this shard.
    pub fn contains(&self, name: &str) -> bool {
        shard_of(name, self.count) == self.index
    }

    /// The shard a batch task runs: `--shard` when given, else the engine's variables (read
    /// through `var`), else none (the whole manifest). `shards` is `--shards N`.
    pub fn resolve(
        option: Option<&str>,
        shards: Option<usize>,
        var: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<(Shard, ShardSource)>, TrainerError> {
        let bad = |m: String| TrainerError::Config { origin: "fleet".into(), key: "shard".into(), message: m };
        if shards == Some(0) {
            return Err(TrainerError::options("--shards must be at least 1"));
        }
        if let Some(s) = option {
            // An option's error names the option once, with its value, and nothing before it.
            let quoted = crate::error::quote_cell(s);
            let sh = Shard::parse(s).map_err(|m| TrainerError::options(format!("--shard {quoted}: {m}")))?;
            if let Some(n) = shards.filter(|&n| n != sh.count) {
                return Err(TrainerError::options(format!(
                    "--shard {quoted} and --shards {n} disagree on the shard count"
                )));
            }
            return Ok(Some((sh, ShardSource::Option)));
        }
        let num = |name: &str| -> Result<Option<usize>, TrainerError> {
            match var(name) {
                None => Ok(None),
                Some(v) if v.trim().is_empty() => Ok(None),
                Some(v) => v
                    .trim()
                    .parse::<usize>()
                    .map(Some)
                    .map_err(|_| bad(format!("environment variable {name}=`{v}` is not a whole number"))),
            }
        };
        if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
            let (index, count) = match (shards, num("SLURM_ARRAY_TASK_COUNT")?, num("SLURM_ARRAY_TASK_MIN")?) {
                (Some(n), _, _) => (id, n),
                (None, Some(n), min) => (id - min.unwrap_or(0).min(id), n),
                (None, None, min) => match (min, num("SLURM_ARRAY_TASK_MAX")?) {
                    (Some(lo), Some(hi)) if hi >= lo && id >= lo => (id - lo, hi - lo + 1),
                    _ => {
                        return Err(bad(
                            "SLURM_ARRAY_TASK_ID is set but neither --shards nor SLURM_ARRAY_TASK_COUNT / \
                             SLURM_ARRAY_TASK_MIN and MAX give the shard count"
                                .into(),
                        ))
                    }
                },
            };
            let sh = Shard::new(index, count).map_err(|m| bad(format!("Slurm array task: {m}")))?;
            return Ok(Some((sh, ShardSource::Slurm)));
        }
        if let Some(index) = num("JOB_COMPLETION_INDEX")? {
            let n = shards.ok_or_else(|| {
                bad("JOB_COMPLETION_INDEX is set (a Kubernetes Indexed Job) but --shards N is not: pass the Job's completions as --shards".into())
            })?;
            let sh = Shard::new(index, n).map_err(|m| bad(format!("Kubernetes Indexed Job: {m}")))?;
            return Ok(Some((sh, ShardSource::Kubernetes)));
        }
        if shards.is_some() {
            return Err(bad(
                "--shards N was given but no shard index: pass --shard I/N, or run as a Slurm array task or a Kubernetes Indexed Job".into(),
            ));
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let m: HashMap<String, String> = pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        move |k| m.get(k).cloned()
    }

    #[test]
    fn every_group_is_in_exactly_one_shard_and_stays_there() {
        let names: Vec<String> = (0..500).map(|i| format!("pier-{i}")).collect();
        for n in 1..=8 {
            let shards: Vec<Shard> = (0..n).map(|i| Shard::new(i, n).unwrap()).collect();
            let mut sizes = vec![0usize; n];
            for name in &names {
                let owners: Vec<usize> = shards.iter().filter(|s| s.contains(name)).map(|s| s.index).collect();
                assert_eq!(owners.len(), 1, "{name} with N = {n}: {owners:?}");
                sizes[owners[0]] += 1;
            }
            // Roughly balanced: no shard under half or over twice its share.
            let share = names.len() / n;
            assert!(sizes.iter().all(|&s| s * 2 >= share && s <= 2 * share), "N = {n}: {sizes:?}");
        }
        // Reordering or dropping other groups does not move a group: the shard is a function of
        // the name; pinned values guard the algorithm itself.
        assert_eq!(shard_of("pier-3", 4), shard_of("pier-3", 4));
        assert_eq!(
            [shard_of("a", 4), shard_of("b", 4), shard_of("sensor-000", 4), shard_of("sensor-000", 3)],
            [1, 1, 0, 0]
        );
    }

    #[test]
    fn crc64_xz_is_the_partition_hash() {
        // The check value of CRC-64/XZ: the partition is the documented algorithm.
        assert_eq!(CRC64.checksum(b"123456789"), 0x995D_C9BB_DF19_39FA);
    }

    #[test]
    fn the_option_parses_and_is_checked() {
        assert_eq!(Shard::parse("1/4"), Ok(Shard { index: 1, count: 4 }));
        assert!(Shard::parse("4/4").unwrap_err().contains("not below"));
        assert!(Shard::parse("0/0").unwrap_err().contains("at least 1"));
        assert!(Shard::parse("x").unwrap_err().contains("I/N"));
        let none = env(&[]);
        assert_eq!(
            Shard::resolve(Some("2/3"), None, &none).unwrap(),
            Some((Shard { index: 2, count: 3 }, ShardSource::Option))
        );
        assert!(Shard::resolve(Some("2/3"), Some(4), &none).is_err());
        assert_eq!(Shard::resolve(None, None, &none).unwrap(), None);
        assert!(Shard::resolve(None, Some(4), &none).unwrap_err().to_string().contains("no shard index"));
        // The option's errors name it once, with its value, and nothing before it.
        let e =
            |option: &str, shards: Option<usize>| Shard::resolve(Some(option), shards, &none).unwrap_err().to_string();
        assert_eq!(e("5/2", None), "--shard 5/2: the index 5 is not below the count 2 (shards count from 0)");
        assert_eq!(e("1/x", None), "--shard 1/x: the count `x` is not a whole number");
        assert_eq!(e("1/2", Some(3)), "--shard 1/2 and --shards 3 disagree on the shard count");
        assert_eq!(e("0/1", Some(0)), "--shards must be at least 1");
    }

    #[test]
    fn slurm_variables_give_the_shard() {
        let s = |p: &[(&str, &str)], n: Option<usize>| Shard::resolve(None, n, env(p)).map(|o| o.map(|x| x.0));
        assert_eq!(
            s(&[("SLURM_ARRAY_TASK_ID", "3"), ("SLURM_ARRAY_TASK_COUNT", "4"), ("SLURM_ARRAY_TASK_MIN", "0")], None)
                .unwrap(),
            Some(Shard { index: 3, count: 4 })
        );
        // An array 1-4: the index counts from MIN.
        assert_eq!(
            s(&[("SLURM_ARRAY_TASK_ID", "4"), ("SLURM_ARRAY_TASK_MIN", "1"), ("SLURM_ARRAY_TASK_MAX", "4")], None)
                .unwrap(),
            Some(Shard { index: 3, count: 4 })
        );
        // A resubmitted single task (--array=2): --shards keeps the partition of the first run.
        let resub = [
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "1"),
            ("SLURM_ARRAY_TASK_MIN", "2"),
            ("SLURM_ARRAY_TASK_MAX", "2"),
        ];
        assert_eq!(s(&resub, Some(4)).unwrap(), Some(Shard { index: 2, count: 4 }));
        assert!(s(&[("SLURM_ARRAY_TASK_ID", "x")], None).unwrap_err().to_string().contains("SLURM_ARRAY_TASK_ID"));
        assert!(s(&[("SLURM_ARRAY_TASK_ID", "5")], Some(4)).unwrap_err().to_string().contains("not below"));
        assert!(s(&[("SLURM_ARRAY_TASK_ID", "1")], None).is_err());
        let src = Shard::resolve(None, Some(4), env(&resub)).unwrap().map(|x| x.1);
        assert_eq!(src, Some(ShardSource::Slurm));
    }

    #[test]
    fn kubernetes_completion_index_needs_the_shard_count() {
        let k = env(&[("JOB_COMPLETION_INDEX", "1")]);
        assert_eq!(
            Shard::resolve(None, Some(3), &k).unwrap(),
            Some((Shard { index: 1, count: 3 }, ShardSource::Kubernetes))
        );
        assert!(Shard::resolve(None, None, &k).unwrap_err().to_string().contains("--shards"));
        // The option wins over the environment.
        assert_eq!(Shard::resolve(Some("0/2"), None, &k).unwrap().map(|x| x.1), Some(ShardSource::Option));
    }
}
