//! `fmuResourceLocation` (FMI 2.0 §2.1.5): a URI (RFC 3986) of the unzipped `resources` folder.
//! The `file` scheme with an absolute path is mandatory, "either including or omitting the
//! authority component": `file:///tmp/x/resources`, `file:/tmp/x/resources`,
//! `file://localhost/tmp/x/resources`, percent-encoded (`pathlib.Path.as_uri()` in FMPy writes
//! a space as `%20`).
//!
//! Hosts are not all exact, so [`resource_file`] also accepts a plain absolute path and, where a
//! host passes the FMU's root folder instead of `resources`, looks one level down.

use std::path::{Path, PathBuf};

/// The local folder a `file:` URI names.
pub fn file_uri_to_path(uri: &str) -> Result<PathBuf, String> {
    let scheme_end = uri
        .find(':')
        .ok_or_else(|| format!("`{uri}` is not a URI (no scheme)"))?;
    let (scheme, rest) = (&uri[..scheme_end], &uri[scheme_end + 1..]);
    if !scheme.eq_ignore_ascii_case("file") {
        return Err(format!(
            "`{uri}`: only file: URIs are supported (the FMU must be unzipped locally)"
        ));
    }
    let path = match rest.strip_prefix("//") {
        Some(after) => {
            let (authority, path) = after.find('/').map_or((after, ""), |i| after.split_at(i));
            if !(authority.is_empty() || authority.eq_ignore_ascii_case("localhost")) {
                return Err(format!(
                    "`{uri}` names the host `{authority}`: only local files can be read"
                ));
            }
            path
        }
        None => rest,
    };
    if !path.starts_with('/') {
        return Err(format!("`{uri}` does not name an absolute path"));
    }
    let bytes = percent_decode(path).map_err(|reason| format!("`{uri}`: {reason}"))?;
    bytes_to_path(bytes, uri)
}

#[cfg(unix)]
fn bytes_to_path(bytes: Vec<u8>, _uri: &str) -> Result<PathBuf, String> {
    use std::os::unix::ffi::OsStringExt;
    Ok(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
}

#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>, uri: &str) -> Result<PathBuf, String> {
    let text = String::from_utf8(bytes).map_err(|_| format!("`{uri}` is not UTF-8"))?;
    // `file:///C:/x` names `C:/x` on Windows.
    let bytes = text.as_bytes();
    let trimmed = if bytes.len() >= 3 && bytes[0] == b'/' && bytes[2] == b':' {
        &text[1..]
    } else {
        &text[..]
    };
    Ok(PathBuf::from(trimmed))
}

fn percent_decode(text: &str) -> Result<Vec<u8>, String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("bad percent escape at byte {i}"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Ok(out)
}

/// The resources file `name` under the location a host passed: a `file:` URI or (leniently) an
/// absolute path, of the `resources` folder or (leniently) of the FMU's root.
pub fn resource_file(location: &str, name: &str) -> Result<PathBuf, String> {
    let dir = if Path::new(location).is_absolute() {
        PathBuf::from(location)
    } else {
        file_uri_to_path(location)?
    };
    let direct = dir.join(name);
    if direct.is_file() {
        return Ok(direct);
    }
    let nested = dir.join("resources").join(name);
    if nested.is_file() {
        return Ok(nested);
    }
    Err(format!(
        "{} does not exist (fmuResourceLocation = `{location}`)",
        direct.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_forms_decode() {
        for uri in [
            "file:///tmp/a b/resources",
            "file:///tmp/a%20b/resources",
            "file:/tmp/a%20b/resources",
            "file://localhost/tmp/a%20b/resources",
            "FILE:///tmp/a%20b/resources",
        ] {
            // (A raw space is not a valid URI character, but some hosts send one.)
            assert_eq!(
                file_uri_to_path(uri).unwrap(),
                PathBuf::from("/tmp/a b/resources"),
                "{uri}"
            );
        }
        assert_eq!(
            file_uri_to_path("file:///tmp/%C3%A5%25/r").unwrap(),
            PathBuf::from("/tmp/å%/r")
        );
    }

    #[test]
    fn remote_relative_and_other_schemes_are_refused() {
        for uri in [
            "http://example.invalid/resources",
            "file://server/share/resources",
            "file:relative/path",
            "file:///tmp/%zz",
            "no-scheme",
        ] {
            assert!(file_uri_to_path(uri).is_err(), "{uri}");
        }
    }

    #[test]
    fn resource_file_accepts_the_root_folder_and_plain_paths() {
        let dir = tempfile::tempdir().unwrap();
        let resources = dir.path().join("resources");
        std::fs::create_dir(&resources).unwrap();
        std::fs::write(resources.join("airsus.toml"), "x").unwrap();
        let want = resources.join("airsus.toml");
        let uri = format!("file://{}", resources.display());
        assert_eq!(resource_file(&uri, "airsus.toml").unwrap(), want);
        let root_uri = format!("file://{}", dir.path().display());
        assert_eq!(resource_file(&root_uri, "airsus.toml").unwrap(), want);
        let plain = resources.display().to_string();
        assert_eq!(resource_file(&plain, "airsus.toml").unwrap(), want);
        assert!(resource_file(&uri, "missing.toml").is_err());
    }
}
