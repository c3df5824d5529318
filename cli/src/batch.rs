//! `ratfit batch`: fit a database of materials, resumably and in shards.
//!
//! A manifest lists the materials and the `ratfit fit` options of each;
//! every output is named by the content key of its input file and settings,
//! written atomically and skipped when present, so a killed run resumes
//! where it stopped and the shards of a job array never write the same file.

use crate::brdf_cmd::{fit_to_json, FitArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, Parser};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `ratfit batch`.
#[derive(Args)]
pub struct BatchArgs {
    /// The manifest (TOML): an optional `[defaults]` table of `ratfit fit`
    /// options and one `[[material]]` per material with its `path`
    /// (relative to the manifest; `$RATFIT_DATA/` is the data folder), an
    /// optional `name` and any options of its own.
    manifest: PathBuf,
    /// Output folder: one fit per material, `NAME-KEY.json`, and
    /// `summary.csv` over the whole manifest.
    #[arg(long)]
    out: PathBuf,
    /// `I/N`: fit only the materials whose index `k` (from 0, in manifest
    /// order) has `k % N == I`, one shard of a job array (Slurm:
    /// `$SLURM_ARRAY_TASK_ID/N` with `--array=0-(N-1)`; Kubernetes Indexed
    /// Jobs: `$JOB_COMPLETION_INDEX/N`).
    #[arg(long, value_parser = shard)]
    shard: Option<Shard>,
}

/// One shard of a job array: index `I` of `N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    index: usize,
    count: usize,
}

