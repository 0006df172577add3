//! The sweep of a study: its grid of points and realisations, the tasks it runs and what their records
//! add up to.

use super::grid::{Axis, Grid, set_key, task_seed};
use super::record::{self, Outcome, TaskId, TaskRecord};
use super::stats::{self, PointStats};
use crate::config::{Study, StudyFile};
use crate::jobs::exec::Executor;
use crate::jobs::select::{Checkpointing, SelectCheckpoint};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use toml::Table;

/// ρ_opt values of a sweep without axes (the command's behaviour before `[sweep]` existed).
pub const DEFAULT_SNRS: [f64; 8] = [100.0, 200.0, 450.0, 1e3, 3e3, 1e4, 5e4, 3e5];

/// What the command line may set over the study's `[sweep]` table.
#[derive(Debug, Clone, Default)]
pub struct SweepArgs {
    /// Axes replacing the study's `[[sweep.axis]]` tables.
    pub axes: Option<Vec<Axis>>,
    pub realisations: Option<usize>,
    pub truth: Option<String>,
    /// Run directory (default `<output>/sweep`).
    pub output: Option<PathBuf>,
    /// `[select]` keys set for every point (the command line's `--target-error`,
    /// `--cross-checks`); they are part of the study, so of every task's identity.
    pub select: Vec<(&'static str, toml::Value)>,
}

/// A planned sweep: the base study, the grid and where its results go.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The study file (for messages).
    pub file: String,
    base_dir: PathBuf,
    base: Table,
    /// Hash of the base study (without `output` and `[sweep]`), part of every task's identity.
    pub study_id: String,
    pub grid: Grid,
    pub realisations: usize,
    pub truth: Option<String>,
    pub seed: u64,
    pub out: PathBuf,
    /// The `[[select.model]]` names.
    pub models: Vec<String>,
    /// What the user should know before the sweep runs.
    pub warnings: Vec<String>,
    /// The base study, resolved ([`crate::config::resolved_toml`]), for the run directory.
    pub resolved: String,
}

/// The numbers of a finished sweep.
#[derive(Debug, Clone)]
pub struct SweepResult {
    /// One per task, in task order.
    pub records: Vec<TaskRecord>,
    pub points: Vec<PointStats>,
    /// Row names of each pair (select's order).
    pub methods: Vec<Vec<String>>,
    /// Tasks read back from an earlier run, and computed now.
    pub reused: usize,
    pub computed: usize,
    pub seconds: f64,
}

impl Sweep {
    /// Plans the sweep of the study file at `path`.
    pub fn load(path: &Path, args: SweepArgs) -> anyhow::Result<Sweep> {
        let text = crate::data::infile::read_to_string(path)
            .with_context(|| format!("{}: cannot read the study file", path.display()))?;
        let base_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        Self::from_text(&text, &path.display().to_string(), &base_dir, args)
    }

