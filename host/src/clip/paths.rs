//! Paths named inside a clip (`frames.csv`'s `chip` and `gt_mask`), resolved so that nothing
//! outside the clip folder is opened.
//!
//! The clip format says such a path is relative to the clip folder, and a path that is absolute
//! or leads outside the folder is refused. [`resolve_clip_path`] is the one place that checks it;
//! every reader of a clip-relative path opens the path it returns, never a path joined by hand.

use std::io;
use std::path::{Component, Path, PathBuf};

/// Why a clip-relative path is not opened.
#[derive(Debug, thiserror::Error)]
pub enum ClipPathError {
    /// The path is absolute, has a root or a drive (also in Windows spelling on any platform).
    #[error(
        "{path:?} is an absolute path, outside the clip folder {}: paths in a clip are relative to its folder",
        clip.display()
    )]
    Absolute {
        /// The path as written in the clip.
        path: String,
        /// The clip folder.
        clip: PathBuf,
    },
    /// Its `..` components lead above the clip folder.
    #[error("{path:?} leads outside the clip folder {}", clip.display())]
    Escapes {
        /// The path as written in the clip.
        path: String,
        /// The clip folder.
        clip: PathBuf,
    },
    /// It resolves, through a symbolic link, to a file outside the clip folder.
    #[error(
        "{path:?} is outside the clip folder {}: it resolves to {}",
        clip.display(),
        target.display()
    )]
    LinksOut {
        /// The path as written in the clip.
        path: String,
        /// The clip folder.
        clip: PathBuf,
        /// Where it resolves to.
        target: PathBuf,
    },
    /// The path (or the clip folder) cannot be resolved, typically because the file is missing.
    #[error("{}: {source}", path.display())]
    Unresolved {
        /// The clip folder joined with the path.
        path: PathBuf,
        /// The file system's reason.
        source: io::Error,
    },
}

impl ClipPathError {
    /// True where the path was refused for leading outside the clip folder (as opposed to a file
    /// that is simply missing).
    pub fn is_outside(&self) -> bool {
        !matches!(self, ClipPathError::Unresolved { .. })
    }
}

/// Resolves `relative`, a path read from the clip in `clip_dir`, to the canonical path of the file
/// it names, refusing it when it is absolute or leads outside the clip folder.
///
/// The check is made before anything is opened, in two steps:
/// 1. Lexically, the same on every platform (`/` and `\` both separate components): an absolute
///    path, a root, a drive prefix (`C:`), or `..` components that climb above the clip folder
///    are refused; so the file system is not even asked about such a path.
/// 2. The clip folder and the candidate are canonicalized (`..` and symbolic links resolved); a
///    candidate whose real path is not inside the real clip folder is refused. A symbolic link
///    that stays inside the clip folder is followed.
///
/// A missing file is [`ClipPathError::Unresolved`], as is a clip folder that cannot be resolved.
/// The returned path is the canonical one, so that the file opened is the file checked (a clip
/// folder changed by someone else between the check and the open is not guarded against).
pub fn resolve_clip_path(clip_dir: &Path, relative: &str) -> Result<PathBuf, ClipPathError> {
    check_lexically(clip_dir, relative)?;
    let root = clip_dir
        .canonicalize()
        .map_err(|source| ClipPathError::Unresolved {
            path: clip_dir.to_path_buf(),
            source,
        })?;
    let joined = clip_dir.join(relative);
    let target =
        root.join(relative)
            .canonicalize()
            .map_err(|source| ClipPathError::Unresolved {
                path: joined,
                source,
            })?;
    if target.starts_with(&root) {
        Ok(target)
    } else {
        Err(ClipPathError::LinksOut {
            path: relative.to_owned(),
            clip: clip_dir.to_path_buf(),
            target,
        })
    }
}

