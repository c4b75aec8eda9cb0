//! A command's output files: checked before any work (format from the extension, an existing
//! folder, never an input, never the same file twice), then written all or none (`fsx::Staged`).

use anyhow::{bail, Context, Result};
use epivox::fsx::Staged;
use epivox::Image;
use std::path::{Path, PathBuf};

/// Which image an output holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum What {
    /// `--out`: the final image, tone mapped as PNG or linear as EXR, by extension.
    Final,
    /// The final linear image (EXR only).
    Hdr,
    /// The in-scattered radiance alone (EXR only).
    Scatter,
    /// The distance along each unit view ray to the surface the method ended it at, in R, G and B
    /// (`inf` for the sky; EXR only).
    Depth,
}

/// The images a render produced, for [`write_all`].
pub struct Rendered<'a> {
    pub hdr: &'a Image,
    pub scatter: &'a Image,
    /// Only when a `--depth-exr` output was asked for.
    pub depth: Option<&'a Image>,
}

/// An image file format, from the path's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

/// One output file as the command line asks for it.
#[derive(Debug, Clone)]
pub struct Output {
    /// The flag it came from, for messages.
    pub flag: &'static str,
    pub path: PathBuf,
    pub what: What,
    /// Set by [`plan`].
    format: Format,
}

impl Output {
    pub fn new(flag: &'static str, path: &Path, what: What) -> Output {
        Output { flag, path: path.to_path_buf(), what, format: Format::Png }
    }

    fn named(&self) -> String {
        format!("{} {}", self.flag, self.path.display())
    }
}

/// The file's identity: its canonical path and, on Unix, device and inode (hard links).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Identity {
    canonical: PathBuf,
    #[cfg(unix)]
    inode: (u64, u64),
}

fn identity(path: &Path) -> Option<Identity> {
    let canonical = std::fs::canonicalize(path).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let m = std::fs::metadata(&canonical).ok()?;
        Some(Identity { canonical, inode: (m.dev(), m.ino()) })
    }
    #[cfg(not(unix))]
    Some(Identity { canonical })
}

fn same_file(a: &Identity, b: &Identity) -> bool {
    #[cfg(unix)]
    if a.inode == b.inode {
        return true;
    }
    a.canonical == b.canonical
}

/// The output's format from its extension (case-insensitive), or an error saying what is allowed.
fn format_of(o: &Output) -> Result<Format> {
    let ext = o.path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match (o.what, ext.as_str()) {
        (What::Final, "png") => Ok(Format::Png),
        (_, "exr") => Ok(Format::Exr),
        (What::Final, _) => {
            bail!("{}: the extension must be .png (the tone-mapped image) or .exr (the linear float image)", o.named())
        }
        _ => bail!("{}: an OpenEXR output needs the .exr extension", o.named()),
    }
}

/// Where a file that may not exist yet would be: its folder's canonical path and its name.
fn destination(o: &Output) -> Result<PathBuf> {
    let Some(name) = o.path.file_name() else { bail!("{}: the path does not name a file", o.named()) };
    let dir = match o.path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(dir).with_context(|| format!("{}: the folder {}", o.named(), dir.display()))?;
    if !dir.is_dir() {
        bail!("{}: {} is not a folder", o.named(), dir.display());
    }
    Ok(dir.join(name))
}

