//! `mdas merge` of sweep and tune parts (issue 52 item 3; references are
//! merged by [`crate::session::parts`]). `mdas sweep --part I/N` measures
//! a contiguous share of the sweep's points and `mdas tune --part I/N` of
//! the search's work items (Halton's budgets, then the configurations),
//! each as one process would, and writes a part record (`sweep-part.json`,
//! `tune-part.json`) holding its rows and everything that makes the whole
//! run what it is. The merge checks that the parts belong together — the
//! same scene bytes, film scale, budgets, seeds, reference (its pixels'
//! SHA-256), MDAS parameters, grid, crate version and commit, and adapter
//! and driver (the times of different devices do not compare) — that each
//! part is there once and holds exactly its share, and only then writes
//! the files one process writes, as one unit: `sweep.json` with its CSV
//! and plots, or `tune.json` and `tune.csv` ranked and fitted from the
//! merged measurements. Every field equals the one-process run's but the
//! measured times (each point's own, so merged times are those of the
//! parts' processes), the provenance's command line and time (the merge's)
//! and `merged_from` (each part's command line and time).

use super::sweep::{self, SweepPart, SweepResult};
use super::tune::{self, TunePart, TuneReport};
use crate::atomic::StagedDir;
use crate::provenance::PartProvenance;
use crate::session::parts::Part;
use anyhow::{bail, Context, Result};
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// What a part file is a part of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartKind {
    Reference,
    Sweep,
    Tune,
}

impl PartKind {
    /// The kind of the part at `path`: a directory holding a sweep or tune
    /// part record, such a record, or a reference part's EXR.
    pub fn of(path: &Path) -> Result<PartKind> {
        if path.is_dir() {
            return match (
                path.join(sweep::PART_FILE).is_file(),
                path.join(tune::PART_FILE).is_file(),
            ) {
                (true, false) => Ok(PartKind::Sweep),
                (false, true) => Ok(PartKind::Tune),
                (true, true) => bail!(
                    "{} holds both a sweep and a tune part; name the file",
                    path.display()
                ),
                (false, false) => bail!(
                    "{} holds no part ({} or {})",
                    path.display(),
                    sweep::PART_FILE,
                    tune::PART_FILE
                ),
            };
        }
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("exr") => Ok(PartKind::Reference),
            Some(e) if e.eq_ignore_ascii_case("json") => {
                match read_value(path)?["format"].as_str() {
                    Some(sweep::PART_FORMAT) => Ok(PartKind::Sweep),
                    Some(tune::PART_FORMAT) => Ok(PartKind::Tune),
                    _ => bail!(
                        "{}: not a part of `mdas sweep --part` or `mdas tune --part`",
                        path.display()
                    ),
                }
            }
            _ => bail!(
                "{}: not a part (a reference part's .exr, or a sweep or tune part's directory or .json)",
                path.display()
            ),
        }
    }

    /// The kind all of `paths` share.
    pub fn of_all(paths: &[PathBuf]) -> Result<PartKind> {
        let Some(first) = paths.first() else {
            bail!("no parts to merge");
        };
        let kind = PartKind::of(first)?;
        for p in &paths[1..] {
            let k = PartKind::of(p)?;
            if k != kind {
                bail!(
                    "{} is a {k:?} part and {} a {kind:?} part: merge parts of one run",
                    p.display(),
                    first.display()
                );
            }
        }
        Ok(kind)
    }
}

/// What a merge needs of a part record's kind.
trait PartRecord: DeserializeOwned + serde::Serialize {
    /// The file a part writes in its directory, and its format tag.
    const FILE: &'static str;
    const FORMAT: &'static str;
    /// The record's fields that are each part's own (dotted paths): all
    /// others must be equal across the parts of one run.
    const OWN: &'static [&'static str];
    fn part(&self) -> Part;
    fn provenance(&self) -> &crate::provenance::Provenance;
    /// Checks every field a merge sizes, indexes or writes something by
    /// against the run the record says it is part of (its own head: the
    /// budgets, points, seeds and part count), naming the field; run on
    /// each part before anything is allocated or written.
    fn check(&self) -> std::result::Result<(), String>;
}