    /// Plans the sweep of study-file text; `file` names it in messages and `base_dir` resolves
    /// its relative paths. Every point's study is built and validated here, before anything is
    /// computed.
    pub fn from_text(
        text: &str,
        file: &str,
        base_dir: &Path,
        args: SweepArgs,
    ) -> anyhow::Result<Sweep> {
        let edited = crate::config::with_select_keys(text, file, &args.select)?;
        let text = edited.as_str();
        let study = Study::from_toml(text, file, base_dir)?;
        let resolved = crate::config::resolved_toml(&study)?;
        if study.select_models.len() < 2 {
            bail!(
                "{file}: a sweep compares models: give at least two [[select.model]] tables (see examples/design-snr.toml)"
            );
        }
        let models: Vec<String> = study.select_models.iter().map(|m| m.name.clone()).collect();
        let opts = study.sweep.clone().unwrap_or_default();
        let axes = match args.axes {
            Some(a) => a,
            None if opts.axis.is_empty() => vec![Axis {
                key: "simulation.target_snr".into(),
                values: DEFAULT_SNRS.to_vec(),
            }],
            None => {
                let grids =
                    opts.validate(&models.iter().map(String::as_str).collect::<Vec<_>>(), file)?;
                opts.axis
                    .iter()
                    .zip(grids)
                    .map(|(a, values)| Axis {
                        key: a.key.clone(),
                        values,
                    })
                    .collect()
            }
        };
        // the command line's axes and counts go through the study's own checks
        let mut checked = opts.clone();
        checked.realisations = args.realisations.unwrap_or(opts.realisations);
        checked.truth = args.truth.or(opts.truth);
        checked.axis = axes
            .iter()
            .map(|a| crate::config::SweepAxis {
                key: a.key.clone(),
                values: Some(a.values.clone()),
                from: None,
                to: None,
                points: None,
                spacing: Default::default(),
            })
            .collect();
        let names: Vec<&str> = models.iter().map(String::as_str).collect();
        checked
            .validate(&names, file)
            .map_err(|e| anyhow::anyhow!("{e} (from the command line or [sweep])"))?;
        let mut base: Table = text.parse().with_context(|| format!("{file}: not TOML"))?;
        base.remove("sweep");
        let mut ident = base.clone();
        ident.remove("output");
        let study_id = format!(
            "{:016x}",
            record::fnv1a(
                toml::to_string(&ident)
                    .context("re-serialising the study")?
                    .as_bytes()
            )
        );
        let mut warnings = Vec::new();
        let read = study.analysis.dataset.is_some() || !study.data_sources.is_empty();
        if read && checked.realisations > 1 {
            warnings.push(format!(
                "{file} reads its data from files: its {} realisations share the same noise and differ only in the samplers' seeds",
                checked.realisations
            ));
        }
        let sweep = Sweep {
            warnings,
            file: file.into(),
            base_dir: base_dir.to_path_buf(),
            base,
            study_id,
            grid: Grid { axes },
            realisations: checked.realisations,
            truth: checked.truth,
            seed: study.seed,
            out: args.output.unwrap_or_else(|| study.output.join("sweep")),
            models,
            resolved,
        };
        for p in 0..sweep.grid.len() {
            sweep.study_at(p, 0)?;
        }
        Ok(sweep)
    }

    /// Number of tasks (points × realisations).
    pub fn task_count(&self) -> usize {
        self.grid.len() * self.realisations
    }

    /// The identity of task `t`.
    pub fn id(&self, t: usize) -> TaskId {
        let (p, r) = (t / self.realisations, t % self.realisations);
        let values = self.grid.point(p);
        TaskId {
            study: self.study_id.clone(),
            keys: self.grid.axes.iter().map(|a| a.key.clone()).collect(),
            seed: task_seed(self.seed, &values, r),
            values,
            realisation: r,
        }
    }

    /// The validated study of point `p`, realisation `r`.
    pub fn study_at(&self, p: usize, r: usize) -> anyhow::Result<Study> {
        let values = self.grid.point(p);
        let mut doc = self.base.clone();
        for (a, v) in self.grid.axes.iter().zip(&values) {
            set_key(&mut doc, &a.key, *v).with_context(|| self.file.clone())?;
        }
        let seed = task_seed(self.seed, &values, r);
        // a TOML integer cannot hold every u64: set the seed after validation
        doc.insert("seed".into(), toml::Value::Integer(0));
        let label = format!("{} [sweep point {}]", self.file, self.grid.label(p));
        let raw: StudyFile = toml::Value::Table(doc)
            .try_into()
            .map_err(|e: toml::de::Error| anyhow::anyhow!("{label}: {e}"))?;
        let mut study = raw.resolve(&label, &self.base_dir)?;
        study.seed = seed;
        Ok(study)
    }

