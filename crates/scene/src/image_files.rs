//! Which file belongs to which image: the one rule for the names of an
//! image's label file (`.vplabel`) and confidence file (`.vpconf`), used by
//! every writer and every reader.
//!
//! An image is named as COLMAP names it: its path relative to the images
//! folder, with `/` separators (`sub/dir/img.v2.JPG`). Its files append an
//! extension to that whole name (`<dir>/sub/dir/img.v2.JPG.vpconf`), as
//! COLMAP's own `stereo/depth_maps/<image name>.geometric.bin` do: `a.jpg`
//! and `a.png` never share a file, and sub-folders are kept.

use std::path::{Component, Path, PathBuf};

use crate::error::{Result, SceneError};

/// Extension of label image files.
pub const LABEL_EXTENSION: &str = "vplabel";
/// Extension of confidence image files.
pub const CONFIDENCE_EXTENSION: &str = "vpconf";
/// Image file extensions found in folders (lower case; matched case-insensitively).
pub const IMAGE_EXTENSIONS: [&str; 7] = ["png", "jpg", "jpeg", "tif", "tiff", "pgm", "ppm"];

/// `<dir>/<image name>.vplabel`.
pub fn label_file(dir: &Path, image_name: &str) -> Result<PathBuf> {
    sidecar(dir, image_name, LABEL_EXTENSION)
}

/// `<dir>/<image name>.vpconf`.
pub fn confidence_file(dir: &Path, image_name: &str) -> Result<PathBuf> {
    sidecar(dir, image_name, CONFIDENCE_EXTENSION)
}

/// `<dir>/<image name>.<extension>`; refuses names that would leave `dir`
/// (absolute, or with `..`).
pub fn sidecar(dir: &Path, image_name: &str, extension: &str) -> Result<PathBuf> {
    let name = Path::new(image_name);
    let inside = !image_name.is_empty()
        && name
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir));
    if !inside {
        return Err(SceneError::InvalidArgument(format!(
            "image name {image_name:?} must be a relative path inside the images folder"
        )));
    }
    Ok(dir.join(format!("{image_name}.{extension}")))
}

/// The image name a label file found under `root` belongs to: its path
/// relative to the innermost `level<N>` folder (the layout `vpctl labelgen
/// run` writes, `<root>/<triplet>/level<N>/<image name>.vplabel`), without
/// the extension; without a `level<N>` folder, the file name alone (folders
/// then group label files, e.g. by triplet). `None` if `path` is not a
/// label file under `root`.
pub fn image_name_of_label(root: &Path, path: &Path) -> Option<String> {
    let rel = path.strip_prefix(root).ok()?;
    let parts: Vec<&str> = rel
        .components()
        .map(|c| c.as_os_str().to_str())
        .collect::<Option<_>>()?;
    let (file, folders) = parts.split_last()?;
    let stem = file.strip_suffix(&format!(".{LABEL_EXTENSION}"))?;
    let is_level = |s: &str| {
        s.strip_prefix("level")
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
    };
    let start = folders
        .iter()
        .rposition(|s| is_level(s))
        .map_or(folders.len(), |i| i + 1);
    let mut name: Vec<&str> = folders[start..].to_vec();
    name.push(stem);
    (!stem.is_empty()).then(|| name.join("/"))
}

/// The images to process from command-line paths: a file is taken as it is
/// and named by its file name; a folder is searched recursively for image
/// files (by [`IMAGE_EXTENSIONS`]), each named by its path relative to that
/// folder, as COLMAP names images. Sorted by name within each folder.
pub fn find_images(paths: &[PathBuf]) -> Result<Vec<(PathBuf, String)>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let found = files_with_extensions(p, &IMAGE_EXTENSIONS)?;
            let mut named: Vec<(PathBuf, String)> = found
                .into_iter()
                .filter_map(|f| {
                    let name = f
                        .strip_prefix(p)
                        .ok()?
                        .components()
                        .map(|c| c.as_os_str().to_str())
                        .collect::<Option<Vec<_>>>()?
                        .join("/");
                    Some((f, name))
                })
                .collect();
            named.sort_by(|a, b| a.1.cmp(&b.1));
            out.extend(named);
        } else {
            let name = p
                .file_name()
                .and_then(|n| n.to_str())
                .ok_or_else(|| {
                    SceneError::InvalidArgument(format!("{}: not a file name", p.display()))
                })?
                .to_string();
            out.push((p.clone(), name));
        }
    }
    Ok(out)
}

/// Every file below `dir` (recursively) whose extension, in lower case, is
/// one of `extensions`, in directory order.
pub fn files_with_extensions(dir: &Path, extensions: &[&str]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    walk(dir, extensions, &mut out)?;
    Ok(out)
}

fn walk(dir: &Path, extensions: &[&str], out: &mut Vec<PathBuf>) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| SceneError::io(dir, e))?;
    for entry in entries {
        let path = entry.map_err(|e| SceneError::io(dir, e))?.path();
        if path.is_dir() {
            walk(&path, extensions, out)?;
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| extensions.contains(&e.to_ascii_lowercase().as_str()))
        {
            out.push(path);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sidecars_append_to_the_whole_image_name() {
        let d = Path::new("out");
        assert_eq!(
            confidence_file(d, "sub/dir/img.v2.JPG").unwrap(),
            Path::new("out/sub/dir/img.v2.JPG.vpconf")
        );
        assert_eq!(
            label_file(d, "a.png").unwrap(),
            Path::new("out/a.png.vplabel")
        );
        assert!(confidence_file(d, "/etc/passwd").is_err());
        assert!(confidence_file(d, "../x.png").is_err());
        assert!(confidence_file(d, "").is_err());
    }

    #[test]
    fn label_names_keep_sub_folders_below_the_level_folder() {
        let root = Path::new("labels");
        let name = |p: &str| image_name_of_label(root, Path::new(p));
        assert_eq!(
            name("labels/t0001/level2/sub/dir/img.v2.JPG.vplabel").as_deref(),
            Some("sub/dir/img.v2.JPG")
        );
        assert_eq!(name("labels/a.png.vplabel").as_deref(), Some("a.png"));
        assert_eq!(name("labels/t1/a.png.vplabel").as_deref(), Some("a.png"));
        assert_eq!(name("labels/x/a.png.vpconf"), None);
        assert_eq!(name("elsewhere/a.png.vplabel"), None);
    }

    #[test]
    fn folders_are_searched_recursively_and_named_relative() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("sub/dir")).unwrap();
        for f in ["b.png", "sub/dir/img.v2.JPG", "notes.txt"] {
            std::fs::write(dir.path().join(f), b"").unwrap();
        }
        let found = find_images(&[dir.path().to_path_buf()]).unwrap();
        let names: Vec<&str> = found.iter().map(|(_, n)| n.as_str()).collect();
        assert_eq!(names, ["b.png", "sub/dir/img.v2.JPG"]);
        let one = find_images(&[dir.path().join("b.png")]).unwrap();
        assert_eq!(one[0].1, "b.png");
    }
}