/// Parses `I/N` with `0 <= I < N`.
fn shard(s: &str) -> Result<Shard, String> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}` is not I/N (for example 0/4)"))?;
    let parse = |v: &str, what: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|_| format!("{what} `{v}` of `{s}` is not a whole number"))
    };
    let (index, count) = (parse(i, "index")?, parse(n, "count")?);
    if count == 0 || index >= count {
        return Err(format!(
            "`{s}`: the index must be below the count (0 <= I < N)"
        ));
    }
    Ok(Shard { index, count })
}

/// Options the manifest may not set: the batch chooses them.
const RESERVED: [&str; 3] = ["output", "o", "json"];

/// Version of the content key: a change of what the key covers changes it.
const KEY_VERSION: &str = "ratfit-batch-1";

/// One material of the manifest, resolved.
struct Entry {
    name: String,
    input: PathBuf,
    /// `ratfit fit` options (defaults merged), in key order.
    options: BTreeMap<String, toml::Value>,
}

impl Entry {
    /// The content key: the input file's bytes, the options and the
    /// version of ratfit (a different version may fit differently).
    fn key(&self) -> Result<u64> {
        let bytes = std::fs::read(&self.input).with_context(|| {
            format!(
                "material `{}`: cannot read {}",
                self.name,
                self.input.display()
            )
        })?;
        let options = serde_json::to_string(&self.options)?;
        Ok(render_cpu::content_hash(&[
            KEY_VERSION.as_bytes(),
            env!("CARGO_PKG_VERSION").as_bytes(),
            &bytes,
            options.as_bytes(),
        ]))
    }

    fn output(&self, out: &Path, key: u64) -> PathBuf {
        out.join(format!("{}-{key:016x}.json", self.name))
    }

    /// `ratfit fit` arguments: each option as its flag (`rel_tol` is
    /// `--rel-tol`; `true` a bare flag, `false` nothing, arrays joined by
    /// commas); the render check only with `render_check = true`.
    fn fit_args(&self) -> Result<FitArgs> {
        #[derive(Parser)]
        #[command(name = "ratfit fit", no_binary_name = true)]
        struct FitCommand {
            #[command(flatten)]
            args: FitArgs,
        }
        let command = <FitCommand as clap::CommandFactory>::command();
        let known = |flag: &str| command.get_arguments().any(|a| a.get_long() == Some(flag));
        if let Some(key) = self
            .options
            .keys()
            .find(|k| *k != "render_check" && !known(&k.replace('_', "-")))
        {
            bail!(
                "material `{}`: `{key}` is not a `ratfit fit` option (see `ratfit fit --help`; `rel_tol` is `--rel-tol`)",
                self.name
            );
        }
        let mut argv = vec![self.input.to_string_lossy().into_owned()];
        let mut render_check = false;
        for (key, value) in &self.options {
            if key == "render_check" {
                render_check = value.as_bool().with_context(|| {
                    format!(
                        "material `{}`: render_check must be true or false",
                        self.name
                    )
                })?;
                continue;
            }
            let flag = format!("--{}", key.replace('_', "-"));
            match value {
                toml::Value::Boolean(true) => argv.push(flag),
                toml::Value::Boolean(false) => {}
                toml::Value::String(s) => argv.extend([flag, s.clone()]),
                toml::Value::Integer(i) => argv.extend([flag, i.to_string()]),
                toml::Value::Float(f) => argv.extend([flag, f.to_string()]),
                toml::Value::Array(items) => {
                    let parts: Result<Vec<String>> = items
                        .iter()
                        .map(|v| match v {
                            toml::Value::Integer(i) => Ok(i.to_string()),
                            toml::Value::Float(f) => Ok(f.to_string()),
                            toml::Value::String(s) => Ok(s.clone()),
                            _ => bail!("material `{}`: `{key}` holds a value that is not a number or a string", self.name),
                        })
                        .collect();
                    argv.extend([flag, parts?.join(",")]);
                }
                _ => bail!(
                    "material `{}`: `{key}` is a table or a date, not a `ratfit fit` option value",
                    self.name
                ),
            }
        }
        if !render_check {
            argv.push("--no-render-check".into());
        }
        // The output path is the batch's; `fit_to_json` does not write it.
        argv.extend(["-o".into(), "-".into()]);
        let parsed = FitCommand::try_parse_from(&argv).map_err(|e| {
            anyhow::anyhow!(
                "material `{}`: its options are not valid `ratfit fit` options: {}",
                self.name,
                e.render().to_string().trim()
            )
        })?;
        Ok(parsed.args)
    }
}

/// Reads and checks the manifest.
fn read_manifest(path: &Path) -> Result<Vec<Entry>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut doc: toml::Table =
        toml::from_str(&text).with_context(|| format!("{} is not TOML", path.display()))?;
    let at = |what: String| format!("{}: {what}", path.display());
    let defaults = match doc.remove("defaults") {
        Some(toml::Value::Table(t)) => t,
        Some(_) => bail!(at("`defaults` must be a table".into())),
        None => toml::Table::new(),
    };
    let materials = match doc.remove("material") {
        Some(toml::Value::Array(a)) => a,
        Some(_) => bail!(at(
            "`material` must be an array of tables ([[material]])".into()
        )),
        None => bail!(at("no [[material]] entry".into())),
    };
    if let Some(k) = doc.keys().next() {
        bail!(at(format!(
            "unknown top-level key `{k}` (defaults, material)"
        )));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut entries: Vec<Entry> = Vec::with_capacity(materials.len());
    for (k, m) in materials.into_iter().enumerate() {
        let toml::Value::Table(mut m) = m else {
            bail!(at(format!("material {k} is not a table")));
        };
        let Some(toml::Value::String(p)) = m.remove("path") else {
            bail!(at(format!("material {k} has no `path` string")));
        };
        let input =
            render_cpu::resolve_path(base, &p).map_err(|e| anyhow::anyhow!(at(e.to_string())))?;
        let name = match m.remove("name") {
            Some(toml::Value::String(n)) => n,
            Some(_) => bail!(at(format!("material {k}: `name` must be a string"))),
            None => input
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
        };
        let plain = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            && !name.starts_with('.');
        if !plain {
            bail!(at(format!(
                "material {k}: name `{name}` is not a plain file name (ASCII letters, digits, `-`, `_`, `.`)"
            )));
        }
        if entries.iter().any(|e| e.name == name) {
            bail!(at(format!("material {k}: the name `{name}` is used twice")));
        }
        let mut options = defaults.clone();
        options.extend(m);
        if let Some(r) = RESERVED.iter().find(|r| options.contains_key(**r)) {
            bail!(at(format!(
                "material `{name}`: `{r}` is set by the batch, not the manifest"
            )));
        }
        if !options.contains_key("format") {
            let f = brdf::TableFormat::of_path(&input).with_context(|| {
                at(format!(
                    "material `{name}`: no `format`, and {} is neither .bsdf (rgl) nor .binary (merl)",
                    input.display()
                ))
            })?;
            options.insert("format".into(), toml::Value::String(f.name().into()));
        }
        entries.push(Entry {
            name,
            input,
            options: options.into_iter().collect(),
        });
    }
    Ok(entries)
}

/// What happened to one material.
enum Outcome {
    Fitted,
    Skipped,
    Failed(String),
}

/// Whether `path` holds a finished output with `key`.
fn is_done(path: &Path, key: u64) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| {
            v.pointer("/batch/key")
                .and_then(|k| k.as_str().map(String::from))
        })
        .is_some_and(|k| k == format!("{key:016x}"))
}

fn fit_one(entry: &Entry, key: u64, path: &Path) -> Result<f64> {
    let start = Instant::now();
    let args = entry.fit_args()?;
    let mut out = fit_to_json(&args).with_context(|| format!("material `{}`", entry.name))?;
    let seconds = start.elapsed().as_secs_f64();
    out["batch"] = serde_json::json!({
        "name": entry.name,
        "input": entry.input,
        "key": format!("{key:016x}"),
        "options": entry.options,
        "seconds": seconds,
        "ratfit": env!("CARGO_PKG_VERSION"),
    });
    crate::output::write(path, serde_json::to_string_pretty(&out)?)?;
    Ok(seconds)
}

/// Runs `ratfit batch`.
pub fn run_batch(args: BatchArgs) -> Result<()> {
    let entries = read_manifest(&args.manifest)?;
    // Every material's options are checked before anything is fitted.
    for e in &entries {
        e.fit_args()
            .with_context(|| format!("in {}", args.manifest.display()))?;
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let shard = args.shard.unwrap_or(Shard { index: 0, count: 1 });
    let mine: Vec<usize> = (0..entries.len())
        .filter(|k| k % shard.count == shard.index)
        .collect();
    println!(
        "{}: {} materials, {} in shard {}/{}",
        args.manifest.display(),
        entries.len(),
        mine.len(),
        shard.index,
        shard.count
    );
    let mut outcomes: BTreeMap<usize, Outcome> = BTreeMap::new();
    for &k in &mine {
        let e = &entries[k];
        let outcome = match e.key() {
            Err(err) => Outcome::Failed(crate::output::chain_text(&err)),
            Ok(key) => {
                let path = e.output(&args.out, key);
                if is_done(&path, key) {
                    println!("{}: done already ({})", e.name, path.display());
                    Outcome::Skipped
                } else {
                    println!("{}: fitting {}", e.name, e.input.display());
                    match fit_one(e, key, &path) {
                        Ok(s) => {
                            println!("{}: wrote {} ({s:.1} s)", e.name, path.display());
                            Outcome::Fitted
                        }
                        Err(err) => Outcome::Failed(crate::output::chain_text(&err)),
                    }
                }
            }
        };
        if let Outcome::Failed(msg) = &outcome {
            eprintln!("{}: failed: {msg}", e.name);
        }
        outcomes.insert(k, outcome);
        if crate::process::requested() {
            // The interrupted material counts as failed; the rest wait.
            break;
        }
    }
    let summary = write_summary(&args.out, &entries, &outcomes)?;
    let count = |f: fn(&Outcome) -> bool| outcomes.values().filter(|o| f(o)).count();
    let failed = count(|o| matches!(o, Outcome::Failed(_)));
    println!(
        "shard {}/{}: {} fitted, {} skipped (done already), {failed} failed; {} of {} materials done; wrote {}",
        shard.index,
        shard.count,
        count(|o| matches!(o, Outcome::Fitted)),
        count(|o| matches!(o, Outcome::Skipped)),
        summary.0,
        entries.len(),
        summary.1.display()
    );
    if failed > 0 {
        bail!(
            "{failed} of {} materials of this shard failed (see above; a rerun retries them)",
            mine.len()
        );
    }
    Ok(())
}

/// One row of `summary.csv`: a material of the manifest, its status, and
/// for a done one what its output holds (empty fields otherwise).
#[derive(serde::Serialize)]
struct SummaryRow<'a> {
    name: &'a str,
    input: String,
    key: Option<String>,
    status: &'static str,
    file: Option<String>,
    coefficients: Option<usize>,
    bytes_f32: Option<usize>,
    fit_s: Option<f64>,
    lights_de: Option<f64>,
    sky_de: Option<f64>,
    note: String,
}

/// `summary.csv` over every material of the manifest (all shards): its
/// status, and for the done ones what the output holds. Returns the number
/// done and the path.
fn write_summary(
    out: &Path,
    entries: &[Entry],
    outcomes: &BTreeMap<usize, Outcome>,
) -> Result<(usize, PathBuf)> {
    let mut rows = Vec::with_capacity(entries.len());
    let mut done = 0;
    for (k, e) in entries.iter().enumerate() {
        let key = e.key().ok();
        let file = key.map(|key| e.output(out, key));
        let value = match (&file, key) {
            (Some(f), Some(key)) if is_done(f, key) => crate::brdf_cmd::read_json(f).ok(),
            _ => None,
        };
        let status = match (&value, outcomes.get(&k)) {
            (Some(_), _) => "done",
            (None, Some(Outcome::Failed(_))) => "failed",
            (None, _) => "missing",
        };
        let note = match outcomes.get(&k) {
            // One line per row.
            Some(Outcome::Failed(m)) => m.replace('\n', " "),
            _ => String::new(),
        };
        let fitted = value
            .as_ref()
            .zip(file.as_deref())
            .and_then(|(v, f)| brdf::FitFile::from_value(v.clone(), f).ok())
            .map(|file| file.brdf);
        let number = |p: &str| {
            value
                .as_ref()
                .and_then(|v| v.pointer(p))
                .and_then(serde_json::Value::as_f64)
        };
        done += usize::from(value.is_some());
        rows.push(SummaryRow {
            name: &e.name,
            input: e.input.to_string_lossy().into_owned(),
            key: key.map(|k| format!("{k:016x}")),
            status,
            file: file
                .as_ref()
                .filter(|_| value.is_some())
                .and_then(|f| f.file_name())
                .map(|f| f.to_string_lossy().into_owned()),
            coefficients: fitted.as_ref().map(|f| f.coefficients()),
            bytes_f32: fitted.as_ref().map(|f| f.byte_size_f32()),
            fit_s: number("/batch/seconds"),
            lights_de: number("/render/scenes/0/mean_de"),
            sky_de: number("/render/scenes/1/mean_de"),
            note,
        });
    }
    let path = out.join("summary.csv");
    crate::output::write_csv(&path, rows)?;
    Ok((done, path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_are_checked() {
        assert_eq!(shard("1/4"), Ok(Shard { index: 1, count: 4 }));
        for bad in ["4/4", "0/0", "1", "a/2", "-1/2", "1/2/3"] {
            assert!(shard(bad).is_err(), "{bad}");
        }
    }
}
