//! The manifest: its TOML, its groups (paths resolved against its directory) and the check of
//! every path a run may write.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::DEFAULT_MAX_CENTRES;
use crate::error::{line_col, TrainerError};
use crate::fit::{FeatureChoice, TrainOptions};
use crate::sign;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    #[serde(default)]
    defaults: Defaults,
    #[serde(default)]
    group: Vec<GroupFile>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Defaults {
    features: Option<String>,
    max_centres: Option<usize>,
    /// Read as any TOML value, so that a string or a table is refused naming the key.
    drift_spec_pm_per_sqrt_day: Option<toml::Value>,
    drift_gains: Option<toml::Value>,
    sign: Option<PathBuf>,
    serial_state: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GroupFile {
    name: String,
    data: PathBuf,
    out: PathBuf,
    features: Option<String>,
    max_centres: Option<usize>,
    drift_spec_pm_per_sqrt_day: Option<toml::Value>,
    drift_gains: Option<toml::Value>,
}

/// One sensor group of a manifest, paths resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Group {
    pub name: String,
    pub data: PathBuf,
    pub out: PathBuf,
    pub features: FeatureChoice,
    pub max_centres: usize,
    /// The interrogator's stated stability \[pm/√day\] (as `train --drift-spec`; checked
    /// 0 ..= 1 000): a floor under the band's growth with the drift's walk.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_spec_pm_per_sqrt_day: Option<f64>,
    /// The drift's relative gain per grating (as `train --drift-gains`; an array of numbers,
    /// one per grating of the group's record).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_gains: Option<Vec<f64>>,
    /// The key id the group's blobs are signed with (hex), when the run signs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub signed_by: Option<String>,
}

impl Group {
    /// The options the group is trained with: as `train --features F --max-centres K
    /// [--drift-spec X] [--drift-gains G1,..]`.
    pub fn train_options(&self) -> Result<TrainOptions, TrainerError> {
        self.features
            .train_options(self.max_centres)
            .map_err(TrainerError::options)?
            .to_builder()
            .drift_spec_pm_per_sqrt_day(self.drift_spec_pm_per_sqrt_day)
            .drift_gains(self.drift_gains.clone())
            .check()
            .map(|o| o.with_drift_gains_name("drift_gains"))
    }

    /// The Model-P blob beside the Model-H blob (`<stem>-p.fbgm`, as `train`).
    pub fn baseline_path(&self) -> PathBuf {
        crate::export::baseline_path(&self.out)
    }
    /// `<stem>.coefficients.json`.
    pub fn coefficients_path(&self) -> PathBuf {
        crate::export::coefficients_path(&self.out)
    }
    /// `<stem>.fleet.json`: the record that the group finished.
    pub fn sidecar_path(&self) -> PathBuf {
        crate::export::sidecar(&self.out, "fleet.json")
    }
    /// `<stem>.fleet-failed.json`: the record of the group's last failure.
    pub(crate) fn failure_path(&self) -> PathBuf {
        crate::export::sidecar(&self.out, "fleet-failed.json")
    }
}

/// A parsed, validated manifest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Manifest {
    pub path: PathBuf,
    pub groups: Vec<Group>,
    /// `[defaults] sign`: the private key every blob is signed with (resolved).
    pub sign: Option<PathBuf>,
    /// `[defaults] serial_state`: the signing state directory (the key id's serial ledger;
    /// resolved; `None`: as `train --sign` finds it, `fbg_trainer::sign::state_dir`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub serial_state: Option<PathBuf>,
    /// Outputs may lie outside the manifest's directory (`fleet --allow-outside`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub allow_outside: bool,
}

fn config_error(origin: &Path, key: impl Into<String>, message: impl Into<String>) -> TrainerError {
    TrainerError::Config { origin: origin.display().to_string(), key: key.into(), message: message.into() }
}

/// A TOML integer or float as a number (integers beyond 2^53 round; the range checks refuse
/// any of them anyway); `None` for any other value.
fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// The key of the stated drift in `[defaults]` and in a `[[group]]`.
const DRIFT_SPEC_KEY: &str = "drift_spec_pm_per_sqrt_day";

/// A stated drift \[pm/√day\] as the manifest gives it (an integer or a float), checked as
/// `train --drift-spec` is; errors name the file and `key`.
fn drift_spec(path: &Path, key: &str, v: Option<&toml::Value>) -> Result<Option<f64>, TrainerError> {
    let Some(v) = v else { return Ok(None) };
    let Some(spec) = number(v) else {
        return Err(config_error(
            path,
            key,
            format!(
                "must be a number of pm/√day; got the {} `{}`",
                v.type_str(),
                crate::error::quote_cell(&v.to_string())
            ),
        ));
    };
    TrainOptions::builder()
        .drift_spec_pm_per_sqrt_day(Some(spec))
        .check_ref()
        .map_err(|e| config_error(path, key, e.to_string()))?;
    Ok(Some(spec))
}

