//! The benchmark's instances, declared in a TOML file (`bench/fit.toml`),
//! and the interval data each one stands for.

use anyhow::{bail, Context, Result};
use brdf::{Reduction, ReductionKind, RglBrdf, Samples};
use rational_core::IntervalData;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The instance list shipped with the repository.
pub const DEFAULT_INSTANCES: &str = include_str!("../fit.toml");

/// A whole instance file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceFile {
    /// Run-wide settings.
    #[serde(default)]
    pub settings: RunSettings,
    /// The instances, in order.
    #[serde(rename = "instance")]
    pub instances: Vec<Instance>,
}

/// Timing settings of a run.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSettings {
    /// A backend is not run on a case whose time it is predicted to exceed
    /// this many seconds (full run).
    pub budget_s: f64,
    /// The same for `--quick`.
    pub quick_budget_s: f64,
    /// Timed repetitions after the warm-up (full run; fewer when slow).
    pub repetitions: usize,
    /// The same for `--quick`.
    pub quick_repetitions: usize,
    /// Backends other than native are not run above this many samples:
    /// their time grows quadratically or worse, and one solve cannot be
    /// interrupted.
    pub comparison_max_samples: usize,
}

impl Default for RunSettings {
    fn default() -> Self {
        Self {
            budget_s: 60.0,
            quick_budget_s: 3.0,
            repetitions: 5,
            quick_repetitions: 3,
            comparison_max_samples: 200_000,
        }
    }
}

/// One benchmark instance: a data family fitted at several sizes,
/// tolerances and splits.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Instance {
    /// Short name (file-name safe).
    pub name: String,
    /// What it is, for the summary.
    #[serde(default)]
    pub description: String,
    /// Relative half-widths of the intervals.
    pub rel_tol: Vec<f64>,
    /// Splits `(n_p, n_q)` solved singly on every backend.
    pub splits: Vec<[usize; 2]>,
    /// Splits for `--quick` (default: `splits`).
    #[serde(default)]
    pub quick_splits: Option<Vec<[usize; 2]>>,
    /// Also run the sweep of every split at this coefficient budget.
    #[serde(default)]
    pub sweep: Option<usize>,
    /// Also run AAA (1-D data only) up to the largest `n_q` of the splits.
    #[serde(default)]
    pub aaa: bool,
    /// Part of `--quick`.
    #[serde(default)]
    pub quick: bool,
    /// Where the data come from.
    pub data: DataSource,
}

/// The data of an instance.
#[derive(Debug, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DataSource {
    /// A standard 1-D function on an even grid.
    Function {
        /// runge, exp, abs, lobe or tan.
        function: String,
        /// Sample counts of the full run.
        samples: Vec<usize>,
        /// Sample counts of `--quick`.
        #[serde(default)]
        quick_samples: Vec<usize>,
    },
    /// A channel of an RGL `.bsdf` file, reduced to 2-D or 3-D.
    Rgl {
        /// Path relative to the data folder (`RATFIT_DATA`).
        file: String,
        /// 2 (slice phi_d = pi/2) or 3 (theta_h, theta_d, phi_d).
        dims: usize,
        /// r, g or b.
        channel: String,
        /// Grazing cut in degrees.
        #[serde(default = "default_max_theta_d")]
        max_theta_d: f64,
        /// Largest elevation of either direction in degrees.
        #[serde(default = "default_max_elevation")]
        max_elevation: f64,
        /// Grids `[n_theta_h, n_theta_d(, n_phi_d)]` of the full run.
        grids: Vec<Vec<usize>>,
        /// Grids of `--quick`.
        #[serde(default)]
        quick_grids: Vec<Vec<usize>>,
    },
}

fn default_max_theta_d() -> f64 {
    78.0
}

fn default_max_elevation() -> f64 {
    70.0
}

impl InstanceFile {
    /// Parses and checks an instance file.
    ///
    /// # Errors
    /// Malformed TOML, unknown keys, or settings that cannot be run.
    pub fn parse(text: &str, origin: &str) -> Result<Self> {
        let file: Self =
            toml::from_str(text).with_context(|| format!("{origin}: bad instance file"))?;
        if file.instances.is_empty() {
            bail!("{origin}: no [[instance]]");
        }
        let mut names = std::collections::HashSet::new();
        for inst in &file.instances {
            let at = format!("{origin}: instance `{}`", inst.name);
            if !names.insert(inst.name.as_str()) {
                bail!("{at} is declared twice");
            }
            if inst.rel_tol.is_empty() || inst.rel_tol.iter().any(|t| !(*t > 0.0 && t.is_finite()))
            {
                bail!("{at}: rel_tol must be positive numbers");
            }
            if inst.splits.is_empty()
                || inst
                    .splits
                    .iter()
                    .chain(inst.quick_splits.iter().flatten())
                    .any(|s| s[0] == 0 || s[1] == 0)
            {
                bail!("{at}: splits must be [n_p, n_q] with both >= 1");
            }
            if inst.sweep.is_some_and(|n| n < 2) {
                bail!("{at}: a sweep needs a budget of at least 2");
            }
            match &inst.data {
                DataSource::Function {
                    function,
                    samples,
                    quick_samples,
                } => {
                    standard_function(function).with_context(|| at.clone())?;
                    if samples.iter().chain(quick_samples).any(|&n| n < 2) {
                        bail!("{at}: sample counts must be >= 2");
                    }
                }
                DataSource::Rgl {
                    dims,
                    channel,
                    grids,
                    quick_grids,
                    ..
                } => {
                    if inst.aaa {
                        bail!("{at}: AAA runs on 1-D functions only");
                    }
                    channel_index(channel).with_context(|| at.clone())?;
                    let want = if *dims == 3 { 3 } else { 2 };
                    if !matches!(dims, 2 | 3)
                        || grids
                            .iter()
                            .chain(quick_grids)
                            .any(|g| g.len() != want || g.iter().any(|&n| n < 2))
                    {
                        bail!("{at}: dims is 2 or 3 and each grid has that many bin counts >= 2");
                    }
                }
            }
        }
        Ok(file)
    }
}

