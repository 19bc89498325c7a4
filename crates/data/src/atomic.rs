//! Outputs are written whole or not at all: into a temporary file beside the target, flushed,
//! then renamed over it. A crash or an error mid-way leaves the old file (or none), never half
//! of a new one.

use std::io::Write;
use std::path::Path;

use crate::error::{DataError, DataErrorKind};

/// Refuses an output path that names one of `inputs`: the same path, or the same file reached
/// through another path (a symbolic or hard link, `./`, `..`). Measured data are never replaced
/// by results. An output that does not exist yet cannot be an input (inputs were read, so they
/// exist), so only existing outputs are compared.
pub fn refuse_overwriting_inputs(output: &Path, inputs: &[&Path]) -> Result<(), DataError> {
    let Ok(out_meta) = std::fs::metadata(output) else {
        return Ok(());
    };
    let out_canonical = std::fs::canonicalize(output).ok();
    for input in inputs {
        let Ok(in_meta) = std::fs::metadata(input) else {
            continue;
        };
        let same_file = same_inode(&out_meta, &in_meta)
            || (out_canonical.is_some() && out_canonical == std::fs::canonicalize(input).ok());
        if same_file {
            return Err(DataError::in_file(
                output,
                DataErrorKind::OutputIsInput {
                    input: input.to_path_buf(),
                    same_path: output == *input,
                },
            ));
        }
    }
    Ok(())
}

#[cfg(unix)]
fn same_inode(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_inode(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    // Elsewhere the canonical-path comparison alone decides.
    false
}

/// Writes `path` atomically with whatever `fill` writes into the buffered writer.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), DataError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".to_owned());
    let tmp = dir.join(format!(".{file_name}.tmp-{}", std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut writer = std::io::BufWriter::new(file);
        fill(&mut writer)?;
        writer.flush()?;
        writer.get_ref().sync_all()?;
        drop(writer);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(DataError::io(path, e));
    }
    Ok(())
}

/// Writes a text file atomically.
pub fn write_text_atomically(path: &Path, text: &str) -> Result<(), DataError> {
    write_atomically(path, |w| w.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_is_refused_by_any_path() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("ds1.csv");
        std::fs::write(&input, "measured\n").unwrap();
        let other = dir.path().join("other.csv");
        std::fs::write(&other, "x\n").unwrap();
        let fresh = dir.path().join("sim.csv");
        assert!(refuse_overwriting_inputs(&fresh, &[&input]).is_ok());
        assert!(refuse_overwriting_inputs(&other, &[&input]).is_ok());
        let err = refuse_overwriting_inputs(&input, &[&other, &input]).unwrap_err();
        assert!(
            err.to_string().contains("ds1.csv") && err.to_string().contains("same file)"),
            "{err}"
        );
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let dotted = dir.path().join("sub").join("..").join("ds1.csv");
        let err = refuse_overwriting_inputs(&dotted, &[&input]).unwrap_err();
        assert!(err.to_string().contains("through another path"), "{err}");
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&input, &link).unwrap();
            assert!(refuse_overwriting_inputs(&link, &[&input]).is_err());
            let hard = dir.path().join("hard.csv");
            std::fs::hard_link(&input, &hard).unwrap();
            assert!(refuse_overwriting_inputs(&hard, &[&input]).is_err());
        }
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "measured\n");
    }

    #[test]
    fn failed_write_leaves_previous_content_and_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        write_text_atomically(&path, "old\n").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"half of a new")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(leftovers.len(), 1, "temporary file left behind");
    }
}
