//! Output folders: the one way every vpctl command writes a folder, so that
//! `--force` never deletes a file vpctl did not write.
//!
//! [`OutDir::check`] runs before any work and refuses, with the reason and
//! the command that fixes it:
//! - the current folder (`--out .`) or a folder that holds it;
//! - a folder that is, or holds, one of the command's inputs;
//! - an existing file;
//! - a non-empty folder without vpctl's manifest ([`MANIFEST_FILE`]): vpctl
//!   never writes into a folder it did not write, even with `--force`;
//! - vpctl's own earlier output, unless `force`;
//! - a folder whose parent does not exist ([`crate::fsio::check_parent_exists`]:
//!   vpctl creates the output folder, never the folders above it).
//!
//! [`OutDir::write`] then builds the output in a fresh sibling folder and
//! swaps it in: the files of the earlier output that its manifest does not
//! list (a user's `notes.txt`) move into the new folder first, the old
//! folder is renamed aside, the new one renamed into place, and only then
//! are the old folder's manifest-listed files deleted. There is no moment at
//! which neither the old nor the new output exists, a failure before the
//! swap restores the old folder as it was, and a failed write leaves the
//! old output untouched.

use std::collections::BTreeSet;
use std::io::ErrorKind;
use std::path::{Component, Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};

/// The manifest vpctl writes into every output folder: which command wrote
/// it and which files and folders are vpctl's.
pub const MANIFEST_FILE: &str = ".vpctl-output.json";

/// The content of [`MANIFEST_FILE`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The command that wrote the folder, as typed after `vpctl` ("demo",
    /// "colmap align").
    pub command: String,
    /// The vpctl version that wrote it.
    pub version: String,
    /// Every file written, relative to the folder, `/`-separated, sorted.
    pub files: Vec<String>,
    /// Every folder written (empty ones included), relative, sorted.
    pub folders: Vec<String>,
}

impl Manifest {
    /// Reads `dir`'s manifest; `None` when it has none. A manifest that does
    /// not parse, or names a path outside the folder, is an error: vpctl
    /// then cannot tell its files from the user's.
    pub fn load(dir: &Path) -> Result<Option<Manifest>> {
        let path = dir.join(MANIFEST_FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(SceneError::io(&path, e)),
        };
        let corrupt = |why: String| SceneError::OutputRefused {
            path: path.clone(),
            why,
            fix: "vpctl cannot tell its files from yours there: choose another --out, or \
                  remove the folder yourself"
                .into(),
        };
        let m: Manifest = serde_json::from_str(&text)
            .map_err(|e| corrupt(format!("is not a vpctl output manifest ({e})")))?;
        if let Some(bad) = m.files.iter().chain(&m.folders).find(|f| !is_plain(f)) {
            return Err(corrupt(format!("names {bad:?}, a path outside its folder")));
        }
        Ok(Some(m))
    }

    /// The folders of the output: those listed and every parent of a file.
    fn owned_folders(&self) -> BTreeSet<PathBuf> {
        let mut out: BTreeSet<PathBuf> = self.folders.iter().map(PathBuf::from).collect();
        for f in &self.files {
            let mut p = Path::new(f).parent();
            while let Some(d) = p.filter(|d| !d.as_os_str().is_empty()) {
                out.insert(d.to_path_buf());
                p = d.parent();
            }
        }
        out
    }
}

/// A relative path of normal components only (no `..`, no root).
fn is_plain(p: &str) -> bool {
    !p.is_empty()
        && Path::new(p)
            .components()
            .all(|c| matches!(c, Component::Normal(_)))
}

/// An output folder that passed [`OutDir::check`].
#[derive(Debug, Clone)]
pub struct OutDir {
    /// As the user gave it (for messages).
    path: PathBuf,
    /// Absolute, symbolic links of its existing part resolved.
    abs: PathBuf,
    command: String,
    force: bool,
}

impl OutDir {
    /// Checks the output folder `path` of `vpctl <command>` against the
    /// command's `inputs` (files or folders it reads; missing ones are
    /// skipped) before any work: see the module docs for what is refused.
    /// `force` allows replacing vpctl's own earlier output.
    pub fn check(path: &Path, command: &str, inputs: &[&Path], force: bool) -> Result<OutDir> {
        crate::fsio::check_parent_exists(path)?;
        let abs = resolve(path)?;
        let out = OutDir {
            path: path.to_path_buf(),
            abs,
            command: command.to_string(),
            force,
        };
        let cwd = std::env::current_dir()
            .and_then(std::fs::canonicalize)
            .map_err(|e| SceneError::io(".", e))?;
        if out.abs.parent().is_none() {
            return Err(out.refuse(&out.path, "is the root of the file system"));
        }
        if cwd.starts_with(&out.abs) {
            let why = if cwd == out.abs {
                "is the current folder: replacing it would replace everything in it".to_string()
            } else {
                format!("holds the current folder {}", cwd.display())
            };
            return Err(out.refuse(&out.path, &why));
        }
        for input in inputs {
            let Ok(i) = resolve(input) else { continue };
            if i.starts_with(&out.abs) {
                let why = if i == out.abs {
                    format!("is the input {} itself", input.display())
                } else {
                    format!("holds the input {}", input.display())
                };
                return Err(out.refuse(&out.path, &why));
            }
        }
        out.inspect()?;
        Ok(out)
    }

