//! The `.fmu` file: a zip archive (FMI 2.0 §2.3) with
//!
//! ```text
//! modelDescription.xml
//! binaries/linux64/airsus_fmu.so
//! resources/airsus.toml
//! ```
//!
//! §2.3 restricts the archive: compression method 8 (deflate) or 0 (store) only, "version
//! needed to extract" at most 2.0, no encryption, no split archives, no links, `/` as the path
//! separator. The small writer here produces exactly that — deflate via `flate2`, CRC-32 via
//! `crc32fast`, sizes in the local headers (no data descriptors, no ZIP64), a fixed timestamp
//! (1980-01-01) so that the same export gives the same bytes — instead of a general zip crate
//! whose defaults (ZIP64 extras, newer methods) would have to be kept in check.

use std::io::Write;
use std::path::Path;

use crate::config::{FmuError, Prepared, RESOURCE_FILE};

/// The library's name inside the FMU.
pub fn library_entry() -> String {
    format!("binaries/linux64/{}.so", crate::MODEL_IDENTIFIER)
}

/// Writes the FMU atomically (a temporary file beside `path`, then renamed): the model
/// description, the library and the resources.
pub fn write_fmu(path: &Path, prepared: &Prepared, library: &[u8]) -> Result<u64, FmuError> {
    let resources = prepared.config.to_toml();
    let library_name = library_entry();
    let resource_name = format!("resources/{RESOURCE_FILE}");
    let entries: [(&str, &[u8]); 6] = [
        (
            "modelDescription.xml",
            prepared.model_description.as_bytes(),
        ),
        ("binaries/", b""),
        ("binaries/linux64/", b""),
        (&library_name, library),
        ("resources/", b""),
        (&resource_name, resources.as_bytes()),
    ];
    let bytes = zip_archive(&entries).map_err(|source| FmuError::Io {
        path: path.display().to_string(),
        source,
    })?;
    airsus_data::atomic::write_atomically(path, |w| w.write_all(&bytes))?;
    Ok(bytes.len() as u64)
}

/// Checks that `bytes` is a Linux x86-64 shared library carrying [`crate::BUILD_MARKER`], i.e.
/// the FMU library of this airsus version; the reason otherwise.
pub fn check_library(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 64 || !bytes.starts_with(b"\x7fELF") {
        return Err("not an ELF file (an FMU for linux64 needs a Linux shared library)".to_owned());
    }
    if bytes[4] != 2 || bytes[5] != 1 {
        return Err("not a 64-bit little-endian ELF file".to_owned());
    }
    let e_type = u16::from_le_bytes([bytes[16], bytes[17]]);
    if e_type != 3 {
        return Err(format!(
            "ELF type {e_type} is not a shared library (3); build the cdylib with `cargo build --release -p airsus-fmu`"
        ));
    }
    let machine = u16::from_le_bytes([bytes[18], bytes[19]]);
    if machine != 0x3e {
        return Err(format!(
            "ELF machine {machine:#x} is not x86-64 (0x3e), which linux64 means"
        ));
    }
    let marker = crate::BUILD_MARKER.as_bytes();
    if !bytes.windows(marker.len()).any(|w| w == marker) {
        return Err(format!(
            "the library does not carry `{}`: it is not the FMU library of this airsus version; rebuild both with `cargo build --release -p airsus -p airsus-fmu`",
            crate::BUILD_MARKER
        ));
    }
    Ok(())
}

/// MS-DOS date of 1980-01-01 (the format's epoch), time 00:00.
const DOS_DATE: u16 = (1 << 5) | 1;
const DOS_TIME: u16 = 0;
/// "Version needed to extract" and "made by": 2.0, made on Unix (upper byte 3).
const VERSION_NEEDED: u16 = 20;
const VERSION_MADE_BY: u16 = (3 << 8) | 20;

fn put16(out: &mut Vec<u8>, v: u16) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn too_large(what: &str) -> std::io::Error {
    std::io::Error::other(format!(
        "{what} exceeds the 4 GiB of a zip archive without ZIP64"
    ))
}