/// Refuses `path` (an output of `flag`) when it is an existing folder or one of `inputs`.
pub fn check_not_input(flag: &str, path: &Path, inputs: &[PathBuf]) -> Result<()> {
    let Some(out) = identity(path) else { return Ok(()) };
    for input in inputs {
        if identity(input).is_some_and(|i| same_file(&i, &out)) {
            bail!(
                "{flag} {}: that is an input of this command ({}); it would be overwritten",
                path.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Checks every output before any work is done and fixes its format.
pub fn plan(mut outputs: Vec<Output>, inputs: &[PathBuf]) -> Result<Vec<Output>> {
    let mut seen: Vec<(PathBuf, &'static str)> = Vec::new();
    for o in &mut outputs {
        o.format = format_of(o)?;
        if o.path.is_dir() {
            bail!("{}: is a folder, not a file", o.named());
        }
        check_not_input(o.flag, &o.path, inputs)?;
        let dest = destination(o)?;
        if let Some((_, other)) = seen.iter().find(|(d, _)| *d == dest) {
            bail!("{} and {other} name the same file {}; give each output its own path", o.flag, o.path.display());
        }
        // An existing file reached through another name (a link) is the same file too.
        if let Some(id) = identity(&o.path) {
            if let Some((_, other)) = seen.iter().find(|(d, _)| identity(d).is_some_and(|i| same_file(&i, &id))) {
                bail!("{} and {other} name the same file {}; give each output its own path", o.flag, o.path.display());
            }
        }
        seen.push((dest, o.flag));
    }
    Ok(outputs)
}

/// Writes every output beside its destination, then renames them all: when one fails, none of the
/// destinations has changed.
pub fn write_all(outputs: &[Output], images: &Rendered, exposure: f32) -> Result<()> {
    let mut staged: Vec<Staged> = Vec::with_capacity(outputs.len());
    for o in outputs {
        let image = match o.what {
            What::Scatter => images.scatter,
            What::Depth => images.depth.with_context(|| format!("{}: no view distances were rendered", o.flag))?,
            What::Final | What::Hdr => images.hdr,
        };
        let s = match o.format {
            Format::Png => image.stage_png(&o.path, exposure),
            Format::Exr => image.stage_exr(&o.path),
        };
        staged.push(s.with_context(|| o.flag)?);
    }
    for s in staged {
        let path = s.path().to_path_buf();
        s.commit().with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outs(dir: &Path, spec: &[(&'static str, &str, What)]) -> Vec<Output> {
        spec.iter().map(|(flag, name, what)| Output::new(flag, &dir.join(name), *what)).collect()
    }

    /// A write that fails after the plan (the folder of the second output vanished) changes no
    /// destination and leaves no temporary file.
    #[test]
    fn a_late_failure_commits_nothing() {
        let d = tempfile::tempdir().unwrap();
        let sub = d.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let first = d.path().join("a.png");
        std::fs::write(&first, b"old").unwrap();
        let plan = plan(outs(d.path(), &[("--out", "a.png", What::Final), ("--hdr-exr", "sub/b.exr", What::Hdr)]), &[])
            .unwrap();
        std::fs::remove_dir(&sub).unwrap();
        let img = Image::new(2, 2);
        let images = Rendered { hdr: &img, scatter: &img, depth: None };
        let err = write_all(&plan, &images, 0.0).unwrap_err();
        assert!(format!("{err:#}").contains("b.exr"), "{err:#}");
        assert_eq!(std::fs::read(&first).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1, "a temporary file was left");
        // With the folder back, both are written.
        std::fs::create_dir(&sub).unwrap();
        write_all(&plan, &images, 0.0).unwrap();
        assert_ne!(std::fs::read(&first).unwrap(), b"old");
        assert!(Image::read_exr(sub.join("b.exr")).is_ok());
    }

    #[test]
    fn formats_and_clashes() {
        let d = tempfile::tempdir().unwrap();
        let p = |spec: &[(&'static str, &str, What)]| plan(outs(d.path(), spec), &[]).map_err(|e| format!("{e:#}"));
        assert!(p(&[("--out", "a.PNG", What::Final), ("--hdr-exr", "a.exr", What::Hdr)]).is_ok());
        assert!(p(&[("--out", "a.exr", What::Final)]).is_ok());
        assert!(p(&[("--out", "a.jpg", What::Final)]).unwrap_err().contains(".png"));
        assert!(p(&[("--out", "a", What::Final)]).unwrap_err().contains(".png"));
        assert!(p(&[("--scatter-exr", "a.png", What::Scatter)]).unwrap_err().contains(".exr extension"));
        assert!(p(&[("--depth-exr", "a.png", What::Depth)]).unwrap_err().contains(".exr extension"));
        let e = p(&[("--out", "a.exr", What::Final), ("--scatter-exr", "./a.exr", What::Scatter)]).unwrap_err();
        assert!(e.contains("same file"), "{e}");
        let input = d.path().join("scene.exr");
        std::fs::write(&input, b"an input").unwrap();
        let e = plan(outs(d.path(), &[("--out", "scene.exr", What::Final)]), std::slice::from_ref(&input)).unwrap_err();
        assert!(format!("{e:#}").contains("input"), "{e:#}");
    }
}