    /// Runs task `t`: the model selection of its study. A failure is the task's result, not
    /// the sweep's.
    pub fn run_task(&self, t: usize) -> TaskRecord {
        let (p, r) = (t / self.realisations, t % self.realisations);
        let result = (|| -> anyhow::Result<Outcome> {
            let study = self.study_at(p, r)?;
            let prep = crate::jobs::prepare::prepare_select(&study)?;
            let (ck, stage) = self.task_checkpoints(t);
            let id = crate::jobs::prepare::identity(&study, &prep.dataset);
            // a task killed part-way continues from its stages (a damaged file: afresh)
            let state = SelectCheckpoint::read(&ck, &id)
                .unwrap_or_else(|_| SelectCheckpoint::new(id))
                .stage_file_at(stage);
            let state = match crate::jobs::select::stage_every_from_env()? {
                Some(every) => state.save_stage_every(every),
                None => state,
            };
            let ckpt = Checkpointing { path: &ck, state };
            let s = crate::jobs::select::run_checkpointed(&study, &prep, None, Some(ckpt))?;
            Ok(Outcome::from_summary(&s))
        })();
        let (outcome, error) = match result {
            Ok(o) => (Some(o), None),
            Err(e) => (None, Some(crate::jobs::error_text(&e))),
        };
        TaskRecord {
            id: self.id(t),
            outcome,
            error,
        }
    }

    /// Task `t`'s select checkpoint and stage file while it runs (`tasks/<hash>.select.cbor`,
    /// `tasks/<hash>.stage.cbor`), removed once its record is written.
    pub fn task_checkpoints(&self, t: usize) -> (PathBuf, PathBuf) {
        let record = self.id(t).path(&self.out);
        (
            record.with_extension("select.cbor"),
            record.with_extension("stage.cbor"),
        )
    }

    /// How many of the sweep's unfinished tasks have a select checkpoint or stage file in its
    /// run directory: work in progress that `--resume` continues.
    pub fn started_tasks(&self) -> usize {
        (0..self.task_count())
            .filter(|&t| TaskRecord::load(&self.out, &self.id(t)).is_none())
            .filter(|&t| {
                let (a, b) = self.task_checkpoints(t);
                a.is_file() || b.is_file()
            })
            .count()
    }

    /// How many of the sweep's tasks are finished in its run directory (what `--resume`
    /// resumes from).
    pub fn finished_tasks(&self) -> usize {
        (0..self.task_count())
            .filter(|&t| TaskRecord::load(&self.out, &self.id(t)).is_some())
            .count()
    }

    /// Runs every task not already in the run directory on `exec`, then computes each
    /// point's statistics. Returns `None` on the processes that are not the root.
    /// `log` prints one line per finished task.
    pub fn run(&self, exec: &dyn Executor, log: bool) -> anyhow::Result<Option<SweepResult>> {
        let print = |line: &str| println!("{line}");
        self.run_observed(exec, log.then_some(&print), None)
    }