/// Step 1 of [`resolve_clip_path`]: the path's spelling alone.
fn check_lexically(clip_dir: &Path, relative: &str) -> Result<(), ClipPathError> {
    let absolute = || ClipPathError::Absolute {
        path: relative.to_owned(),
        clip: clip_dir.to_path_buf(),
    };
    let native = Path::new(relative);
    if native.is_absolute()
        || native.has_root()
        || native
            .components()
            .any(|c| matches!(c, Component::Prefix(_) | Component::RootDir))
    {
        return Err(absolute());
    }
    // Windows spellings, refused on every platform: `\dir`, `\\server\share`, `C:\dir`, `C:dir`.
    let bytes = relative.as_bytes();
    let drive = bytes.len() >= 2 && bytes[0].is_ascii_alphabetic() && bytes[1] == b':';
    if relative.starts_with(['/', '\\']) || drive {
        return Err(absolute());
    }
    let mut depth: usize = 0;
    for part in relative.split(['/', '\\']) {
        match part {
            "" | "." => {}
            ".." => {
                depth = depth.checked_sub(1).ok_or_else(|| ClipPathError::Escapes {
                    path: relative.to_owned(),
                    clip: clip_dir.to_path_buf(),
                })?;
            }
            _ => depth += 1,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clip folder `clip/` with `chips/000001.png`, and `outside.png` beside the folder.
    fn folder() -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let clip = dir.path().join("clip");
        std::fs::create_dir_all(clip.join("chips")).unwrap();
        std::fs::write(clip.join("chips/000001.png"), b"inside").unwrap();
        std::fs::write(dir.path().join("outside.png"), b"outside").unwrap();
        (dir, clip)
    }

    fn outside(result: Result<PathBuf, ClipPathError>) -> ClipPathError {
        let error = result.expect_err("refused");
        assert!(error.is_outside(), "{error}");
        assert!(
            error.to_string().contains("outside the clip folder"),
            "{error}"
        );
        error
    }

    #[test]
    fn a_plain_relative_path_resolves_inside() {
        let (_dir, clip) = folder();
        let path = resolve_clip_path(&clip, "chips/000001.png").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"inside");
        assert_eq!(path, clip.join("chips/000001.png").canonicalize().unwrap());
        assert_eq!(
            resolve_clip_path(&clip, "./chips/000001.png").unwrap(),
            path
        );
    }

    #[test]
    fn dot_dot_that_stays_inside_is_fine() {
        let (_dir, clip) = folder();
        let path = resolve_clip_path(&clip, "chips/../chips/000001.png").unwrap();
        assert_eq!(path, resolve_clip_path(&clip, "chips/000001.png").unwrap());
    }

    #[test]
    fn absolute_paths_are_refused() {
        let (dir, clip) = folder();
        let absolute = dir.path().join("outside.png");
        for path in [
            absolute.to_str().unwrap(),
            "/etc/hostname",
            "\\etc\\hostname",
            "\\\\server\\share\\chip.png",
            "C:\\Windows\\win.ini",
            "c:/chip.png",
            "C:chip.png",
        ] {
            let error = outside(resolve_clip_path(&clip, path));
            assert!(
                matches!(error, ClipPathError::Absolute { .. }),
                "{path}: {error}"
            );
        }
    }

    #[test]
    fn dot_dot_leading_out_is_refused() {
        let (_dir, clip) = folder();
        for path in [
            "../outside.png",
            "../../../../etc/passwd",
            "chips/../../outside.png",
            "chips/../../clip/chips/000001.png",
            "..\\outside.png",
            "..",
        ] {
            let error = outside(resolve_clip_path(&clip, path));
            assert!(
                matches!(error, ClipPathError::Escapes { .. }),
                "{path}: {error}"
            );
        }
    }

    #[test]
    fn a_missing_file_is_unresolved_not_outside() {
        let (_dir, clip) = folder();
        let error = resolve_clip_path(&clip, "chips/000002.png").unwrap_err();
        assert!(!error.is_outside(), "{error}");
        assert!(error.to_string().contains("chips/000002.png"), "{error}");
        let ClipPathError::Unresolved { source, .. } = error else {
            unreachable!()
        };
        assert_eq!(source.kind(), io::ErrorKind::NotFound);
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_out_of_the_clip_is_refused() {
        let (dir, clip) = folder();
        std::os::unix::fs::symlink(dir.path().join("outside.png"), clip.join("chips/out.png"))
            .unwrap();
        std::os::unix::fs::symlink("../../outside.png", clip.join("chips/rel.png")).unwrap();
        std::os::unix::fs::symlink(dir.path(), clip.join("up")).unwrap();
        for path in ["chips/out.png", "chips/rel.png", "up/outside.png"] {
            let error = outside(resolve_clip_path(&clip, path));
            assert!(
                matches!(error, ClipPathError::LinksOut { .. }),
                "{path}: {error}"
            );
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_within_the_clip_is_followed() {
        let (_dir, clip) = folder();
        std::os::unix::fs::symlink("000001.png", clip.join("chips/000002.png")).unwrap();
        std::os::unix::fs::symlink("chips", clip.join("frames")).unwrap();
        let real = resolve_clip_path(&clip, "chips/000001.png").unwrap();
        assert_eq!(resolve_clip_path(&clip, "chips/000002.png").unwrap(), real);
        assert_eq!(resolve_clip_path(&clip, "frames/000001.png").unwrap(), real);
    }

    #[cfg(unix)]
    #[test]
    fn a_clip_folder_reached_through_a_symlink_still_works() {
        let (dir, clip) = folder();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&clip, &link).unwrap();
        let path = resolve_clip_path(&link, "chips/000001.png").unwrap();
        assert_eq!(std::fs::read(path).unwrap(), b"inside");
    }
}