impl PartRecord for SweepPart {
    const FILE: &'static str = sweep::PART_FILE;
    const FORMAT: &'static str = sweep::PART_FORMAT;
    const OWN: &'static [&'static str] = &[
        "part",
        "first",
        "end",
        "result.rows",
        "result.provenance.command_line",
        "result.provenance.timestamp_utc",
    ];
    fn part(&self) -> Part {
        Part {
            index: self.part,
            count: self.parts,
        }
    }
    fn provenance(&self) -> &crate::provenance::Provenance {
        &self.result.provenance
    }
    fn check(&self) -> std::result::Result<(), String> {
        if self.spps.is_empty() || self.spps.contains(&0) {
            return Err(format!("'spps' {:?} are not budgets", self.spps));
        }
        let mut sorted = self.spps.clone();
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            return Err(format!("'spps' {:?} list a budget twice", self.spps));
        }
        let skipped = &self.result.mdas_skipped;
        if !skipped.iter().all(|s| self.spps.contains(s)) || {
            let mut k = skipped.clone();
            k.sort_unstable();
            k.windows(2).any(|w| w[0] == w[1])
        } {
            return Err(format!(
                "'result.mdas_skipped' {skipped:?} are not budgets of 'spps' {:?}",
                self.spps
            ));
        }
        let mdas_spps: Vec<u32> = self
            .spps
            .iter()
            .copied()
            .filter(|s| !skipped.contains(s))
            .collect();
        // With pixel-adaptive Halton's points after Halton's, or without
        // them (`--methods halton,mdas`).
        let adaptive = self.points.iter().any(|(m, _)| m == super::adaptive::NAME);
        let points = super::sweep::points_of(&mdas_spps, &self.spps, adaptive);
        if self.points != points {
            return Err(format!(
                "'points' are not the sweep of 'spps' {:?} less 'result.mdas_skipped' for MDAS",
                self.spps
            ));
        }
        check_seeds(self.seeds)?;
        if let Some(row) = self
            .result
            .rows
            .iter()
            .find(|r| r.seeds.len() != self.seeds as usize)
        {
            return Err(format!(
                "'result.rows' {} {} spp has {} seeds, not 'seeds' {}",
                row.method,
                row.spp,
                row.seeds.len(),
                self.seeds
            ));
        }
        check_count(self.part(), points.len(), "points")
    }
}

/// A record's seeds per point or configuration: as `--seeds` takes them.
fn check_seeds(seeds: u32) -> std::result::Result<(), String> {
    let max = super::intervals::MAX_SEEDS;
    if !(1..=max).contains(&seeds) {
        return Err(format!("'seeds' {seeds} is not in 1..={max}"));
    }
    Ok(())
}

/// That `part` is one of at most `items` parts (each part holds an item).
fn check_count(part: Part, items: usize, what: &str) -> std::result::Result<(), String> {
    if part.count == 0 || part.index == 0 || part.index > part.count {
        return Err(format!(
            "'part' {} of 'parts' {} is not a part",
            part.index, part.count
        ));
    }
    if part.count as usize > items {
        return Err(format!(
            "'parts' {} is more than the run's {items} {what} (each part holds one)",
            part.count
        ));
    }
    Ok(())
}