    /// The folder as the user gave it.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A refusal of `at` with the way out: a new folder.
    fn refuse(&self, at: &Path, why: &str) -> SceneError {
        let fix = format!(
            "nothing was written; give `vpctl {}` a new folder instead, e.g. --out {}",
            self.command,
            self.suggestion()
        );
        SceneError::OutputRefused {
            path: at.to_path_buf(),
            why: why.to_string(),
            fix,
        }
    }

    /// A fresh folder name beside the current folder for the messages.
    fn suggestion(&self) -> String {
        let base = format!("vpctl-{}", self.command.replace(' ', "-"));
        let free = |n: &str| std::fs::symlink_metadata(n).is_err();
        if free(&base) {
            return base;
        }
        (2..100)
            .map(|i| format!("{base}-{i}"))
            .find(|n| free(n))
            .unwrap_or(base)
    }

    /// The state of the folder now: its manifest if it is vpctl's output
    /// that may be replaced, `None` if missing or empty; refused otherwise.
    fn inspect(&self) -> Result<Option<Manifest>> {
        let meta = match std::fs::symlink_metadata(&self.abs) {
            Ok(m) => m,
            Err(e) if e.kind() == ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(SceneError::io(&self.path, e)),
        };
        if !meta.is_dir() {
            return Err(self.refuse(&self.path, "is a file, not a folder"));
        }
        if let Some(m) = Manifest::load(&self.abs)? {
            if !self.force {
                return Err(SceneError::OutputRefused {
                    path: self.path.clone(),
                    why: format!("holds the output of an earlier `vpctl {}`", m.command),
                    fix: format!(
                        "nothing was written; pass --force to replace the files vpctl wrote \
                         there (other files stay), or choose another folder, e.g. --out {}",
                        self.suggestion()
                    ),
                });
            }
            return Ok(Some(m));
        }
        let mut entries =
            std::fs::read_dir(&self.abs).map_err(|e| SceneError::io(&self.path, e))?;
        if entries.next().is_some() {
            return Err(SceneError::OutputRefused {
                path: self.path.clone(),
                why: format!("is not empty and is not a vpctl output (it has no {MANIFEST_FILE})"),
                fix: format!(
                    "nothing was written; vpctl never writes into a folder of other files, \
                     even with --force: give `vpctl {}` a new folder, e.g. --out {}, or move \
                     the files away",
                    self.command,
                    self.suggestion()
                ),
            });
        }
        Ok(None)
    }

    /// Runs `write` on a fresh staging folder beside the output, then swaps
    /// it in ([`Stage::commit`]). If `write` fails the staging folder is
    /// removed and the output is untouched.
    pub fn write<T, E: From<SceneError>>(
        &self,
        write: impl FnOnce(&Path) -> std::result::Result<T, E>,
    ) -> std::result::Result<T, E> {
        let stage = self.stage()?;
        let value = write(stage.path())?;
        stage.commit()?;
        Ok(value)
    }

    /// Creates the staging folder: a new sibling of the output (created
    /// with its parents if needed).
    pub fn stage(&self) -> Result<Stage<'_>> {
        let dir = fresh_sibling(&self.abs, "stage", true)?;
        Ok(Stage {
            out: self,
            dir,
            keep: false,
            done: false,
        })
    }
}

/// `.<name>.vpctl-<what>-<pid>-<n>` beside `abs`, the first `n` free;
/// created (as an empty folder) when `create`.
fn fresh_sibling(abs: &Path, what: &str, create: bool) -> Result<PathBuf> {
    let (Some(parent), Some(name)) = (abs.parent(), abs.file_name()) else {
        return Err(SceneError::InvalidArgument(format!(
            "{}: not a folder path",
            abs.display()
        )));
    };
    if create {
        std::fs::create_dir_all(parent).map_err(|e| SceneError::io(parent, e))?;
    }
    let name = name.to_string_lossy();
    for n in 0..10_000 {
        let p = parent.join(format!(".{name}.vpctl-{what}-{}-{n}", std::process::id()));
        if create {
            match std::fs::create_dir(&p) {
                Ok(()) => return Ok(p),
                Err(e) if e.kind() == ErrorKind::AlreadyExists => {}
                Err(e) => return Err(SceneError::io(&p, e)),
            }
        } else if std::fs::symlink_metadata(&p).is_err() {
            return Ok(p);
        }
    }
    Err(SceneError::InvalidArgument(format!(
        "{}: no free name for a {what} folder beside it",
        abs.display()
    )))
}