/// The key of the drift's gains in `[defaults]` and in a `[[group]]`.
const DRIFT_GAINS_KEY: &str = "drift_gains";

/// The drift's gains as the manifest gives them (an array of numbers), checked as
/// `train --drift-gains` is (the count against the record's gratings when the group trains);
/// errors name the file and `key`.
fn drift_gains(path: &Path, key: &str, v: Option<&toml::Value>) -> Result<Option<Vec<f64>>, TrainerError> {
    let Some(v) = v else { return Ok(None) };
    let not_numbers = |what: &toml::Value| {
        config_error(
            path,
            key,
            format!(
                "must be an array of numbers, one per grating; got the {} `{}`",
                what.type_str(),
                crate::error::quote_cell(&what.to_string())
            ),
        )
    };
    let toml::Value::Array(items) = v else { return Err(not_numbers(v)) };
    let gains =
        items.iter().map(|x| number(x).ok_or_else(|| not_numbers(x))).collect::<Result<Vec<f64>, TrainerError>>()?;
    TrainOptions::builder()
        .drift_gains(Some(gains.clone()))
        .check_ref()
        .map_err(|e| config_error(path, key, e.to_string()))?;
    Ok(Some(gains))
}

impl Manifest {
    /// Read and validate a manifest file; errors name the file and the key
    /// (`group[2].max_centres`, ...).
    pub fn from_file(path: &Path) -> Result<Manifest, TrainerError> {
        let text = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
        Self::from_str_at(&text, path)
    }