impl Instance {
    /// The splits of this run.
    pub fn splits(&self, quick: bool) -> &[[usize; 2]] {
        match (&self.quick_splits, quick) {
            (Some(q), true) => q,
            _ => &self.splits,
        }
    }

    /// The sizes of this run, in the order given.
    pub fn sizes(&self, quick: bool) -> Vec<Size> {
        match &self.data {
            DataSource::Function {
                samples,
                quick_samples,
                ..
            } => if quick { quick_samples } else { samples }
                .iter()
                .map(|&n| Size::Samples(n))
                .collect(),
            DataSource::Rgl {
                grids, quick_grids, ..
            } => if quick { quick_grids } else { grids }
                .iter()
                .map(|g| Size::Grid(g.clone()))
                .collect(),
        }
    }

    /// Loads what the sizes share (the measured file), once.
    ///
    /// # Errors
    /// The data folder or file is missing or malformed.
    pub fn source(&self, data_dir: Option<&Path>) -> Result<Source> {
        match &self.data {
            DataSource::Function { function, .. } => {
                Ok(Source::Function(standard_function(function)?))
            }
            DataSource::Rgl { file, .. } => {
                let dir = data_dir.context(
                    "the measured data folder is missing (set RATFIT_DATA or place it at ../shared/data)",
                )?;
                let path = dir.join(file);
                Ok(Source::Rgl(Box::new(RglBrdf::read(&path).with_context(
                    || format!("cannot read {}", path.display()),
                )?)))
            }
        }
    }

    /// Samples of one size (before intervals are put around them).
    pub fn sample(&self, source: &Source, size: &Size) -> Result<Sampled> {
        match (&self.data, source, size) {
            (_, Source::Function(f), Size::Samples(n)) => {
                let (a, b) = f.domain;
                let x: Vec<f64> = (0..*n)
                    .map(|i| a + (b - a) * i as f64 / (*n - 1) as f64)
                    .collect();
                let v = x.iter().map(|&x| (f.eval)(x)).collect();
                Ok(Sampled::Values { x, v })
            }
            (
                DataSource::Rgl {
                    dims,
                    channel,
                    max_theta_d,
                    max_elevation,
                    ..
                },
                Source::Rgl(brdf),
                Size::Grid(g),
            ) => {
                let kind = if *dims == 3 {
                    ReductionKind::Full3d
                } else {
                    ReductionKind::Slice2d
                };
                let mut r = Reduction::default()
                    .with_kind(kind)
                    .with_max_theta_d(*max_theta_d)
                    .with_max_elevation(*max_elevation)
                    .with_resolution(g[0], g[1]);
                if let Some(&p) = g.get(2) {
                    r = r.with_phi_resolution(p);
                }
                Ok(Sampled::Brdf {
                    samples: Box::new(r.sample(brdf.as_ref())),
                    channel: channel_index(channel)?,
                })
            }
            _ => bail!(
                "instance `{}`: size {size} does not match its data",
                self.name
            ),
        }
    }
}

/// One size of an instance.
#[derive(Debug, Clone, PartialEq)]
pub enum Size {
    /// Samples of a 1-D function.
    Samples(usize),
    /// Bins of a BRDF reduction.
    Grid(Vec<usize>),
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Size::Samples(n) => write!(f, "{n} samples"),
            Size::Grid(g) => {
                let s: Vec<String> = g.iter().map(usize::to_string).collect();
                write!(f, "grid {}", s.join("x"))
            }
        }
    }
}

/// What the sizes of an instance share.
pub enum Source {
    /// A standard function.
    Function(StandardFunction),
    /// A measured BRDF.
    Rgl(Box<RglBrdf>),
}

/// The samples of one size.
pub enum Sampled {
    /// Points and values of a 1-D function.
    Values {
        /// Abscissae.
        x: Vec<f64>,
        /// Values.
        v: Vec<f64>,
    },
    /// A BRDF reduction and the channel fitted.
    Brdf {
        /// The reduction's samples.
        samples: Box<Samples>,
        /// Channel index.
        channel: usize,
    },
}