/// A staging folder of an [`OutDir`]: write into [`Stage::path`], then
/// [`Stage::commit`]. Dropped without commit, it is removed.
#[derive(Debug)]
pub struct Stage<'a> {
    out: &'a OutDir,
    dir: PathBuf,
    /// Keep the folder on drop (it holds the only copy of something).
    keep: bool,
    done: bool,
}

impl Stage<'_> {
    /// The folder to write the output into.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// Refuses when a file that is not vpctl's would be overwritten by the
    /// new output (or would need a folder where the new output has a file);
    /// the staged output is then kept.
    fn refuse_clashes(&mut self, foreign: &[PathBuf]) -> Result<()> {
        for f in foreign {
            let clash = f
                .ancestors()
                .filter(|a| !a.as_os_str().is_empty())
                .find(|a| {
                    std::fs::symlink_metadata(self.dir.join(a))
                        .is_ok_and(|m| *a == f.as_path() || !m.is_dir())
                });
            if let Some(a) = clash {
                self.keep = true;
                return Err(SceneError::OutputRefused {
                    path: self.out.path.join(f),
                    why: format!(
                        "is not vpctl's (not in {MANIFEST_FILE}) and the new output writes {} \
                         too",
                        a.display()
                    ),
                    fix: format!(
                        "nothing was replaced; move it away and run the command again, or \
                         take the new output from {}",
                        self.dir.display()
                    ),
                });
            }
        }
        Ok(())
    }

    /// Writes the manifest and swaps the staged folder in place of the
    /// output (see the module docs). The output is checked again first: if
    /// it changed during the work so that it must be refused now, the staged
    /// output is kept and the error says where it is.
    pub fn commit(mut self) -> Result<()> {
        let kept_here = |e: SceneError, dir: &Path| match e {
            SceneError::OutputRefused { path, why, fix } => SceneError::OutputRefused {
                path,
                why,
                fix: format!("{fix}; the new output waits in {}", dir.display()),
            },
            other => other,
        };
        let previous = match self.out.inspect() {
            Ok(p) => p,
            Err(e) => {
                self.keep = true;
                return Err(kept_here(e, &self.dir));
            }
        };
        let (files, folders) = list_tree(&self.dir)?;
        let manifest = Manifest {
            command: self.out.command.clone(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            files,
            folders,
        };
        let json = serde_json::to_string_pretty(&manifest)
            .map_err(|e| SceneError::InvalidArgument(format!("output manifest: {e}")))?;
        crate::fsio::write_file_atomic(&self.dir.join(MANIFEST_FILE), json.as_bytes())?;
        let target = self.out.abs.clone();
        if std::fs::symlink_metadata(&target).is_err() {
            std::fs::rename(&self.dir, &target).map_err(|e| SceneError::io(&self.out.path, e))?;
            self.done = true;
            return Ok(());
        }
        // Files that are not vpctl's move into the new output first.
        let foreign = foreign_entries(&target, previous.as_ref())?;
        self.refuse_clashes(&foreign)?;
        let mut moved: Vec<&PathBuf> = Vec::new();
        let mut step = || -> std::io::Result<PathBuf> {
            for f in &foreign {
                if let Some(p) = self.dir.join(f).parent() {
                    std::fs::create_dir_all(p)?;
                }
                std::fs::rename(target.join(f), self.dir.join(f))?;
                moved.push(f);
            }
            let aside = fresh_sibling(&target, "old", false)
                .map_err(|e| std::io::Error::other(e.to_string()))?;
            std::fs::rename(&target, &aside)?;
            if let Err(e) = std::fs::rename(&self.dir, &target) {
                std::fs::rename(&aside, &target)?;
                return Err(e);
            }
            Ok(aside)
        };
        match step() {
            Ok(aside) => {
                self.done = true;
                remove_owned(&aside, previous.as_ref());
                Ok(())
            }
            Err(e) => {
                // Put the user's files back where they were.
                for f in moved.iter().rev() {
                    if std::fs::rename(self.dir.join(f), target.join(f)).is_err() {
                        self.keep = true;
                    }
                }
                let e = SceneError::io(&self.out.path, e);
                if self.keep {
                    return Err(SceneError::OutputRefused {
                        path: self.out.path.clone(),
                        why: format!("could not be replaced ({e})"),
                        fix: format!(
                            "some of its files could not be put back: they are in {}",
                            self.dir.display()
                        ),
                    });
                }
                Err(e)
            }
        }
    }
}