impl PartRecord for TunePart {
    const FILE: &'static str = tune::PART_FILE;
    const FORMAT: &'static str = tune::PART_FORMAT;
    // The reference's path may differ between machines; its pixels'
    // SHA-256 may not.
    const OWN: &'static [&'static str] = &[
        "part",
        "first",
        "end",
        "halton",
        "measured",
        "head.reference_path",
        "head.provenance.command_line",
        "head.provenance.timestamp_utc",
    ];
    fn part(&self) -> Part {
        Part {
            index: self.part,
            count: self.parts,
        }
    }
    fn provenance(&self) -> &crate::provenance::Provenance {
        &self.head.provenance
    }
    fn check(&self) -> std::result::Result<(), String> {
        let head = &self.head;
        if !(head.spp.is_finite() && head.spp >= 1.0 && head.spp <= MAX_TUNE_SPP) {
            return Err(format!(
                "'head.spp' {} is not a budget (1..={MAX_TUNE_SPP})",
                head.spp
            ));
        }
        let budgets = tune::halton_budgets(head.spp);
        if head.budgets != budgets {
            return Err(format!(
                "'head.budgets' {:?} are not Halton's budgets at 'head.spp' {} ({budgets:?})",
                head.budgets, head.spp
            ));
        }
        let seeds = head.mdas_seeds.len();
        check_seeds(u32::try_from(seeds).unwrap_or(u32::MAX))
            .map_err(|e| e.replace("'seeds'", "'head.mdas_seeds' has"))?;
        if head.halton_seeds.len() != seeds {
            return Err(format!(
                "'head.halton_seeds' has {} seeds, 'head.mdas_seeds' {seeds}",
                head.halton_seeds.len()
            ));
        }
        // The configurations are the grid's, at most its product.
        let product = head
            .grid
            .iter()
            .try_fold(1usize, |n, (_, values)| n.checked_mul(values.len()));
        if product.is_none_or(|n| self.configurations.len() > n) {
            return Err(format!(
                "'configurations' ({}) are more than 'head.grid' makes",
                self.configurations.len()
            ));
        }
        check_count(
            self.part(),
            budgets.len() + self.configurations.len(),
            "Halton budgets and configurations",
        )
    }
}

/// The largest budget of a search whose part a merge takes: `--spp` is an
/// f32 whose Halton budgets (up to 4×) are u32s.
const MAX_TUNE_SPP: f32 = (1u32 << 29) as f32;

/// Reads the parts at `paths` and checks that they are the parts
/// 1..=N of one run ([`check_parts`]); returns them in index order.
fn read_parts<T: PartRecord>(paths: &[PathBuf]) -> Result<Vec<Read<T>>> {
    let parts = paths
        .iter()
        .map(|p| read_part::<T>(p, T::FILE, T::FORMAT))
        .collect::<Result<Vec<_>>>()?;
    if parts.is_empty() {
        bail!("no parts to merge");
    }
    let order = check_parts(&parts, T::OWN)?;
    let mut slots: Vec<Option<Read<T>>> = parts.into_iter().map(Some).collect();
    Ok(order
        .into_iter()
        .map(|k| slots[k].take().expect("each position once"))
        .collect())
}

/// The record file of a part given as its directory or its file.
fn record_file(path: &Path, part_file: &str) -> PathBuf {
    if path.is_dir() {
        path.join(part_file)
    } else {
        path.to_path_buf()
    }
}

/// Most bytes read from a part record (a search of the most configurations
/// writes well under a megabyte).
pub const MAX_RECORD_BYTES: u64 = 64 << 20;

/// A part record as JSON; anything but a regular file is refused (a FIFO
/// would block the read).
fn read_value(file: &Path) -> Result<Value> {
    let bytes = crate::scene::read_input(file, MAX_RECORD_BYTES)
        .with_context(|| format!("cannot read {}", file.display()))?;
    serde_json::from_slice(&bytes).with_context(|| {
        format!(
            "{}: not valid JSON (a truncated or damaged part?)",
            file.display()
        )
    })
}

/// One part as read back: its file, its record and the record as JSON.
struct Read<T> {
    file: PathBuf,
    record: T,
    value: Value,
}

fn read_part<T: PartRecord>(path: &Path, part_file: &str, format: &str) -> Result<Read<T>> {
    let file = record_file(path, part_file);
    let value = read_value(&file)?;
    if value["format"] != format {
        bail!(
            "{}: not a part of the kind merged ({format})",
            file.display()
        );
    }
    let record: T = serde_json::from_value(value.clone())
        .with_context(|| format!("{}: not a valid {format} record", file.display()))?;
    // The record as `mdas` writes it, and nothing else: serde takes an
    // array for an object and ignores unknown fields, and the checks
    // below read the JSON as well as the typed record (written as text
    // and read back, so that f32s compare as written).
    let written: Value = serde_json::from_str(&serde_json::to_string(&record)?)?;
    if let Some(field) = first_difference(&written, &value, "") {
        bail!(
            "{}: '{field}' is not as `mdas` writes a {format} record (found {}, expected {})",
            file.display(),
            shortened(pointer(&value, &field)),
            shortened(pointer(&written, &field))
        );
    }
    if let Err(e) = record.check() {
        bail!("{}: {e}", file.display());
    }
    Ok(Read {
        file,
        record,
        value,
    })
}