/// A zip archive of `(name, content)` entries; names ending in `/` are folders.
pub fn zip_archive(entries: &[(&str, &[u8])]) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    let count = u16::try_from(entries.len()).map_err(|_| too_large("the entry count"))?;
    for (name, data) in entries {
        let is_dir = name.ends_with('/');
        let crc = crc32fast::hash(data);
        let deflated = if is_dir || data.is_empty() {
            None
        } else {
            let mut encoder =
                flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::default());
            encoder.write_all(data)?;
            Some(encoder.finish()?).filter(|d| d.len() < data.len())
        };
        let (method, body): (u16, &[u8]) = match &deflated {
            Some(d) => (8, d.as_slice()),
            None => (0, *data),
        };
        let offset = u32::try_from(out.len()).map_err(|_| too_large("the archive"))?;
        let compressed = u32::try_from(body.len()).map_err(|_| too_large(name))?;
        let size = u32::try_from(data.len()).map_err(|_| too_large(name))?;
        let name_len = u16::try_from(name.len()).map_err(|_| too_large(name))?;

        // Local file header (APPNOTE 4.3.7).
        put32(&mut out, 0x0403_4b50);
        put16(&mut out, VERSION_NEEDED);
        put16(&mut out, 0); // flags: no data descriptor, no encryption
        put16(&mut out, method);
        put16(&mut out, DOS_TIME);
        put16(&mut out, DOS_DATE);
        put32(&mut out, crc);
        put32(&mut out, compressed);
        put32(&mut out, size);
        put16(&mut out, name_len);
        put16(&mut out, 0); // extra field length
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(body);

        // Central directory header (APPNOTE 4.3.12).
        let mode: u32 = if is_dir {
            0o40755
        } else if name.ends_with(".so") {
            0o100755
        } else {
            0o100644
        };
        let dos_attributes: u32 = if is_dir { 0x10 } else { 0 };
        put32(&mut central, 0x0201_4b50);
        put16(&mut central, VERSION_MADE_BY);
        put16(&mut central, VERSION_NEEDED);
        put16(&mut central, 0);
        put16(&mut central, method);
        put16(&mut central, DOS_TIME);
        put16(&mut central, DOS_DATE);
        put32(&mut central, crc);
        put32(&mut central, compressed);
        put32(&mut central, size);
        put16(&mut central, name_len);
        put16(&mut central, 0); // extra field length
        put16(&mut central, 0); // comment length
        put16(&mut central, 0); // disk number start
        put16(&mut central, 0); // internal attributes
        put32(&mut central, (mode << 16) | dos_attributes);
        put32(&mut central, offset);
        central.extend_from_slice(name.as_bytes());
    }
    let central_offset = u32::try_from(out.len()).map_err(|_| too_large("the archive"))?;
    let central_size = u32::try_from(central.len()).map_err(|_| too_large("the directory"))?;
    out.extend_from_slice(&central);
    // End of central directory record (APPNOTE 4.3.16).
    put32(&mut out, 0x0605_4b50);
    put16(&mut out, 0);
    put16(&mut out, 0);
    put16(&mut out, count);
    put16(&mut out, count);
    put32(&mut out, central_size);
    put32(&mut out, central_offset);
    put16(&mut out, 0);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    fn u16_at(b: &[u8], at: usize) -> u16 {
        u16::from_le_bytes([b[at], b[at + 1]])
    }

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
    }

    /// Reads the archive back through its central directory: (name, method, content).
    fn read_back(zip: &[u8]) -> Vec<(String, u16, Vec<u8>)> {
        let eocd = zip.len() - 22;
        assert_eq!(u32_at(zip, eocd), 0x0605_4b50);
        let count = usize::from(u16_at(zip, eocd + 10));
        let mut at = u32_at(zip, eocd + 16) as usize;
        let mut entries = Vec::new();
        for _ in 0..count {
            assert_eq!(u32_at(zip, at), 0x0201_4b50);
            assert_eq!(u16_at(zip, at + 6), VERSION_NEEDED);
            let method = u16_at(zip, at + 10);
            let crc = u32_at(zip, at + 16);
            let csize = u32_at(zip, at + 20) as usize;
            let name_len = usize::from(u16_at(zip, at + 28));
            let local = u32_at(zip, at + 42) as usize;
            let name = String::from_utf8(zip[at + 46..at + 46 + name_len].to_vec()).unwrap();
            assert_eq!(u32_at(zip, local), 0x0403_4b50);
            let start = local + 30 + usize::from(u16_at(zip, local + 26));
            let body = &zip[start..start + csize];
            let content = match method {
                0 => body.to_vec(),
                8 => {
                    let mut out = Vec::new();
                    flate2::read::DeflateDecoder::new(body)
                        .read_to_end(&mut out)
                        .unwrap();
                    out
                }
                m => panic!("method {m}"),
            };
            assert_eq!(crc32fast::hash(&content), crc, "{name}");
            entries.push((name, method, content));
            at += 46 + name_len;
        }
        entries
    }

    #[test]
    fn the_archive_reads_back_with_the_allowed_methods_only() {
        let text = "airsus ".repeat(500);
        let zip = zip_archive(&[
            ("a/", b""),
            ("a/text.txt", text.as_bytes()),
            ("a/tiny", b"x"),
        ])
        .unwrap();
        let back = read_back(&zip);
        assert_eq!(back.len(), 3);
        assert_eq!(back[0], ("a/".to_owned(), 0, Vec::new()));
        assert_eq!(back[1].0, "a/text.txt");
        assert_eq!(back[1].1, 8, "compressible text is deflated");
        assert_eq!(back[1].2, text.as_bytes());
        assert_eq!(back[2], ("a/tiny".to_owned(), 0, b"x".to_vec()));
        // Same input, same bytes.
        assert_eq!(
            zip,
            zip_archive(&[
                ("a/", b""),
                ("a/text.txt", text.as_bytes()),
                ("a/tiny", b"x")
            ])
            .unwrap()
        );
    }

    #[test]
    fn only_this_versions_linux_library_is_accepted() {
        assert!(check_library(b"not a library").is_err());
        let mut elf = vec![0u8; 128];
        elf[..4].copy_from_slice(b"\x7fELF");
        elf[4] = 2;
        elf[5] = 1;
        elf[16] = 3;
        elf[18] = 0x3e;
        let err = check_library(&elf).unwrap_err();
        assert!(err.contains("does not carry"), "{err}");
        elf.extend_from_slice(crate::BUILD_MARKER.as_bytes());
        assert_eq!(check_library(&elf), Ok(()));
        elf[18] = 0xb7; // aarch64
        assert!(check_library(&elf).unwrap_err().contains("x86-64"));
    }

    #[test]
    fn write_fmu_packs_the_three_files() {
        let config = crate::config::ExportConfig::new(
            "m2",
            &airsus_data::TruckParameters::reference(),
            crate::config::DEFAULT_INITIAL_HEIGHT_MM,
        )
        .unwrap();
        let prepared = Prepared::new(config).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m2.fmu");
        write_fmu(&path, &prepared, b"\x7fELF fake library").unwrap();
        let back = read_back(&std::fs::read(&path).unwrap());
        let names: Vec<&str> = back.iter().map(|(n, _, _)| n.as_str()).collect();
        assert!(names.contains(&"modelDescription.xml"));
        assert!(names.contains(&"binaries/linux64/airsus_fmu.so"));
        assert!(names.contains(&"resources/airsus.toml"));
        let resources = back
            .iter()
            .find(|(n, _, _)| n == "resources/airsus.toml")
            .map(|(_, _, c)| String::from_utf8(c.clone()).unwrap())
            .unwrap();
        let reread =
            Prepared::new(crate::config::ExportConfig::from_toml(&resources).unwrap()).unwrap();
        assert_eq!(reread.guid, prepared.guid);
    }
}