impl Sampled {
    /// Interval data with relative half-width `rel_tol`.
    ///
    /// # Errors
    /// Invalid values (zero-width intervals are accepted by the data type
    /// but are never feasible).
    pub fn intervals(&self, rel_tol: f64) -> Result<IntervalData> {
        Ok(match self {
            Sampled::Values { x, v } => {
                IntervalData::from_values_relative(1, x.clone(), v.clone(), rel_tol)?
            }
            Sampled::Brdf { samples, channel } => samples.channel(*channel, rel_tol, 0.0)?.0,
        })
    }

    /// The 1-D abscissae and values, when the data are 1-D.
    pub fn one_dimensional(&self) -> Option<(&[f64], &[f64])> {
        match self {
            Sampled::Values { x, v } => Some((x, v)),
            Sampled::Brdf { .. } => None,
        }
    }
}

/// A standard function of the 1-D instances.
#[derive(Clone, Copy)]
pub struct StandardFunction {
    /// The function.
    pub eval: fn(f64) -> f64,
    /// Its domain.
    pub domain: (f64, f64),
}

/// The standard functions by name.
///
/// # Errors
/// Unknown name.
pub fn standard_function(name: &str) -> Result<StandardFunction> {
    Ok(match name {
        "runge" => StandardFunction {
            eval: |x| 1.0 / (1.0 + 25.0 * x * x),
            domain: (-1.0, 1.0),
        },
        "exp" => StandardFunction {
            eval: f64::exp,
            domain: (-1.0, 1.0),
        },
        "abs" => StandardFunction {
            eval: |x| x.abs() + 0.1,
            domain: (-1.0, 1.0),
        },
        // A Phong-like specular lobe of exponent 500 over a diffuse floor:
        // it falls by 100x within 0.14 rad.
        "lobe" => StandardFunction {
            eval: |x| 0.02 + x.cos().powi(500),
            domain: (0.0, std::f64::consts::FRAC_PI_2),
        },
        // tan approaches its pole at pi/2 to within 0.02 (value 48).
        "tan" => StandardFunction {
            eval: f64::tan,
            domain: (0.05, 1.55),
        },
        other => bail!("unknown function `{other}` (runge, exp, abs, lobe, tan)"),
    })
}

fn channel_index(c: &str) -> Result<usize> {
    Ok(match c {
        "r" => 0,
        "g" => 1,
        "b" => 2,
        other => bail!("unknown channel `{other}` (r, g, b)"),
    })
}

/// The measured data folder: `RATFIT_DATA`, else `../shared/data` from the
/// working directory, else beside the repository.
pub fn data_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RATFIT_DATA") {
        return Some(PathBuf::from(d)).filter(|d| d.is_dir());
    }
    [
        PathBuf::from("../shared/data"),
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
    ]
    .into_iter()
    .find(|d| d.is_dir())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_instance_file_parses() {
        let f = InstanceFile::parse(DEFAULT_INSTANCES, "bench/fit.toml").unwrap();
        assert!(f.instances.iter().any(|i| i.quick));
        for name in ["runge", "exp", "abs", "lobe", "tan"] {
            assert!(
                f.instances.iter().any(
                    |i| matches!(&i.data, DataSource::Function { function, .. } if function == name)
                ),
                "{name}"
            );
        }
    }

    #[test]
    fn bad_files_name_the_problem() {
        let base = "[[instance]]\nname = \"a\"\nrel_tol = [0.1]\nsplits = [[2, 2]]\n";
        let err = |s: &str| format!("{:#}", InstanceFile::parse(s, "t.toml").unwrap_err());
        assert!(err("").contains("instance"));
        assert!(err(&format!(
            "{base}data = {{ kind = \"function\", function = \"sinc\", samples = [10] }}"
        ))
        .contains("sinc"));
        assert!(err(&format!(
            "{base}data = {{ kind = \"function\", function = \"exp\", samples = [10], bogus = 1 }}"
        ))
        .contains("bogus"));
        let zero = base.replace("[[2, 2]]", "[[0, 2]]");
        assert!(err(&format!(
            "{zero}data = {{ kind = \"function\", function = \"exp\", samples = [10] }}"
        ))
        .contains("splits"));
        assert!(err(&format!("{base}aaa = true\ndata = {{ kind = \"rgl\", file = \"x\", dims = 2, channel = \"b\", grids = [[9, 9]] }}")).contains("AAA"));
        assert!(err(&format!("{base}data = {{ kind = \"rgl\", file = \"x\", dims = 3, channel = \"b\", grids = [[9, 9]] }}")).contains("grid"));
    }

    #[test]
    fn functions_sample_their_domain() {
        let inst = &InstanceFile::parse(DEFAULT_INSTANCES, "t")
            .unwrap()
            .instances[0];
        let src = inst.source(None).unwrap();
        let s = inst.sample(&src, &Size::Samples(11)).unwrap();
        let (x, v) = s.one_dimensional().unwrap();
        assert_eq!(x.len(), 11);
        assert!(v.iter().all(|v| v.is_finite()));
        let d = s.intervals(0.01).unwrap();
        assert_eq!(d.len(), 11);
    }
}
