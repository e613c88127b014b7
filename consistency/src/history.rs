//! The run registry behind `--history <dir>`: one JSON line per run in `<dir>/runs.jsonl` with the
//! headline errors and the effects enabled, so the report can show the error falling as effects are
//! added.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

/// One registry entry.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct HistoryEntry {
    pub run_id: String,
    /// Seconds since the Unix epoch.
    pub unix_time_s: f64,
    pub status: String,
    /// Headline RMS residual per quantity.
    pub error: std::collections::BTreeMap<String, f64>,
    /// Effects switched on by `--enable`.
    pub enabled: Vec<String>,
    /// Effects switched off by `--disable`.
    pub disabled: Vec<String>,
    /// Effects the attribution accepted.
    pub accepted: Vec<String>,
}

/// File of the registry inside a history folder.
pub fn registry(dir: &Path) -> std::path::PathBuf {
    dir.join("runs.jsonl")
}

/// Reads the previous runs (missing file = none; unreadable lines are skipped with a warning).
pub fn load(dir: &Path, warnings: &mut Vec<String>) -> Result<Vec<HistoryEntry>> {
    let path = registry(dir);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("cannot read `{}`", path.display())),
    };
    let mut out = Vec::new();
    for (i, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        match serde_json::from_str::<HistoryEntry>(line) {
            Ok(e) => out.push(e),
            Err(e) => warnings.push(format!("{}:{}: skipped: {e}", path.display(), i + 1)),
        }
    }
    Ok(out)
}

/// Appends a run.
pub fn append(dir: &Path, entry: &HistoryEntry) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create `{}`", dir.display()))?;
    let path = registry(dir);
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .with_context(|| format!("cannot open `{}`", path.display()))?;
    writeln!(f, "{}", serde_json::to_string(entry)?)
        .with_context(|| format!("cannot write `{}`", path.display()))
}
