//! A rosbag2 bag folder read as one recording ([`crate::bag`]): each of its files in order
//! through [`extract`] (MCAP, SQLite, either compressed whole), their tables appended in
//! that order and their reports summed, so that runs and visits cross the files' boundaries.
//! A file the bag lists that is missing, or that cannot be read at all, is a loss naming it;
//! the other files are read.

use std::collections::BTreeSet;

use crate::bag::{Bag, METADATA};

use super::*;

/// Extract every table of the bag in `dir`.
pub(super) fn extract_bag(
    dir: &Path,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    let bag = Bag::open(dir)?;
    let n = bag.parts.len();
    let sizes: Vec<u64> = bag
        .parts
        .iter()
        .map(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0))
        .collect();
    let total: u64 = sizes.iter().sum();
    let listed: Vec<u64> = bag
        .metadata
        .as_ref()
        .map(|m| m.files.iter().map(|f| f.message_count).collect())
        .unwrap_or_default();
    let mut tables = Tables::default();
    let mut report = Report {
        used_summary: true,
        ..Report::default()
    };
    report.notes.extend(bag.notes.iter().cloned());
    let mut hashes = Vec::new();
    let mut read_any = false;
    let mut present: BTreeSet<String> = BTreeSet::new();
    let mut before = 0u64;
    let mut frames_before = 0u64;
    for (i, p) in bag.parts.iter().enumerate() {
        let name = Bag::part_name(p);
        let whose = format!("file {} of {n} of the bag ({name})", i + 1);
        let held = listed
            .get(i)
            .map(|c| format!(" ({c} messages, {METADATA} says)"))
            .unwrap_or_default();
        if !p.is_file() {
            report.losses.push(Loss::new(
                "missing_part",
                0,
                0,
                format!("{whose} is missing: its messages{held} are lost"),
            ));
            hashes.push((name, None));
            continue;
        }
        let cb = |d: u64, _t: u64, f: u64| progress(before + d, total, frames_before + f);
        let res = extract(p, rig, opts, &cb);
        let digest = |r: Option<&Report>| match r.and_then(|r| r.content_hash.clone()) {
            Some(h) => Some(h),
            None if opts.content_hash => crate::digest::content_hash(p).ok(),
            None => None,
        };
        match res {
            Ok((t, r)) => {
                read_any = true;
                frames_before += t.frames.t_ns.len() as u64;
                hashes.push((name.clone(), digest(Some(&r))));
                tables.append(&t);
                absorb(&mut report, r, &name);
            }
            Err(Error::Interrupted) => return Err(Error::Interrupted),
            Err(Error::NoRigTopics { present: pr, .. }) => {
                present.extend(pr);
                report.file_bytes += sizes[i];
                hashes.push((name, digest(None)));
            }
            Err(e) => {
                report.file_bytes += sizes[i];
                report.losses.push(Loss::new(
                    "unreadable_part",
                    0,
                    sizes[i],
                    format!("{whose} cannot be read, its messages{held} are lost: {e}"),
                ));
                hashes.push((name, digest(None)));
            }
        }
        before += sizes[i];
    }
    if !read_any && report.losses.is_empty() {
        let ctx = Context::new(rig, opts.spot.clone(), None, None);
        return Err(Error::NoRigTopics {
            path: dir.display().to_string(),
            topics: ctx.rig_topics().iter().map(|t| t.to_string()).collect(),
            present: present.into_iter().collect(),
        });
    }
    if opts.content_hash {
        report.content_hash = Some(crate::bag::combine_hashes(&hashes));
    }
    report.parts = hashes
        .into_iter()
        .zip(&sizes)
        .map(|((file, content_hash), &bytes)| PartInfo {
            file,
            bytes,
            content_hash,
        })
        .collect();
    Ok((tables, report))
}

/// Add the report of one file of the bag (named `name`) to the bag's.
fn absorb(report: &mut Report, mut r: Report, name: &str) {
    for l in &mut r.losses {
        l.detail = format!("{name}: {}", l.detail);
        l.part = Some(name.to_string());
    }
    report.merge(&r);
    report.file_bytes += r.file_bytes;
    report.used_summary &= r.used_summary;
    report.metadata.extend(r.metadata);
    for (k, v) in r.lost_messages {
        *report.lost_messages.entry(k).or_insert(0) += v;
    }
    report
        .notes
        .extend(r.notes.into_iter().map(|x| format!("{name}: {x}")));
}