/// The first place (a JSON path) where `a` and `b` differ.
fn first_difference(a: &Value, b: &Value, at: &str) -> Option<String> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| {
                let path = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                first_difference(
                    x.get(k).unwrap_or(&Value::Null),
                    y.get(k).unwrap_or(&Value::Null),
                    &path,
                )
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (u, v))| first_difference(u, v, &format!("{at}[{i}]"))),
        _ => (a != b).then(|| at.to_string()),
    }
}

/// `v` without the fields at `paths` (dotted).
fn without(v: &Value, paths: &[&str]) -> Value {
    let mut v = v.clone();
    for path in paths {
        let mut keys: Vec<&str> = path.split('.').collect();
        let last = keys.pop().expect("a path has a key");
        // Through objects only (indexing an array by a key panics); the
        // records are checked to be objects there ([`read_part`]).
        let mut at = Some(&mut v);
        for k in keys {
            at = at
                .and_then(|a| a.as_object_mut())
                .and_then(|o| o.get_mut(k));
        }
        if let Some(o) = at.and_then(|a| a.as_object_mut()) {
            o.remove(last);
        }
    }
    v
}

/// Checks that `parts` are the parts 1..=N of one run, each once: equal
/// records but for the fields at `own` (each part's own), indices in
/// range and none missing ([`crate::session::parts::in_order`]). Returns
/// their positions in index order.
fn check_parts<T: PartRecord>(parts: &[Read<T>], own: &[&str]) -> Result<Vec<usize>> {
    let first = &parts[0];
    let key = without(&first.value, own);
    for p in &parts[1..] {
        if let Some(field) = first_difference(&key, &without(&p.value, own), "") {
            bail!(
                "{} and {} are parts of different runs ({field}: {} against {})",
                first.file.display(),
                p.file.display(),
                pointer(&first.value, &field),
                pointer(&p.value, &field)
            );
        }
    }
    let indexed: Vec<(u32, &Path)> = parts
        .iter()
        .map(|p| (p.record.part().index, p.file.as_path()))
        .collect();
    crate::session::parts::in_order(first.record.part().count, &indexed)
}

/// `text`, cut after 80 characters.
fn shortened(text: String) -> String {
    match text.char_indices().nth(80) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text,
    }
}

/// The value at a dotted path with `[i]` indices, as text.
fn pointer(v: &Value, path: &str) -> String {
    let pointer: String = path
        .split('.')
        .flat_map(|k| {
            let mut parts = k.split('[');
            let head = parts.next().unwrap_or("").to_string();
            std::iter::once(head).chain(parts.map(|i| i.trim_end_matches(']').to_string()))
        })
        .map(|k| format!("/{k}"))
        .collect();
    v.pointer(&pointer)
        .map_or_else(|| "nothing".into(), |x| x.to_string())
}

/// That a part holds exactly its share of `total` items.
fn check_share(file: &Path, part: Part, first: u32, end: u32, total: usize) -> Result<()> {
    if part.range(total as u32) != (first..end) {
        bail!(
            "{}: its items {first}..{end} are not part {}/{} of {total}",
            file.display(),
            part.index,
            part.count
        );
    }
    Ok(())
}

/// Each part's command line and time.
fn merged_from<T: PartRecord>(parts: &[Read<T>]) -> Vec<PartProvenance> {
    parts
        .iter()
        .map(|p| {
            let (part, prov) = (p.record.part(), p.record.provenance());
            PartProvenance {
                part: format!("{}/{}", part.index, part.count),
                command_line: prov.command_line.clone(),
                timestamp_utc: prov.timestamp_utc.clone(),
            }
        })
        .collect()
}