impl Drop for Stage<'_> {
    fn drop(&mut self) {
        if !self.done && !self.keep {
            // Created empty by `stage` and written only by vpctl.
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Every file and every folder under `root`, relative, `/`-separated.
fn list_tree(root: &Path) -> Result<(Vec<String>, Vec<String>)> {
    fn walk(
        root: &Path,
        rel: &Path,
        files: &mut Vec<String>,
        dirs: &mut Vec<String>,
    ) -> Result<()> {
        let here = root.join(rel);
        for entry in std::fs::read_dir(&here).map_err(|e| SceneError::io(&here, e))? {
            let entry = entry.map_err(|e| SceneError::io(&here, e))?;
            let r = rel.join(entry.file_name());
            let ty = entry.file_type().map_err(|e| SceneError::io(&r, e))?;
            let s = r
                .components()
                .map(|c| c.as_os_str().to_string_lossy())
                .collect::<Vec<_>>()
                .join("/");
            if ty.is_dir() {
                dirs.push(s);
                walk(root, &r, files, dirs)?;
            } else if r != Path::new(MANIFEST_FILE) {
                files.push(s);
            }
        }
        Ok(())
    }
    let (mut files, mut dirs) = (Vec::new(), Vec::new());
    walk(root, Path::new(""), &mut files, &mut dirs)?;
    files.sort();
    dirs.sort();
    Ok((files, dirs))
}

/// The entries of `root` that are not vpctl's: whole folders the manifest
/// does not know, and files it does not list. Without a manifest (an empty
/// folder), everything.
fn foreign_entries(root: &Path, manifest: Option<&Manifest>) -> Result<Vec<PathBuf>> {
    fn walk(
        root: &Path,
        rel: &Path,
        files: &BTreeSet<PathBuf>,
        folders: &BTreeSet<PathBuf>,
        out: &mut Vec<PathBuf>,
    ) -> Result<()> {
        let here = root.join(rel);
        for entry in std::fs::read_dir(&here).map_err(|e| SceneError::io(&here, e))? {
            let entry = entry.map_err(|e| SceneError::io(&here, e))?;
            let r = rel.join(entry.file_name());
            let ty = entry.file_type().map_err(|e| SceneError::io(&r, e))?;
            if r == Path::new(MANIFEST_FILE) {
                continue;
            }
            if ty.is_dir() && folders.contains(&r) {
                walk(root, &r, files, folders, out)?;
            } else if ty.is_dir() || !files.contains(&r) {
                out.push(r);
            }
        }
        Ok(())
    }
    let files: BTreeSet<PathBuf> = manifest
        .map(|m| m.files.iter().map(PathBuf::from).collect())
        .unwrap_or_default();
    let folders = manifest.map(Manifest::owned_folders).unwrap_or_default();
    let mut out = Vec::new();
    walk(root, Path::new(""), &files, &folders, &mut out)?;
    Ok(out)
}

/// Deletes the old output moved aside: only the files its manifest lists,
/// then the folders left empty. Anything else (a file that appeared during
/// the swap) stays where it is.
fn remove_owned(aside: &Path, manifest: Option<&Manifest>) {
    if let Some(m) = manifest {
        for f in &m.files {
            let _ = std::fs::remove_file(aside.join(f));
        }
        let mut folders: Vec<PathBuf> = m.owned_folders().into_iter().collect();
        // Deepest first.
        folders.sort_by_key(|f| std::cmp::Reverse(f.components().count()));
        for d in folders {
            let _ = std::fs::remove_dir(aside.join(d));
        }
    }
    let _ = std::fs::remove_file(aside.join(MANIFEST_FILE));
    let _ = std::fs::remove_dir(aside);
}

/// `p` made absolute, with its longest existing prefix canonicalised
/// (symbolic links resolved) and the rest normalised lexically.
fn resolve(p: &Path) -> Result<PathBuf> {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir()
            .map_err(|e| SceneError::io(".", e))?
            .join(p)
    };
    let comps: Vec<Component> = abs.components().collect();
    for k in (1..=comps.len()).rev() {
        let prefix: PathBuf = comps[..k].iter().collect();
        if let Ok(mut out) = std::fs::canonicalize(&prefix) {
            for c in &comps[k..] {
                match c {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::Normal(n) => out.push(n),
                    _ => {}
                }
            }
            return Ok(out);
        }
    }
    Err(SceneError::io(
        p,
        std::io::Error::new(ErrorKind::NotFound, "no part of this path exists"),
    ))
}

#[cfg(test)]
#[path = "outdir_tests.rs"]
mod tests;