    /// [`Sweep::run`], handing its lines (one per finished task) to `log` and counting the
    /// tasks this process finishes into `work` (its total: the tasks left to compute).
    pub fn run_observed(
        &self,
        exec: &dyn Executor,
        log: Option<&(dyn Fn(&str) + Sync)>,
        work: Option<&crate::jobs::progress::Work>,
    ) -> anyhow::Result<Option<SweepResult>> {
        let t0 = Instant::now();
        let n = self.task_count();
        let mut stored: Vec<Option<TaskRecord>> = vec![None; n];
        let mut todo = Vec::new();
        if exec.is_root() {
            let tasks = self.out.join("tasks");
            std::fs::create_dir_all(&tasks).with_context(|| {
                format!("cannot create the sweep's directory {}", tasks.display())
            })?;
            // temporaries of a killed run (atomic writes rename theirs on success)
            if let Ok(rd) = std::fs::read_dir(&tasks) {
                for e in rd.flatten() {
                    let name = e.file_name().to_string_lossy().into_owned();
                    if name.starts_with('.') && name.contains(".tmp-") {
                        let _ = std::fs::remove_file(e.path());
                    }
                }
            }
            let probe = tasks.join(".write-test");
            crate::atomic::write_bytes(&probe, b"")
                .and_then(|_| std::fs::remove_file(&probe))
                .with_context(|| format!("{} is not writable", tasks.display()))?;
            for (t, slot) in stored.iter_mut().enumerate() {
                *slot = TaskRecord::load(&self.out, &self.id(t));
                if slot.is_none() {
                    todo.push(t);
                }
            }
            if let Some(log) = log
                && todo.len() < n
            {
                log(&format!(
                    "reusing {} of {n} finished tasks from {}",
                    n - todo.len(),
                    tasks.display()
                ));
            }
        }
        let root = exec.is_root();
        let done = AtomicUsize::new(if root { n - todo.len() } else { 0 });
        if let Some(w) = work {
            w.start(todo.len() as u64);
        }
        let task = |t: usize| -> anyhow::Result<Vec<u8>> {
            // asked to stop: the tasks not started yet stay to do (tasks in flight finish,
            // their records kept, so a rerun continues after them)
            if crate::jobs::progress::stop_requested(work) {
                return Err(crate::jobs::progress::Interrupted.into());
            }
            let ts = Instant::now();
            let rec = self.run_task(t);
            let bytes = rec.to_bytes();
            let path = rec.id.path(&self.out);
            crate::atomic::write_bytes(&path, &bytes)
                .with_context(|| format!("writing {}", path.display()))?;
            // the record holds the task now; absent files are fine
            for f in <[PathBuf; 2]>::from(self.task_checkpoints(t)) {
                let _ = std::fs::remove_file(f);
            }
            if let Some(w) = work {
                w.done.fetch_add(1, Ordering::Relaxed);
            }
            if let Some(log) = log {
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                // only the root knows how many tasks were left: other ranks count their own
                let k = if root {
                    format!("{k}/{n}")
                } else {
                    format!("{k} here")
                };
                let what = match (&rec.outcome, &rec.error) {
                    (Some(o), _) => o
                        .pairs
                        .first()
                        .map(|p| match p.reference_ln_b() {
                            Some(v) => format!("ln B_{}{} = {v:.3} ({})", p.x, p.y, p.reference),
                            None => "no reference ln B".into(),
                        })
                        .unwrap_or_default(),
                    (None, e) => format!("failed: {}", e.as_deref().unwrap_or("")),
                };
                log(&format!(
                    "[{k}] {} r={}: {what} ({:.1} s)",
                    self.grid.label(t / self.realisations),
                    t % self.realisations,
                    ts.elapsed().as_secs_f64()
                ));
            }
            Ok(bytes)
        };
        let computed = exec.run(&todo, &task)?;
        if !exec.is_root() {
            return Ok(None);
        }
        let n_computed = computed.len();
        for (t, bytes) in computed {
            let rec = TaskRecord::from_bytes(&bytes)
                .with_context(|| format!("task {t}: a worker returned an unreadable result"))?;
            stored[t] = Some(rec);
        }
        let records: Vec<TaskRecord> = stored
            .into_iter()
            .enumerate()
            .map(|(t, r)| r.with_context(|| format!("task {t} has no result")))
            .collect::<anyhow::Result<_>>()?;
        let methods = methods_of(&records);
        let points = (0..self.grid.len())
            .map(|p| {
                let recs: Vec<&TaskRecord> = records
                    [p * self.realisations..(p + 1) * self.realisations]
                    .iter()
                    .collect();
                stats::point_stats(
                    p,
                    &self.grid.point(p),
                    &recs,
                    &self.models,
                    &methods,
                    self.truth.as_deref(),
                )
            })
            .collect();
        Ok(Some(SweepResult {
            reused: n - n_computed,
            computed: n_computed,
            records,
            points,
            methods,
            seconds: t0.elapsed().as_secs_f64(),
        }))
    }
}

/// Each pair's row names, in select's order (from the first task with numbers).
fn methods_of(records: &[TaskRecord]) -> Vec<Vec<String>> {
    records
        .iter()
        .find_map(|r| r.outcome.as_ref())
        .map(|o| {
            o.pairs
                .iter()
                .map(|p| p.estimates.iter().map(|e| e.method.clone()).collect())
                .collect()
        })
        .unwrap_or_default()
}