    /// Parse manifest text as if read from `path` (relative paths resolve against its
    /// directory).
    pub fn from_str_at(text: &str, path: &Path) -> Result<Manifest, TrainerError> {
        let raw: ManifestFile = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| line_col(text, s.start)).unwrap_or_default();
            config_error(path, at, e.message().trim_end().to_string())
        })?;
        if raw.group.is_empty() {
            return Err(config_error(path, "group", "no [[group]] in the manifest"));
        }
        // Checked even when every group gives its own.
        let default_drift =
            drift_spec(path, &format!("defaults.{DRIFT_SPEC_KEY}"), raw.defaults.drift_spec_pm_per_sqrt_day.as_ref())?;
        let default_gains =
            drift_gains(path, &format!("defaults.{DRIFT_GAINS_KEY}"), raw.defaults.drift_gains.as_ref())?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let resolve = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
        let mut groups: Vec<Group> = Vec::with_capacity(raw.group.len());
        let mut names: HashMap<String, usize> = HashMap::with_capacity(raw.group.len());
        let mut blobs: HashMap<PathBuf, usize> = HashMap::with_capacity(2 * raw.group.len());
        for (i, g) in raw.group.into_iter().enumerate() {
            let key = |k: &str| format!("group[{i}].{k}");
            if g.name.trim().is_empty() {
                return Err(config_error(path, key("name"), "must not be empty"));
            }
            if let Some(j) = names.insert(g.name.clone(), i) {
                return Err(config_error(path, key("name"), format!("`{}` is also the name of group[{j}]", g.name)));
            }
            if g.out.file_name().is_none() {
                return Err(config_error(path, key("out"), "must name a file"));
            }
            let (own_features, own_max) = (g.features.is_some(), g.max_centres.is_some());
            let max_centres = g.max_centres.or(raw.defaults.max_centres).unwrap_or(DEFAULT_MAX_CENTRES);
            let which = |k: &str, own: bool| if own { key(k) } else { format!("defaults.{k}") };
            let features = match g.features.as_deref().or(raw.defaults.features.as_deref()) {
                None => FeatureChoice::default(),
                Some(name) => FeatureChoice::from_name(name).ok_or_else(|| {
                    config_error(
                        path,
                        which("features", own_features),
                        format!("unknown feature set `{name}` (memory, hysteresis-aware, paper, all)"),
                    )
                })?,
            };
            if let Err(m) = FeatureChoice::default().train_options(max_centres) {
                return Err(config_error(path, which("max_centres", own_max), m));
            }
            let drift_spec_pm_per_sqrt_day = match &g.drift_spec_pm_per_sqrt_day {
                Some(v) => drift_spec(path, &key(DRIFT_SPEC_KEY), Some(v))?,
                None => default_drift,
            };
            let drift_gains = match &g.drift_gains {
                Some(v) => drift_gains(path, &key(DRIFT_GAINS_KEY), Some(v))?,
                None => default_gains.clone(),
            };
            let group = Group {
                name: g.name,
                data: resolve(&g.data),
                out: resolve(&g.out),
                features,
                max_centres,
                drift_spec_pm_per_sqrt_day,
                drift_gains,
                signed_by: None,
            };
            for p in [lexical(&group.out), lexical(&group.baseline_path())] {
                if let Some(j) = blobs.insert(p, i).filter(|&j| j != i) {
                    let other = &groups[j].name;
                    return Err(config_error(
                        path,
                        key("out"),
                        format!("writes the same file as group[{j}] (`{other}`)"),
                    ));
                }
            }
            groups.push(group);
        }
        let sign = raw.defaults.sign.as_deref().map(resolve);
        let serial_state = raw.defaults.serial_state.as_deref().map(resolve);
        // Outputs that are the same file however spelt (`sub/../m.fbgm`), an input, or
        // outside the manifest's directory are refused by `check_paths` before any work.
        Ok(Manifest { path: path.to_path_buf(), groups, sign, serial_state, allow_outside: false })
    }

    /// Check every file the run may write (each group's blobs, coefficients, record and
    /// failure record; a shard's report) before any work (DESIGN §9): none may be the same
    /// file as another output or as an input (the manifest, any group's data or its
    /// `.meta.json`, the signing key's files), by canonical path or by device and inode; none
    /// may lie outside the manifest's directory unless [`Manifest::allow_outside`]. Returns
    /// the outputs outside it (allowed). Hashing: O(n log n) in the number of groups.
    pub fn check_paths(
        &self,
        signer: Option<&sign::BlobSigner>,
        shard_report: Option<&Path>,
    ) -> Result<Vec<PathBuf>, TrainerError> {
        use crate::data::files::{first_clash, Clash, Resolver};
        let mut r = Resolver::default();
        let mut outputs: Vec<(PathBuf, Option<usize>, &str)> = Vec::with_capacity(5 * self.groups.len() + 1);
        for (i, g) in self.groups.iter().enumerate() {
            outputs.push((g.out.clone(), Some(i), "its Model-H blob"));
            outputs.push((g.baseline_path(), Some(i), "its Model-P blob"));
            outputs.push((g.coefficients_path(), Some(i), "its coefficients"));
            outputs.push((g.sidecar_path(), Some(i), "its record"));
            outputs.push((g.failure_path(), Some(i), "its failure record"));
        }
        if let Some(p) = shard_report {
            outputs.push((p.to_path_buf(), None, "the shard's report"));
        }
        let mut inputs: Vec<(PathBuf, String)> = vec![(self.path.clone(), "the manifest".into())];
        for (i, g) in self.groups.iter().enumerate() {
            inputs.push((g.data.clone(), format!("group[{i}].data")));
            inputs.push((crate::sim::meta::meta_path(&g.data), format!("group[{i}].data's .meta.json")));
            inputs.push((crate::data::record_meta::sidecar_path(&g.data), format!("group[{i}].data's .record.json")));
        }
        if let Some(s) = signer {
            for p in s.files_read() {
                inputs.push((p, "the signing key's files".into()));
            }
        }
        let outs: Vec<_> = outputs.iter().map(|(p, _, _)| r.resolve(p)).collect();
        let ins: Vec<_> = inputs.iter().map(|(p, _)| r.resolve(p)).collect();
        let key_of = |k: usize| outputs[k].1.map(|i| format!("group[{i}].out")).unwrap_or_else(|| "shard".into());
        if let Some((k, clash)) = first_clash(&outs, &ins) {
            let (p, _, what) = &outputs[k];
            let other = match clash {
                Clash::Input(j) => format!("{} (`{}`)", inputs[j].1, inputs[j].0.display()),
                Clash::Output(j) => format!("{} of {} (`{}`)", outputs[j].2, key_of(j), outputs[j].0.display()),
            };
            return Err(config_error(
                &self.path,
                key_of(k),
                format!("`{}` ({what}) is the same file as {other}; refusing to overwrite it", p.display()),
            ));
        }
        let base = r.resolve(&self.path.parent().map(|d| d.join(".")).unwrap_or_else(|| PathBuf::from("."))).canonical;
        let mut outside = Vec::new();
        for (k, o) in outs.iter().enumerate() {
            if o.canonical.starts_with(&base) {
                continue;
            }
            if !self.allow_outside {
                return Err(config_error(
                    &self.path,
                    key_of(k),
                    format!(
                        "`{}` is outside the manifest's directory `{}`; refusing to write there (pass --allow-outside to allow it)",
                        outputs[k].0.display(),
                        base.display()
                    ),
                ));
            }
            outside.push(outputs[k].0.clone());
        }
        Ok(outside)
    }
}

/// `path` with `.` dropped and `name/..` folded, as text only (the file system check,
/// [`Manifest::check_paths`], also sees symbolic and hard links).
fn lexical(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}