/// Merges sweep parts (directories or `sweep-part.json` files) into the
/// sweep one process measures, written to `out` as `sweep` writes it.
/// Nothing is written unless every check passes.
pub fn merge_sweep(paths: &[PathBuf], out: &Path) -> Result<SweepResult> {
    let ordered = read_parts::<SweepPart>(paths)?;
    let mut rows = Vec::new();
    for p in &ordered {
        let r = &p.record;
        check_share(&p.file, r.part(), r.first, r.end, r.points.len())?;
        let expected = &r.points[r.first as usize..r.end as usize];
        let got: Vec<(String, u32)> = r
            .result
            .rows
            .iter()
            .map(|row| (row.method.clone(), row.spp))
            .collect();
        if got != expected {
            bail!(
                "{}: its rows {got:?} are not its points {expected:?}",
                p.file.display()
            );
        }
        rows.extend(r.result.rows.iter().cloned());
    }
    let first = &ordered[0].record;
    let result = SweepResult {
        rows,
        provenance: first.result.provenance.merged(),
        merged_from: Some(merged_from(&ordered)),
        ..first.result.clone()
    };
    let staged = StagedDir::new(out)?;
    sweep::write_sweep(staged.path(), &result)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("sweep.json")?;
    Ok(result)
}

/// Merges tune parts (directories or `tune-part.json` files) into the
/// search one process runs — fitted, ranked and written to `out` as `tune`
/// writes it. Nothing is written unless every check passes.
pub fn merge_tune(paths: &[PathBuf], out: &Path) -> Result<TuneReport> {
    let ordered = read_parts::<TunePart>(paths)?;
    let (mut halton, mut measured) = (Vec::new(), Vec::new());
    for p in &ordered {
        let r = &p.record;
        let (budgets, configs) = (&r.head.budgets, &r.configurations);
        check_share(
            &p.file,
            r.part(),
            r.first,
            r.end,
            budgets.len() + configs.len(),
        )?;
        let b = budgets.len();
        let (first, end) = (r.first as usize, r.end as usize);
        let want_spps = &budgets[first.min(b)..end.min(b)];
        let want_labels = &configs[first.max(b) - b..end.max(b) - b];
        let spps: Vec<u32> = r.halton.iter().map(|h| h.spp).collect();
        let labels: Vec<String> = r.measured.iter().map(|m| m.label.clone()).collect();
        if spps != want_spps || labels != want_labels {
            bail!(
                "{}: it holds Halton at {spps:?} and {labels:?}, not its share (Halton at {want_spps:?}, {want_labels:?})",
                p.file.display()
            );
        }
        halton.extend(r.halton.iter().cloned());
        measured.extend(r.measured.iter().cloned());
    }
    let first = &ordered[0].record;
    let mut head = first.head.clone();
    head.provenance = head.provenance.merged();
    let from = merged_from(&ordered);
    let report = tune::finish(head, halton, measured, Some(from));
    let staged = StagedDir::new(out)?;
    super::tune_report::write_tune(staged.path(), &report)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("tune.json")?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn differences_are_found_and_named() {
        let a = json!({"x": 1, "y": {"z": [1, 2, 3]}, "t": "a"});
        assert_eq!(first_difference(&a, &a, ""), None);
        let b = json!({"x": 1, "y": {"z": [1, 5, 3]}, "t": "a"});
        let at = first_difference(&a, &b, "").unwrap();
        assert_eq!(at, "y.z[1]");
        assert_eq!(pointer(&b, &at), "5");
        let c = json!({"x": 1, "y": {"z": [1, 2]}, "t": "a"});
        assert_eq!(first_difference(&a, &c, "").as_deref(), Some("y.z"));
        let d = json!({"x": 1, "y": {"z": [1, 2, 3]}});
        assert_eq!(first_difference(&a, &d, "").as_deref(), Some("t"));
        assert_eq!(pointer(&d, "t"), "nothing");
        let stripped = without(&a, &["y.z", "t"]);
        assert_eq!(stripped, json!({"x": 1, "y": {}}));
    }
}
